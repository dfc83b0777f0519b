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

/// Sparse audio: white-noise bursts of 0.5 s every 3 s, all from one direction (35 deg
/// azimuth, 12 deg up, 3 m), in free field over sensor noise 24 dB below them.
pub fn bursts_toml(rate: u32, seconds: f64, seed: u64) -> String {
    let mut s = format!(
        "sample_rate = {rate}\nduration = {seconds}\nseed = {seed}\nformat = \"int16\"\n\
         [array]\ngeometry = \"array.toml\"\nposition = [0.0, 0.0, 0.0]\n\
         [[source]]\nazimuth_deg = 35.0\nelevation_deg = 12.0\ndistance = 3.0\n\
         signal = \"white\"\nlevel_db = -26\nactive = ["
    );
    let mut t = 1.0;
    while t + 0.5 < seconds {
        write!(s, "[{t:.2}, {:.2}], ", t + 0.5).unwrap();
        t += 3.0;
    }
    s + "]\n[noise]\nsensor_db = -50\n"
}

/// Busy audio: four talkers around the array (azimuths -135, -40, 50 and 140 deg, 7 deg
/// below it, 2 m away) taking twelve turns, some overlapping by 0.3 s, in an 8 x 7 x 3 m
/// room at RT60 0.35 s with a fan and diffuse noise 10 dB below them (the tracking
/// benchmark's meeting). Returns the scene and its length (s).
pub fn meeting_toml(rate: u32, seed: u64) -> (String, f64) {
    let (turns, t) = meeting_turns();
    let mut active = vec![String::new(); MEETING_AZIMUTHS.len()];
    for (who, spans) in turns.iter().enumerate() {
        for [from, to] in spans {
            write!(active[who], "[{from:.2}, {to:.2}], ").unwrap();
        }
    }
    let seconds = ((t + 1.5) * 100.0).round() / 100.0;
    let mut s = format!(
        "sample_rate = {rate}\nduration = {seconds}\nseed = {seed}\nformat = \"int16\"\n\
         [room]\ndimensions = [8.0, 7.0, 3.0]\nrt60 = 0.35\n\
         [array]\ngeometry = \"array.toml\"\nposition = [4.0, 3.5, 0.8]\n"
    );
    for (who, azimuth) in MEETING_AZIMUTHS.iter().enumerate() {
        write!(
            s,
            "[[source]]\nazimuth_deg = {azimuth}\nelevation_deg = -7.0\ndistance = 2.0\n\
             signal = \"file\"\nfile = \"{}\"\nlevel_db = -26\nactive = [{}]\n",
            CLIPS[who % CLIPS.len()].0,
            active[who]
        )
        .unwrap();
    }
    (
        s + "[noise]\nsnr_db = 10\nsensor_db = -70\n[[noise.fan]]\nposition = [7.6, 6.6, 2.7]\n\
             signal = \"pink\"\n[noise.diffuse]\nsignal = \"pink\"\nweight_db = -6\n",
        seconds,
    )
}

/// The meeting's talkers' azimuths (degrees).
pub const MEETING_AZIMUTHS: [f64; 4] = [-135.0, -40.0, 50.0, 140.0];

/// The meeting's twelve turns, the four talkers in turn with gaps and overlaps: each
/// talker's active spans (seconds), and when the last turn ends.
pub fn meeting_turns() -> (Vec<Vec<[f64; 2]>>, f64) {
    let gaps = [-0.3, 0.4, 0.2, -0.3, 0.6, 0.3];
    let mut active = vec![Vec::new(); MEETING_AZIMUTHS.len()];
    let mut t = 1.0;
    for turn in 0..12 {
        let who = turn % MEETING_AZIMUTHS.len();
        let length = CLIPS[who % CLIPS.len()].1;
        active[who].push([t, t + length]);
        t += length + gaps[turn % gaps.len()];
    }
    (active, t)
}

/// Two talkers at once, three times in 15 s (20 deg and -70 deg azimuth, 2 m), in the
/// meeting's room, for an array named `array.toml` of any size.
pub fn two_talkers_toml(rate: u32, seed: u64) -> String {
    format!(
        "sample_rate = {rate}\nduration = 15\nseed = {seed}\nformat = \"int16\"\n\
         [room]\ndimensions = [8.0, 7.0, 3.0]\nrt60 = 0.35\n\
         [array]\ngeometry = \"array.toml\"\nposition = [4.0, 3.5, 1.2]\n\
         [[source]]\nazimuth_deg = 20.0\nelevation_deg = 5.0\ndistance = 2.0\n\
         signal = \"file\"\nfile = \"{}\"\nlevel_db = -26\nactive = [[0.5, 4.4], [5.0, 8.9], [10.0, 13.9]]\n\
         [[source]]\nazimuth_deg = -70.0\nelevation_deg = 10.0\ndistance = 2.0\n\
         signal = \"file\"\nfile = \"{}\"\nlevel_db = -26\nactive = [[1.0, 4.5], [5.5, 9.0], [10.5, 14.0]]\n\
         [noise]\nsnr_db = 10\nsensor_db = -70\n[[noise.fan]]\nposition = [7.6, 6.6, 2.7]\n\
         signal = \"pink\"\n[noise.diffuse]\nsignal = \"pink\"\nweight_db = -6\n",
        CLIPS[0].0, CLIPS[2].0
    )
}
