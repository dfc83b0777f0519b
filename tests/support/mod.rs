//! Fixtures shared by the integration tests and the benchmarks: the paper's array and
//! other arrays, synthetic recordings with known truth, hand-made WAV bytes for corner
//! cases, running the `ssl` binary, and the accuracy benchmark's scenes ([`bench`]).
#![allow(dead_code)]

pub mod bench;
pub mod harness;
#[cfg(feature = "simulate")]
pub mod moving;
pub mod scenes;

use nalgebra::Vector3;
use ssl::geometry::{angle_between_deg, unit_from_angles};
use ssl::sim::freefield::{render, Place, Scene, Source};
use ssl::sim::signals::Signal;
use ssl::sim::{write_wav, Encoding};
use ssl::Geometry;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// The CMU ARCTIC sentences in `testdata/speech/` and their lengths (seconds).
pub const SPEECH: [(&str, f64); 3] = [
    ("cmu_arctic_us_aew_a0001.wav", 3.9),
    ("cmu_arctic_us_axb_a0004.wav", 2.8),
    ("arctic_a0010.wav", 3.5),
];

/// Copies the [`SPEECH`] clips into `dir` (scene files name them there).
pub fn copy_speech(dir: &Path) -> std::io::Result<()> {
    for (clip, _) in SPEECH {
        std::fs::copy(testdata(&format!("speech/{clip}")), dir.join(clip))?;
    }
    Ok(())
}

/// `k` microphones on a horizontal circle of radius `r` (m), the first on +x.
pub fn circle(k: usize, r: f64) -> Vec<Vector3<f64>> {
    (0..k)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / k as f64;
            Vector3::new(r * a.cos(), r * a.sin(), 0.0)
        })
        .collect()
}

/// A regular tetrahedron of `edge` (m), centred on the origin.
pub fn tetrahedron(edge: f64) -> Vec<Vector3<f64>> {
    let e = edge / (2.0 * 2f64.sqrt());
    vec![
        Vector3::new(e, e, e),
        Vector3::new(e, -e, -e),
        Vector3::new(-e, e, -e),
        Vector3::new(-e, -e, e),
    ]
}

/// The shipped files: `testdata/NAME`.
/// The method's parameters `ssl analyze` runs with its tracker (the defaults).
pub fn tracked_params() -> ssl::Params {
    ssl::Config::default().settings().expect("valid").method
}

/// `params` with what only a tracker confirms turned on as `ssl analyze` does (the
/// steered response, further sources, patterns, candidates, riders).
pub fn for_tracker(params: ssl::Params) -> ssl::Params {
    tracker_fields(params, &tracked_params())
}

/// `params` with what only a tracker confirms turned off as `ssl analyze --no-track`
/// does.
pub fn untracked(params: ssl::Params) -> ssl::Params {
    let alone = ssl::Config::untracked().settings().expect("valid").method;
    tracker_fields(params, &alone)
}

/// `params` with the fields that depend on a tracker (the steered response, further
/// sources, patterns, candidates, riders) taken from `from`.
fn tracker_fields(mut params: ssl::Params, from: &ssl::Params) -> ssl::Params {
    params.steered = from.steered;
    params.frame_sources = from.frame_sources;
    params.talkers.max_sources = from.talkers.max_sources;
    params.talkers.patterns_s = from.talkers.patterns_s;
    params.talkers.candidates = from.talkers.candidates;
    params.talkers.riders = from.talkers.riders;
    params
}

pub fn testdata(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("testdata")
        .join(name)
}

/// The paper's array (8 microphones on the corners of a 50 x 40 x 36 cm prism), as
/// shipped in `testdata/prism.toml`.
pub fn prism_geometry() -> Geometry {
    Geometry::from_file(&testdata("prism.toml")).unwrap()
}

/// The paper's array's microphone positions (metres, array frame).
pub fn prism() -> Vec<Vector3<f64>> {
    prism_geometry().positions()
}

/// `k` points spread evenly over a sphere of radius `r` centred on the origin (a
/// Fibonacci lattice): arrays of any size.
pub fn sphere_lattice(k: usize, r: f64) -> Vec<Vector3<f64>> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..k)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / k as f64;
            let rho = (1.0 - z * z).sqrt();
            let phi = golden * i as f64;
            Vector3::new(r * rho * phi.cos(), r * rho * phi.sin(), r * z)
        })
        .collect()
}

/// A geometry TOML for positions, with optional extra top-level lines.
pub fn geometry_toml(positions: &[Vector3<f64>], extra: &str) -> String {
    let mut s = format!("{extra}\n");
    for p in positions {
        s += &format!("[[mic]]\nposition = [{}, {}, {}]\n", p.x, p.y, p.z);
    }
    s
}

/// A geometry TOML for positions, each microphone on the given channel.
pub fn geometry_toml_with_channels(positions: &[Vector3<f64>], channels: &[usize]) -> String {
    positions
        .iter()
        .zip(channels)
        .map(|(p, c)| {
            format!(
                "[[mic]]\nposition = [{}, {}, {}]\nchannel = {c}\n",
                p.x, p.y, p.z
            )
        })
        .collect()
}

