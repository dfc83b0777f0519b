//! Free-field recordings with known truth, fast enough for tests and measurements:
//! sources from known directions (far field) or positions (near field, 1/r spreading),
//! delayed by exact fractional delays, plus independent sensor noise. Delays are applied
//! in the frequency domain (a linear phase on the spectrum of the whole signal), which is
//! exact for band-limited signals. The same seed gives the same samples.

use super::signals::{generate, Signal};
use crate::geometry::unit_from_angles;
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use realfft::num_complex::Complex64;
use realfft::RealFftPlanner;

/// Where a source is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Place {
    /// Far field: a unit vector from the array centre.
    Direction(Vector3<f64>),
    /// Near field: a point in the array frame (metres), with 1/r spreading.
    Position(Vector3<f64>),
    /// Far field, moving: at `azimuth_deg`, `elevation_deg` when the source starts, its
    /// azimuth then turning at `deg_per_s` (rendered sample by sample, see [`render`]).
    Moving {
        /// Azimuth at the source's start (degrees).
        azimuth_deg: f64,
        /// Elevation, constant (degrees).
        elevation_deg: f64,
        /// How fast the azimuth turns (degrees per second; negative: clockwise).
        deg_per_s: f64,
    },
}

/// A source of a free-field scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Source {
    /// Where it is.
    pub place: Place,
    /// What it emits.
    pub signal: Signal,
    /// Start of its active interval (seconds).
    pub start_s: f64,
    /// End of its active interval (seconds).
    pub end_s: f64,
    /// RMS level of the emitted signal at the array centre (full scale = 1).
    pub level: f64,
}

/// A free-field scene: microphones, sources, sensor noise.
#[derive(Debug, Clone)]
pub struct Scene {
    /// Sample rate (Hz).
    pub sample_rate: u32,
    /// Length (seconds).
    pub duration_s: f64,
    /// Microphone positions (metres).
    pub mics: Vec<Vector3<f64>>,
    /// Speed of sound (m/s).
    pub speed_of_sound: f64,
    /// The sources.
    pub sources: Vec<Source>,
    /// RMS of independent Gaussian noise added to every channel.
    pub sensor_noise: f64,
    /// Random seed.
    pub seed: u64,
}

impl Source {
    /// The unit vector from `centre` toward the source (a moving one where it starts).
    pub fn direction_from(&self, centre: &Vector3<f64>) -> Vector3<f64> {
        self.direction_at(centre, self.start_s)
    }

    /// The unit vector from `centre` toward the source at time `t_s` (seconds).
    pub fn direction_at(&self, centre: &Vector3<f64>, t_s: f64) -> Vector3<f64> {
        match self.place {
            Place::Direction(u) => u.normalize(),
            Place::Position(p) => (p - centre).normalize(),
            Place::Moving {
                azimuth_deg,
                elevation_deg,
                deg_per_s,
            } => unit_from_angles(
                azimuth_deg + deg_per_s * (t_s - self.start_s),
                elevation_deg,
            ),
        }
    }
}

