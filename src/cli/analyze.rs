//! `ssl analyze`: every file through the method, detections to one output.
//!
//! Nothing is written until a file gives its first frame: when every input fails, an
//! existing `-o` file is left as it was and standard output gets nothing (the errors are
//! on standard error, and the exit status is 1). When some file fails, `-o` is left as
//! it was too, and the results go to `<stem>.partial.<ext>` beside it.

use super::args::{AnalyzeArgs, WarningKind};
use super::inputs::Input;
use super::sink::{same_file, Sink};
use super::{error, output_error, warn, warning_with_hint, with_hint};
use crate::localize::{Output as Found, RunError};
use crate::method::StageTimes;
use crate::record::FileEntry;
use crate::stream::{SampleSource, Warning};
use crate::{Analysis, Exporter, Format, Geometry, Localizer, OutputError, RunMetadata};
use anyhow::Result;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::cell::RefCell;
use std::io::{self, BufWriter, IsTerminal};
use std::path::Path;
use std::time::Instant;

type Out = BufWriter<Sink>;

/// What [`Output::finish`] wrote.
pub(super) enum Written {
    /// Nothing: no file gave a frame.
    Nothing,
    /// The output, of this many bytes.
    Result(u64),
    /// The rows of a run that failed, beside the output; the line that says where.
    Partial(String),
}

/// The output, opened on the first frame of the first file that gives one.
pub(super) struct Output<'a> {
    args: &'a AnalyzeArgs,
    meta: RunMetadata,
    sink: Option<Sink>,
    exporter: Option<Box<dyn Exporter<Out>>>,
    shown: String,
    /// Some input is a pipe or a device: records go out as they are made.
    live_input: bool,
}

impl<'a> Output<'a> {
    /// An output to `sink` with the run's metadata.
    pub(super) fn new(
        args: &'a AnalyzeArgs,
        meta: RunMetadata,
        sink: Sink,
        live_input: bool,
    ) -> Self {
        Output {
            args,
            meta,
            shown: sink.shown().to_string(),
            sink: Some(sink),
            exporter: None,
            live_input,
        }
    }

