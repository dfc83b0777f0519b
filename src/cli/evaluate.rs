//! `ssl evaluate`: score a result against a simulation's truth.

use super::args::EvaluateArgs;
use anyhow::{Context, Result};
use ssl::evaluate::evaluate;
use ssl::record::read_detections;
use ssl::stream::{io_reason, read_text_from};
use ssl::Truth;
use std::path::Path;

/// Runs `ssl evaluate`. `-` reads the result (or the truth) from standard input.
pub fn run(args: &EvaluateArgs) -> Result<()> {
    let stdin = |limit| {
        read_text_from(std::io::stdin().lock(), limit)
            .map_err(|e| anyhow::anyhow!("<stdin>: cannot read: {}", io_reason(&e)))
    };
    let truth = if args.truth == Path::new("-") {
        Truth::from_json(&stdin(ssl::record::MAX_TRUTH_BYTES)?).context("<stdin>")?
    } else {
        Truth::from_file(&args.truth)?
    };
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
    super::print(text.as_bytes())
}