/// A path as a command-line argument.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A fresh folder with a recording of one white-noise source (azimuth 30, elevation 10)
/// on for `seconds`, 16-bit, 48 kHz, and the prism's geometry: `(folder, wav, geometry)`.
pub fn recording(seconds: f64) -> (tempfile::TempDir, PathBuf, PathBuf) {
    let dir = tempdir();
    let sc = scene(
        prism(),
        48000,
        &[(30.0, 10.0, Signal::WhiteNoise)],
        seconds,
        0.005,
        1,
    );
    let wav = render_wav(dir.path(), "rec.wav", &sc, Encoding::Int16);
    let geo = write(dir.path(), "prism.toml", geometry_toml(&prism(), ""));
    (dir, wav, geo)
}

pub fn write(dir: &Path, name: &str, contents: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, contents).unwrap();
    p
}

/// One source per time slot: `(azimuth, elevation, signal)`, each active for `slot_s`
/// seconds with a 0.1 s gap, far field, at RMS 0.05 (-26 dBFS; clicks, which are 2 ms
/// transients, at 0.2 during each click), with sensor noise `noise`.
pub fn scene(
    mics: Vec<Vector3<f64>>,
    rate: u32,
    dirs: &[(f64, f64, Signal)],
    slot_s: f64,
    noise: f64,
    seed: u64,
) -> Scene {
    let sources = dirs
        .iter()
        .enumerate()
        .map(|(i, (az, el, sig))| Source {
            place: Place::Direction(unit_from_angles(*az, *el)),
            signal: sig.clone(),
            start_s: 0.1 + i as f64 * (slot_s + 0.1),
            end_s: 0.1 + i as f64 * (slot_s + 0.1) + slot_s,
            level: if matches!(sig, Signal::Clicks { .. }) {
                0.2
            } else {
                0.05
            },
        })
        .collect::<Vec<_>>();
    let duration_s = 0.2 + dirs.len() as f64 * (slot_s + 0.1);
    Scene {
        sample_rate: rate,
        duration_s,
        mics,
        speed_of_sound: 343.0,
        sources,
        sensor_noise: noise,
        seed,
    }
}

pub fn render_wav(dir: &Path, name: &str, scene: &Scene, encoding: Encoding) -> PathBuf {
    let channels = render(scene);
    let p = dir.join(name);
    write_wav(&p, &channels, scene.sample_rate, encoding).unwrap();
    p
}

/// The frame size and every frame's detection (or none) of channels in memory, through
/// the library's one entry point.
pub fn frame_detections(
    channels: &[Vec<f32>],
    rate: u32,
    geometry: &Geometry,
    params: &ssl::Params,
) -> (usize, Vec<Option<ssl::Detection>>) {
    let slices = channels.iter().map(|c| &c[..]).collect();
    let analysis = ssl::Analysis::from_channels("memory", slices, rate, geometry, params).unwrap();
    let n = analysis.frame_size();
    let mut all = Vec::new();
    let (_, result) = analysis.run(|_, d| {
        all.push(d.first().copied());
        std::ops::ControlFlow::Continue(())
    });
    result.unwrap();
    (n, all)
}

pub fn ssl() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ssl"))
}

/// Runs `ssl args` with `input` written to its standard input (from another thread, so
/// that a large input cannot block against the output).
pub fn run_with_stdin(args: &[&str], input: Vec<u8>) -> Output {
    let mut child = ssl()
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || {
        use std::io::Write;
        // The reader may stop early (an error); that is for the caller to check.
        let _ = stdin.write_all(&input);
    });
    let out = child.wait_with_output().unwrap();
    writer.join().unwrap();
    out
}

/// The files in `dir` whose names end in `.tmp` (the temporary outputs).
pub fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect()
}

/// `ssl analyze` of the file `path` with `args`, and of its bytes through a pipe: each
/// run's status, stdout and stderr, with the input's name replaced by `IN`, so that the
/// two can be compared.
pub fn analyze_file_and_pipe(path: &Path, args: &[&str]) -> [(Option<i32>, String, String); 2] {
    let from_file = run(&[&["analyze", s(path)][..], args].concat());
    let from_pipe = run_with_stdin(
        &[&["analyze", "-"][..], args].concat(),
        std::fs::read(path).unwrap(),
    );
    [(from_file, s(path)), (from_pipe, "<stdin>")].map(|(out, name)| {
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stdout).replace(name, "IN"),
            stderr(&out).replace(name, "IN"),
        )
    })
}

pub fn run(args: &[&str]) -> Output {
    ssl().args(args).stdin(Stdio::null()).output().unwrap()
}

