//! The steered response's tests.

use super::*;
use crate::geometry::Geometry;
use crate::geometry::{angle_between_deg, unit_from_angles};
use crate::method::paper::pairs::pair_count;

#[test]
fn running_max_is_the_naive_one() {
    let w: Vec<f32> = (0..37)
        .map(|i| ((i * 7919) % 23) as f32 - 9.0 + 0.5 * (i as f32).sin())
        .collect();
    let (mut out, mut scratch) = (Vec::new(), Vec::new());
    for r in [0, 1, 2, 5, 13, 40] {
        running_max(&w, r, &mut out, &mut scratch);
        let naive: Vec<f32> = (0..w.len())
            .map(|i| {
                let lo = i.saturating_sub(r);
                let hi = (i + r).min(w.len() - 1);
                w[lo..=hi].iter().copied().fold(0.0f32, f32::max)
            })
            .collect();
        assert_eq!(out, naive, "r = {r}");
    }
}

const RATE: f64 = 48000.0;
const SPEED: f64 = 343.0;

/// The shipped prism (`testdata/prism.toml`).
fn prism_geometry() -> Geometry {
    Geometry::from_file(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata/prism.toml"),
    )
    .unwrap()
}

/// The prism at 48 kHz: its positions, lags per pair, a steered response and
/// the solver of all its microphones.
fn prism() -> (Vec<Vector3<f64>>, Vec<usize>, Steered, DirectionSolver) {
    let geometry = prism_geometry();
    let positions: Vec<Vector3<f64>> = geometry.mics.iter().map(|m| m.position).collect();
    let mics = positions.len();
    let max_lag: Vec<usize> = (0..pair_count(mics))
        .map(|_| (0.8 * RATE / SPEED) as usize)
        .collect();
    let steered = Steered::new(&positions, RATE, SPEED, &max_lag);
    let solver = DirectionSolver::new(&geometry, (1 << mics) - 1, RATE, SPEED).unwrap();
    (positions, max_lag, steered, solver)
}

/// The search stops before its grid only when no refinement could reach its floor: with
/// one source between samples (each pair's refined peak above its samples), a floor at
/// the best score found still gives that score, and one just above the pairs' largest
/// refined maxima gives nothing.
#[test]
fn the_refined_maxima_stop_only_searches_that_cannot_reach_the_floor() {
    let (positions, max_lag, mut steered, solver) = prism();
    let mics = positions.len();
    let u = unit_from_angles(30.0, 10.0);
    let mut single = Vec::new();
    for i in 0..mics {
        for j in i + 1..mics {
            let half = max_lag[pair_index(i, j, mics)] + 1;
            let lag = u.dot(&((positions[j] - positions[i]) * RATE / SPEED)) + half as f64;
            single.extend((0..2 * half + 1).map(|k| {
                let d = k as f64 - lag;
                (-d * d).exp() as f32
            }));
        }
    }
    let live: Vec<usize> = (0..mics).collect();
    let query = |floor| Query {
        live: &live,
        mics,
        found: &[],
        tolerance: 2.0,
        floor,
    };
    let mut windows = single.clone();
    let best = steered.search(&mut windows, &query(0.0), &solver).unwrap();
    assert!(best.score > 0.0);
    let again = steered
        .search(&mut windows, &query(best.score), &solver)
        .expect("a floor the best direction reaches is searched");
    assert_eq!(again.score, best.score);
    // The pairs' largest refined maxima, summed as the search sums them, and their
    // largest samples.
    let (mut most, mut samples) = (0.0f64, 0.0f64);
    let mut start = 0;
    for h in &max_lag {
        let w = &single[start..start + 2 * h + 3];
        let top = (1..w.len() - 1)
            .filter(|&i| w[i] > 0.0 && w[i] >= w[i - 1] && w[i] > w[i + 1])
            .map(|i| refine_peak(w, i).1)
            .fold(0.0f32, f32::max);
        most += top as f64;
        samples += window_max(w, 0.0) as f64;
        start += 2 * h + 3;
    }
    // The peaks' samples alone would have stopped the search at its own score.
    assert!(samples < best.score && best.score <= most);
    assert!(steered
        .search(&mut windows, &query(most * 1.000001), &solver)
        .is_none());
}

