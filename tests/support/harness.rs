//! For the benchmark harnesses: their arguments, and running the `ssl` binary while
//! watching its memory.

use std::path::Path;
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The harness's arguments, without the `--bench` flag cargo adds.
pub fn args() -> Vec<String> {
    std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect()
}

/// The first argument, a length of audio in seconds, or `default`.
pub fn seconds_arg(default: f64) -> Result<f64, std::num::ParseFloatError> {
    args()
        .iter()
        .find(|a| !a.starts_with("--"))
        .map(|s| s.parse())
        .transpose()
        .map(|s| s.unwrap_or(default))
}

/// The cores the benchmarks run "all cores" on.
pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// The `ssl` binary cargo built for this harness (release, with `cargo bench`).
pub fn binary() -> &'static Path {
    Path::new(env!("CARGO_BIN_EXE_ssl"))
}

/// Runs `exe args` while another thread polls its peak resident memory (VmHWM) from
/// /proc every 5 ms. Returns the wall time in seconds (to the moment it exits) and the
/// peak in MB; fails if the command fails.
pub fn run_measured(exe: &Path, args: &[&str]) -> Result<(f64, f64), Box<dyn std::error::Error>> {
    let (wall, peak, status) = run_measured_status(exe, args)?;
    if !status.success() {
        return Err(format!("{} {} failed", exe.display(), args.join(" ")).into());
    }
    Ok((wall, peak))
}

