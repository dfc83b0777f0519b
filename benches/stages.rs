//! Per-stage costs of one analysis frame, and the consistency search against the FFT
//! work it rides on. `cargo bench --bench stages`
//!
//! Prints, before the timings, the search's node counts on real frames (a source in
//! sensor noise, and sensor noise alone) for 8, 16 and 32 microphones.

#[path = "../tests/support/mod.rs"]
mod support;

use nalgebra::Vector3;
use realfft::num_complex::Complex32;
use ssl::geometry::unit_from_angles;
use ssl::method::correlation::{whiten, Correlator};
use ssl::method::pairs::{pair_count, pair_index};
use ssl::method::peaks::{find_peaks, Interpolation, Peak};
use ssl::method::search::Searcher;
use ssl::method::spectrum::{ForwardFft, Window};
use ssl::sim::freefield::{render, Place, Scene, Source};
use ssl::sim::signals::Signal;
use ssl::{Analysis, Geometry, Params};
use std::hint::black_box;
use std::ops::ControlFlow;
use std::time::Instant;

const N: usize = 1024;

/// `mics` positions: the prism for 8, else points spread over a 0.5 m sphere (fixed).
fn array(mics: usize) -> Vec<Vector3<f64>> {
    if mics == 8 {
        return support::prism();
    }
    support::sphere_lattice(mics, 0.25)
}

fn geometry(positions: &[Vector3<f64>]) -> Geometry {
    Geometry::from_positions(
        &positions
            .iter()
            .map(|p| [p.x, p.y, p.z])
            .collect::<Vec<_>>(),
    )
    .unwrap()
}

/// One frame (mic-major) of a scene: with a source, or sensor noise alone.
fn frame(positions: &[Vector3<f64>], with_source: bool) -> Vec<f32> {
    let scene = Scene {
        sample_rate: 48000,
        duration_s: 0.1,
        mics: positions.to_vec(),
        speed_of_sound: 343.0,
        sources: if with_source {
            vec![Source {
                place: Place::Direction(unit_from_angles(35.0, 12.0)),
                signal: Signal::WhiteNoise,
                start_s: 0.0,
                end_s: 0.1,
                level: 0.05,
            }]
        } else {
            vec![]
        },
        sensor_noise: 0.01,
        seed: 5,
    };
    let ch = render(&scene);
    ch.iter()
        .flat_map(|c| c[1000..1000 + N].iter().copied())
        .collect()
}

/// The peak table of a frame, as the pipeline builds it (plain PHAT weights).
fn peaks(positions: &[Vector3<f64>], frame: &[f32]) -> Vec<Vec<Peak>> {
    let k = positions.len();
    let g = geometry(positions);
    let mut fft = ForwardFft::new(N, Window::Hann);
    let ones = vec![1.0f32; N / 2 + 1];
    let spectra: Vec<Vec<Complex32>> = (0..k)
        .map(|m| {
            let mut x = vec![Complex32::default(); N / 2 + 1];
            fft.transform(&frame[m * N..(m + 1) * N], &mut x);
            let mut y = x.clone();
            whiten(&x, &ones, &mut y);
            y
        })
        .collect();
    let mut corr = Correlator::new(N);
    let mut r = Vec::new();
    let mut table = vec![Vec::new(); pair_count(k)];
    for a in 0..k {
        for b in a + 1..k {
            corr.correlate((&spectra[a], &spectra[b]), None, N as f32);
            let lag = (g.max_lag_samples(a, b, 48000.0, 343.0) * 1.03).ceil() as usize + 1;
            corr.lags(false, lag + 1, &mut r);
            find_peaks(
                &r,
                8,
                Interpolation::Parabolic,
                &mut table[pair_index(a, b, k)],
            );
        }
    }
    table
}

