//! `ssl evaluate`: score results against their truth: one recording against one truth,
//! or many recordings (folders of results, a concatenation) each against its own truth
//! in a folder of truths, then pooled.

use super::args::{EvaluateArgs, MetricArg};
use super::results::{expand, ResultFile};
use crate::evaluate::{evaluate_by, pool, Metric, Pooled, Report};
use crate::record::{read_records_with_info, DetectionRecord, EventRecord, ResultInfo};
use crate::stream::{io_reason, read_text_from};
use crate::{Geometry, Truth};
use anyhow::{bail, Context, Result};
use serde::Serialize;
use std::path::{Component, Path, PathBuf};

/// Runs `ssl evaluate`. `-` reads the result (or the truth) from standard input.
/// Returns whether every recording was scored.
pub fn run(args: &EvaluateArgs) -> Result<bool> {
    let results = expand(&args.results)?;
    if args.truth != Path::new("-") && args.truth.is_dir() {
        return many(args, &results);
    }
    let truth = if args.truth == Path::new("-") {
        let text = read_text_from(std::io::stdin().lock(), crate::record::MAX_TRUTH_BYTES)
            .map_err(|e| anyhow::anyhow!("<stdin>: cannot read: {}", io_reason(&e)))?;
        Truth::from_text(&text).context("<stdin>")?
    } else {
        Truth::from_file(&args.truth)?
    };
    let (mut detections, mut events) = (Vec::new(), Vec::new());
    let mut geometry = None;
    for r in &results {
        let (rows, written, info) = read_records_with_info(&r.path)?;
        detections.extend(rows);
        events.extend(written);
        geometry = geometry.or_else(|| array(&r.path, &info));
    }
    let shown = results
        .iter()
        .map(|r| r.path.display().to_string())
        .collect::<Vec<_>>();
    let detections = drop_repeats(detections, &shown.join(", "));
    let geometry = match &args.score.geometry {
        Some(path) => Some(Geometry::from_file(path)?),
        None => geometry,
    };
    let metric = metric(args.score.metric, geometry.as_ref())?;
    let names = shown.join(", ");
    let (tail, rule) = tail(args.score.tail, &truth, &detections);
    let shown = results[0].path.display();
    let events = (!events.is_empty()).then_some(events.as_slice());
    let report = evaluate_by(&truth, &detections, events, tail, &metric)
        .map(|r| with_rule(r, rule))
        .map_err(|e| match e {
            crate::evaluate::EvaluateError::SeveralFiles(_) => anyhow::anyhow!(
                "{shown}: {e}, or give --truth a folder holding each one's truth (NAME.truth.json)"
            ),
            e => anyhow::anyhow!("{shown}: {e}"),
        })?;
    let text = if args.json {
        serde_json::to_string_pretty(&report)? + "\n"
    } else {
        report.table()
    };
    super::print(text.as_bytes())?;
    // Said once the report is out (an error is the only line when there is one).
    if truth.sources.iter().all(|s| !s.azimuth_only) {
        warn_if_unknown_array(args.score.metric, geometry.as_ref(), &names);
    }
    Ok(true)
}

/// The tail `--tail` gives, or the default for the rows (one frame, and half the
/// truth's RT60 when it has a room), with where it comes from. `ssl plot` takes the
/// same.
pub(super) fn tail(
    given: Option<f32>,
    truth: &Truth,
    rows: &[crate::DetectionRecord],
) -> (f64, String) {
    match given {
        Some(t) => (f64::from(t), "--tail".into()),
        None => crate::evaluate::default_tail(truth, rows),
    }
}

/// `report` saying where its tail comes from.
pub(super) fn with_rule(
    mut report: crate::evaluate::Report,
    rule: String,
) -> crate::evaluate::Report {
    report.tail_rule = rule;
    report
}

/// Says once that `shown` is scored by the 3-D angle only because nothing named its
/// array: a planar or linear array's errors would then be its elevation's.
pub(super) fn warn_if_unknown_array(
    arg: Option<MetricArg>,
    geometry: Option<&Geometry>,
    shown: &str,
) {
    if arg.is_none() && geometry.is_none() {
        super::warn(
            false,
            &format!("{shown}: scored by the 3-D angle: the result does not name its array (a CSV or NDJSON result names it only in an --out-dir folder, through its stamp); for a planar or linear array give -g ARRAY.toml, or --metric azimuth, to score what it observes"),
        );
    }
}

/// The metric `--metric` asks for, or what `geometry` observes.
pub(super) fn metric(arg: Option<MetricArg>, geometry: Option<&Geometry>) -> Result<Metric> {
    Metric::asked(arg.map(MetricArg::name), geometry).map_err(|e| {
        anyhow::anyhow!("--metric {e}: give it with --geometry (a JSON result carries it)")
    })
}

