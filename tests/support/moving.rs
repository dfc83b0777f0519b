//! A talker turning around the array (real speech, far field, free field with sensor
//! noise 20 dB below), analysed and tracked as `ssl analyze` does, and scored against
//! its trajectory: the tracking benchmark's "A talker moving" and tests/integration/tracking.rs.

use super::harness::analyse_channels;
use super::{testdata, SPEECH};
use nalgebra::Vector3;
use ssl::geometry::angle_between_deg;
use ssl::sim::freefield::{render, Place, Scene, Source};
use ssl::sim::recorded::read_mono;
use ssl::sim::signals::Signal;
use ssl::track::TrackParams;
use ssl::Geometry;

/// What a moving talker's analysis gives, against the truth.
#[derive(Debug, Clone)]
pub struct Moving {
    /// Rows (with a track).
    pub rows: usize,
    /// Their mean angle to the talker's direction at their time (degrees).
    pub mean_error_deg: Option<f64>,
    /// Distinct tracks among the rows.
    pub tracks: usize,
    /// The share of the 0.1 s windows of the talker's sentence with a row.
    pub windows: f64,
}

/// The first sentence of [`SPEECH`] (3.9 s) from 1 s on, starting at azimuth -60 deg and
/// elevation `elevation`, its azimuth turning at `deg_per_s`, on `geometry` at `rate`.
pub fn moving_talker(
    geometry: &Geometry,
    rate: u32,
    elevation: f64,
    deg_per_s: f64,
    seed: u64,
) -> Result<Moving, Box<dyn std::error::Error>> {
    let speech = read_mono(
        &testdata(&format!("speech/{}", SPEECH[0].0)),
        rate,
        f64::INFINITY,
    )?;
    let (start, end) = (1.0, 1.0 + SPEECH[0].1);
    let source = Source {
        place: Place::Moving {
            azimuth_deg: -60.0,
            elevation_deg: elevation,
            deg_per_s,
        },
        signal: Signal::Recording(speech),
        start_s: start,
        end_s: end,
        level: 0.05,
    };
    // The mean of the microphone positions, as the renderer takes it.
    let centre = geometry.centre;
    let scene = Scene {
        sample_rate: rate,
        duration_s: end + 1.0,
        mics: geometry.mics.iter().map(|m| m.position).collect(),
        speed_of_sound: geometry.speed_of_sound,
        sources: vec![source.clone()],
        sensor_noise: 0.005,
        seed,
    };
    let channels = render(&scene);
    let params = super::tracked_params();
    let rows = analyse_channels(
        &channels,
        rate,
        geometry,
        &params,
        Some(TrackParams::default()),
    )?;
    let errors: Vec<f64> = rows
        .iter()
        .map(|r| {
            let truth = source.direction_at(&centre, r.time_s.clamp(start, end));
            angle_between_deg(&Vector3::new(r.x, r.y, r.z), &truth)
        })
        .collect();
    let mut ids: Vec<u64> = rows.iter().filter_map(|r| r.source).collect();
    ids.sort_unstable();
    ids.dedup();
    let windows = window_share(rows.iter().map(|r| r.time_s), start, end);
    Ok(Moving {
        rows: rows.len(),
        mean_error_deg: (!errors.is_empty())
            .then(|| errors.iter().sum::<f64>() / errors.len() as f64),
        tracks: ids.len(),
        windows,
    })
}

/// The share of the 0.1 s windows from `start` to `end` (seconds) with a row at one of
/// `times`.
pub fn window_share(times: impl Iterator<Item = f64> + Clone, start: f64, end: f64) -> f64 {
    let windows = ((end - start) / 0.1).floor() as usize;
    let seen = (0..windows)
        .filter(|&w| {
            let a = start + w as f64 * 0.1;
            times.clone().any(|t| t >= a && t < a + 0.1)
        })
        .count();
    seen as f64 / windows.max(1) as f64
}
