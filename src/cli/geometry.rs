//! `ssl geometry`: what the tool understood of an array.

use super::args::GeometryArgs;
use crate::method::default_frame_size;
use crate::record::metadata::ambiguity_note;
use crate::Geometry;
use anyhow::Result;
use std::fmt::Write as _;

/// Runs `ssl geometry`.
pub fn run(args: &GeometryArgs) -> Result<()> {
    let g = Geometry::from_file(&args.geometry)?;
    let path = args.geometry.display().to_string();
    for w in &g.warnings {
        eprintln!("ssl: warning: {path}: {w}");
    }
    let text = report(
        &g,
        &path,
        args.rate,
        args.speed_of_sound.unwrap_or(g.speed_of_sound),
    );
    super::print(text.as_bytes())
}

/// The report: a summary, the microphones, and every pair's largest delay at `rate`.
fn report(g: &Geometry, path: &str, rate: u32, c: f64) -> String {
    let (aperture, i, j) = g.aperture();
    let n = default_frame_size(rate);
    let named = g
        .name
        .as_ref()
        .map(|n| format!(" ({n})"))
        .unwrap_or_default();
    let mut summary = vec![
        ("geometry", format!("{path}{named}")),
        ("microphones", g.mics.len().to_string()),
        ("shape", g.shape.label().to_string()),
    ];
    if let Some(note) = ambiguity_note(g) {
        summary.push(("note", note));
    }
    summary.extend([
        (
            "aperture",
            format!("{aperture:.4} m (mics {} and {})", i + 1, j + 1),
        ),
        (
            "centre",
            format!(
                "[{:.4}, {:.4}, {:.4}] m",
                g.centre.x + 0.0,
                g.centre.y + 0.0,
                g.centre.z + 0.0
            ),
        ),
        (
            "orientation",
            match g.orientation {
                None => "none: directions in the array frame".to_string(),
                Some(r) => format!(
                    "directions and positions below in the room frame; the array's x, y, z axes point to {}, {}, {}",
                    axis(&r.column(0).into_owned()),
                    axis(&r.column(1).into_owned()),
                    axis(&r.column(2).into_owned())
                ),
            },
        ),
        ("speed of sound", format!("{c} m/s")),
        (
            "sample rate",
            format!(
                "{rate} Hz (default frame size {n} = {:.1} ms)",
                n as f64 * 1000.0 / rate as f64
            ),
        ),
    ]);
    let mut s = String::new();
    for (label, value) in summary {
        let _ = writeln!(s, "{:<17}{value}", format!("{label}:"));
    }
    let _ = writeln!(s, "\n mic  channel         x         y         z");
    for (k, m) in g.mics.iter().enumerate() {
        let p = m.position.map(|v| (v * 1e9).round() / 1e9 + 0.0);
        let _ = writeln!(
            s,
            "{:>4}  {:>7}  {:>8.4}  {:>8.4}  {:>8.4}",
            k + 1,
            m.channel,
            p.x,
            p.y,
            p.z
        );
    }
    let _ = writeln!(s, "\n pair   distance_m  max_lag_samples");
    let count = g.mics.len();
    for a in 0..count {
        for b in a + 1..count {
            let lag = g.max_lag_samples(a, b, rate as f64, c);
            let _ = writeln!(
                s,
                "{:>2}-{:<2}  {:>10.4}  {:>15.2}",
                a + 1,
                b + 1,
                g.spacing(a, b),
                lag
            );
        }
    }
    s
}

/// A room-frame unit vector as `[x, y, z]` with 3 decimals.
fn axis(v: &nalgebra::Vector3<f64>) -> String {
    format!("[{:.3}, {:.3}, {:.3}]", v.x + 0.0, v.y + 0.0, v.z + 0.0)
}
