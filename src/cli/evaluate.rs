//! `ssl evaluate`: score a result against a simulation's truth.

use super::args::{EvaluateArgs, MetricArg};
use anyhow::{bail, Context, Result};
use ssl::evaluate::{evaluate_by, Metric};
use ssl::geometry::Shape;
use ssl::record::{read_detections_with_info, GeometryInfo};
use ssl::stream::{io_reason, read_text_from};
use ssl::{Geometry, Truth};
use std::path::Path;

/// Runs `ssl evaluate`. `-` reads the result (or the truth) from standard input.
pub fn run(args: &EvaluateArgs) -> Result<()> {
    let stdin = |limit| {
        read_text_from(std::io::stdin().lock(), limit)
            .map_err(|e| anyhow::anyhow!("<stdin>: cannot read: {}", io_reason(&e)))
    };
    let truth = if args.truth == Path::new("-") {
        Truth::from_text(&stdin(ssl::record::MAX_TRUTH_BYTES)?).context("<stdin>")?
    } else {
        Truth::from_file(&args.truth)?
    };
    let (detections, info) = read_detections_with_info(&args.result)?;
    let geometry = match &args.geometry {
        Some(path) => Some(Geometry::from_file(path)?),
        None => info
            .geometry
            .and_then(|g| serde_json::from_value::<GeometryInfo>(g).ok())
            .and_then(|g| {
                let positions: Vec<[f64; 3]> = g.mics.iter().map(|m| m.position).collect();
                let geometry = Geometry::from_positions(&positions).ok()?;
                Some(match g.orientation {
                    Some(rows) => geometry.oriented(nalgebra::Matrix3::from_fn(|i, j| rows[i][j])),
                    None => geometry,
                })
            }),
    };
    let metric = metric(args.metric, geometry.as_ref())?;
    let tail = args
        .tail
        .map_or(truth.rt60_s().map_or(0.0, |t| t / 2.0), f64::from);
    let report = evaluate_by(&truth, &detections, tail, &metric)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.result.display()))?;
    let text = if args.json {
        serde_json::to_string_pretty(&report)? + "\n"
    } else {
        report.table()
    };
    super::print(text.as_bytes())
}

/// The metric `--metric` asks for, or what `geometry` observes.
fn metric(arg: Option<MetricArg>, geometry: Option<&Geometry>) -> Result<Metric> {
    let shape = geometry.map(|g| g.shape);
    Ok(match (arg, shape) {
        (None, Some(_)) => Metric::of_geometry(geometry.expect("a shape")),
        (None, None) | (Some(MetricArg::ThreeD), _) => Metric::ThreeD,
        (Some(MetricArg::Azimuth), Some(Shape::Planar { normal })) => Metric::Azimuth { normal },
        (Some(MetricArg::Azimuth), _) => Metric::azimuth(),
        (Some(MetricArg::Axis), Some(Shape::Linear { axis })) => Metric::Axis { axis },
        (Some(MetricArg::Axis), _) => {
            bail!("--metric axis needs a linear array's geometry: give it with --geometry (a JSON result carries it)")
        }
    })
}
