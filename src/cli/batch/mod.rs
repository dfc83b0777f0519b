//! `ssl analyze --out-dir DIR`: one result per input at its relative path under DIR (the
//! extension replaced by the format's), each written atomically and never through a
//! link ([`outdir`]): a half-written result never has the result's name. A file that
//! fails never stops the batch and is listed with its reason in the summary that ends
//! the run (on stderr, and with `--format json` in DIR/batch.json); what it gave before
//! it failed goes to `<result stem>.partial.<ext>`, as with `-o`.
//!
//! Nothing is lost: a result is only ever replaced by a run that produced a new one for
//! the same input. A run that fails withdraws an earlier result only on proof that its
//! input changed since (the stamp's contents against the recording's now, at the same
//! path): a failure the options cause (`--start` past the end, `--clock` without a
//! `bext` chunk) leaves every result as it was. A result stamped from another recording
//! (the same relative name from another folder, as recorders name every card's files)
//! is not replaced. The names the batch itself writes (the summaries, the stamps in
//! `.ssl/`, its temporaries) cannot be a result's.
//!
//! `--shard K/N` analyses the K-th of N shares of the inputs ([`deal`]: about equal
//! bytes each), so that N runs on as many machines (GNU parallel over ssh, a Slurm
//! array: contrib/) share one batch and one DIR, each result byte for byte what the
//! whole batch writes; each share's summary is DIR/batch.K-of-N.json. With several
//! threads, a batch analyses one input per thread at a time ([`schedule`]).
//!
//! Each result gets a stamp once it has its name ([`stamp`]); `--resume` skips an input
//! whose stamp matches it and this run's recipe, so a batch stopped at any moment and
//! started again ends with the results of an uninterrupted run: a result renamed but
//! not yet stamped is redone, to the same bytes.

pub(super) mod stamp;

use super::analyze::{analyze_one, prepare, Output, SaidOnce, Written};
use super::args::{AnalyzeArgs, WarningKind};
use super::inputs::Input;
use super::outdir::{Entry, OutDir};
use super::sink::Sink;
use crate::Format;
use anyhow::{bail, Result};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::Serialize;
use stamp::{Fnv, InputId};
use std::collections::HashMap;
use std::fs::File;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The share (from 0) each input falls to among `count` (`--shard K/N`). The inputs are
/// dealt largest first (by file size: the audio to analyse), each to the share with
/// the fewest bytes so far (then the fewest inputs, then the lowest number), so the
/// shares take about equal time; among inputs of one size the order is a hash of the
/// path, so that a pattern in the names (every other file from a busy room) does not
/// fall to one share. Every share computes the same deal from the same inputs.
fn deal(inputs: &[Input], count: usize) -> Vec<usize> {
    use std::cmp::Reverse;
    let sizes: Vec<u64> = inputs
        .iter()
        .map(|i| std::fs::metadata(&i.path).map_or(0, |m| m.len()))
        .collect();
    let mut order: Vec<usize> = (0..inputs.len()).collect();
    order.sort_by_key(|&i| (Reverse(sizes[i]), fnv64(&inputs[i].path), i));
    // Only the first `inputs.len()` shares can get an input (an empty share is always
    // the lowest), so no more are made: `--shard 1/18446744073709551615` costs what
    // `--shard 1/<inputs>` does.
    let mut shares: std::collections::BinaryHeap<Reverse<(u64, usize, usize)>> = (0..count
        .min(inputs.len()))
        .map(|k| Reverse((0, 0, k)))
        .collect();
    let mut dealt = vec![0; inputs.len()];
    for i in order {
        let Reverse((bytes, n, k)) = shares.pop().expect("count >= 1");
        dealt[i] = k;
        shares.push(Reverse((bytes + sizes[i], n + 1, k)));
    }
    dealt
}

fn fnv64(text: &str) -> u64 {
    let mut h = Fnv::new();
    h.bytes(text.as_bytes());
    h.0
}

/// The summary of a batch (DIR/batch.json).
#[derive(Debug, Serialize)]
struct BatchSummary {
    /// The share of the inputs this run analysed (`--shard K/N`), as `K/N`.
    #[serde(skip_serializing_if = "Option::is_none")]
    shard: Option<String>,
    /// Inputs analysed to their end, with a result written.
    done: usize,
    /// Inputs skipped by `--resume`: their result was current.
    skipped: usize,
    /// Inputs that failed: no result.
    failed: usize,
    /// Seconds of audio analysed into the results written (not skipped or failed ones).
    audio_s: f64,
    /// Seconds the batch took.
    wall_s: f64,
    /// Audio seconds per second (`audio_s / wall_s`; 0 when nothing was analysed).
    speed: f64,
    /// Per input: its path, its result (null when it failed) and its error (null when
    /// it did not).
    files: Vec<BatchFile>,
}

