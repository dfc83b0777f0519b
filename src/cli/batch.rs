//! `ssl analyze --out-dir DIR`: one result per input at its relative path under DIR (the
//! extension replaced by the format's), each written atomically: a half-written result
//! never has the result's name. A file that fails has no result, never stops the batch,
//! and is listed with its reason in the summary that ends the run (on stderr, and with
//! `--format json` in DIR/batch.json).
//!
//! `--shard K/N` analyses the K-th of N shares of the inputs ([`deal`]: about equal
//! bytes each), so that N runs on as many machines (GNU parallel over ssh, a Slurm
//! array: contrib/) share one batch and one DIR, each result byte for byte what the
//! whole batch writes; each share's summary is DIR/batch.K-of-N.json. With several
//! threads, a batch analyses one input per thread at a time ([`schedule`]).
//!
//! Each result gets a stamp once it has its name, `DIR/.ssl/<result>.json`: the input's
//! size and modification time, a hash of the run's metadata (the geometry as understood,
//! every parameter, the version) and the result's size. `--resume` skips an input whose
//! stamp matches, so a batch stopped at any moment and started again ends with the
//! results of an uninterrupted run: a result renamed but not yet stamped is redone, to
//! the same bytes. Size and time rather than a hash of the audio: resuming a finished
//! archive must cost seconds, and reading every recording again costs what analysing
//! it does at this tool's speed; a recording rewritten in place changes its time.

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

/// What a result was made from (DIR/.ssl/<result>.json).
#[derive(Debug, Serialize, serde::Deserialize, PartialEq)]
struct Stamp {
    input_size: u64,
    input_mtime_ns: u128,
    /// FNV-1a of the run's metadata as JSON (tool version, geometry, parameters).
    run: String,
    result_size: u64,
}

impl Stamp {
    /// The stamp `input` would get now for a result of `result_size` bytes (`None`: its
    /// size or time cannot be read, as for standard input).
    fn of(input: &str, run: &str, result_size: u64) -> Option<Stamp> {
        let meta = std::fs::metadata(input).ok().filter(|m| m.is_file())?;
        let mtime = meta.modified().ok()?;
        let since = mtime.duration_since(std::time::UNIX_EPOCH).ok()?;
        Some(Stamp {
            input_size: meta.len(),
            input_mtime_ns: since.as_nanos(),
            run: run.to_string(),
            result_size,
        })
    }

    fn path(dir: &Path, result: &Path) -> PathBuf {
        let relative = result.strip_prefix(dir).unwrap_or(result);
        let mut p = dir.join(".ssl").join(relative).into_os_string();
        p.push(".json");
        PathBuf::from(p)
    }

    /// Whether `result` is complete and was made from `input` by this run's settings.
    fn current(dir: &Path, result: &Path, input: &str, run: &str) -> bool {
        let Ok(size) = std::fs::metadata(result).map(|m| m.len()) else {
            return false;
        };
        let Some(now) = Stamp::of(input, run, size) else {
            return false;
        };
        std::fs::read(Stamp::path(dir, result))
            .ok()
            .and_then(|b| serde_json::from_slice::<Stamp>(&b).ok())
            .is_some_and(|saved| saved == now)
    }

    /// Removes the result of an input that failed, when a stamp shows this tool made it
    /// (from an earlier version of the input): a result must not outlive the recording
    /// it describes. The stamp goes first, so that a run stopped between the two leaves
    /// an unstamped result, which `--resume` redoes.
    fn withdraw(dir: &Path, result: &Path) {
        let stamp = Stamp::path(dir, result);
        if std::fs::remove_file(&stamp).is_ok() {
            let _ = std::fs::remove_file(result);
        }
    }

    /// Writes the stamp of `result`, atomically.
    fn write(dir: &Path, result: &Path, input: &str, run: &str) -> Result<()> {
        let size = std::fs::metadata(result)?.len();
        let Some(stamp) = Stamp::of(input, run, size) else {
            return Ok(());
        };
        let path = Stamp::path(dir, result);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)?;
        }
        let mut sink = Sink::open(Some(&path), &[])?;
        serde_json::to_writer(&mut sink, &stamp)?;
        sink.commit()
    }
}

