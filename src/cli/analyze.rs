//! `ssl analyze`: every file through the method, detections to one output.
//!
//! Nothing is written until a file gives its first frame: when every input fails, an
//! existing `-o` file is left as it was and standard output gets nothing (the errors are
//! on standard error, and the exit status is 1).

use super::args::AnalyzeArgs;
use super::sink::{same_file, Sink};
use super::{error, output_error, warn, warning_with_hint, with_hint};
use anyhow::Result;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use ssl::record::FileEntry;
use ssl::{Analysis, DetectionRecord, Exporter, Format, Geometry, OutputError, RunMetadata};
use std::io::{self, BufWriter, IsTerminal};
use std::ops::ControlFlow;
use std::path::Path;

type Out = BufWriter<Sink>;

/// The output, opened on the first frame of the first file that gives one.
struct Output<'a> {
    args: &'a AnalyzeArgs,
    meta: RunMetadata,
    sink: Option<Sink>,
    exporter: Option<Box<dyn Exporter<Out>>>,
    shown: String,
}

impl Output<'_> {
    fn exporter(&mut self) -> Result<&mut Box<dyn Exporter<Out>>, OutputError> {
        if self.exporter.is_none() {
            let sink = self
                .sink
                .take()
                .expect("the sink until the exporter takes it");
            let live = sink.is_live();
            let mut exporter = self
                .args
                .format
                .exporter(BufWriter::with_capacity(1 << 16, sink));
            if live && self.args.format == Format::Ndjson {
                exporter.flush_each_record();
            }
            exporter.begin(&self.meta)?;
            self.exporter = Some(exporter);
        }
        Ok(self.exporter.as_mut().expect("just made"))
    }

    fn failed(&self, e: OutputError) -> anyhow::Error {
        output_error(&self.shown, e)
    }
}

/// Runs `ssl analyze`. Returns whether every file succeeded.
pub fn run(args: &AnalyzeArgs) -> Result<bool> {
    let geometry = Geometry::from_file(&args.geometry)?;
    let geometry_path = args.geometry.display().to_string();
    for w in &geometry.warnings {
        warn(args.quiet, &format!("{geometry_path}: {w}"));
    }
    let params = args.params();
    let mut inputs: Vec<&Path> = args.files.iter().map(Path::new).collect();
    inputs.push(&args.geometry);
    let sink = Sink::open(args.output.as_deref(), &inputs)?;
    warn_about_repeats(args);
    let mut out = Output {
        args,
        meta: RunMetadata::new(&geometry, &geometry_path, &params),
        shown: sink.shown().to_string(),
        sink: Some(sink),
        exporter: None,
    };

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
        let mut output_failure = None;
        let (summary, result) = analysis.run(|index, detection| {
            if index % 64 == 0 {
                bar.set_position(index);
            }
            let written = out.exporter().and_then(|exporter| match detection {
                Some(d) => exporter.detection(&DetectionRecord::new(&name, d)?),
                None => Ok(()),
            });
            match written {
                Ok(()) => ControlFlow::Continue(()),
                Err(e) => {
                    output_failure = Some(e);
                    ControlFlow::Break(())
                }
            }
        });
        bar.finish_and_clear();
        if let Some(e) = output_failure {
            return Err(out.failed(e));
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
    let Some(exporter) = out.exporter.take() else {
        // Nothing was analysed: nothing is written, an existing file stays as it was.
        return Ok(false);
    };
    let buffered = exporter.finish(&files).map_err(|e| out.failed(e))?;
    let sink = buffered
        .into_inner()
        .map_err(|e| out.failed(e.into_error().into()))?;
    sink.commit()?;
    Ok(all_ok)
}

/// Warns when the same file is given twice (its detections would be written twice).
fn warn_about_repeats(args: &AnalyzeArgs) {
    for (i, a) in args.files.iter().enumerate() {
        if let Some(b) = args.files[..i]
            .iter()
            .find(|b| *b == a || (a != "-" && same_file(Path::new(a), Path::new(b))))
        {
            warn(
                args.quiet,
                &format!("{a}: the same file as {b}, given earlier; it is analysed twice"),
            );
        }
    }
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