#[derive(Debug, Serialize)]
struct BatchFile {
    input: String,
    result: Option<String>,
    /// Whether `--resume` kept its result.
    skipped: bool,
    error: Option<String>,
    /// Where the rows of a recording that failed part-way went (`<stem>.partial.<ext>`).
    #[serde(skip_serializing_if = "Option::is_none")]
    partial: Option<String>,
}

impl BatchFile {
    fn failed(input: &Input, error: String) -> (BatchFile, f64) {
        let file = BatchFile {
            input: input.path.clone(),
            result: None,
            skipped: false,
            error: Some(error),
            partial: None,
        };
        (file, 0.0)
    }
}

/// The extension of `format`'s results.
fn extension(format: Format) -> &'static str {
    match format {
        Format::Csv => "csv",
        Format::Json => "json",
        Format::Ndjson => "ndjson",
    }
}

/// The result path of `input` under DIR for `format`.
fn target(input: &Input, format: Format) -> PathBuf {
    input.relative.with_extension(extension(format))
}

/// Whether `relative` (under DIR) is a name the batch's summaries take: `batch.json`
/// or `batch.K-of-N.json` at the top.
pub fn is_summary_name(relative: &Path) -> bool {
    if relative.parent() != Some(Path::new("")) {
        return false;
    }
    let Some(name) = relative.to_str() else {
        return false;
    };
    let Some(middle) = name
        .strip_prefix("batch")
        .and_then(|n| n.strip_suffix(".json"))
    else {
        return false;
    };
    middle.is_empty()
        || middle
            .strip_prefix('.')
            .and_then(|m| m.split_once("-of-"))
            .is_some_and(|(k, n)| {
                !k.is_empty()
                    && !n.is_empty()
                    && k.bytes().all(|b| b.is_ascii_digit())
                    && n.bytes().all(|b| b.is_ascii_digit())
            })
}

/// The recipe of this run's results ([`stamp::recipe`]): the record kind, the format,
/// the run's metadata and every option but those that choose inputs, threads or what
/// is said on the terminal.
fn recipe(args: &AnalyzeArgs, metadata: &str) -> String {
    let mut a = args.clone();
    a.files.clear();
    a.files_from = None;
    a.glob.clear();
    a.out_dir = None;
    a.resume = false;
    a.shard = None;
    a.threads = 0;
    a.timings = false;
    a.quiet = false;
    stamp::recipe(&format!("{metadata}\n{a:?}"))
}

/// Opens a recording for a batch: a regular file only (a FIFO or a device named in a
/// list would block the batch), opened without waiting.
fn open_recording(path: &str) -> std::result::Result<File, String> {
    use std::os::unix::fs::OpenOptionsExt;
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(rustix::fs::OFlags::NONBLOCK.bits() as i32)
        .open(path)
        .map_err(|e| format!("{path}: cannot open: {}", crate::stream::io_reason(&e)))?;
    let meta = file
        .metadata()
        .map_err(|e| format!("{path}: cannot read: {}", crate::stream::io_reason(&e)))?;
    if !meta.is_file() {
        let kind = meta.file_type();
        use std::os::unix::fs::FileTypeExt;
        let what = if meta.is_dir() {
            "a folder"
        } else if kind.is_fifo() {
            "a FIFO"
        } else if kind.is_socket() {
            "a socket"
        } else {
            "a device"
        };
        return Err(format!(
            "{path}: is {what}, not a recording file; a batch reads regular files (analyse a pipe without --out-dir)"
        ));
    }
    // Reads of a regular file do not wait anyway; the flag is cleared for clarity.
    let _ = rustix::fs::fcntl_setfl(&file, rustix::fs::OFlags::empty());
    Ok(file)
}

