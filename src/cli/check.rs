//! `ssl check`: does a recording fit its geometry and channel order?

use super::args::{CheckArgs, CheckFormat};
use anyhow::Result;
use ssl::check::{check, CheckReport};
use ssl::Geometry;
use std::fmt::Write as _;

/// Runs `ssl check`. Returns whether the recording fits.
pub fn run(args: &CheckArgs) -> Result<bool> {
    let geometry = Geometry::from_file(&args.geometry)?;
    let path = args.geometry.display().to_string();
    for w in &geometry.warnings {
        super::warn(false, &format!("{path}: {w}"));
    }
    let report = check(&args.recording, &geometry)?;
    let text = match args.format {
        CheckFormat::Json => serde_json::to_string_pretty(&report)? + "\n",
        CheckFormat::Text => text(&report),
    };
    super::print(text.as_bytes())?;
    Ok(report.fits)
}

/// The report for people.
fn text(r: &CheckReport) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: {} channels, {} Hz, {:.1} s read, {} clear frames",
        r.file, r.channels, r.sample_rate, r.seconds_read, r.clear_frames
    );
    let levels: Vec<String> = r
        .levels_dbfs
        .iter()
        .map(|l| l.map_or("constant".to_string(), |v| format!("{v:.1}")))
        .collect();
    let _ = writeln!(s, "levels (dBFS, by channel): {}", levels.join(", "));
    if let Some(us) = r.residual_us {
        let _ = writeln!(
            s,
            "far-field fit: residual {us:.1} us, {:.1}% of delays beyond the spacing, solution length {:.2}",
            100.0 * r.beyond_share.unwrap_or(0.0),
            r.length.unwrap_or(0.0)
        );
    }
    if r.residual_us.is_some() && !r.order_checked {
        s += "channel order: not checked (every order of these microphones is a symmetry of the array: delays cannot tell them apart)\n";
    }
    if r.fits {
        s += "fits: the channels and their delays agree with the geometry\n";
    } else {
        for f in &r.findings {
            let _ = writeln!(s, "misfit ({}): {}", f.kind, f.message);
        }
    }
    s
}