/// Correlations with a peak at every pair's delay of source A, weaker ones at
/// source B's, and three pairs that disagree with A: the first search finds A with
/// the other pairs agreeing, the second (A cleared) finds B.
#[test]
fn finds_a_source_most_pairs_agree_on_then_the_next() {
    let (positions, max_lag, mut steered, solver) = prism();
    let (rate, speed) = (RATE, SPEED);
    let mics = positions.len();
    let (a, b) = (unit_from_angles(30.0, 10.0), unit_from_angles(-60.0, -5.0));
    let mut windows = vec![0.0f32; max_lag.iter().map(|&h| 2 * h + 3).sum()];
    let mut start = 0;
    for i in 0..mics {
        for j in i + 1..mics {
            let half = max_lag[pair_index(i, j, mics)] + 1;
            let x = (positions[j] - positions[i]) * rate / speed;
            let w = &mut windows[start..start + 2 * half + 1];
            // Pairs 0-2 put A's peak 6 samples off.
            let off = if pair_index(i, j, mics) < 3 { 6.0 } else { 0.0 };
            for (u, height, shift) in [(a, 1.0, off), (b, 0.5, 0.0)] {
                let lag = u.dot(&x) + shift + half as f64;
                for (k, v) in w.iter_mut().enumerate() {
                    let d = k as f64 - lag;
                    *v += (height * (-d * d).exp()) as f32;
                }
            }
            start += 2 * half + 1;
        }
    }
    let live: Vec<usize> = (0..mics).collect();
    let query = |found, floor| Query {
        live: &live,
        mics,
        found,
        tolerance: 2.0,
        floor,
    };
    let first = steered
        .search(&mut windows, &query(&[], 0.0), &solver)
        .unwrap();
    assert!(angle_between_deg(&first.direction, &a) < 0.5);
    assert_eq!(first.agreeing, pair_count(mics) - 3);
    assert!(first.score > 0.9 * (pair_count(mics) - 3) as f64);
    // A floor above what any direction can score: nothing is searched.
    assert!(steered
        .search(&mut windows, &query(&[], 100.0), &solver)
        .is_none());
    let second = steered
        .search(&mut windows, &query(&[first.direction], 0.0), &solver)
        .unwrap();
    assert!(
        angle_between_deg(&second.direction, &b) < 0.5,
        "{:?}",
        crate::geometry::angles_deg(&second.direction)
    );
    assert!(second.agreeing >= pair_count(mics) - 3);
}

/// The refinement's peak is the one a scan of the window itself finds: the highest
/// positive local maximum in reach, the first of equal ones.
#[test]
fn local_peak_from_marks_is_the_scanned_one() {
    let w: Vec<f32> = (0..61)
        .map(|i| (((i * 7919) % 13) as f32 - 5.0) * 0.1 + if i % 9 == 0 { 0.3 } else { 0.0 })
        .collect();
    let mut marks = vec![0.0; w.len()];
    mark_peaks(&w, &mut marks);
    for centre in [0.0f64, 3.4, 17.0, 30.5, 59.9] {
        for reach in [0.0f64, 1.0, 2.4, 8.0, 70.0] {
            let lo = ((centre - reach).ceil().max(1.0)) as usize;
            let hi = ((centre + reach).floor().min(w.len() as f64 - 2.0)) as isize;
            let mut scanned: Option<(usize, f32)> = None;
            for i in lo..=hi.max(0) as usize {
                if hi < lo as isize {
                    break;
                }
                let v = w[i];
                if v > 0.0 && v >= w[i - 1] && v > w[i + 1] && scanned.is_none_or(|(_, b)| v > b) {
                    scanned = Some((i, v));
                }
            }
            let got = local_peak(&w, &marks, centre, reach);
            assert_eq!(
                got.is_some(),
                scanned.is_some(),
                "centre {centre} reach {reach}"
            );
            if let (Some((at, _)), Some((i, _))) = (got, scanned) {
                assert!(
                    (at - i as f64).abs() <= 0.5,
                    "centre {centre} reach {reach}"
                );
            }
        }
    }
}

/// A value in `0..modulus` that jumps about with `i` (Knuth's multiplicative hash),
/// different for each `seed`.
fn scattered(i: u64, seed: u64, modulus: u64) -> u64 {
    (i * 2654435761 + seed * 40503) % modulus
}