/// Runs `ssl analyze --out-dir DIR`; returns whether every input gave its result.
pub fn run(args: &AnalyzeArgs, dir_path: &Path) -> Result<bool> {
    let (localizer, inputs) = prepare(args)?;
    let (localizer, inputs) = (&localizer, &inputs[..]);
    let geometry_path = args.geometry.display().to_string();
    // Two inputs must not write one result.
    let mut seen: HashMap<PathBuf, &str> = HashMap::new();
    for input in inputs.iter().filter(|i| i.refused.is_none()) {
        let t = target(input, args.format);
        if let Some(other) = seen.insert(t.clone(), &input.path) {
            bail!(
                "{} and {} would both write {}: give them from different directories, or analyse them in separate runs",
                other,
                input.path,
                dir_path.join(&t).display()
            );
        }
    }
    let dir = OutDir::open(dir_path)?;
    let swept = dir.sweep();
    if swept > 0 {
        super::warn(
            !args.warns(WarningKind::Batch),
            &format!(
                "{}: removed {swept} temporary file(s) that killed batches on this host left",
                dir_path.display()
            ),
        );
    }
    // A share of the batch: the collision check above saw every input, so that a
    // sharded run refuses what a whole one does.
    let total = inputs.len();
    let shares = args.shard.map(|s| (s.index - 1, deal(inputs, s.count)));
    let inputs: Vec<&Input> = inputs
        .iter()
        .enumerate()
        .filter(|(i, _)| shares.as_ref().is_none_or(|(k, of)| of[*i] == *k))
        .map(|(_, input)| input)
        .collect();
    let started = Instant::now();
    let said = SaidOnce::default();
    let metadata = serde_json::to_value(localizer.metadata(&geometry_path))?;
    let recipe = stamp::Recipe {
        hash: recipe(args, &serde_json::to_string(&metadata)?),
        geometry: metadata.get("geometry").cloned(),
    };
    let progress = BatchProgress::new(args.quiet, inputs.len());
    let dir = &dir;
    // One input to its result: what the summary lists, and the seconds of audio read.
    let one = |input: &Input| -> Result<(BatchFile, f64)> {
        let outcome = one(args, localizer, dir, &recipe, &said, input, &geometry_path);
        if let Ok((file, audio_s)) = &outcome {
            progress.file(file, *audio_s, dir_path);
        }
        outcome
    };
    let (files, audio): (Vec<BatchFile>, Vec<f64>) = schedule(&inputs, one)?.into_iter().unzip();
    progress.bar.finish_and_clear();
    let audio_s: f64 = audio.iter().sum();
    let skipped = files.iter().filter(|f| f.skipped).count();
    let failed = files.iter().filter(|f| f.error.is_some()).count();
    let done = files.len() - skipped - failed;
    let wall_s = started.elapsed().as_secs_f64();
    let summary = BatchSummary {
        shard: args.shard.map(|s| format!("{}/{}", s.index, s.count)),
        done,
        skipped,
        failed,
        audio_s,
        wall_s,
        speed: if done > 0 {
            audio_s / wall_s.max(1e-9)
        } else {
            0.0
        },
        files,
    };
    let share = args
        .shard
        .map(|s| format!(" (share {}/{} of {total})", s.index, s.count))
        .unwrap_or_default();
    let analysed = if summary.done > 0 {
        format!(
            "{} of audio analysed in {:.1} s ({:.0}x real time)",
            hours(summary.audio_s),
            summary.wall_s,
            summary.speed
        )
    } else {
        format!("nothing analysed ({:.1} s)", summary.wall_s)
    };
    eprintln!(
        "ssl: batch: {} input(s){share}: {} done, {} skipped, {} failed; {analysed}; results in {}",
        inputs.len(),
        summary.done,
        summary.skipped,
        summary.failed,
        dir_path.display()
    );
    for f in summary.files.iter().filter(|f| f.error.is_some()) {
        eprintln!(
            "ssl: batch: failed: {}",
            f.error.as_deref().unwrap_or_default()
        );
    }
    if args.format == Format::Json {
        let name = match args.shard {
            Some(s) => format!("batch.{}-of-{}.json", s.index, s.count),
            None => "batch.json".into(),
        };
        let root = dir.folder(Path::new(""), false)?.expect("DIR exists");
        let mut w = std::io::BufWriter::new(Sink::staged(root.stage(name.as_ref())?));
        serde_json::to_writer_pretty(&mut w, &summary)?;
        std::io::Write::write_all(&mut w, b"\n")?;
        w.into_inner().map_err(|e| e.into_error())?.commit()?;
    }
    Ok(summary.failed == 0)
}

