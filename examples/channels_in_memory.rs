//! Localize sources in channels already in memory (from a sound card, another program,
//! or, here, the simulator), writing the rows `ssl analyze` would write as NDJSON with the library's own
//! exporter.
//!
//! `cargo run --example channels_in_memory`

use ssl::geometry::unit_from_angles;
use ssl::localize::{Localizer, Output};
use ssl::sim::freefield::{render, Place, Scene, Source};
use ssl::sim::signals::Signal;
use ssl::Config;
use ssl::{Format, Geometry};
use std::io::Write;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // A 4-microphone tetrahedron, 10 cm across (positions in metres, x forward, y left,
    // z up), and a noise burst from azimuth 60, elevation 20 between 0.2 and 0.8 s.
    let geometry = Geometry::from_positions(&[
        [0.035, 0.035, 0.035],
        [0.035, -0.035, -0.035],
        [-0.035, 0.035, -0.035],
        [-0.035, -0.035, 0.035],
    ])?;
    let channels: Vec<Vec<f32>> = render(&Scene {
        sample_rate: 48000,
        duration_s: 1.0,
        mics: geometry.positions(),
        speed_of_sound: geometry.speed_of_sound,
        sources: vec![Source {
            place: Place::Direction(unit_from_angles(60.0, 20.0)),
            signal: Signal::WhiteNoise,
            start_s: 0.2,
            end_s: 0.8,
            level: 0.05,
        }],
        sensor_noise: 0.002,
        seed: 1,
    });

    // Any slices of one length will do: one per channel, in geometry order.
    let slices = channels.iter().map(|c| &c[..]).collect();
    let localizer = Localizer::new(geometry, &Config::default())?;
    let mut out =
        Format::Ndjson.exporter(std::io::stdout().lock(), ssl::record::Records::Detections);
    out.begin(&localizer.metadata("tetrahedron"))?;
    let recording = localizer.from_channels("memory", slices, 48000)?;
    let (_, result) = recording.run(|found| match found {
        Output::Row(row) => out.detection(&row),
        _ => Ok(()),
    });
    result?;
    out.finish(&[])?.flush()?;
    Ok(())
}
