//! One source of a scene: its signal in each active interval, where it is (and, when it
//! turns, where it is at each moment), through the room's responses; and its truth.

use super::placed::{convolve, Placed};
use super::recorded::read_mono;
use super::scene::{SceneFile, SignalKind, SourceSpec};
use super::signals::{generate, Signal};
use super::SceneError;
use crate::geometry::{angles_deg, unit_from_angles};
use crate::record::{fixed, TruthSource};
use nalgebra::Vector3;
use rand_chacha::ChaCha8Rng;
use std::path::Path;

/// Renders source `i` into `out`: its signal in each active interval, through the room;
/// returns its truth.
pub(super) fn render_source(
    scene: &SceneFile,
    dir: &Path,
    placed: &Placed,
    (i, s): (usize, &SourceSpec),
    out: &mut [Vec<f64>],
    rng: &mut ChaCha8Rng,
) -> Result<TruthSource, SceneError> {
    let fs = placed.fs;
    let what = format!("source {}", i + 1);
    let about = |error| SceneError::About {
        what: what.clone(),
        error: Box::new(error),
    };
    let position = source_position(s, placed).map_err(about)?;
    placed.check_inside(&what, &position)?;
    let distance = (position - placed.centre).norm();
    if distance < 1e-3 {
        fail!(SceneError::Invalid, "{what} is at the array centre");
    }
    let level = 10f64.powf(s.level_db / 20.0);
    let signal = generated(s);
    let recording = match (&s.signal, &s.file) {
        (SignalKind::File, Some(f)) => {
            // The longest interval plays the most of it.
            let longest = s.active.as_deref().map_or(scene.duration, |list| {
                list.iter().map(|[a, b]| b - a).fold(0.0, f64::max)
            });
            Some(read_mono(&dir.join(f), scene.sample_rate, longest).map_err(about)?)
        }
        (SignalKind::File, None) => fail!(
            SceneError::Invalid,
            "{what}: signal = \"file\" needs `file = \"...\"`"
        ),
        _ => None,
    };
    let len = out[0].len();
    let turn = s.turn_deg_per_s.filter(|&t| t != 0.0);
    let turn_from = s
        .active
        .as_ref()
        .and_then(|a| a.first())
        .map_or(0.0, |a| a[0]);
    let (az0, el) = (s.azimuth_deg.unwrap_or(0.0), s.elevation_deg.unwrap_or(0.0));
    // Where a moving source is at time `t` (seconds).
    let at = |t: f64| {
        let az = az0 + turn.unwrap_or(0.0) * (t - turn_from);
        placed.centre + placed.rotation * unit_from_angles(az, el) * distance
    };
    let responses = match turn {
        None => placed.responses(&position),
        Some(_) => Vec::new(),
    };
    let delay_s = distance / placed.c;
    // Every interval checked, then as samples: its start and length.
    let mut spans = Vec::new();
    for [a, b] in s.active.clone().unwrap_or(vec![[0.0, scene.duration]]) {
        if !(a.is_finite() && b.is_finite() && 0.0 <= a && a < b && b <= scene.duration) {
            fail!(
                SceneError::Invalid,
                "{what}: active interval [{a}, {b}] must lie within [0, {}] and not be empty",
                scene.duration
            );
        }
        let start = (a * fs).round() as usize;
        spans.push(([a, b], start, ((b * fs).round() as usize).min(len) - start));
    }
    // A turning source's whole path is checked before anything is rendered.
    if let Some(turn) = turn {
        let hop = block_hop(turn, fs);
        for &(_, start, n) in &spans {
            for centre in block_centres(hop, n) {
                placed.check_inside(&what, &at((start + centre) as f64 / fs))?;
            }
        }
    }
    let mut active = Vec::new();
    for ([a, b], start, n) in spans {
        let (dry, sounding) = dry(&signal, recording.as_deref(), level * distance, fs, n, rng);
        match turn {
            None => add_at(out, start, convolve(&dry, &responses)),
            Some(turn) => {
                // Blocks a degree apart (at most 50 ms), each through the responses of
                // its centre's position, cross-faded by triangles that sum to 1.
                let hop = block_hop(turn, fs);
                for centre in block_centres(hop, n) {
                    let from = centre.saturating_sub(hop);
                    let to = (centre + hop).min(n);
                    if from >= to {
                        continue;
                    }
                    let p = at((start + centre) as f64 / fs);
                    let block: Vec<f64> = (from..to)
                        .map(|k| {
                            let w = 1.0 - (k as f64 - centre as f64).abs() / hop as f64;
                            dry[k] * w
                        })
                        .collect();
                    add_at(out, start + from, convolve(&block, &placed.responses(&p)));
                }
            }
        }
        let (from, to) = (
            a + sounding.0 as f64 / fs,
            b.min(a + sounding.1 as f64 / fs),
        );
        active.push([
            fixed(from + delay_s, 6),
            fixed((to + delay_s).min(scene.duration), 6),
        ]);
    }
    let u = placed.rotation.transpose() * (position - placed.centre) / distance;
    let (azimuth_deg, elevation_deg) = angles_deg(&u);
    // A moving source's truth is its direction when it starts turning, and its turn
    // from that time as heard at the array centre.
    let turn = turn.map(|t| (t, fixed(turn_from + delay_s, 6)));
    Ok(TruthSource {
        index: i,
        signal: format!("{:?}", s.signal).to_lowercase(),
        level_db: s.level_db,
        position_room: [position.x, position.y, position.z],
        x: u.x,
        y: u.y,
        z: u.z,
        azimuth_deg,
        elevation_deg,
        distance_m: Some(distance),
        active,
        turn_deg_per_s: turn.map(|t| t.0),
        turn_from_s: turn.map(|t| t.1),
        waypoints: Vec::new(),
        azimuth_only: false,
    })
}