    /// Ends the output with the files' entries: commits it when `ok`, or sets what was
    /// written aside as `<stem>.partial.<ext>` ([`Sink::set_aside`]).
    pub(super) fn finish(mut self, files: &[FileEntry], ok: bool) -> Result<Written> {
        let Some(exporter) = self.exporter.take() else {
            return Ok(Written::Nothing);
        };
        let buffered = exporter.finish(files).map_err(|e| self.failed(e))?;
        let mut sink = buffered
            .into_inner()
            .map_err(|e| self.failed(e.into_error().into()))?;
        if ok {
            let size = sink.len().map_err(|e| sink.write_error(&e))?;
            sink.commit()?;
            return Ok(Written::Result(size));
        }
        Ok(match sink.set_aside()? {
            Some(note) => Written::Partial(note),
            None => Written::Nothing,
        })
    }

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
            if live && (self.args.format == Format::Ndjson || self.live_input) {
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

/// The localizer of `args` and their inputs, each said once: the geometry's warnings.
pub(super) fn prepare(args: &AnalyzeArgs) -> Result<(Localizer, Vec<Input>)> {
    let geometry = Geometry::from_file(&args.geometry)?;
    for w in &geometry.warnings {
        warn(
            !args.warns(WarningKind::Geometry),
            &format!("{}: {w}", args.geometry.display()),
        );
    }
    let localizer = Localizer::new(geometry, &args.config)?;
    Ok((localizer, super::inputs::expand(args)?))
}

/// Runs `ssl analyze` into one output. Returns whether every file succeeded.
pub fn run(args: &AnalyzeArgs) -> Result<bool> {
    let (localizer, expanded) = prepare(args)?;
    let geometry_path = args.geometry.display().to_string();
    let refused: std::collections::HashMap<String, String> = expanded
        .iter()
        .filter_map(|i| Some((i.path.clone(), i.refused.clone()?)))
        .collect();
    let paths: Vec<String> = expanded.into_iter().map(|i| i.path).collect();
    let mut inputs: Vec<&Path> = paths.iter().map(Path::new).collect();
    inputs.push(&args.geometry);
    let sink = Sink::open(args.output.as_deref(), &inputs)?;
    warn_about_repeats(!args.warns(WarningKind::Repeat), &paths);
    let live_input = paths
        .iter()
        .any(|f| f == "-" || !std::fs::metadata(f).is_ok_and(|m| m.is_file()));
    let mut out = Output::new(args, localizer.metadata(&geometry_path), sink, live_input);

    // Rows written to the terminal would be torn by a bar redrawn between them: no bar.
    let rows_on_terminal = args
        .output
        .as_deref()
        .is_none_or(|o| o == std::path::Path::new("-"))
        && io::stdout().is_terminal();
    let show_progress = !args.quiet && io::stderr().is_terminal() && !rows_on_terminal;
    let mut all_ok = true;
    let mut files = Vec::new();
    let said = SaidOnce::default();
    for path in &paths {
        if let Some(why) = refused.get(path) {
            error(why);
            all_ok = false;
            files.push(FileEntry::new(path, None, Some(why.clone())));
            continue;
        }
        let entry = analyze_one(args, &localizer, path, None, &mut out, show_progress, &said)?;
        all_ok &= entry.error.is_none();
        files.push(entry);
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

/// What has been said once per run (the array's coarse delays and a band's narrowness,
/// per sample rate).
#[derive(Default)]
pub(super) struct SaidOnce(
    std::sync::Mutex<std::collections::HashSet<(std::mem::Discriminant<Warning>, u32)>>,
);

impl SaidOnce {
    /// Whether `w` (at `rate`) is said for the first time in this run.
    fn first(&self, w: &Warning, rate: u32) -> bool {
        self.0
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert((std::mem::discriminant(w), rate))
    }
}

/// Analyses the recording at `path` (read from `file` when it is open already) into
/// `out` (opened on its first frame), saying its error and warnings on stderr; returns
/// its entry. Only an output that fails is an error.
pub(super) fn analyze_one(
    args: &AnalyzeArgs,
    localizer: &Localizer,
    path: &str,
    file: Option<std::fs::File>,
    out: &mut Output,
    show_progress: bool,
    said: &SaidOnce,
) -> Result<FileEntry> {
    let opened = match file {
        Some(file) => localizer.open_file(path, file),
        None => localizer.open(path),
    };
    let mut recording = match opened {
        Ok(r) => r,
        Err(e) => {
            let message = with_hint(&e);
            error(&message);
            return Ok(FileEntry::new(shown_name(path), None, Some(message)));
        }
    };
    if args.timings {
        recording.enable_stage_timing();
    }
    let hop_s =
        recording.analysis().frame_size() as f64 / 2.0 / recording.analysis().sample_rate() as f64;
    let progress = Progress::new(show_progress, recording.analysis());
    // The output opens on the first frame of the first file that gives one.
    let shared = RefCell::new(&mut *out);
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
            }
        },
    );
    progress.finish(&report.summary, report.rows);
    let result = match result {
        Err(RunError::Output(e)) => return Err(out.failed(e)),
        Err(RunError::Input(e)) => Err(e),
        Ok(()) => Ok(()),
    };
    let summary = &report.summary;
    if let Some(times) = &summary.stage_times {
        eprint!(
            "{}",
            timings_table(&summary.name, times, summary.stats.frames, hop_s)
        );
    }
    // A file's own error first, then its remarks.
    let message = result.err().map(|e| with_hint(&e));
    if let Some(e) = &message {
        error(e);
    }
    for w in &summary.warnings {
        // The array's coarse delays are the same for every file at a rate: said once.
        // So is a band's narrowness.
        if let Warning::CoarseDelays { sample_rate, .. } | Warning::NarrowBand { sample_rate, .. } =
            w
        {
            if !said.first(w, *sample_rate) {
                continue;
            }
        }
        warn(
            !args.warns(WarningKind::of(w)),
            &warning_with_hint(&summary.name, w),
        );
    }
    let unconfirmed = report
        .tracking
        .zip(localizer.tracking())
        .and_then(|(stats, p)| stats.nothing_confirmed(p))
        .map(|note| format!("{}: {note}", summary.name));
    if let Some(note) = &unconfirmed {
        warn(!args.warns(WarningKind::Unconfirmed), note);
    }
    Ok(FileEntry::new(shown_name(path), Some(summary), message)
        .with_rows(report.rows)
        .with_tracking(report.tracking)
        .with_warning(unconfirmed))
}

/// The name a recording has in the output: standard input is `<stdin>` in `files[]`
/// as in its rows.
fn shown_name(path: &str) -> &str {
    if path == "-" {
        "<stdin>"
    } else {
        path
    }
}

/// Warns when the same file is given twice (its detections would be written twice).
fn warn_about_repeats(quiet: bool, files: &[String]) {
    for (i, a) in files.iter().enumerate() {
        if let Some(b) = files[..i]
            .iter()
            .find(|b| *b == a || (a != "-" && same_file(Path::new(a), Path::new(b))))
        {
            warn(
                quiet,
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
    fn finish(self, summary: &crate::Summary, rows: u64) {
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

/// `--timings`: each stage's time, per frame and as a share of the stages' sum.
fn timings_table(name: &str, times: &StageTimes, frames: u64, hop_s: f64) -> String {
    let total = times.total().as_secs_f64();
    let audio_s = frames as f64 * hop_s;
    let mut s = format!(
        "ssl: {name}: stage times ({frames} frames, {audio_s:.1} s of audio; {total:.3} s in all, {:.0}x real time per thread)\n",
        audio_s / total.max(1e-9)
    );
    s += &format!(
        "  {:<12} {:>9} {:>7} {:>10}\n",
        "stage", "seconds", "share", "us/frame"
    );
    for (stage, time) in times.stages() {
        let t = time.as_secs_f64();
        s += &format!(
            "  {stage:<12} {t:>9.3} {:>6.1}% {:>10.1}\n",
            100.0 * t / total.max(1e-9),
            1e6 * t / frames.max(1) as f64
        );
    }
    s
}