/// The array a result names: a JSON result's own, or a CSV or NDJSON result's batch
/// stamp's (`--out-dir`).
pub(super) fn array(path: &Path, info: &ResultInfo) -> Option<Geometry> {
    info.array()
        .or_else(|| super::batch::stamp::stamped_array(path))
}

/// One recording's rows and events, as the results name it, with the geometry its
/// result carries.
struct Recording {
    name: String,
    rows: Vec<DetectionRecord>,
    events: Vec<EventRecord>,
    geometry: Option<Geometry>,
}

/// The recordings one result holds, in order of first appearance. A result without
/// rows (an empty NDJSON file, a CSV header) stands for the recording its path names.
fn recordings(r: &ResultFile) -> Result<Vec<Recording>> {
    let empty = r.relative.is_some() && std::fs::metadata(&r.path).is_ok_and(|m| m.len() == 0);
    let (rows, events, info) = if empty {
        (Vec::new(), Vec::new(), ResultInfo::default())
    } else {
        read_records_with_info(&r.path)?
    };
    let geometry = array(&r.path, &info);
    if rows.is_empty() && events.is_empty() {
        let name = r.relative.as_deref().unwrap_or(&r.path);
        return Ok(vec![Recording {
            name: name.display().to_string(),
            rows,
            events,
            geometry,
        }]);
    }
    let mut out: Vec<Recording> = Vec::new();
    let mut index: std::collections::HashMap<String, usize> = Default::default();
    let mut place = |file: &str, out: &mut Vec<Recording>| match index.get(file) {
        Some(&i) => i,
        None => {
            index.insert(file.to_string(), out.len());
            out.push(Recording {
                name: file.to_string(),
                rows: Vec::new(),
                events: Vec::new(),
                geometry: geometry.clone(),
            });
            out.len() - 1
        }
    };
    for row in drop_repeats(rows, &r.path.display().to_string()) {
        let i = place(&row.file, &mut out);
        out[i].rows.push(row);
    }
    for event in events {
        let i = place(&event.file, &mut out);
        out[i].events.push(event);
    }
    Ok(out)
}

/// `rows` without repeats: a row of one run is never repeated whole (its recording,
/// time, direction and source), so a repeat is the same result given twice
/// (`cat a.csv a.csv`); it is counted once, and said.
fn drop_repeats(rows: Vec<DetectionRecord>, shown: &str) -> Vec<DetectionRecord> {
    let mut seen = std::collections::HashSet::new();
    let mut repeated: std::collections::BTreeMap<String, usize> = Default::default();
    let kept = rows
        .into_iter()
        .filter(|row| {
            let key = (
                row.file.clone(),
                row.time_s.to_bits(),
                [row.x, row.y, row.z].map(f64::to_bits),
                row.source,
            );
            let first = seen.insert(key);
            if !first {
                *repeated.entry(row.file.clone()).or_default() += 1;
            }
            first
        })
        .collect();
    for (file, n) in repeated {
        super::warn(
            false,
            &format!(
                "{shown}: {n} row(s) of {file} appear twice (the same result given twice?); each is counted once"
            ),
        );
    }
    kept
}

/// The truth of the recording `name` under `dir`: `PART.truth.json` or
/// `PART.truth.csv`, PART the longest trailing part of the name (its extension dropped)
/// that has one.
pub(super) fn truth_path(dir: &Path, name: &str) -> Option<PathBuf> {
    let stem = Path::new(name).with_extension("");
    let parts: Vec<&std::ffi::OsStr> = stem
        .components()
        .filter_map(|c| match c {
            Component::Normal(p) => Some(p),
            _ => None,
        })
        .collect();
    (0..parts.len()).find_map(|from| {
        let stem: PathBuf = parts[from..].iter().collect();
        ["truth.json", "truth.csv"].iter().find_map(|ext| {
            let mut p = dir.join(&stem).into_os_string();
            p.push(".");
            p.push(ext);
            let p = PathBuf::from(p);
            p.is_file().then_some(p)
        })
    })
}

/// One recording's line of the report.
#[derive(Serialize)]
struct Scored {
    recording: String,
    truth: String,
    report: Report,
}

/// The report of many recordings.
#[derive(Serialize)]
struct ManyReport {
    /// Per recording with a truth.
    recordings: Vec<Scored>,
    /// All of them pooled.
    pooled: Pooled,
    /// Recordings with no truth under the folder.
    without_truth: Vec<String>,
    /// Recordings that could not be scored, with the reason.
    failed: Vec<Failed>,
}

#[derive(Serialize)]
struct Failed {
    recording: String,
    error: String,
}