/// One input of a batch to its result (or its failure); `Err` only for what must stop
/// the batch (an output that cannot be written part-way).
fn one(
    args: &AnalyzeArgs,
    localizer: &crate::Localizer,
    dir: &OutDir,
    recipe: &stamp::Recipe,
    said: &SaidOnce,
    input: &Input,
    geometry_path: &str,
) -> Result<(BatchFile, f64)> {
    if let Some(why) = &input.refused {
        super::error(why);
        return Ok(BatchFile::failed(input, why.clone()));
    }
    let relative = target(input, args.format);
    let shown = dir.path().join(&relative);
    let fail = |why: String| {
        super::error(&why);
        Ok(BatchFile::failed(input, why))
    };
    if args.format == Format::Json && is_summary_name(&relative) {
        return fail(format!(
            "{}: its result would be {}, the name of the batch's summary: give it another path under the archive (a subfolder, or a --files-from line)",
            input.path,
            shown.display()
        ));
    }
    // The recording as opened: what is analysed, and what its stamp describes.
    let (file, id) = if input.path == "-" {
        (None, None)
    } else {
        let file = match open_recording(&input.path) {
            Ok(f) => f,
            Err(why) => return fail(why),
        };
        match InputId::of(&file, &input.path, &input.relative) {
            Ok(id) => (Some(file), Some(id)),
            Err(e) => {
                return fail(format!(
                    "{}: cannot read: {}",
                    input.path,
                    crate::stream::io_reason(&e)
                ))
            }
        }
    };
    // Both folders are opened (and made) before the analysis: a link on the way to
    // either fails this input before any work.
    let places = stamp::open(dir, &relative, true)
        .and_then(|s| Ok((stamp::result_folder(dir, &relative, true)?, s)));
    let ((folder, name), (stamps, stamp_name)) = match places {
        Ok((Some(r), Some(s))) => (r, s),
        Ok(_) => unreachable!("made when missing"),
        Err(e) => return fail(format!("{e:#}")),
    };
    let old = stamp::read(&stamps, &stamp_name);
    let existing = folder.entry(&name).unwrap_or(Entry::Missing);
    if let (Some(id), Some(old)) = (&id, &old) {
        if args.resume
            && old.recipe == recipe.hash
            && old.input.relative == id.relative
            && old.input.same_contents(id)
            && existing == Entry::File(old.result_size)
        {
            let file = BatchFile {
                input: input.path.clone(),
                result: Some(shown.display().to_string()),
                skipped: true,
                error: None,
                partial: None,
            };
            return Ok((file, 0.0));
        }
        if old.input.path != id.path
            && !old.input.same_contents(id)
            && matches!(existing, Entry::File(_))
        {
            return fail(format!(
                "{}: holds the result of {}, another recording; it is not replaced by the result of {} (choose another --out-dir, or remove it)",
                shown.display(),
                old.input.path,
                input.path
            ));
        }
    }
    let staged = match folder.stage(&name) {
        Ok(s) => s,
        Err(e) => return fail(format!("{e:#}")),
    };
    let sink = Sink::staged(staged);
    let mut out = Output::new(args, localizer.metadata(geometry_path), sink, false);
    let watch = file.as_ref().and_then(|f| f.try_clone().ok());
    let entry = analyze_one(args, localizer, &input.path, file, &mut out, false, said)?;
    let mut error = entry.error.clone();
    if let (Some(id), Some(watch)) = (&id, &watch) {
        if error.is_none() && id.moved(watch) {
            let why = format!(
                "{}: changed while it was analysed (its size or time moved); analyse it again once it is complete",
                input.path
            );
            super::error(&why);
            error = Some(why);
        }
    }
    let audio_s = match (entry.frames, entry.frame_size, entry.sample_rate) {
        (Some(frames), Some(n), Some(rate)) if frames > 0 => {
            ((frames - 1) as f64 * n as f64 / 2.0 + n as f64) / rate as f64
        }
        _ => 0.0,
    };
    let partial_name = super::sink::partial_name(Path::new(&name));
    let ok = error.is_none();
    let mut partial = None;
    match out.finish(&[entry], ok)? {
        Written::Result(size) => {
            // Replaced atomically: a run stopped between the result and its stamp
            // leaves the old stamp, which matches only when the bytes are the same.
            if let Some(id) = &id {
                stamp::write(&stamps, &stamp_name, &relative, id, recipe, size).map_err(|e| {
                    anyhow::anyhow!("{}: cannot stamp the result: {e:#}", shown.display())
                })?;
            }
            // A partial result of an earlier failure is out of date now.
            let _ = folder.remove(partial_name.as_os_str());
            let file = BatchFile {
                input: input.path.clone(),
                result: Some(shown.display().to_string()),
                skipped: false,
                error: None,
                partial: None,
            };
            return Ok((file, audio_s));
        }
        Written::Partial(note) => {
            super::error(&note);
            partial = Some(folder.path().join(&partial_name).display().to_string());
        }
        Written::Nothing => {}
    }
    let error = error.unwrap_or_else(|| "nothing was analysed".into());
    // Withdrawn only on proof that the recording changed since its result was made:
    // the stamp names this very file, with other contents than it has now.
    if let (Some(id), Some(old)) = (&id, &old) {
        if old.input.path == id.path && !old.input.same_contents(id) {
            let _ = stamps.remove(&stamp_name);
            let _ = folder.remove(&name);
        }
    }
    let file = BatchFile {
        input: input.path.clone(),
        result: None,
        skipped: false,
        error: Some(error),
        partial,
    };
    Ok((file, 0.0))
}