/// FNV-1a, 64 bits.
fn fnv64(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// FNV-1a, 64 bits, as hex.
fn fnv(text: &str) -> String {
    format!("{:016x}", fnv64(text))
}

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
    let mut shares: std::collections::BinaryHeap<Reverse<(u64, usize, usize)>> =
        (0..count).map(|k| Reverse((0, 0, k))).collect();
    let mut dealt = vec![0; inputs.len()];
    for i in order {
        let Reverse((bytes, n, k)) = shares.pop().expect("count >= 1");
        dealt[i] = k;
        shares.push(Reverse((bytes + sizes[i], n + 1, k)));
    }
    dealt
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
    /// Whether `--resume` kept its result.
    skipped: bool,
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
    let said = Said::default();
    let run = fnv(&serde_json::to_string(&localizer.metadata(&geometry_path))?);
    // One input to its result: what the summary lists, and the seconds of audio read.
    let one = |input: &Input| -> Result<(BatchFile, f64)> {
        let t = target(dir, input, args.format);
        if args.resume && Stamp::current(dir, &t, &input.path, &run) {
            let file = BatchFile {
                input: input.path.clone(),
                result: Some(t.display().to_string()),
                skipped: true,
                error: None,
            };
            return Ok((file, 0.0));
        }
        if let Some(parent) = t.parent() {
            std::fs::create_dir_all(parent)
                .with_context(|| format!("{}: cannot create the directory", parent.display()))?;
        }
        let sink = Sink::open(Some(&t), &[Path::new(&input.path), &args.geometry])?;
        let mut out = Output::new(args, localizer.metadata(&geometry_path), sink, false);
        let entry = analyze_one(args, localizer, &input.path, &mut out, false, &said)?;
        let audio_s = match (entry.frames, entry.frame_size, entry.sample_rate) {
            (Some(frames), Some(n), Some(rate)) if frames > 0 => {
                ((frames - 1) as f64 * n as f64 / 2.0 + n as f64) / rate as f64
            }
            _ => 0.0,
        };
        let error = entry.error.clone();
        let ok = error.is_none() && out.finish_into(&[entry])?;
        if ok {
            Stamp::write(dir, &t, &input.path, &run)
                .with_context(|| format!("{}: cannot stamp the result", t.display()))?;
        } else {
            Stamp::withdraw(dir, &t);
        }
        let file = BatchFile {
            input: input.path.clone(),
            result: ok.then(|| t.display().to_string()),
            skipped: false,
            error: if ok {
                None
            } else {
                Some(error.unwrap_or_else(|| "nothing was analysed".into()))
            },
        };
        Ok((file, audio_s))
    };
    let (files, audio): (Vec<BatchFile>, Vec<f64>) = schedule(&inputs, one)?.into_iter().unzip();
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
        speed: audio_s / wall_s.max(1e-9),
        files,
    };
    let share = args
        .shard
        .map(|s| format!(" (share {}/{} of {total})", s.index, s.count))
        .unwrap_or_default();
    eprintln!(
        "ssl: batch: {} input(s){share}: {} done, {} skipped, {} failed; {} of audio in {:.1} s ({:.0}x real time); results in {}",
        inputs.len(),
        summary.done,
        summary.skipped,
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
        let path = dir.join(match args.shard {
            Some(s) => format!("batch.{}-of-{}.json", s.index, s.count),
            None => "batch.json".into(),
        });
        let sink = Sink::open(Some(&path), &[])?;
        let mut w = std::io::BufWriter::new(sink);
        serde_json::to_writer_pretty(&mut w, &summary)?;
        std::io::Write::write_all(&mut w, b"\n")?;
        w.into_inner().map_err(|e| e.into_error())?.commit()?;
    }
    Ok(summary.failed == 0)
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
