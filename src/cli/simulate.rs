//! `ssl simulate`: render a scene to a WAV file and its truth, both atomically.

use super::args::SimulateArgs;
use super::sink::Sink;
use anyhow::{bail, Context, Result};
use ssl::sim::{simulate_file, write_wav};
use std::io::Write;

/// Runs `ssl simulate`.
pub fn run(args: &SimulateArgs) -> Result<()> {
    let sim = simulate_file(&args.scene)?;
    let truth_path = args
        .truth
        .clone()
        .unwrap_or_else(|| args.output.with_extension("truth.json"));
    // A WAV writer must seek back to finish its header: only regular files will do.
    let wav = Sink::open(Some(&args.output))?;
    let Sink::Atomic(tmp, _) = &wav else {
        bail!(
            "{}: the WAV output must be a regular file (not a device or pipe)",
            args.output.display()
        );
    };
    write_wav(
        tmp.path(),
        &sim.channels,
        sim.sample_rate,
        sim.format.into(),
    )
    .with_context(|| format!("{}: cannot write", args.output.display()))?;
    let mut truth = sim.truth;
    truth.recording = Some(args.output.display().to_string());
    let text = serde_json::to_string_pretty(&truth)? + "\n";
    let mut truth_sink = Sink::open(Some(&truth_path))?;
    wav.commit(&args.output)?;
    truth_sink
        .write_all(text.as_bytes())
        .with_context(|| format!("{}: cannot write", truth_path.display()))?;
    truth_sink.commit(&truth_path)
}