/// Runs `ssl args` in `dir` and checks that it succeeded (its stderr in the message).
pub fn run_ok_in(dir: &Path, args: &[&str]) -> Output {
    let out = ssl().current_dir(dir).args(args).output().unwrap();
    assert!(out.status.success(), "{args:?}: {}", stderr(&out));
    out
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    pub time_s: f64,
    pub azimuth_deg: f64,
    pub elevation_deg: f64,
    pub u: Vector3<f64>,
    pub score: f64,
    pub file: String,
    pub frame: u64,
    pub mics: usize,
    /// The track (`None` with `--no-track`).
    pub source: Option<u64>,
}

/// The rows of a CSV result, read by the library's reader (the header is checked).
pub fn parse_csv(text: &str) -> Vec<Row> {
    assert_eq!(
        text.lines().next().unwrap(),
        "time_s,azimuth_deg,elevation_deg,x,y,z,score,file,frame,mics,source,uncertainty_deg"
    );
    ssl::record::parse_detections(text)
        .unwrap()
        .into_iter()
        .map(|r| Row {
            time_s: r.time_s,
            azimuth_deg: r.azimuth_deg,
            elevation_deg: r.elevation_deg,
            u: Vector3::new(r.x, r.y, r.z),
            score: r.score,
            file: r.file,
            frame: r.frame.unwrap(),
            mics: r.mics.unwrap(),
            source: r.source,
        })
        .collect()
}

/// For each source of the scene: (detections whose frame lies inside its active
/// interval, frames inside it, mean angular error, max angular error) against `expect`.
pub fn score_sources(
    scene: &Scene,
    rows: &[Row],
    n: usize,
    expect: impl Fn(&Vector3<f64>) -> Vector3<f64>,
) -> Vec<(usize, usize, f64, f64)> {
    let fs = scene.sample_rate as f64;
    let half = n as f64 / 2.0 / fs;
    let centre = scene.mics.iter().sum::<Vector3<f64>>() / scene.mics.len() as f64;
    scene
        .sources
        .iter()
        .map(|s| {
            let truth = expect(&s.direction_from(&centre));
            let inside = |t: f64| t - half >= s.start_s && t + half <= s.end_s;
            let errs: Vec<f64> = rows
                .iter()
                .filter(|r| inside(r.time_s))
                .map(|r| angle_between_deg(&r.u, &truth))
                .collect();
            let hop = n as f64 / 2.0 / fs;
            let frames = (((s.end_s - s.start_s) - 2.0 * half) / hop).floor() as usize + 1;
            let mean = errs.iter().sum::<f64>() / errs.len().max(1) as f64;
            let max = errs.iter().cloned().fold(0.0, f64::max);
            (errs.len(), frames, mean, max)
        })
        .collect()
}

/// A WAV file made by hand: `fmt` body and data bytes, with the data chunk's length
/// field set to `data_len` (`None`: the true length) and the RIFF tag `riff`.
pub fn raw_wav(riff: &[u8; 4], fmt: &[u8], data: &[u8], data_len: Option<u32>) -> Vec<u8> {
    let mut v = Vec::new();
    v.extend_from_slice(riff);
    v.extend_from_slice(&((4 + 8 + fmt.len() + 8 + data.len()) as u32).to_le_bytes());
    v.extend_from_slice(b"WAVE");
    v.extend_from_slice(b"fmt ");
    v.extend_from_slice(&(fmt.len() as u32).to_le_bytes());
    v.extend_from_slice(fmt);
    v.extend_from_slice(b"data");
    v.extend_from_slice(&data_len.unwrap_or(data.len() as u32).to_le_bytes());
    v.extend_from_slice(data);
    v
}

/// A plain `fmt ` body (16 bytes); the block size wraps at 16 bits, as in a header
/// written for more channels than it can describe.
pub fn fmt_body(tag: u16, channels: u16, rate: u32, bits: u16) -> Vec<u8> {
    let block = channels.wrapping_mul(bits) / 8;
    let mut v = Vec::new();
    v.extend_from_slice(&tag.to_le_bytes());
    v.extend_from_slice(&channels.to_le_bytes());
    v.extend_from_slice(&rate.to_le_bytes());
    v.extend_from_slice(&rate.wrapping_mul(block as u32).to_le_bytes());
    v.extend_from_slice(&block.to_le_bytes());
    v.extend_from_slice(&bits.to_le_bytes());
    v
}

/// Interleaves channels as 16-bit little-endian PCM bytes.
pub fn pcm16(channels: &[Vec<f32>]) -> Vec<u8> {
    let len = channels[0].len();
    let mut v = Vec::with_capacity(len * channels.len() * 2);
    for i in 0..len {
        for ch in channels {
            let q = (ch[i] * 32768.0).round().clamp(-32768.0, 32767.0) as i16;
            v.extend_from_slice(&q.to_le_bytes());
        }
    }
    v
}

pub fn tempdir() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

pub fn signals() -> [Signal; 2] {
    [Signal::WhiteNoise, Signal::Clicks { per_second: 25.0 }]
}

pub fn int_enc() -> Encoding {
    Encoding::Int16
}