/// What a batch shows on a terminal: a bar over its inputs, and a line per input.
struct BatchProgress {
    bar: ProgressBar,
    show: bool,
    count: usize,
    done: std::sync::atomic::AtomicUsize,
}

impl BatchProgress {
    fn new(quiet: bool, count: usize) -> Self {
        let show = !quiet && std::io::stderr().is_terminal();
        let bar = if show {
            ProgressBar::with_draw_target(Some(count as u64), ProgressDrawTarget::stderr())
                .with_style(
                    ProgressStyle::with_template("batch [{bar:25}] {pos}/{len} inputs, {elapsed}")
                        .expect("valid template")
                        .progress_chars("=> "),
                )
        } else {
            ProgressBar::hidden()
        };
        BatchProgress {
            bar,
            show,
            count,
            done: Default::default(),
        }
    }

    fn file(&self, f: &BatchFile, audio_s: f64, dir: &Path) {
        let n = self.done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        if !self.show {
            return;
        }
        let what = if f.skipped {
            "current, skipped".to_string()
        } else if f.error.is_some() {
            "failed".to_string()
        } else {
            format!(
                "{} of audio -> {}",
                hours(audio_s),
                f.result
                    .as_deref()
                    .map(Path::new)
                    .and_then(|r| r.strip_prefix(dir).ok())
                    .unwrap_or(Path::new(""))
                    .display()
            )
        };
        self.bar.println(format!(
            "ssl: batch: [{n}/{}] {}: {what}",
            self.count, f.input
        ));
        self.bar.inc(1);
    }
}

/// Runs `one` on every input, in input order: with one thread (or fewer inputs than
/// threads), one input after another, each analysed by every thread; otherwise one
/// input per thread at a time, each analysed by its thread alone, which costs no
/// synchronisation per frame (the results are the same bytes either way). An error of
/// `one` (an output that cannot be written) stops the batch.
fn schedule<T: Send>(
    inputs: &[&Input],
    one: impl Fn(&Input) -> Result<T> + Sync,
) -> Result<Vec<T>> {
    let lanes = rayon::current_num_threads();
    if lanes <= 1 || inputs.len() < lanes {
        return inputs.iter().map(|input| one(input)).collect();
    }
    let next = std::sync::atomic::AtomicUsize::new(0);
    let stop = std::sync::atomic::AtomicBool::new(false);
    let slots: Vec<std::sync::Mutex<Option<Result<T>>>> =
        inputs.iter().map(|_| std::sync::Mutex::new(None)).collect();
    std::thread::scope(|scope| {
        for _ in 0..lanes {
            scope.spawn(|| {
                // The analysis inside sees one thread: no work is split per frame.
                let Ok(pool) = rayon::ThreadPoolBuilder::new().num_threads(1).build() else {
                    return;
                };
                pool.install(|| {
                    use std::sync::atomic::Ordering::Relaxed;
                    while !stop.load(Relaxed) {
                        let i = next.fetch_add(1, Relaxed);
                        let Some(input) = inputs.get(i) else { break };
                        let outcome = one(input);
                        if outcome.is_err() {
                            stop.store(true, Relaxed);
                        }
                        *slots[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(outcome);
                    }
                });
            });
        }
    });
    let mut out = Vec::with_capacity(inputs.len());
    for (slot, input) in slots.into_iter().zip(inputs) {
        match slot.into_inner().unwrap_or_else(|e| e.into_inner()) {
            Some(outcome) => out.push(outcome?),
            // Not reached: an earlier error stopped the batch (and is returned above),
            // or a thread could not start.
            None => bail!("{}: not analysed: a thread could not start", input.path),
        }
    }
    Ok(out)
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