/// Renders the scene: one `Vec<f32>` per microphone.
pub fn render(scene: &Scene) -> Vec<Vec<f32>> {
    let fs = scene.sample_rate as f64;
    let len = (scene.duration_s * fs).round() as usize;
    let centre = scene.mics.iter().sum::<Vector3<f64>>() / scene.mics.len() as f64;
    let aperture = scene
        .mics
        .iter()
        .map(|p| (p - centre).norm())
        .fold(0.0, f64::max);
    let mut rng = ChaCha8Rng::seed_from_u64(scene.seed);
    let mut out = vec![vec![0.0f64; len]; scene.mics.len()];
    // Room for the longest delay plus a margin, so circular wrap-around stays silent.
    let pad = ((2.0 * aperture / scene.speed_of_sound) * fs).ceil() as usize + 64;
    let size = (len + 2 * pad).next_power_of_two();
    let mut planner = RealFftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(size);
    let inv = planner.plan_fft_inverse(size);
    for src in &scene.sources {
        let mut s = vec![0.0f64; size];
        emit(src, fs, len, &mut s[pad..pad + len], &mut rng);
        if let Place::Moving { .. } = src.place {
            render_moving(scene, src, &centre, &s[pad..pad + len], &mut out);
            continue;
        }
        let mut spec = fwd.make_output_vec();
        fwd.process(&mut s, &mut spec).expect("sizes match");
        for (m, p) in scene.mics.iter().enumerate() {
            // Arrival time relative to the centre (seconds) and gain.
            let (t, g) = match src.place {
                Place::Direction(u) => (
                    -(u.normalize().dot(&(p - centre))) / scene.speed_of_sound,
                    1.0,
                ),
                Place::Position(q) => {
                    let r0 = (q - centre).norm();
                    let r = (q - p).norm();
                    ((r - r0) / scene.speed_of_sound, r0 / r)
                }
                Place::Moving { .. } => unreachable!("rendered sample by sample"),
            };
            let shift = t * fs;
            let mut shifted: Vec<Complex64> = spec
                .iter()
                .enumerate()
                .map(|(k, x)| {
                    let ph = -std::f64::consts::TAU * k as f64 * shift / size as f64;
                    x * Complex64::from_polar(g / size as f64, ph)
                })
                .collect();
            let last = shifted.len() - 1;
            shifted[0].im = 0.0;
            shifted[last] = Complex64::new(0.0, 0.0);
            let mut y = vec![0.0f64; size];
            inv.process(&mut shifted, &mut y).expect("sizes match");
            for (o, v) in out[m].iter_mut().zip(&y[pad..pad + len]) {
                *o += v;
            }
        }
    }
    out.into_iter()
        .map(|ch| {
            ch.into_iter()
                .map(|v| {
                    let noise: f64 = StandardNormal.sample(&mut rng);
                    (v + scene.sensor_noise * noise) as f32
                })
                .collect()
        })
        .collect()
}

/// Half the taps of the windowed-sinc interpolation of a moving source.
const LANCZOS: isize = 16;

/// A moving far-field source, sample by sample: microphone `m` hears at time `t` what
/// reached the centre at `t - tau_m(t)`, `tau_m(t) = -u(t) . (p_m - centre) / c`, read
/// between samples through a Lanczos kernel of [`LANCZOS`] lobes (within -30 dB of the
/// exact delay of the spectral path for a source that does not move; test below).
fn render_moving(
    scene: &Scene,
    src: &Source,
    centre: &Vector3<f64>,
    signal: &[f64],
    out: &mut [Vec<f64>],
) {
    let fs = scene.sample_rate as f64;
    let sinc = |x: f64| {
        if x.abs() < 1e-12 {
            1.0
        } else {
            let px = std::f64::consts::PI * x;
            px.sin() / px
        }
    };
    let n = signal.len() as isize;
    for (m, p) in scene.mics.iter().enumerate() {
        let offset = p - centre;
        for (i, o) in out[m].iter_mut().enumerate() {
            let t = i as f64 / fs;
            let u = src.direction_at(centre, t);
            let at = i as f64 + u.dot(&offset) / scene.speed_of_sound * fs;
            let base = at.floor() as isize;
            let mut v = 0.0;
            for k in base - LANCZOS + 1..=base + LANCZOS {
                if (0..n).contains(&k) {
                    let x = at - k as f64;
                    v += signal[k as usize] * sinc(x) * sinc(x / LANCZOS as f64);
                }
            }
            *o += v;
        }
    }
}

