//! `ssl analyze`: every file through the method, detections to one output.
//!
//! Nothing is written until a file gives its first frame: when every input fails, an
//! existing `-o` file is left as it was and standard output gets nothing (the errors are
//! on standard error, and the exit status is 1). When some file fails, `-o` is left as
//! it was too, and the results go to `<stem>.partial.<ext>` beside it.

use super::args::AnalyzeArgs;
use super::sink::{same_file, Sink};
use super::{error, output_error, warn, warning_with_hint, with_hint};
use anyhow::Result;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use ssl::localize::{Output as Found, RunError};
use ssl::record::FileEntry;
use ssl::stream::{SampleSource, Warning};
use ssl::{Analysis, Exporter, Format, Geometry, Localizer, OutputError, RunMetadata};
use std::cell::RefCell;
use std::io::{self, BufWriter, IsTerminal};
use std::path::Path;
use std::time::Instant;

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
                .exporter(BufWriter::with_capacity(1 << 16, sink), self.args.records());
            // Records go out as they are made to a reader of standard output that waits
            // for them: always as NDJSON, in every format when the input is live.
            let live_input = self
                .args
                .files
                .iter()
                .any(|f| f == "-" || !std::fs::metadata(f).is_ok_and(|m| m.is_file()));
            if live && (self.args.format == Format::Ndjson || live_input) {
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
    let localizer = Localizer::new(geometry, &args.options())?;
    let mut inputs: Vec<&Path> = args.files.iter().map(Path::new).collect();
    inputs.push(&args.geometry);
    let sink = Sink::open(args.output.as_deref(), &inputs)?;
    warn_about_repeats(args);
    let mut out = Output {
        args,
        meta: localizer.metadata(&geometry_path),
        shown: sink.shown().to_string(),
        sink: Some(sink),
        exporter: None,
    };

    // Rows written to the terminal would be torn by a bar redrawn between them: no bar.
    let rows_on_terminal = args
        .output
        .as_deref()
        .is_none_or(|o| o == std::path::Path::new("-"))
        && io::stdout().is_terminal();
    let show_progress = !args.quiet && io::stderr().is_terminal() && !rows_on_terminal;
    let mut all_ok = true;
    let mut files = Vec::new();
    let mut coarse_said = std::collections::HashSet::new();
    for path in &args.files {
        let recording = match localizer.open(path) {
            Ok(r) => r,
            Err(e) => {
                let message = with_hint(&e);
                error(&message);
                files.push(FileEntry::new(path, None, Some(message)));
                all_ok = false;
                continue;
            }
        };
        let progress = Progress::new(show_progress, recording.analysis());
        // The output opens on the first frame of the first file that gives one.
        let shared = RefCell::new(&mut out);
        let (report, result) = recording.run_observed(
            |index| {
                progress.frame(index);
                shared.borrow_mut().exporter().map(|_| ())
            },
            |found| {
                let mut out = shared.borrow_mut();
                let exporter = out.exporter()?;
                match found {
                    Found::Row(row) => exporter.detection(&row),
                    Found::Event(event) => exporter.event(&event),
                    Found::Source(source) => exporter.source(&source),
                    _ => Ok(()),
                }
            },
        );
        progress.finish(&report.summary, report.rows);
        let result = match result {
            Err(RunError::Output(e)) => return Err(out.failed(e)),
            Err(RunError::Input(e)) => Err(e),
            Err(e) => return Err(e.into()),
            Ok(()) => Ok(()),
        };
        let summary = &report.summary;
        // A file's own error first, then its remarks.
        let message = result.err().map(|e| with_hint(&e));
        if let Some(e) = &message {
            error(e);
            all_ok = false;
        }
        for w in &summary.warnings {
            // The array's coarse delays are the same for every file at a rate: said once.
            // So is a band's narrowness.
            if let Warning::CoarseDelays { sample_rate, .. }
            | Warning::NarrowBand { sample_rate, .. } = w
            {
                if !coarse_said.insert((std::mem::discriminant(w), *sample_rate)) {
                    continue;
                }
            }
            warn(args.quiet, &warning_with_hint(&summary.name, w));
        }
        let unconfirmed = report
            .tracking
            .zip(localizer.tracking())
            .and_then(|(stats, p)| nothing_confirmed(&stats, p))
            .map(|note| format!("{}: {note}", summary.name));
        if let Some(note) = &unconfirmed {
            warn(args.quiet, note);
        }
        files.push(
            FileEntry::new(path, Some(summary), message)
                .with_rows(report.rows)
                .with_tracking(report.tracking)
                .with_warning(unconfirmed),
        );
    }
    let Some(exporter) = out.exporter.take() else {
        // Nothing was analysed: nothing is written, an existing file stays as it was.
        return Ok(false);
    };
    let buffered = exporter.finish(&files).map_err(|e| out.failed(e))?;
    let sink = buffered
        .into_inner()
        .map_err(|e| out.failed(e.into_error().into()))?;
    if all_ok {
        sink.commit()?;
    } else if let Some(note) = sink.set_aside()? {
        // A failed run leaves `-o` as it was; what was read is kept under another name.
        error(&note);
    }
    Ok(all_ok)
}