fn many(args: &EvaluateArgs, results: &[ResultFile]) -> Result<bool> {
    let given = match &args.score.geometry {
        Some(path) => Some(Geometry::from_file(path)?),
        None => None,
    };
    let mut scored = Vec::new();
    let mut without_truth = Vec::new();
    let mut failed = Vec::new();
    // Each result is scored as it is read, and its rows dropped: the memory is one
    // result's rows (and every counted detection's error, for the pooled median).
    let mut seen = std::collections::HashSet::new();
    for rec in results.iter().map(recordings).flat_map(|r| match r {
        Ok(recs) => recs.into_iter().map(Ok).collect::<Vec<_>>(),
        Err(e) => vec![Err(e)],
    }) {
        let rec = rec?;
        if !seen.insert(rec.name.clone()) {
            failed.push(Failed {
                error: "its rows are split over two results (scored from the first alone): give them as one (cat)".into(),
                recording: rec.name,
            });
            continue;
        }
        let Some(path) = truth_path(&args.truth, &rec.name) else {
            without_truth.push(rec.name);
            continue;
        };
        let outcome = Truth::from_file(&path)
            .map_err(anyhow::Error::from)
            .and_then(|truth| {
                let metric = metric(args.score.metric, given.as_ref().or(rec.geometry.as_ref()))?;
                let (tail, rule) = tail(args.score.tail, &truth, &rec.rows);
                let events = (!rec.events.is_empty()).then_some(rec.events.as_slice());
                evaluate_by(&truth, &rec.rows, events, tail, &metric)
                    .map(|r| with_rule(r, rule))
                    .map_err(|e| anyhow::anyhow!("{e}"))
            });
        match outcome {
            Ok(report) => scored.push(Scored {
                recording: rec.name,
                truth: path.display().to_string(),
                report,
            }),
            Err(e) => failed.push(Failed {
                recording: rec.name,
                error: format!("{e:#}"),
            }),
        }
    }
    if scored.is_empty() && failed.is_empty() {
        bail!(
            "{}: no truth for any of the {} recording(s) (looked for NAME.truth.json and NAME.truth.csv at each recording's path, the longest trailing part first; the first is {})",
            args.truth.display(),
            without_truth.len(),
            without_truth.first().map_or("-", String::as_str)
        );
    }
    let report = ManyReport {
        pooled: pool(scored.iter().map(|s| &s.report)),
        recordings: scored,
        without_truth,
        failed,
    };
    let text = if args.json {
        serde_json::to_string_pretty(&report)? + "\n"
    } else {
        table(&report)
    };
    super::print(text.as_bytes())?;
    for f in &report.failed {
        super::warn(false, &format!("{}: {}", f.recording, f.error));
    }
    Ok(report.failed.is_empty())
}

fn table(r: &ManyReport) -> String {
    let opt = |v: Option<f64>, d: usize| v.map_or("-".to_string(), |x| format!("{x:.d$}"));
    let pct = |v: Option<f64>| opt(v.map(|x| 100.0 * x), 1) + "%";
    let width = r
        .recordings
        .iter()
        .map(|s| s.recording.chars().count())
        .max()
        .unwrap_or(0)
        .max("recording".len());
    let mut s = String::new();
    if let Some(first) = r.recordings.first() {
        s += &format!("errors: {}\n", first.report.metric);
    }
    s += &format!(
        "{:<width$}  detections  mean_err  median_err  frames_detected  events_detected  heard  false_per_min\n",
        "recording"
    );
    for x in &r.recordings {
        let p = &x.report;
        s += &format!(
            "{:<width$}  {:>10}  {:>8}  {:>10}  {:>15}  {:>15}  {:>5}  {:>13}\n",
            x.recording,
            p.detections,
            opt(p.mean_error_deg, 2),
            opt(p.median_error_deg, 2),
            pct(p.frame_detection_rate),
            pct(p.event_detection_rate),
            opt(p.event_coverage.map(|c| 100.0 * c), 0) + "%",
            opt(p.false_per_minute, 1),
        );
    }
    let p = &r.pooled;
    s += &format!(
        "pooled: {} recordings, {} detections, mean error {} deg, median {} deg, frames detected {}, events detected {} (heard {}), {} false detections in {:.1} s ({} per minute)\n",
        p.recordings,
        p.detections,
        opt(p.mean_error_deg, 2),
        opt(p.median_error_deg, 2),
        pct(p.frame_detection_rate),
        pct(p.event_detection_rate),
        pct(p.event_coverage),
        p.false_detections,
        p.background_s,
        opt(p.false_per_minute, 1),
    );
    if !r.without_truth.is_empty() {
        let shown: Vec<&str> = r.without_truth.iter().take(5).map(String::as_str).collect();
        s += &format!(
            "without a truth (not scored): {} recording(s): {}{}\n",
            r.without_truth.len(),
            shown.join(", "),
            if r.without_truth.len() > 5 {
                ", ..."
            } else {
                ""
            }
        );
    }
    if !r.failed.is_empty() {
        s += &format!(
            "not scored (errors on standard error): {}\n",
            r.failed.len()
        );
    }
    s
}
