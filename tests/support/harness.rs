//! For the benchmark harnesses: their arguments, and running the `ssl` binary while
//! watching its memory.

use std::path::Path;
use std::process::Command;
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

/// Runs `exe args`, polling its peak resident memory (VmHWM) from /proc every 5 ms.
/// Returns the wall time in seconds and the peak in MB; fails if the command fails.
pub fn run_measured(exe: &Path, args: &[&str]) -> Result<(f64, f64), Box<dyn std::error::Error>> {
    let start = Instant::now();
    let mut child = Command::new(exe).args(args).spawn()?;
    let mut peak_kb = 0u64;
    let status = loop {
        if let Ok(s) = std::fs::read_to_string(format!("/proc/{}/status", child.id())) {
            if let Some(v) = s.lines().find(|l| l.starts_with("VmHWM:")) {
                let kb = v.split_whitespace().nth(1).and_then(|x| x.parse().ok());
                peak_kb = peak_kb.max(kb.unwrap_or(0));
            }
        }
        if let Some(status) = child.try_wait()? {
            break status;
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    if !status.success() {
        return Err(format!("{} {} failed", exe.display(), args.join(" ")).into());
    }
    Ok((start.elapsed().as_secs_f64(), peak_kb as f64 / 1024.0))
}

/// The method's parameters a harness runs with: the defaults; `paper` for the paper's
/// consistency check (2 samples, no residual gate); or a tolerance and a residual gate
/// in microseconds (`0` turns the gate off).
pub fn params_from(args: &[String]) -> ssl::Params {
    if args.first().is_some_and(|a| a == "paper") {
        return ssl::Params::paper();
    }
    // `calibrated`: the threshold calibrated against the background, with reverberation.
    if args.first().is_some_and(|a| a == "calibrated") {
        return ssl::Params {
            threshold_sigmas: ssl::Params::calibrated().threshold_sigmas,
            reverb_level: ssl::Params::calibrated().reverb_level,
            ..params_from(&args[1..])
        };
    }
    // `rev=X`: the share of late reverberation in the noise estimate.
    if let Some(x) = args.iter().find_map(|a| a.strip_prefix("rev=")) {
        let rest: Vec<String> = args
            .iter()
            .filter(|a| !a.starts_with("rev="))
            .cloned()
            .collect();
        return ssl::Params {
            reverb_level: x.parse().expect("rev=X takes a number"),
            ..params_from(&rest)
        };
    }
    // `min=X`: a fixed threshold per pair.
    if let Some(x) = args.iter().find_map(|a| a.strip_prefix("min=")) {
        let rest: Vec<String> = args
            .iter()
            .filter(|a| !a.starts_with("min="))
            .cloned()
            .collect();
        return ssl::Params {
            min_score_per_pair: x.parse().expect("min=X takes a number"),
            threshold_sigmas: None,
            ..params_from(&rest)
        };
    }
    // `avg=N`: frames each correlation is averaged over.
    if let Some(n) = args.iter().find_map(|a| a.strip_prefix("avg=")) {
        let rest: Vec<String> = args
            .iter()
            .filter(|a| !a.starts_with("avg="))
            .cloned()
            .collect();
        return ssl::Params {
            average_frames: n.parse().expect("avg=N takes a number of frames"),
            ..params_from(&rest)
        };
    }
    let number = |i: usize| args.get(i).and_then(|a| a.parse::<f64>().ok());
    let defaults = ssl::Params::default();
    ssl::Params {
        tolerance_us: number(0).or(defaults.tolerance_us),
        residual_gate_us: match number(1) {
            Some(g) if g > 0.0 => Some(g),
            Some(_) => None,
            None => defaults.residual_gate_us,
        },
        ..defaults
    }
}
