//! Localize the sources in a WAV recording with the `ssl` library, and print what was
//! found: one line per detection, then the run's counters.
//!
//! `cargo run --example analyze_file -- [REC.wav] [ARRAY.toml]` (default: the shipped
//! example and the paper's prism).

use ssl::{Analysis, Geometry, Params};
use std::ops::ControlFlow;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let wav = args.next().unwrap_or("testdata/example.wav".into());
    let toml = args.next().unwrap_or("testdata/prism.toml".into());

    let geometry = Geometry::from_file(toml.as_ref())?;
    let analysis = Analysis::open(&wav, &geometry, &Params::default())?;
    println!("{wav}: frames of {} samples", analysis.frame_size());
    println!("  time_s  azimuth  elevation   score");
    let (summary, result) = analysis.run(|_frame, detections| {
        for d in detections {
            println!(
                "{:8.3} {:8.1} {:10.1} {:7.1}",
                d.time_s, d.azimuth_deg, d.elevation_deg, d.score
            );
        }
        ControlFlow::Continue(())
    });
    // A read error (a truncated file) comes after the frames before it were analysed.
    result?;
    let stats = &summary.stats;
    println!(
        "{} detections in {} frames ({} without a consistent set of delays, {} below the threshold)",
        stats.detections, stats.frames, stats.inconsistent_frames, stats.below_threshold_frames
    );
    for warning in &summary.warnings {
        println!("warning: {warning}");
    }
    Ok(())
}