fn stages(c: &mut Timer) {
    for mics in [8usize, 16, 32] {
        let pos = array(mics);
        for (label, with_source) in [("source", true), ("noise only", false)] {
            let table = peaks(&pos, &frame(&pos, with_source));
            let mut s = Searcher::new(2.0, u64::MAX);
            let found = s.search(mics, &table).is_some();
            eprintln!(
                "search, {mics} mics, {label}: {} nodes (of 8^{} sets), consistent set found: {found}",
                s.nodes(),
                mics - 1
            );
        }
    }

    let pos = array(8);
    let frame8 = frame(&pos, true);
    let mut fft = ForwardFft::new(N, Window::Hann);
    let mut spec = vec![Complex32::default(); N / 2 + 1];
    let mut spec2 = spec.clone();
    c.bench_function("forward FFTs, 8 ch x 1024, two per FFT", |b| {
        b.iter(|| {
            for m in (0..8).step_by(2) {
                fft.transform_two(
                    black_box(&frame8[m * N..(m + 1) * N]),
                    &frame8[(m + 1) * N..(m + 2) * N],
                    &mut spec,
                    &mut spec2,
                );
            }
        })
    });
    let mut corr = Correlator::new(N);
    let y = vec![Complex32::new(0.5, 0.5); N / 2 + 1];
    c.bench_function(
        "cross-spectra and inverse FFTs of 28 pairs, two per FFT",
        |b| {
            b.iter(|| {
                for _ in 0..14 {
                    corr.correlate((black_box(&y), &y), Some((&y, &y)), N as f32);
                }
            })
        },
    );
    // The 28 pairs' lag windows of a frame with a source (plain PHAT weights).
    let g = geometry(&pos);
    let ones = vec![1.0f32; N / 2 + 1];
    let white: Vec<Vec<Complex32>> = (0..8)
        .map(|m| {
            fft.transform(&frame8[m * N..(m + 1) * N], &mut spec);
            let mut y = spec.clone();
            whiten(&spec, &ones, &mut y);
            y
        })
        .collect();
    let mut windows = Vec::new();
    for a in 0..8 {
        for b in a + 1..8 {
            corr.correlate((&white[a], &white[b]), None, N as f32);
            let lag = (g.max_lag_samples(a, b, 48000.0, 343.0) * 1.03).ceil() as usize + 1;
            let mut w = Vec::new();
            corr.lags(false, lag + 1, &mut w);
            windows.push(w);
        }
    }
    let mut found = Vec::with_capacity(8);
    c.bench_function("peaks of 28 pairs, 8 mics x 8 peaks", |b| {
        b.iter(|| {
            for w in &windows {
                find_peaks(black_box(w), 8, Interpolation::Parabolic, &mut found);
            }
        })
    });
    for mics in [8usize, 16, 32] {
        let pos = array(mics);
        for (label, with_source) in [("source", true), ("noise only", false)] {
            let table = peaks(&pos, &frame(&pos, with_source));
            let mut s = Searcher::new(2.0, u64::MAX);
            c.bench_function(&format!("search, {mics} mics x 8 peaks, {label}"), |b| {
                b.iter(|| black_box(s.search(mics, black_box(&table)).is_some()))
            });
        }
    }
    // --min-score 0: no correlation can be skipped.
    let every_pair = {
        let mut p = Params::default();
        p.threshold = ssl::method::Threshold::Fixed { per_pair: 0.0 };
        p
    };
    let g = geometry(&pos);
    let second = render(&Scene {
        sample_rate: 48000,
        duration_s: 1.0,
        mics: pos.clone(),
        speed_of_sound: 343.0,
        sources: vec![Source {
            place: Place::Direction(unit_from_angles(35.0, 12.0)),
            signal: Signal::WhiteNoise,
            start_s: 0.0,
            end_s: 1.0,
            level: 0.05,
        }],
        sensor_noise: 0.01,
        seed: 5,
    });
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    c.bench_function(
        "a whole second, 8 mics, every correlation (92 frames, one thread)",
        |b| {
            b.iter(|| {
                one.install(|| {
                    let channels = second.iter().map(|c| &c[..]).collect();
                    let analysis =
                        Analysis::from_channels("bench", channels, 48000, &g, &every_pair).unwrap();
                    let mut found = 0;
                    let (_, result) = analysis.run(|_, d| {
                        found += d.len();
                        ControlFlow::Continue(())
                    });
                    result.unwrap();
                    black_box(found)
                })
            })
        },
    );
}

fn main() {
    stages(&mut Timer);
}

/// Times a closure as a benchmark harness does, without one: a warm-up of about 0.2 s,
/// then 15 samples of about 0.1 s each; prints the median time per call and the spread
/// (the lowest and highest sample).
struct Timer;

impl Timer {
    fn bench_function(&mut self, name: &str, mut run: impl FnMut(&mut Bencher)) {
        let mut b = Bencher {
            iters: 1,
            took: 0.0,
        };
        // Warm up, and find how many calls fill a sample.
        let start = Instant::now();
        while start.elapsed().as_secs_f64() < 0.2 {
            run(&mut b);
            if b.took < 0.01 {
                b.iters *= 2;
            }
        }
        b.iters = ((0.1 / (b.took / b.iters as f64).max(1e-9)) as u64).max(1);
        let mut per_call: Vec<f64> = (0..15)
            .map(|_| {
                run(&mut b);
                b.took / b.iters as f64
            })
            .collect();
        per_call.sort_by(f64::total_cmp);
        println!(
            "{name:<70} {} (range {} to {})",
            shown(per_call[7]),
            shown(per_call[0]),
            shown(per_call[14])
        );
    }
}

/// What a benchmarked closure gets: [`Bencher::iter`] calls the work `iters` times.
struct Bencher {
    iters: u64,
    took: f64,
}

impl Bencher {
    fn iter<R>(&mut self, mut work: impl FnMut() -> R) {
        let start = Instant::now();
        for _ in 0..self.iters {
            black_box(work());
        }
        self.took = start.elapsed().as_secs_f64();
    }
}

/// Seconds as ns, us or ms.
fn shown(s: f64) -> String {
    match s {
        s if s < 1e-6 => format!("{:.1} ns", s * 1e9),
        s if s < 1e-3 => format!("{:.2} us", s * 1e6),
        s => format!("{:.3} ms", s * 1e3),
    }
}