/// Why a tracked file gave no row although the method detected something: every
/// detection (candidates included) was isolated, and the tracker with parameters `p`
/// dropped it (or, with `--keep-unconfirmed`, wrote it without a source), with the rule
/// a track needs. `None` when a track was confirmed or nothing was detected (the
/// method's own warnings say why).
fn nothing_confirmed(
    stats: &ssl::track::TrackStats,
    p: &ssl::track::TrackParams,
) -> Option<String> {
    (stats.rows == 0 && stats.unconfirmed > 0).then(|| {
        let rule = match p.confirm_by {
            ssl::track::ConfirmBy::Rules => format!(
                "a track starts from {} detections above the threshold within --confirm-s, {} of which 1 is above it, or {} candidates",
                p.confirm_hits, p.confirm_candidates, p.confirm_weak
            ),
            ssl::track::ConfirmBy::Evidence => format!(
                "none gathered the evidence a source needs for at most {} false sources an hour (--false-per-hour)",
                p.false_per_hour
            ),
        };
        if p.keep_unconfirmed {
            format!(
                "no source confirmed: all {} detections (candidates included) were isolated ({rule}); they are written with an empty source",
                stats.unconfirmed
            )
        } else {
            format!(
                "no source confirmed: the tracker dropped all {} detections (candidates included) as isolated ({rule}); --keep-unconfirmed writes them with an empty source, --no-track writes every frame's detection",
                stats.unconfirmed
            )
        }
    })
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

/// The progress of one file on a terminal: audio time done and total, speed, ETA; then
/// one summary line.
struct Progress {
    bar: ProgressBar,
    show: bool,
    name: String,
    hop_s: f64,
    frame_s: f64,
    total_s: Option<f64>,
    started: Instant,
}

impl Progress {
    fn new<S: SampleSource>(show: bool, analysis: &Analysis<S>) -> Self {
        let rate = analysis.sample_rate() as f64;
        let n = analysis.frame_size() as f64;
        let name = analysis.name().to_string();
        let bar = if show {
            let bar = match analysis.total_frames() {
                Some(t) => ProgressBar::with_draw_target(Some(t), ProgressDrawTarget::stderr())
                    .with_style(
                        ProgressStyle::with_template("{prefix} [{bar:25}] {msg}")
                            .expect("valid template")
                            .progress_chars("=> "),
                    ),
                None => ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr())
                    .with_style(
                        ProgressStyle::with_template("{prefix} {spinner} {msg}")
                            .expect("valid template"),
                    ),
            };
            bar.set_prefix(name.clone());
            bar
        } else {
            ProgressBar::hidden()
        };
        Progress {
            bar,
            show,
            name,
            hop_s: n / 2.0 / rate,
            frame_s: n / rate,
            total_s: analysis.duration_s(),
            started: Instant::now(),
        }
    }

    /// Shows frame `index` done.
    fn frame(&self, index: u64) {
        if !self.show || index % 64 != 0 {
            return;
        }
        self.bar.set_position(index);
        let done = index as f64 * self.hop_s + self.frame_s;
        let wall = self.started.elapsed().as_secs_f64().max(1e-6);
        let speed = done / wall;
        let mut msg = match self.total_s {
            Some(total) => format!("{} of {}", clock(done.min(total)), clock(total)),
            None => clock(done),
        };
        msg += &format!(", {speed:.0}x real time");
        if let Some(total) = self.total_s {
            msg += &format!(", ETA {}", clock(((total - done) / speed).max(0.0)));
        }
        self.bar.set_message(msg);
    }

    /// Clears the bar and, on a terminal, prints what the file gave.
    fn finish(self, summary: &ssl::Summary, rows: u64) {
        self.bar.finish_and_clear();
        if self.show {
            let frames = summary.stats.frames;
            let audio = if frames == 0 {
                0.0
            } else {
                (frames - 1) as f64 * self.hop_s + self.frame_s
            };
            let wall = self.started.elapsed().as_secs_f64().max(1e-6);
            eprintln!(
                "{}: {} of audio in {:.1} s ({:.0}x real time), {rows} rows ({} frames with a detection)",
                self.name,
                clock(audio),
                wall,
                audio / wall,
                summary.stats.detections
            );
        }
    }
}

/// Seconds as `m:ss.s` (or `h:mm:ss`).
fn clock(s: f64) -> String {
    let s = s.max(0.0);
    if s >= 3600.0 {
        let t = s.round() as u64;
        format!("{}:{:02}:{:02}", t / 3600, t / 60 % 60, t % 60)
    } else {
        format!("{}:{:04.1}", (s / 60.0).floor() as u64, s % 60.0)
    }
}
