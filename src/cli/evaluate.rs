//! `ssl evaluate`: score a result against a simulation's truth.

use super::args::EvaluateArgs;
use anyhow::Result;
use ssl::evaluate::evaluate;
use ssl::record::read_detections;
use ssl::Truth;
use std::io::Write;

/// Runs `ssl evaluate`.
pub fn run(args: &EvaluateArgs) -> Result<()> {
    let truth = Truth::from_file(&args.truth)?;
    let detections = read_detections(&args.result)?;
    let tail = args
        .tail
        .map_or(truth.rt60_s().map_or(0.0, |t| t / 2.0), f64::from);
    let report = evaluate(&truth, &detections, tail)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.result.display()))?;
    let text = if args.json {
        serde_json::to_string_pretty(&report)? + "\n"
    } else {
        report.table()
    };
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())?;
    out.flush()?;
    Ok(())
}