/// As [`run_measured`], whatever the command's exit status, which it returns too.
pub fn run_measured_status(
    exe: &Path,
    args: &[&str],
) -> Result<(f64, f64, std::process::ExitStatus), Box<dyn std::error::Error>> {
    let start = Instant::now();
    let mut child = Command::new(exe).args(args).spawn()?;
    let status_file = format!("/proc/{}/status", child.id());
    let done = Arc::new(AtomicBool::new(false));
    let watcher = {
        let done = Arc::clone(&done);
        std::thread::spawn(move || {
            let mut peak_kb = 0u64;
            while !done.load(Ordering::Relaxed) {
                if let Ok(s) = std::fs::read_to_string(&status_file) {
                    if let Some(v) = s.lines().find(|l| l.starts_with("VmHWM:")) {
                        let kb = v.split_whitespace().nth(1).and_then(|x| x.parse().ok());
                        peak_kb = peak_kb.max(kb.unwrap_or(0));
                    }
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            peak_kb
        })
    };
    // Waiting (not polling) ends the wall time when the command exits.
    let status = child.wait();
    let wall = start.elapsed().as_secs_f64();
    done.store(true, Ordering::Relaxed);
    let peak_kb = watcher.join().map_err(|_| "the memory watcher panicked")?;
    Ok((wall, peak_kb as f64 / 1024.0, status?))
}

/// The value of `key=NAME` among the names of `T` (one of the library's closed sets).
fn named<T: ssl::Named>(arg: &str) -> T {
    let (_, name) = arg.split_once('=').expect("key=value");
    T::from_name(name).unwrap_or_else(|| {
        let names: Vec<&str> = T::ALL.iter().map(|c| c.1).collect();
        panic!("{arg}: one of {}", names.join(", "))
    })
}

/// The method's parameters a harness runs with: the defaults; `paper` for the paper's
/// method; otherwise the defaults changed by any of `fixed` (`--min-score` at its
/// default) or `min=X` (a fixed threshold per pair, without late reverberation),
/// `rev=X` (late reverberation, after them), `riders=X` (riders' share; 1: none), `sig=X` (the calibrated threshold's sigmas), `steer=0` (no steered response), `k=N` (sources per frame), `own=0` (no further sources from a frame's own correlations), `avg=N` (frames
/// averaged), `ms=X` (the frame length), `drv=auto|on|off` (the diffuse part removed), `wpe` (the input dereverberated first, `--wpe`), `bg=S` (the coherent background's time constant, 0: none), and a tolerance and a residual gate in microseconds (`0` turns the gate
/// off), in any order.
pub fn params_from(args: &[String]) -> ssl::Params {
    if args.first().is_some_and(|a| a == "paper") {
        return ssl::Config::paper().settings().expect("valid").method;
    }
    // As `ssl analyze`: candidates for the tracker (none without one, see
    // `analyse_scene`).
    let mut params = super::tracked_params();
    let mut numbers = Vec::new();
    for arg in args {
        let value = |what: &str| -> f64 {
            let (_, v) = arg.split_once('=').expect("key=value");
            v.parse()
                .unwrap_or_else(|_| panic!("{arg}: {what} takes a number"))
        };
        match arg.split_once('=').map(|(k, _)| k) {
            // The fixed threshold per pair of `--min-score` (default or given), without
            // late reverberation, without the steered response or candidates (as
            // `ssl analyze --min-score`).
            _ if arg == "fixed" || arg.starts_with("min=") => {
                let per_pair = match arg.split_once('=') {
                    Some((_, v)) => v.parse().expect("min takes a number"),
                    None => 0.5,
                };
                let mut fixed = ssl::Config::fixed_threshold(per_pair);
                fixed.tracking.on = false;
                let f = fixed.settings().expect("valid").method;
                params.threshold = f.threshold;
                params.weighting.reverb_level = f.weighting.reverb_level;
                params.steered = f.steered;
                params.talkers.max_sources = f.talkers.max_sources;
                params.talkers.candidates = Some(1.0);
            }
            // The calibrated threshold's sigmas of chance correlation.
            Some("sig") => {
                params.threshold = ssl::method::Threshold::Calibrated {
                    sigmas: value("sig"),
                }
            }
            // The share of late reverberation in the noise estimate.
            Some("rev") => params.weighting.reverb_level = Some(value("rev")),
            // The coherent background's time constant (0: none).
            Some("bg") => params.room.background_s = value("bg"),
            // The steered response (0: off).
            Some("steer") => {
                params.steered = if value("steer") > 0.0 {
                    ssl::method::Steering::Partial
                } else {
                    ssl::method::Steering::Off
                }
            }
            // Candidates down to this share of the threshold.
            Some("cand") => params.talkers.candidates = Some(value("cand")),
            // Riders down to this share of the threshold (1: none).
            Some("riders") => params.talkers.riders = Some(value("riders")),
            // The most sources per frame.
            Some("k") => params.talkers.max_sources = value("k") as usize,
            // Each talker's pattern removed before a second look (its longer average's
            // time constant, seconds; 0: none, the default).
            Some("pat") => params.talkers.patterns_s = value("pat"),
            // Further sources from each frame's own correlations (1: on, the default).
            Some("own") => params.frame_sources = value("own") > 0.0,
            // The frame length in milliseconds.
            Some("ms") => params.framing.size = ssl::method::FrameSize::Ms(value("ms")),
            // Frames each correlation is averaged over.
            Some("avg") => params.room.average_frames = value("avg") as usize,
            // The peaks' sub-sample refinement, by name.
            Some("interp") => params.peaks.interpolation = Some(named(arg)),
            // When the diffuse part is removed, by name.
            Some("drv") => params.room.dereverb = named(arg),
            // The input dereverberated first (`--wpe`).
            _ if arg == "wpe" => params.room.wpe = true,
            // No riders from the bins' directions (`--no-bin-votes`).
            _ if arg == "novotes" => params.talkers.bin_votes = false,
            // The tracker's (see `track_from`).
            Some(
                "by" | "fph" | "weak" | "tight" | "tightdeg" | "span" | "alone" | "confirm"
                | "delay" | "gate" | "cgate" | "cgs" | "smooth",
            ) => {}
            // A benchmark's own (an offset to its scenes' seeds).
            Some("seed" | "rot" | "only") => {}
            _ => numbers.push(
                arg.parse::<f64>()
                    .unwrap_or_else(|_| panic!("unknown argument {arg}")),
            ),
        }
    }
    // A tolerance and a residual gate in microseconds (0 turns the gate off).
    if let Some(&us) = numbers.first() {
        params.tolerance = ssl::method::Tolerance::Us(us);
    }
    if let Some(&gate) = numbers.get(1) {
        params.room.residual_gate_us = gate;
    }
    params
}

/// The tracker's parameters a harness runs with: the defaults changed by any of
/// `weak=N` (candidates that confirm a track alone), `tight=N` and `tightdeg=DEG` (a
/// steady run of candidates that does), `span=S` (the least span of those runs),
/// `alone=S` (how long no other track may have been heard before a detection alone),
/// `by=evidence|rules` (how a candidate is confirmed), `fph=F` (false sources an hour),
/// `confirm=S` (the confirmation
/// window, seconds), `delay=S` (the tracker's delay), `cgate=DEG` and `cgs=SAMPLES` (a candidate's gate) and `gate=DEG` (the association gate); other arguments are left to
/// `params_from`.
pub fn track_from(args: &[String]) -> ssl::track::TrackParams {
    let mut track = ssl::track::TrackParams::default();
    for (key, value) in args.iter().filter_map(|a| a.split_once('=')) {
        match key {
            "by" => {
                track.confirm_by = ssl::Named::from_name(value).expect("by takes evidence or rules")
            }
            "fph" => track.false_per_hour = value.parse().expect("fph takes a rate"),
            "weak" => track.confirm_weak = value.parse().expect("weak takes a count"),
            "tight" => track.confirm_tight = value.parse().expect("tight takes a count"),
            "tightdeg" => track.tight_deg = value.parse().expect("tightdeg takes degrees"),
            "span" => track.weak_span_s = value.parse().expect("span takes seconds"),
            "alone" => track.alone_s = value.parse().expect("alone takes seconds"),
            "confirm" => track.confirm_s = value.parse().expect("confirm takes seconds"),
            "delay" => track.delay_s = value.parse().expect("delay takes seconds"),
            "gate" => track.gate_deg = value.parse().expect("gate takes degrees"),
            "cgs" => track.candidate_gate_samples = value.parse().expect("cgs takes samples"),
            "cgate" => track.candidate_gate_deg = value.parse().expect("cgate takes degrees"),
            "smooth" => track.smooth_s = value.parse().expect("smooth takes seconds"),
            _ => {}
        }
    }
    track
}

/// Simulates `scene` in `dir` and analyses it in memory as `ssl analyze` does, through a
/// tracker with `track` (else every frame's detection): the records and the truth.
#[cfg(feature = "simulate")]
pub fn analyse_scene(
    dir: &Path,
    scene: &ssl::sim::scene::SceneFile,
    geometry: &ssl::Geometry,
    params: &ssl::Params,
    track: Option<ssl::track::TrackParams>,
) -> Result<(Vec<ssl::DetectionRecord>, ssl::Truth), Box<dyn std::error::Error>> {
    let (rows, _, truth) = analyse_scene_with_events(dir, scene, geometry, params, track)?;
    Ok((rows, truth))
}

/// A simulated scene's rows, its events and its truth.
#[cfg(feature = "simulate")]
pub type SceneRun = (
    Vec<ssl::DetectionRecord>,
    Vec<ssl::record::EventRecord>,
    ssl::Truth,
);

/// As [`analyse_scene`], with the events the run writes (`ssl analyze --events`): what
/// a run whose tracker is not at the defaults is scored by.
#[cfg(feature = "simulate")]
pub fn analyse_scene_with_events(
    dir: &Path,
    scene: &ssl::sim::scene::SceneFile,
    geometry: &ssl::Geometry,
    params: &ssl::Params,
    track: Option<ssl::track::TrackParams>,
) -> Result<SceneRun, Box<dyn std::error::Error>> {
    let sim = ssl::sim::simulate(scene, dir)?;
    let (rows, events) =
        analyse_channels_with_events(&sim.channels, sim.sample_rate, geometry, params, track)?;
    Ok((rows, events, sim.truth))
}

/// Analyses `channels` in memory as `ssl analyze` does, through a tracker with `track`
/// (else every frame's detection): the records.
#[cfg(feature = "simulate")]
pub fn analyse_channels(
    channels: &[Vec<f32>],
    rate: u32,
    geometry: &ssl::Geometry,
    params: &ssl::Params,
    track: Option<ssl::track::TrackParams>,
) -> Result<Vec<ssl::DetectionRecord>, Box<dyn std::error::Error>> {
    Ok(analyse_channels_with_events(channels, rate, geometry, params, track)?.0)
}

/// As [`analyse_channels`], with the events the run writes.
#[cfg(feature = "simulate")]
pub fn analyse_channels_with_events(
    channels: &[Vec<f32>],
    rate: u32,
    geometry: &ssl::Geometry,
    params: &ssl::Params,
    track: Option<ssl::track::TrackParams>,
) -> Result<(Vec<ssl::DetectionRecord>, Vec<ssl::record::EventRecord>), Box<dyn std::error::Error>>
{
    let channels = channels.iter().map(|c| &c[..]).collect();
    let localizer = localizer(geometry, params, track)?;
    records(localizer.from_channels("scene", channels, rate)?)
}

/// A localizer of `geometry` with `params` and `track`; without a tracker, `params` as
/// `ssl analyze --no-track` runs them (no candidates, no steered response, one source a
/// frame).
pub fn localizer(
    geometry: &ssl::Geometry,
    params: &ssl::Params,
    track: Option<ssl::track::TrackParams>,
) -> Result<ssl::Localizer, ssl::SettingsError> {
    let params = match track {
        Some(_) => params.clone(),
        None => super::untracked(params.clone()),
    };
    let settings = ssl::Settings::new(params, track)?;
    ssl::Localizer::with_settings(geometry.clone(), settings)
}

/// The rows of `recording`, as `ssl analyze` writes them.
pub fn rows<S: ssl::stream::SampleSource>(
    recording: ssl::localize::Recording<'_, S>,
) -> Result<Vec<ssl::DetectionRecord>, Box<dyn std::error::Error>> {
    Ok(records(recording)?.0)
}

/// The rows and events of `recording`, as `ssl analyze` and `ssl analyze --events`
/// write them.
pub fn records<S: ssl::stream::SampleSource>(
    recording: ssl::localize::Recording<'_, S>,
) -> Result<(Vec<ssl::DetectionRecord>, Vec<ssl::record::EventRecord>), Box<dyn std::error::Error>>
{
    let (mut rows, mut events) = (Vec::new(), Vec::new());
    let (_, result) = recording.run(|out| {
        match out {
            ssl::localize::Output::Row(row) => rows.push(row),
            ssl::localize::Output::Event(e) => events.push(e),
            _ => {}
        }
        Ok(())
    });
    result?;
    Ok((rows, events))
}