/// Marking a window returns what refining each marked maximum one by one and keeping the
/// largest gives, bit for bit, whatever the window's length against the eight lanes (and
/// 0 for a window with no positive local maximum).
#[test]
fn marking_returns_the_largest_refined_maximum() {
    for len in [3usize, 4, 9, 10, 17, 61, 210] {
        for seed in 0..5u64 {
            let w: Vec<f32> = (0..len as u64)
                .map(|i| {
                    let h = scattered(i, seed, 1000);
                    (h as f32 / 500.0 - 1.0) * if i % 7 == seed % 7 { 2.0 } else { 0.5 }
                })
                .collect();
            let mut marks = vec![f32::NAN; len];
            let top = mark_peaks(&w, &mut marks);
            let mut expected = 0.0f32;
            for i in 1..len - 1 {
                let v = w[i];
                let hit = v > 0.0 && v >= w[i - 1] && v > w[i + 1];
                assert_eq!(
                    marks[i],
                    if hit { v } else { 0.0 },
                    "len {len} seed {seed} at {i}"
                );
                if hit {
                    expected = expected.max(refine_peak(&w, i).1);
                }
            }
            assert_eq!((marks[0], marks[len - 1]), (0.0, 0.0));
            assert_eq!(top.to_bits(), expected.to_bits(), "len {len} seed {seed}");
        }
    }
    assert_eq!(mark_peaks(&[-1.0, -0.5, -2.0], &mut [0.0; 3]), 0.0);
}

/// The best points are the first of a full sort by power (ties to the lower index),
/// with ties, excluded points (-inf) and fewer points than asked for.
#[test]
fn best_points_are_a_full_sorts_first() {
    for n in [1usize, 5, 63, 64, 65, 130, 1000] {
        for seed in 0..6u64 {
            let power: Vec<f32> = (0..n as u64)
                .map(|g| {
                    let h = scattered(g, seed, 1009);
                    match (h % 11, seed) {
                        (0, _) => f32::NEG_INFINITY,
                        (_, 5) => 1.0,
                        _ => (h % 40) as f32 * 0.25,
                    }
                })
                .collect();
            for top in [0usize, 1, 6, 64, 2000] {
                let mut all: Vec<usize> = (0..n).collect();
                all.sort_by(|x, y| power[*y].total_cmp(&power[*x]).then(x.cmp(y)));
                all.truncate(top);
                let mut order = vec![7usize; 3];
                best_points(&power, top, &mut order);
                assert_eq!(order, all, "n {n} seed {seed} top {top}");
            }
        }
    }
}

/// The whole numbers within a span are `ceil` and `floor`'s, at whole numbers, halves,
/// just either side of them, and either sign.
#[test]
fn whole_within_is_ceil_and_floor() {
    for base in [-300.0f64, -2.0, -1.0, -0.0, 0.0, 1.0, 17.0, 209.0] {
        for offset in [0.0, 0.5, -0.5, 1e-9, -1e-9, 0.999, -0.999, 2.4] {
            let x = base + offset;
            let (lo, hi) = whole_within(x, x);
            assert_eq!((lo as f64, hi as f64), (x.ceil(), x.floor()), "{x}");
        }
    }
}

/// The steered response's pairs take two samples at 16 kHz on the prism (the default
/// consistency tolerance there is one), the consistency tolerance on an 8-mic circle of
/// radius 15 cm (its longest delay, 14 samples, is under [`LOOSE_MIN_LAGS`]) and at 48
/// kHz (where the tolerance is 2.4 samples, 1.9 at 40 us), and with `--every-frame`.
#[test]
fn a_steered_direction_takes_two_samples_on_arrays_of_sixteen_or_more() {
    use crate::method::layout::Layout;
    use crate::method::Params;
    let prism = prism_geometry();
    let circle: Vec<[f64; 3]> = (0..8)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / 8.0;
            [0.15 * a.cos(), 0.15 * a.sin(), 0.0]
        })
        .collect();
    let circle = Geometry::from_positions(&circle).unwrap();
    let at_steering = |g: &Geometry, rate, us, steered| {
        let params = Params {
            tolerance: crate::method::Tolerance::Us(us),
            steered,
            ..Params::default()
        };
        let l = Layout::new(g, rate, &params).unwrap();
        (l.tolerance, l.steer_tolerance)
    };
    let at = |g: &Geometry, rate, us| at_steering(g, rate, us, Params::default().steered);
    assert_eq!(at(&prism, 16000, 50.0), (1.0, LOOSE_SAMPLES));
    // Every frame's direction keeps the consistency tolerance.
    assert_eq!(
        at_steering(&prism, 16000, 50.0, Steering::EveryFrame),
        (1.0, 1.0)
    );
    assert_eq!(at(&circle, 16000, 50.0), (1.0, 1.0));
    for us in [50.0, 40.0] {
        let (tolerance, steer) = at(&prism, 48000, us);
        assert!((tolerance - us as f32 * 0.048).abs() < 1e-4 && steer == tolerance);
    }
}
