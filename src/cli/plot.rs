//! `ssl plot`: draw results as one SVG.

use super::args::PlotArgs;
use super::sink::Sink;
use crate::evaluate::evaluate_by;
use crate::plot::{plot, read_plot_file, PlotData};
use crate::stream::{io_reason, read_text, read_text_from};
use crate::Truth;
use anyhow::{bail, Context, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

fn text(path: &Path, limit: u64) -> Result<String> {
    if path == Path::new("-") {
        read_text_from(std::io::stdin().lock(), limit)
            .map_err(|e| anyhow::anyhow!("<stdin>: cannot read: {}", io_reason(&e)))
    } else {
        read_text(path, limit)
            .map_err(|e| anyhow::anyhow!("{}: cannot read: {}", path.display(), io_reason(&e)))
    }
}

fn shown(path: &Path) -> String {
    if path == Path::new("-") {
        "<stdin>".into()
    } else {
        path.display().to_string()
    }
}

/// Runs `ssl plot`.
pub fn run(args: &PlotArgs) -> Result<()> {
    if args.results.iter().filter(|p| *p == Path::new("-")).count()
        + args.truth.iter().filter(|p| *p == Path::new("-")).count()
        > 1
    {
        bail!("standard input (-) can be read only once");
    }
    // The output is checked against the inputs before anything is read.
    let mut inputs: Vec<&Path> = args.results.iter().map(PathBuf::as_path).collect();
    inputs.extend(args.truth.as_deref());
    let mut sink = Sink::open(args.output.as_deref(), &inputs)?;
    let mut data = PlotData::default();
    for result in super::results::expand(&args.results)? {
        // A folder's empty result (NDJSON of a recording without a detection): nothing
        // to draw.
        if result.relative.is_some() && std::fs::metadata(&result.path).is_ok_and(|m| m.len() == 0)
        {
            continue;
        }
        let one = read_plot_file(&result.path)?;
        data.array = data.array.or(one.array);
        data.threshold = data.threshold.or(one.threshold);
        data.geometry = data
            .geometry
            .or(one.geometry)
            .or_else(|| super::batch::stamp::stamped_array(&result.path));
        data.files.extend(one.files);
    }
    let truth = match &args.truth {
        // A folder of truths, as `ssl evaluate` takes it: the drawn recording's own.
        Some(dir) if dir != Path::new("-") && dir.is_dir() => {
            let name = args
                .file
                .clone()
                .or_else(|| data.files.first().map(|f| f.name.clone()))
                .unwrap_or_default();
            let path = super::evaluate::truth_path(dir, &name).with_context(|| {
                format!(
                    "{}: no truth for `{name}` (NAME.truth.json or NAME.truth.csv at its relative path)",
                    dir.display()
                )
            })?;
            Some(Truth::from_file(&path)?)
        }
        Some(path) => Some(
            Truth::from_text(&text(path, crate::record::MAX_TRUTH_BYTES)?)
                .with_context(|| shown(path))?,
        ),
        None => None,
    };
    // The same metric and tail as `ssl evaluate`, by the same functions.
    let geometry = match &args.score.geometry {
        Some(path) => Some(crate::Geometry::from_file(path)?),
        None => data.geometry.clone(),
    };
    // Scored by the 3-D angle for want of an array: said after the picture is out.
    let unknown = truth
        .as_ref()
        .is_some_and(|t| t.sources.iter().all(|s| !s.azimuth_only))
        && args.score.metric.is_none()
        && geometry.is_none();
    let report = match &truth {
        Some(t) => {
            let files = || {
                data.files
                    .iter()
                    .filter(|f| args.file.as_ref().is_none_or(|n| &f.name == n))
            };
            let rows: Vec<_> = files().flat_map(|f| f.detections.iter().cloned()).collect();
            let events: Vec<_> = files().flat_map(|f| f.events.iter().cloned()).collect();
            let events = (!events.is_empty()).then_some(events.as_slice());
            let metric = super::evaluate::metric(args.score.metric, geometry.as_ref())?;
            let (tail, rule) = super::evaluate::tail(args.score.tail, t, &rows);
            Some(
                evaluate_by(t, &rows, events, tail, &metric)
                    .map(|r| super::evaluate::with_rule(r, rule))
                    .map_err(|e| {
                        anyhow::anyhow!("{}: {e} (--file picks one)", shown(&args.results[0]))
                    })?,
            )
        }
        None => None,
    };
    let svg = plot(
        &data,
        args.file.as_deref(),
        truth.as_ref().zip(report.as_ref()),
    )
    .map_err(|e| {
        let hint = match e {
            crate::plot::PlotError::TooManyFiles(_) => " with --file NAME",
            _ => "",
        };
        anyhow::anyhow!("{}: {e}{hint}", shown(&args.results[0]))
    })?;
    sink.write_all(svg.as_bytes())
        .map_err(|e| anyhow::anyhow!("cannot write {}: {}", sink.shown(), io_reason(&e)))?;
    sink.commit()?;
    if unknown {
        super::evaluate::warn_if_unknown_array(None, None, &shown(&args.results[0]));
    }
    Ok(())
}
