//! Scene files for `ssl simulate` that the benchmarks share: free-field noise events
//! from changing directions, and reverberant speech taking turns. Both name the array
//! `array.toml` beside them; the speech scene names the [`SPEECH`] clips, which
//! [`copy_speech`](super::copy_speech) puts there.

use super::SPEECH as CLIPS;
use std::fmt::Write as _;

/// A free-field scene of white-noise events, each from its own direction.
pub fn scene_toml(rate: u32, seconds: f64, seed: u64) -> String {
    let mut s = format!(
        "sample_rate = {rate}\nduration = {seconds}\nseed = {seed}\nformat = \"int16\"\n\
         [array]\ngeometry = \"array.toml\"\nposition = [0.0, 0.0, 0.0]\n"
    );
    let mut t = 0.4;
    let mut i = 0;
    while t + 0.8 < seconds {
        let azimuth = -170.0 + (i * 67 % 340) as f64;
        let elevation = -40.0 + (i * 29 % 80) as f64;
        write!(
            s,
            "[[source]]\nazimuth_deg = {azimuth}\nelevation_deg = {elevation}\ndistance = 3.0\n\
             signal = \"white\"\nlevel_db = -26\nactive = [[{t:.2}, {:.2}]]\n",
            t + 0.8
        )
        .unwrap();
        t += 1.5;
        i += 1;
    }
    s + "[noise]\nsensor_db = -50\n"
}

/// A reverberant scene of real speech: the two clips taking turns, 0.3 s apart (above
/// the array's plane for a planar array, which cannot tell above from below).
pub fn speech_scene_toml(rate: u32, seconds: f64, planar: bool, seed: u64) -> String {
    let mut s = format!(
        "sample_rate = {rate}\nduration = {seconds}\nseed = {seed}\nformat = \"int16\"\n\
         [room]\ndimensions = [8.0, 7.0, 3.0]\nrt60 = 0.35\n\
         [array]\ngeometry = \"array.toml\"\nposition = [4.0, 3.5, 1.2]\n"
    );
    let mut t = 0.4;
    let mut i = 0;
    while t + CLIPS[i % 2].1 < seconds {
        let (clip, length) = CLIPS[i % 2];
        let azimuth = -170.0 + (i * 67 % 340) as f64;
        let elevation = if planar {
            5.0 + (i * 13 % 30) as f64
        } else {
            -20.0 + (i * 13 % 40) as f64
        };
        let distance = 1.5 + (i % 4) as f64 * 0.5;
        write!(
            s,
            "[[source]]\nazimuth_deg = {azimuth}\nelevation_deg = {elevation}\n\
             distance = {distance}\nsignal = \"file\"\nfile = \"{clip}\"\nlevel_db = -26\n\
             active = [[{t:.2}, {:.2}]]\n",
            t + length
        )
        .unwrap();
        t += length + 0.3;
        i += 1;
    }
    s + "[noise]\nsnr_db = 10\nsensor_db = -70\n[[noise.fan]]\nposition = [7.6, 6.6, 2.7]\n\
         signal = \"pink\"\n[noise.diffuse]\nsignal = \"pink\"\nweight_db = -6\n"
}
