//! The learned patterns' setup: on which arrays, and with which parameters.

use super::*;
use crate::geometry::Geometry;
use crate::method::engine::setup::Setup;
use crate::method::Params;

/// Microphones at the corners of a cube `side` metres across.
fn cube(side: f64) -> Geometry {
    let mut toml = String::new();
    for i in 0..8 {
        let at = |bit: usize| {
            if i >> bit & 1 == 1 {
                side / 2.0
            } else {
                -side / 2.0
            }
        };
        toml += &format!("[[mic]]\nposition = [{}, {}, {}]\n", at(0), at(1), at(2));
    }
    Geometry::from_toml_str(&toml).unwrap()
}

fn patterns_of(setup: &Setup) -> Option<Patterns> {
    Patterns::new(setup, &setup.threshold)
}

fn setup(geometry: &Geometry, rate: u32, params: &Params) -> Setup {
    Setup::new(geometry, rate, params).unwrap()
}

#[test]
fn patterns_are_learned_with_a_tracker_on_arrays_with_room_for_reflections() {
    let tracked = crate::Config::default().settings().unwrap().method;
    // A 40 cm cube: its longest delay is 32 samples at 16 kHz, 16 at 8 kHz.
    let large = cube(0.4);
    assert!(patterns_of(&setup(&large, 16000, &tracked)).is_some());
    assert!(patterns_of(&setup(&large, 8000, &tracked)).is_some());
    // A 4 cm cube: 3 samples at 16 kHz, 9 at 48 kHz.
    let small = cube(0.04);
    assert!(patterns_of(&setup(&small, 16000, &tracked)).is_none());
    assert!(patterns_of(&setup(&small, 48000, &tracked)).is_some());
    // Without a tracker (no steered response), or turned off: none.
    assert!(patterns_of(&setup(&large, 16000, &Params::default())).is_none());
    let mut off = tracked.clone();
    off.talkers.patterns_s = 0.0;
    assert!(patterns_of(&setup(&large, 16000, &off)).is_none());
}

#[test]
fn a_time_constant_that_is_negative_or_not_finite_is_refused() {
    for bad in [-1.0, f64::NAN, f64::INFINITY] {
        let mut params = crate::Config::default().settings().unwrap().method;
        params.talkers.patterns_s = bad;
        assert!(Setup::new(&cube(0.4), 16000, &params).is_err(), "{bad}");
    }
}

#[test]
fn products_are_the_naive_sums() {
    let a: Vec<f32> = (0..43).map(|i| (i as f32 * 0.37).sin()).collect();
    let b: Vec<f32> = (0..43).map(|i| (i as f32 * 0.11).cos() - 0.2).collect();
    let (c, e) = products(&a, &b);
    let naive_c: f64 = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (*x as f64) * (*y as f64))
        .sum();
    let naive_e: f64 = b.iter().map(|y| (*y as f64) * (*y as f64)).sum();
    assert!((c - naive_c).abs() < 1e-5, "{c} {naive_c}");
    assert!((e - naive_e).abs() < 1e-5, "{e} {naive_e}");
}
