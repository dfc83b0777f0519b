//! `ssl check`: does a recording fit its geometry and channel order?

use super::args::{CheckArgs, CheckFormat};
use crate::check::{check, CheckOptions, CheckReport};
use crate::Geometry;
use anyhow::Result;
use std::fmt::Write as _;

/// Runs `ssl check`. Returns whether the recording fits.
pub fn run(args: &CheckArgs) -> Result<bool> {
    let geometry = Geometry::from_file(&args.geometry)?;
    let path = args.geometry.display().to_string();
    for w in &geometry.warnings {
        super::warn(false, &format!("{path}: {w}"));
    }
    let options = CheckOptions {
        expect: args.expect.clone(),
    };
    let report = check(&args.recording, &geometry, &options)?;
    let text = match args.format {
        CheckFormat::Json => serde_json::to_string_pretty(&report)? + "\n",
        CheckFormat::Text => text(&report, &geometry),
    };
    super::print(text.as_bytes())?;
    Ok(report.fits)
}

/// The report for people.
fn text(r: &CheckReport, geometry: &Geometry) -> String {
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
    let _ = writeln!(
        s,
        "levels (dBFS, by channel 0, 1, ...): {}",
        levels.join(", ")
    );
    if let Some(us) = r.residual_us {
        let _ = writeln!(
            s,
            "far-field fit: residual {us:.1} us, {:.1}% of delays beyond the spacing, solution length {:.2}",
            100.0 * r.beyond_share.unwrap_or(0.0),
            r.length.unwrap_or(0.0)
        );
    }
    if r.symmetries > 1 {
        let _ = writeln!(
            s,
            "symmetry: the geometry cannot tell {} channel orders apart (mirror images and rotations of the array)",
            r.symmetries
        );
    }
    for f in &r.remarks {
        let _ = writeln!(s, "remark ({}): {}", f.kind, f.message);
    }
    if r.fits {
        s += "fits: the channels and their delays agree with the geometry and its channel order\n";
    }
    for f in &r.findings {
        let _ = writeln!(s, "misfit ({}): {}", f.kind, f.message);
        if let Some(order) = &f.order {
            let _ = writeln!(s, "  the geometry with this order, to paste:");
            s += &mic_tables(geometry, order);
        }
    }
    s
}

/// `[[mic]]` tables of `geometry` with `order` as their channels, positions as the file
/// gives them.
fn mic_tables(geometry: &Geometry, order: &[usize]) -> String {
    let mut s = String::new();
    for (i, c) in order.iter().enumerate() {
        let p = geometry.array_position(i);
        let _ = writeln!(
            s,
            "  [[mic]]\n  position = [{}, {}, {}]\n  channel = {c}",
            p.x, p.y, p.z
        );
    }
    s
}