/// The signal a source generates (`None`: it plays a file).
fn generated(s: &SourceSpec) -> Option<Signal> {
    match s.signal {
        SignalKind::White => Some(Signal::WhiteNoise),
        SignalKind::Pink => Some(Signal::PinkNoise),
        SignalKind::Speech => Some(Signal::SpeechLike),
        SignalKind::Clicks => Some(Signal::Clicks {
            per_second: s.rate.unwrap_or(10.0),
        }),
        SignalKind::Tone => Some(Signal::Tone {
            hz: s.frequency.unwrap_or(1000.0),
        }),
        SignalKind::File => None,
    }
}

/// `n` samples of a source's dry signal at RMS `scale` (the direct sound's level at the
/// array centre times the distance): generated, or its recording looped; and the part
/// that sounds (a recording's own leading and trailing silence is not part of the
/// truth).
fn dry(
    signal: &Option<Signal>,
    recording: Option<&[f64]>,
    scale: f64,
    fs: f64,
    n: usize,
    rng: &mut ChaCha8Rng,
) -> (Vec<f64>, (usize, usize)) {
    let mut dry = vec![0.0; n];
    // A recording's own leading and trailing silence is not part of the truth.
    let mut sounding = (0, n);
    // Scaled so that the direct sound at the array centre (gain 1 / distance) has `level`.
    match (&signal, &recording) {
        (Some(sig), _) => generate(sig, scale, fs, &mut dry, rng),
        (None, Some(rec)) => {
            for (k, v) in dry.iter_mut().enumerate() {
                *v = rec[k % rec.len()];
            }
            let rms = (dry.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
            if rms > 0.0 {
                dry.iter_mut().for_each(|v| *v *= scale / rms);
            }
            sounding = sounding_span(&dry, fs).unwrap_or(sounding);
        }
        _ => unreachable!("a signal or a recording"),
    }
    (dry, sounding)
}

/// Blocks over which a recording's sounding part is found (seconds).
pub(crate) const SOUNDING_BLOCK_S: f64 = 0.01;

/// A block sounds when its power is at least this far (dB) under the mean power of
/// the whole interval.
pub(crate) const SOUNDING_DB: f64 = -30.0;

/// The samples `[from, to)` of `x` from its first to its last block of
/// [`SOUNDING_BLOCK_S`] whose power is within [`SOUNDING_DB`] of `x`'s mean power; none
/// when `x` is silent.
pub(crate) fn sounding_span(x: &[f64], fs: f64) -> Option<(usize, usize)> {
    let mean = x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64;
    let floor = mean * 10f64.powf(SOUNDING_DB / 10.0);
    let block = ((SOUNDING_BLOCK_S * fs).round() as usize).max(1);
    let loud = |(j, c): (usize, &[f64])| {
        let p = c.iter().map(|v| v * v).sum::<f64>() / c.len() as f64;
        (mean > 0.0 && p >= floor).then_some(j)
    };
    let first = x.chunks(block).enumerate().find_map(loud)?;
    let last = x.chunks(block).enumerate().rev().find_map(loud)?;
    Some((first * block, ((last + 1) * block).min(x.len())))
}

/// Adds `wet[m]` to `out[m]` from sample `start` on (what falls past the end is left
/// out).
fn add_at(out: &mut [Vec<f64>], start: usize, wet: Vec<Vec<f64>>) {
    for (m, wet) in wet.into_iter().enumerate() {
        for (o, v) in out[m][start..].iter_mut().zip(wet) {
            *o += v;
        }
    }
}

/// Samples between the positions a source turning at `turn` deg/s is rendered from:
/// a degree, at most 50 ms.
fn block_hop(turn: f64, fs: f64) -> usize {
    ((1.0 / turn.abs()).min(0.05) * fs).round().max(1.0) as usize
}

/// The centres (samples from its start) of the blocks a turning source's interval of
/// `n` samples is rendered in, `hop` apart: the last at or past its end.
fn block_centres(hop: usize, n: usize) -> impl Iterator<Item = usize> {
    (0..n.div_ceil(hop) + 1).map(move |j| j * hop)
}

/// How many positions source `s` is rendered from in a scene of `duration` seconds at
/// `fs` (1 unless it moves): what its responses cost.
pub(crate) fn positions(s: &SourceSpec, duration: f64, fs: f64) -> usize {
    match s.turn_deg_per_s.filter(|&t| t != 0.0 && t.is_finite()) {
        None => 1,
        Some(turn) => {
            let hop = block_hop(turn, fs);
            let intervals = s.active.clone().unwrap_or(vec![[0.0, duration]]);
            intervals
                .iter()
                .map(|[a, b]| block_centres(hop, ((b - a).max(0.0) * fs) as usize).count())
                .sum()
        }
    }
}

pub(super) fn source_position(s: &SourceSpec, placed: &Placed) -> Result<Vector3<f64>, SceneError> {
    match (s.position, s.azimuth_deg, s.elevation_deg, s.distance) {
        (Some(p), None, None, None) => Ok(Vector3::from(p)),
        (None, Some(az), el, Some(d)) => {
            if !(d.is_finite() && d > 0.0) {
                fail!(SceneError::Invalid, "distance must be positive, got {d}");
            }
            let u = unit_from_angles(az, el.unwrap_or(0.0));
            Ok(placed.centre + placed.rotation * u * d)
        }
        _ => {
            fail!(
SceneError::Invalid,
            "give either `position`, or `azimuth_deg`, `distance` (and optionally `elevation_deg`)"
        )
        }
    }
}