/// Writes the source's signal (at the array centre) into `buf` (the whole duration).
fn emit(src: &Source, fs: f64, len: usize, buf: &mut [f64], rng: &mut ChaCha8Rng) {
    let a = ((src.start_s * fs).round().max(0.0) as usize).min(len);
    let b = ((src.end_s * fs).round().max(0.0) as usize).min(len);
    if a >= b {
        return;
    }
    generate(&src.signal, src.level, fs, &mut buf[a..b], rng);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn delays_and_levels_follow_the_geometry() {
        // Two mics 0.5 m apart on x, a far source on +x: mic at +x hears it first by
        // 0.5/343 s = 69.97 samples at 48 kHz.
        let scene = Scene {
            sample_rate: 48000,
            duration_s: 0.5,
            mics: vec![Vector3::new(0.25, 0.0, 0.0), Vector3::new(-0.25, 0.0, 0.0)],
            speed_of_sound: 343.0,
            sources: vec![Source {
                place: Place::Direction(Vector3::x()),
                signal: Signal::WhiteNoise,
                start_s: 0.0,
                end_s: 0.5,
                level: 0.1,
            }],
            sensor_noise: 0.0,
            seed: 1,
        };
        let ch = render(&scene);
        let expect = 0.5 / 343.0 * 48000.0;
        // Cross-correlate by brute force around the expected lag.
        let corr = |lag: i64| -> f64 {
            (200..23000)
                .map(|t| ch[0][t] as f64 * ch[1][(t as i64 + lag) as usize] as f64)
                .sum()
        };
        let best = (60..80)
            .max_by(|&a, &b| corr(a).total_cmp(&corr(b)))
            .unwrap();
        assert!((best as f64 - expect).abs() <= 0.5, "{best} vs {expect}");
        let rms = (ch[0][2000..22000]
            .iter()
            .map(|v| (*v as f64).powi(2))
            .sum::<f64>()
            / 20000.0)
            .sqrt();
        assert!((rms - 0.1).abs() < 0.005, "{rms}");
        // Same seed, same samples.
        assert_eq!(render(&scene), ch);
    }

    /// A moving source that does not move is rendered, sample by sample, as the static
    /// one is through the spectrum; one that turns is heard from where it is at the time.
    #[test]
    fn a_moving_source_is_heard_where_it_is() {
        let mics = vec![
            Vector3::new(0.25, 0.0, 0.0),
            Vector3::new(-0.25, 0.0, 0.0),
            Vector3::new(0.0, 0.25, 0.0),
        ];
        let scene = |place| Scene {
            sample_rate: 16000,
            duration_s: 1.0,
            mics: mics.clone(),
            speed_of_sound: 343.0,
            sources: vec![Source {
                place,
                signal: Signal::PinkNoise,
                start_s: 0.0,
                end_s: 1.0,
                level: 0.1,
            }],
            sensor_noise: 0.0,
            seed: 3,
        };
        let fixed = render(&scene(Place::Direction(unit_from_angles(30.0, 10.0))));
        let still = render(&scene(Place::Moving {
            azimuth_deg: 30.0,
            elevation_deg: 10.0,
            deg_per_s: 0.0,
        }));
        for (a, b) in fixed.iter().zip(&still) {
            let (mut err, mut power) = (0.0, 0.0);
            for t in 800..15200 {
                err += (a[t] as f64 - b[t] as f64).powi(2);
                power += (a[t] as f64).powi(2);
            }
            // The kernel's truncation: about -32 dB, near the Nyquist frequency.
            assert!(err < 1e-3 * power, "{}", err / power);
        }
        // Turning at 90 deg/s from azimuth 0: at 0.5 s the source is at 45 deg, where
        // mics 0 and 2 hear it at the same time.
        let turning = render(&scene(Place::Moving {
            azimuth_deg: 0.0,
            elevation_deg: 0.0,
            deg_per_s: 90.0,
        }));
        let corr = |lag: i64| -> f64 {
            (7600..8400)
                .map(|t| turning[0][t] as f64 * turning[2][(t as i64 + lag) as usize] as f64)
                .sum()
        };
        let best = (-8..=8)
            .max_by(|&a, &b| corr(a).total_cmp(&corr(b)))
            .unwrap();
        assert_eq!(best, 0);
    }
}
