//! `ssl analyze --out-dir DIR`: one result per input at its relative path under DIR (the
//! extension replaced by the format's), each written atomically: a half-written result
//! never has the result's name. A file that fails has no result, never stops the batch,
//! and is listed with its reason in the summary that ends the run (on stderr, and with
//! `--format json` in DIR/batch.json).

use super::analyze::{analyze_one, prepare, Output, Said};
use super::args::AnalyzeArgs;
use super::inputs::Input;
use super::sink::Sink;
use anyhow::{bail, Context, Result};
use serde::Serialize;
use ssl::Format;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The summary of a batch (DIR/batch.json).
#[derive(Debug, Serialize)]
struct BatchSummary {
    /// Inputs analysed to their end, with a result written.
    done: usize,
    /// Inputs that failed: no result.
    failed: usize,
    /// Seconds of audio analysed.
    audio_s: f64,
    /// Seconds the batch took.
    wall_s: f64,
    /// Audio seconds per second.
    speed: f64,
    /// Per input: its path, its result (null when it failed) and its error (null when
    /// it did not).
    files: Vec<BatchFile>,
}

#[derive(Debug, Serialize)]
struct BatchFile {
    input: String,
    result: Option<String>,
    error: Option<String>,
}

/// The result path of `input` under `dir` for `format`.
fn target(dir: &Path, input: &Input, format: Format) -> PathBuf {
    let ext = match format {
        Format::Csv => "csv",
        Format::Json => "json",
        Format::Ndjson => "ndjson",
    };
    dir.join(&input.relative).with_extension(ext)
}

/// Runs `ssl analyze --out-dir DIR`; returns whether every input gave its result.
pub fn run(args: &AnalyzeArgs, dir: &Path) -> Result<bool> {
    let (localizer, inputs) = prepare(args)?;
    let (localizer, inputs) = (&localizer, &inputs[..]);
    let geometry_path = args.geometry.display().to_string();
    // Two inputs must not write one result.
    let mut seen: HashMap<PathBuf, &str> = HashMap::new();
    for input in inputs {
        let t = target(dir, input, args.format);
        if let Some(other) = seen.insert(t.clone(), &input.path) {
            bail!(
                "{} and {} would both write {}: give them from different directories, or analyse them in separate runs",
                other,
                input.path,
                t.display()
            );
        }
    }
    let started = Instant::now();
    let mut said = Said::default();
    let mut files = Vec::new();
    let (mut done, mut failed, mut audio_s) = (0, 0, 0.0);
    for input in inputs {
        let t = target(dir, input, args.format);
        if let Some(parent) = t.parent() {
            std::fs::create_dir_all(parent)
                .with_context(|| format!("{}: cannot create the directory", parent.display()))?;
        }
        let sink = Sink::open(Some(&t), &[Path::new(&input.path), &args.geometry])?;
        let mut out = Output::new(args, localizer.metadata(&geometry_path), sink, false);
        let entry = analyze_one(args, localizer, &input.path, &mut out, false, &mut said)?;
        if let (Some(frames), Some(n), Some(rate)) =
            (entry.frames, entry.frame_size, entry.sample_rate)
        {
            if frames > 0 {
                audio_s += ((frames - 1) as f64 * n as f64 / 2.0 + n as f64) / rate as f64;
            }
        }
        let error = entry.error.clone();
        let ok = error.is_none() && out.finish_into(&[entry])?;
        if ok {
            done += 1;
        } else {
            failed += 1;
        }
        files.push(BatchFile {
            input: input.path.clone(),
            result: ok.then(|| t.display().to_string()),
            error: if ok {
                None
            } else {
                Some(error.unwrap_or_else(|| "nothing was analysed".into()))
            },
        });
    }
    let wall_s = started.elapsed().as_secs_f64();
    let summary = BatchSummary {
        done,
        failed,
        audio_s,
        wall_s,
        speed: audio_s / wall_s.max(1e-9),
        files,
    };
    eprintln!(
        "ssl: batch: {} input(s): {} done, {} failed; {} of audio in {:.1} s ({:.0}x real time); results in {}",
        inputs.len(),
        summary.done,
        summary.failed,
        hours(summary.audio_s),
        summary.wall_s,
        summary.speed,
        dir.display()
    );
    for f in summary.files.iter().filter(|f| f.error.is_some()) {
        eprintln!(
            "ssl: batch: failed: {}",
            f.error.as_deref().unwrap_or_default()
        );
    }
    if args.format == Format::Json {
        let path = dir.join("batch.json");
        let sink = Sink::open(Some(&path), &[])?;
        let mut w = std::io::BufWriter::new(sink);
        serde_json::to_writer_pretty(&mut w, &summary)?;
        std::io::Write::write_all(&mut w, b"\n")?;
        w.into_inner().map_err(|e| e.into_error())?.commit()?;
    }
    Ok(summary.failed == 0)
}

/// Seconds as hours and minutes (`2 h 05 min`), or seconds under a minute.
fn hours(s: f64) -> String {
    if s < 60.0 {
        format!("{s:.1} s")
    } else {
        let m = (s / 60.0).round() as u64;
        format!("{} h {:02} min", m / 60, m % 60)
    }
}
