//! Tests of [`super`]: single bins' directions against plane waves built bin by bin.

use super::*;
use crate::geometry::{angles_deg, unit_from_angles};
use crate::method::engine::setup::Setup;
use realfft::num_complex::Complex32;

const RATE: f64 = 16000.0;
const N: usize = 256;
const C: f64 = 343.0;

fn circle() -> Geometry {
    ring(6, 0.0463)
}

/// `k` microphones on a horizontal circle of radius `r` (m).
fn ring(k: usize, r: f64) -> Geometry {
    let toml: String = (0..k)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / k as f64;
            format!(
                "[[mic]]\nposition = [{}, {}, 0.0]\n",
                r * a.cos(),
                r * a.sin()
            )
        })
        .collect();
    Geometry::from_toml_str(&format!("speed_of_sound = {C}\n{toml}")).unwrap()
}

/// A frame whose bin `k` holds a plane wave from `source(k)` (none: noise of the
/// given seed's phases), 100 times the noise estimate.
fn frame(geometry: &Geometry, source: impl Fn(usize) -> Option<Vector3<f64>>) -> FrameState {
    let setup = Setup::new(
        geometry,
        RATE as u32,
        &crate::Config::default().settings().unwrap().method,
    )
    .unwrap();
    let mut state = FrameState::new(&setup);
    state.live = (0..geometry.mics.len()).collect();
    let mut seed = 12345u64;
    for k in 0..=N / 2 {
        let omega = std::f64::consts::TAU * k as f64 * RATE / N as f64;
        for (m, mic) in geometry.mics.iter().enumerate() {
            // A wave from u reaches p at -u.p / c.
            let phase = match source(k) {
                Some(u) => omega * u.dot(&mic.position) / C,
                None => {
                    seed = seed
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    (seed >> 11) as f64 / (1u64 << 53) as f64 * std::f64::consts::TAU
                }
            };
            state.spectra[m][k] = Complex32::new(phase.cos() as f32, phase.sin() as f32);
        }
        state.power[k] = 1.0;
        state.noise[k] = 0.01;
    }
    state
}

fn votes_of(geometry: &Geometry, state: &FrameState) -> (BinVotes, Vec<Vote>) {
    let bins = BinVotes::new(geometry, N, RATE, C).expect("a small array votes");
    let mut votes = Vec::new();
    bins.collect(state, RATE, N, C, &mut votes);
    (bins, votes)
}

#[test]
fn every_bin_of_a_plane_wave_votes_for_its_direction() {
    let geometry = circle();
    let u = unit_from_angles(40.0, 20.0);
    let (bins, votes) = votes_of(&geometry, &frame(&geometry, |_| Some(u)));
    assert_eq!(votes.len(), bins.band_of.len());
    for v in &votes {
        let (azimuth, elevation) = angles_deg(&v.direction);
        assert!((azimuth - 40.0).abs() < 0.01, "{azimuth}");
        assert!((elevation - 20.0).abs() < 0.01, "{elevation}");
    }
}

#[test]
fn two_waves_in_different_bins_give_two_peaks() {
    let geometry = circle();
    let (a, b) = (unit_from_angles(20.0, 15.0), unit_from_angles(-40.0, 15.0));
    let state = frame(&geometry, |k| Some(if k % 3 == 0 { b } else { a }));
    let (bins, mut votes) = votes_of(&geometry, &state);
    let mut peaks = Vec::new();
    bins.peaks(&mut votes, 4, &mut peaks);
    let azimuths: Vec<f64> = peaks.iter().map(|p| angles_deg(&p.direction).0).collect();
    assert_eq!(azimuths.len(), 2, "{azimuths:?}");
    assert!((azimuths[0] - 20.0).abs() < 0.5, "{azimuths:?}");
    assert!((azimuths[1] + 40.0).abs() < 0.5, "{azimuths:?}");
}

#[test]
fn bins_of_random_phases_or_in_the_noise_give_no_peak() {
    let geometry = circle();
    let (bins, mut votes) = votes_of(&geometry, &frame(&geometry, |_| None));
    let mut peaks = Vec::new();
    bins.peaks(&mut votes, 4, &mut peaks);
    assert!(peaks.is_empty(), "{} votes", votes.len());
    // A plane wave at the level of the noise estimate does not vote.
    let mut state = frame(&geometry, |_| Some(unit_from_angles(40.0, 20.0)));
    state.noise.iter_mut().for_each(|n| *n = 0.6);
    let (_, votes) = votes_of(&geometry, &state);
    assert!(votes.is_empty());
}

#[test]
fn the_prism_and_a_line_do_not_vote() {
    let prism = Geometry::from_toml_str(
        &std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/testdata/prism.toml"))
            .unwrap(),
    )
    .unwrap();
    assert!(BinVotes::new(&prism, 1024, 48000.0, C).is_none());
    let line = Geometry::from_toml_str(
        "[[mic]]\nposition = [0.0, 0, 0]\n[[mic]]\nposition = [0.04, 0, 0]\n[[mic]]\nposition = [0.08, 0, 0]\n",
    )
    .unwrap();
    assert!(BinVotes::new(&line, N, RATE, C).is_none());
}

/// A ring of 16 (120 pairs, more than a bin uses) votes with its 66 shortest pairs.
#[test]
fn a_large_ring_votes_with_its_shortest_pairs() {
    let geometry = ring(16, 0.04);
    let bins = BinVotes::new(&geometry, N, RATE, C).expect("it votes");
    assert!(bins.bands.iter().all(|b| b.pairs.len() <= MAX_PAIRS));
    assert_eq!(bins.bands[0].pairs.len(), MAX_PAIRS);
    let u = unit_from_angles(-100.0, 10.0);
    let (_, votes) = votes_of(&geometry, &frame(&geometry, |_| Some(u)));
    assert_eq!(votes.len(), bins.band_of.len());
    assert!(votes
        .iter()
        .all(|v| v.direction.angle(&u).to_degrees() < 0.01));
}
