//! `ssl simulate`: render a scene to a WAV file and its truth, both or neither.

use super::args::SimulateArgs;
use super::sink::Sink;
use crate::sim::{simulate_read, write_wav, SceneFile};
use anyhow::{bail, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Runs `ssl simulate`.
pub fn run(args: &SimulateArgs) -> Result<()> {
    let truth_path = args
        .truth
        .clone()
        .unwrap_or_else(|| args.output.with_extension("truth.json"));
    // Both outputs are checked against every file the scene reads (and each other)
    // before anything runs.
    let scene = SceneFile::from_file(&args.scene)?;
    let read = scene.files_read(args.scene.parent().unwrap_or(Path::new(".")));
    let mut inputs: Vec<&Path> = read.iter().map(PathBuf::as_path).collect();
    inputs.push(&args.scene);
    let wav = Sink::open(Some(&args.output), &[&inputs[..], &[&truth_path]].concat())?;
    let mut truth_sink = Sink::open(Some(&truth_path), &[&inputs[..], &[&args.output]].concat())?;
    if truth_path == args.output || truth_path == Path::new("-") && args.output == Path::new("-") {
        bail!(
            "{}: the WAV file and the truth need two outputs",
            args.output.display()
        );
    }
    // A WAV writer must seek back to finish its header: only regular files will do.
    let Some(tmp) = wav.temporary_path() else {
        bail!(
            "{}: the WAV output must be a regular file (not standard output, a device or a pipe)",
            args.output.display()
        );
    };
    let sim = simulate_read(&scene, &args.scene)?;
    write_wav(tmp, &sim.channels, sim.sample_rate, sim.format.into())
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", wav.shown()))?;
    let mut truth = sim.truth;
    truth.recording = Some(args.output.display().to_string());
    let text = serde_json::to_string_pretty(&truth)? + "\n";
    truth_sink
        .write_all(text.as_bytes())
        .map_err(|e| truth_sink.write_error(&e))?;
    wav.commit_both(truth_sink)
}
