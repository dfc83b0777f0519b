//! The rows `ssl analyze REC.wav --geometry ARRAY.toml` writes, from the library: one
//! [`Localizer`] runs the method, the tracker and the smoother as the command line does
//! (tests/integration/entry_points.rs proves the rows identical to the binary's).
//!
//! `cargo run --release --example rows -- [REC.wav] [ARRAY.toml]` (default: the shipped
//! example and the paper's prism).

use ssl::localize::{Localizer, Output};
use ssl::Config;
use ssl::{DetectionRecord, Geometry};

/// Every row of `wav` on the array of `toml`, at the defaults.
pub fn rows(wav: &str, toml: &str) -> Result<Vec<DetectionRecord>, Box<dyn std::error::Error>> {
    let geometry = Geometry::from_file(toml.as_ref())?;
    let localizer = Localizer::new(geometry, &Config::default())?;
    let mut rows = Vec::new();
    let (_report, result) = localizer.open(wav)?.run(|out| {
        if let Output::Row(row) = out {
            rows.push(row);
        }
        Ok(())
    });
    result?; // a read error (a truncated file) comes after the rows before it
    Ok(rows)
}

#[allow(dead_code)] // the test includes this file for `rows`
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let wav = args.next().unwrap_or("testdata/example.wav".into());
    let toml = args.next().unwrap_or("testdata/prism.toml".into());
    println!("  time_s  azimuth  elevation   score  source");
    for r in rows(&wav, &toml)? {
        let source = r.source.map_or("-".into(), |s| s.to_string());
        println!(
            "{:8.3} {:8.1} {:10.1} {:7.1}  {source}",
            r.time_s, r.azimuth_deg, r.elevation_deg, r.score
        );
    }
    Ok(())
}
