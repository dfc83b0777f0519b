//! `ssl analyze`: every file through the method, detections to one output.

use super::args::AnalyzeArgs;
use super::sink::Sink;
use super::{error, warn, warning_with_hint, with_hint};
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use ssl::record::FileEntry;
use ssl::{Analysis, DetectionRecord, Format, Geometry, OutputError, RunMetadata};
use std::io::{self, BufWriter, IsTerminal};
use std::ops::ControlFlow;

/// Runs `ssl analyze`. Returns whether every file succeeded.
pub fn run(args: &AnalyzeArgs) -> Result<bool> {
    let geometry = Geometry::from_file(&args.geometry)?;
    let geometry_path = args.geometry.display().to_string();
    for w in &geometry.warnings {
        warn(args.quiet, &format!("{geometry_path}: {w}"));
    }
    let params = args.params();
    let sink = Sink::open(args.output.as_deref())?;
    let live = sink.is_live();
    let mut exporter = args
        .format
        .exporter(BufWriter::with_capacity(1 << 16, sink));
    if live && args.format == Format::Ndjson {
        exporter.flush_each_record();
    }
    let output_failed = |e: OutputError| {
        anyhow::Error::new(e).context(match &args.output {
            Some(p) => format!("{}: cannot write", p.display()),
            None => "cannot write to standard output".to_string(),
        })
    };
    exporter
        .begin(&RunMetadata::new(&geometry, &geometry_path, &params))
        .map_err(output_failed)?;

    let show_progress = !args.quiet && io::stderr().is_terminal();
    let mut all_ok = true;
    let mut files = Vec::new();
    for path in &args.files {
        let analysis = match Analysis::open(path, &geometry, &params) {
            Ok(a) => a,
            Err(e) => {
                let message = with_hint(&e);
                error(&message);
                files.push(FileEntry::new(path, None, Some(message)));
                all_ok = false;
                continue;
            }
        };
        let bar = progress_bar(show_progress, path, analysis.total_frames());
        let name = analysis.name().to_string();
        let mut output_error = None;
        let (summary, result) = analysis.run(|index, detection| {
            if index % 64 == 0 {
                bar.set_position(index);
            }
            let written = detection.map_or(Ok(()), |d| {
                DetectionRecord::new(&name, d).and_then(|r| exporter.detection(&r))
            });
            match written {
                Ok(()) => ControlFlow::Continue(()),
                Err(e) => {
                    output_error = Some(e);
                    ControlFlow::Break(())
                }
            }
        });
        bar.finish_and_clear();
        if let Some(e) = output_error {
            return Err(output_failed(e));
        }
        for w in &summary.warnings {
            warn(args.quiet, &warning_with_hint(&summary.name, w));
        }
        let message = result.err().map(|e| with_hint(&e));
        if let Some(e) = &message {
            error(e);
            all_ok = false;
        }
        files.push(FileEntry::new(path, Some(&summary), message));
    }
    let out = exporter.finish(&files).map_err(output_failed)?;
    let sink = out
        .into_inner()
        .map_err(|e| output_failed(e.into_error().into()))?;
    match &args.output {
        Some(path) => sink.commit(path)?,
        None => sink
            .commit("-".as_ref())
            .context("cannot write to standard output")?,
    }
    Ok(all_ok)
}

fn progress_bar(show: bool, name: &str, total: Option<u64>) -> ProgressBar {
    if !show {
        return ProgressBar::hidden();
    }
    let bar = match total {
        Some(t) => ProgressBar::with_draw_target(Some(t), ProgressDrawTarget::stderr()).with_style(
            ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} frames ({eta})")
                .expect("valid template")
                .progress_chars("=> "),
        ),
        None => ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr()).with_style(
            ProgressStyle::with_template("{prefix} {spinner} {pos} frames")
                .expect("valid template"),
        ),
    };
    bar.set_prefix(name.to_string());
    bar
}
