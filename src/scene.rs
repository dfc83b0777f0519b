//! Simulated recordings with known truth: a scene file (room, array pose, sources,
//! noise) rendered to multichannel audio by the image-source method ([`crate::room`]),
//! with a truth document giving each source's direction in the array frame (per the
//! interface contract), its distance and its active intervals.
//!
//! Levels: a source's `level_db` is the RMS of its direct sound at the array centre while
//! it is active (dB re full scale). Fans and diffuse noise are scaled together so that
//! the mean source level is `snr_db` above their combined power (averaged over the
//! microphones); `sensor_db` adds independent noise to every channel. Same scene and seed,
//! same samples.

use crate::direction::angles_deg;
use crate::geometry::Geometry;
use crate::room::Room;
use crate::synth::{self, Signal};
use anyhow::{bail, Context, Result};
use nalgebra::{DMatrix, Matrix3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use realfft::num_complex::Complex64;
use realfft::RealFftPlanner;
use serde::Deserialize;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    pub sample_rate: u32,
    /// Seconds.
    pub duration: f64,
    #[serde(default)]
    pub seed: u64,
    #[serde(default)]
    pub format: SampleFormat,
    pub speed_of_sound: Option<f64>,
    /// No room: free field.
    pub room: Option<RoomSpec>,
    pub array: ArraySpec,
    #[serde(default)]
    pub source: Vec<SourceSpec>,
    pub noise: Option<NoiseSpec>,
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SampleFormat {
    #[default]
    Int16,
    Int24,
    Int32,
    Float32,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoomSpec {
    pub dimensions: [f64; 3],
    pub rt60: Option<f64>,
    pub absorption: Option<f64>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArraySpec {
    /// Geometry file, relative to the scene file.
    pub geometry: PathBuf,
    /// Where the array's centre (mean of its microphone positions) is, in the room.
    pub position: [f64; 3],
    /// Rotation about the vertical axis: the azimuth of the array's +x axis in the room.
    #[serde(default)]
    pub yaw_deg: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SignalKind {
    White,
    Pink,
    Clicks,
    Tone,
    Speech,
    File,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SourceSpec {
    /// Position in the room; or give `azimuth_deg`, `elevation_deg` and `distance` in the
    /// array frame.
    pub position: Option<[f64; 3]>,
    pub azimuth_deg: Option<f64>,
    pub elevation_deg: Option<f64>,
    pub distance: Option<f64>,
    pub signal: SignalKind,
    #[serde(default = "default_level")]
    pub level_db: f64,
    /// Active intervals in seconds (default: the whole scene).
    pub active: Option<Vec<[f64; 2]>>,
    /// Clicks per second.
    pub rate: Option<f64>,
    /// Tone frequency (Hz).
    pub frequency: Option<f64>,
    /// Mono WAV at the scene's sample rate (relative to the scene file).
    pub file: Option<PathBuf>,
}

fn default_level() -> f64 {
    -26.0
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Colour {
    White,
    #[default]
    Pink,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseSpec {
    /// Mean source level over the combined fan and diffuse noise (dB).
    #[serde(default = "default_snr")]
    pub snr_db: f64,
    /// Independent noise in every channel (dB re full scale RMS).
    pub sensor_db: Option<f64>,
    #[serde(default)]
    pub fan: Vec<FanSpec>,
    pub diffuse: Option<DiffuseSpec>,
}

fn default_snr() -> f64 {
    20.0
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FanSpec {
    pub position: [f64; 3],
    #[serde(default)]
    pub signal: Colour,
    /// Level relative to the other noise components (dB).
    #[serde(default)]
    pub weight_db: f64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiffuseSpec {
    #[serde(default)]
    pub signal: Colour,
    #[serde(default)]
    pub weight_db: f64,
}

/// A rendered scene.
pub struct Simulation {
    pub sample_rate: u32,
    pub format: SampleFormat,
    pub channels: Vec<Vec<f32>>,
    pub truth: Value,
}

impl SceneFile {
    pub fn from_file(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("{}: cannot read scene file", path.display()))?;
        toml::from_str(&text).map_err(|e| {
            let line = e
                .span()
                .map(|s| text[..s.start.min(text.len())].lines().count().max(1));
            anyhow::anyhow!(
                "{}: invalid scene TOML{}: {}",
                path.display(),
                line.map(|l| format!(" at line {l}")).unwrap_or_default(),
                e.message().trim()
            )
        })
    }
}

/// Reads and renders a scene file; relative paths in it are relative to its folder.
pub fn simulate_file(path: &Path) -> Result<Simulation> {
    let scene = SceneFile::from_file(path)?;
    let dir = path.parent().unwrap_or(Path::new("."));
    simulate(&scene, dir).with_context(|| format!("{}", path.display()))
}

struct Placed {
    room: Option<Room>,
    mics: Vec<Vector3<f64>>,
    centre: Vector3<f64>,
    /// Array frame to room frame.
    rotation: Matrix3<f64>,
}

impl Placed {
    fn check_inside(&self, what: &str, p: &Vector3<f64>) -> Result<()> {
        if let Some(room) = &self.room {
            if !room.contains(p) {
                bail!(
                    "{what} at [{:.3}, {:.3}, {:.3}] is outside the room [0..{}, 0..{}, 0..{}]",
                    p.x,
                    p.y,
                    p.z,
                    room.dims.x,
                    room.dims.y,
                    room.dims.z
                );
            }
        }
        Ok(())
    }

    /// Impulse responses from `p` to every microphone (1/r gain, direct path included).
    fn responses(&self, p: &Vector3<f64>, fs: f64, c: f64, tail_s: f64) -> Vec<Vec<f64>> {
        let far = self.mics.iter().map(|m| (m - p).norm()).fold(0.0, f64::max);
        let len = ((far / c + tail_s) * fs) as usize + 2 * crate::room::SINC_HALF_WIDTH + 1;
        self.mics
            .iter()
            .map(|m| match &self.room {
                Some(room) => room.impulse_response(p, m, fs, c, len),
                None => {
                    // Free field: the direct path only.
                    let mut h = vec![0.0; len];
                    let d = (m - p).norm();
                    crate::room::add_tap(&mut h, d / c * fs, 1.0 / d.max(1e-3));
                    h
                }
            })
            .collect()
    }
}

/// Renders a scene; `dir` resolves relative paths.
pub fn simulate(scene: &SceneFile, dir: &Path) -> Result<Simulation> {
    let fs = scene.sample_rate as f64;
    if !(1000..=768_000).contains(&scene.sample_rate) {
        bail!(
            "sample_rate must be between 1000 and 768000 Hz, got {}",
            scene.sample_rate
        );
    }
    if !(scene.duration.is_finite() && scene.duration > 0.0 && scene.duration <= 3600.0) {
        bail!(
            "duration must be between 0 and 3600 seconds, got {}",
            scene.duration
        );
    }
    let c = scene.speed_of_sound.unwrap_or(343.0);
    if !(c.is_finite() && c > 0.0) {
        bail!("speed_of_sound must be positive, got {c}");
    }
    let len = (scene.duration * fs).round() as usize;
    let geometry = Geometry::from_file(&dir.join(&scene.array.geometry))?;
    let room = match &scene.room {
        None => None,
        Some(r) => {
            let dims = Vector3::from(r.dimensions);
            Some(match (r.rt60, r.absorption) {
                (Some(t), None) => Room::with_rt60(dims, t)?,
                (None, Some(a)) => Room::with_absorption(dims, a)?,
                _ => bail!("[room] needs exactly one of `rt60` or `absorption`"),
            })
        }
    };
    let tail_s = room.map_or(0.0, |r| 1.2 * r.rt60());
    let yaw = scene.array.yaw_deg.to_radians();
    let rotation = Matrix3::new(
        yaw.cos(),
        -yaw.sin(),
        0.0,
        yaw.sin(),
        yaw.cos(),
        0.0,
        0.0,
        0.0,
        1.0,
    );
    let centre = Vector3::from(scene.array.position);
    let placed = Placed {
        room,
        mics: geometry
            .mics
            .iter()
            .map(|m| centre + rotation * (m.position - geometry.centre))
            .collect(),
        centre,
        rotation,
    };
    for (i, m) in placed.mics.iter().enumerate() {
        placed.check_inside(&format!("mic {}", i + 1), m)?;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(scene.seed);
    let mics = placed.mics.len();
    let mut out = vec![vec![0.0f64; len]; mics];
    let mut truth_sources = Vec::new();
    let mut level_sum = 0.0;

    for (i, s) in scene.source.iter().enumerate() {
        let what = format!("source {}", i + 1);
        let position = source_position(s, &placed).with_context(|| what.clone())?;
        placed.check_inside(&what, &position)?;
        let distance = (position - placed.centre).norm();
        if distance < 1e-3 {
            bail!("{what} is at the array centre");
        }
        let level = 10f64.powf(s.level_db / 20.0);
        level_sum += level * level;
        let signal = match s.signal {
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
        };
        let recording = match (&s.signal, &s.file) {
            (SignalKind::File, Some(f)) => {
                Some(read_mono(&dir.join(f), scene.sample_rate).with_context(|| what.clone())?)
            }
            (SignalKind::File, None) => bail!("{what}: signal = \"file\" needs `file = \"...\"`"),
            _ => None,
        };
        let intervals = s.active.clone().unwrap_or(vec![[0.0, scene.duration]]);
        let responses = placed.responses(&position, fs, c, tail_s);
        let delay_s = distance / c;
        let mut truth_intervals = Vec::new();
        for [a, b] in intervals {
            if !(a.is_finite() && b.is_finite() && 0.0 <= a && a < b && b <= scene.duration) {
                bail!(
                    "{what}: active interval [{a}, {b}] must lie within [0, {}] and not be empty",
                    scene.duration
                );
            }
            let start = (a * fs).round() as usize;
            let n = ((b * fs).round() as usize).min(len) - start;
            let mut dry = vec![0.0; n];
            // Scaled so that the direct sound at the array centre (gain 1 / distance) has `level`.
            match (&signal, &recording) {
                (Some(sig), _) => synth::generate(sig, level * distance, fs, &mut dry, &mut rng),
                (None, Some(rec)) => {
                    for (k, v) in dry.iter_mut().enumerate() {
                        *v = rec[k % rec.len()];
                    }
                    let rms = (dry.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
                    if rms > 0.0 {
                        dry.iter_mut().for_each(|v| *v *= level * distance / rms);
                    }
                }
                _ => unreachable!(),
            }
            for (m, wet) in convolve(&dry, &responses).into_iter().enumerate() {
                for (o, v) in out[m][start..].iter_mut().zip(wet) {
                    *o += v;
                }
            }
            truth_intervals.push(json!([
                round6(a + delay_s),
                round6((b + delay_s).min(scene.duration))
            ]));
        }
        let u = placed.rotation.transpose() * (position - placed.centre) / distance;
        let (az, el) = angles_deg(&u);
        truth_sources.push(json!({
            "index": i,
            "signal": format!("{:?}", s.signal).to_lowercase(),
            "level_db": s.level_db,
            "position_room": [position.x, position.y, position.z],
            "x": u.x, "y": u.y, "z": u.z,
            "azimuth_deg": az, "elevation_deg": el,
            "distance_m": distance,
            "active": truth_intervals,
        }));
    }

    // Fans and diffuse noise, each normalised to unit power, weighted, then scaled together.
    let mut truth_noise = json!(null);
    if let Some(noise) = &scene.noise {
        let mut total = vec![vec![0.0f64; len]; mics];
        let mut components = 0;
        for (i, fan) in noise.fan.iter().enumerate() {
            let p = Vector3::from(fan.position);
            placed.check_inside(&format!("fan {}", i + 1), &p)?;
            let responses = placed.responses(&p, fs, c, tail_s);
            // Start the fan early so the room is already ringing at time 0.
            let lead = responses[0].len();
            let mut dry = vec![0.0; len + lead];
            colour_noise(fan.signal, fs, &mut dry, &mut rng);
            let wet = convolve(&dry, &responses);
            add_normalised(
                &mut total,
                wet.iter().map(|w| &w[lead..lead + len]).collect(),
                fan.weight_db,
            );
            components += 1;
        }
        if let Some(d) = &noise.diffuse {
            let field = diffuse_noise(&placed.mics, d.signal, fs, c, len, &mut rng);
            add_normalised(
                &mut total,
                field.iter().map(|w| &w[..]).collect(),
                d.weight_db,
            );
            components += 1;
        }
        if components > 0 {
            if level_sum == 0.0 {
                bail!("[noise] snr_db needs at least one [[source]] to be relative to");
            }
            let mean_level2 = level_sum / scene.source.len() as f64;
            let power = mean_power(&total);
            let gain = (mean_level2 / 10f64.powf(noise.snr_db / 10.0) / power).sqrt();
            for (o, t) in out.iter_mut().zip(&total) {
                for (a, b) in o.iter_mut().zip(t) {
                    *a += gain * b;
                }
            }
        }
        if let Some(db) = noise.sensor_db {
            let sigma = 10f64.powf(db / 20.0);
            for ch in out.iter_mut() {
                for v in ch.iter_mut() {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    *v += sigma * z;
                }
            }
        }
        truth_noise = json!({
            "snr_db": noise.snr_db,
            "sensor_db": noise.sensor_db,
            "fans": noise.fan.iter().map(|f| {
                let p = Vector3::from(f.position);
                let u = placed.rotation.transpose() * (p - placed.centre);
                let (az, el) = angles_deg(&u.normalize());
                json!({ "position_room": f.position, "azimuth_deg": az, "elevation_deg": el, "distance_m": u.norm() })
            }).collect::<Vec<_>>(),
            "diffuse": noise.diffuse.is_some(),
        });
    }

    let peak = out.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    if scene.format != SampleFormat::Float32 && peak >= 1.0 {
        bail!("the scene clips (peak {peak:.2} of full scale): lower the levels or use format = \"float32\"");
    }
    let truth = json!({
        "tool": { "name": "ssl", "version": env!("CARGO_PKG_VERSION") },
        "sample_rate": scene.sample_rate,
        "duration_s": scene.duration,
        "seed": scene.seed,
        "speed_of_sound": c,
        "room": placed.room.map(|r| json!({
            "dimensions": [r.dims.x, r.dims.y, r.dims.z],
            "rt60_requested": scene.room.as_ref().and_then(|s| s.rt60),
            "rt60_measured": r.rt60(),
            "rt60_eyring": r.eyring_rt60(),
            "reflection_coefficient": r.beta,
        })),
        "array": {
            "geometry": scene.array.geometry,
            "position": scene.array.position,
            "yaw_deg": scene.array.yaw_deg,
        },
        "sources": truth_sources,
        "noise": truth_noise,
    });
    Ok(Simulation {
        sample_rate: scene.sample_rate,
        format: scene.format,
        channels: out
            .into_iter()
            .map(|ch| ch.into_iter().map(|v| v as f32).collect())
            .collect(),
        truth,
    })
}

fn round6(v: f64) -> f64 {
    (v * 1e6).round() / 1e6
}

fn source_position(s: &SourceSpec, placed: &Placed) -> Result<Vector3<f64>> {
    match (s.position, s.azimuth_deg, s.elevation_deg, s.distance) {
        (Some(p), None, None, None) => Ok(Vector3::from(p)),
        (None, Some(az), el, Some(d)) => {
            if !(d.is_finite() && d > 0.0) {
                bail!("distance must be positive, got {d}");
            }
            let u = crate::direction::unit_from_angles(az, el.unwrap_or(0.0));
            Ok(placed.centre + placed.rotation * u * d)
        }
        _ => bail!(
            "give either `position`, or `azimuth_deg`, `distance` (and optionally `elevation_deg`)"
        ),
    }
}

/// Reads a mono WAV at the given rate as f64 samples.
fn read_mono(path: &Path, rate: u32) -> Result<Vec<f64>> {
    let name = path.display().to_string();
    let mut stream = crate::audio::WavStream::open(&name)?;
    if stream.format.channels != 1 || stream.format.sample_rate != rate {
        bail!(
            "{name}: a source file must be mono at the scene's rate ({rate} Hz); it has {} channel(s) at {} Hz",
            stream.format.channels,
            stream.format.sample_rate
        );
    }
    let mut all = Vec::new();
    let mut buf = vec![0.0f32; 65536];
    loop {
        let n = stream.read(&mut buf)?;
        if n == 0 {
            break;
        }
        all.extend(buf[..n].iter().map(|&v| v as f64));
    }
    if all.is_empty() {
        bail!("{name}: no samples");
    }
    Ok(all)
}

/// Convolves `x` with each response by FFT; outputs have `x.len() + h.len() - 1` samples.
fn convolve(x: &[f64], responses: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let hlen = responses.iter().map(Vec::len).max().unwrap_or(1);
    let n = (x.len() + hlen).next_power_of_two();
    let mut planner = RealFftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(n);
    let inv = planner.plan_fft_inverse(n);
    let mut buf = vec![0.0; n];
    buf[..x.len()].copy_from_slice(x);
    let mut xs = fwd.make_output_vec();
    fwd.process(&mut buf, &mut xs).expect("sizes match");
    responses
        .iter()
        .map(|h| {
            let mut hb = vec![0.0; n];
            hb[..h.len()].copy_from_slice(h);
            let mut hs = fwd.make_output_vec();
            fwd.process(&mut hb, &mut hs).expect("sizes match");
            for (a, b) in hs.iter_mut().zip(&xs) {
                *a = *a * b / n as f64;
            }
            inv.process(&mut hs, &mut hb).expect("sizes match");
            hb.truncate(x.len() + h.len() - 1);
            hb
        })
        .collect()
}

fn mean_power(channels: &[Vec<f64>]) -> f64 {
    let n: usize = channels.iter().map(Vec::len).sum();
    channels.iter().flatten().map(|v| v * v).sum::<f64>() / n.max(1) as f64
}

fn add_normalised(total: &mut [Vec<f64>], part: Vec<&[f64]>, weight_db: f64) {
    let n: usize = part.iter().map(|p| p.len()).sum();
    let power = part
        .iter()
        .flat_map(|p| p.iter())
        .map(|v| v * v)
        .sum::<f64>()
        / n.max(1) as f64;
    if power <= 0.0 {
        return;
    }
    let g = 10f64.powf(weight_db / 20.0) / power.sqrt();
    for (t, p) in total.iter_mut().zip(part) {
        for (a, b) in t.iter_mut().zip(p) {
            *a += g * b;
        }
    }
}

fn colour_noise(colour: Colour, fs: f64, out: &mut [f64], rng: &mut ChaCha8Rng) {
    let signal = match colour {
        Colour::White => Signal::WhiteNoise,
        Colour::Pink => Signal::PinkNoise,
    };
    synth::generate(&signal, 1.0, fs, out, rng);
}

/// A spherically isotropic (diffuse) noise field at the microphones: in every frequency
/// bin, independent complex Gaussians shaped by the Cholesky factor of the field's
/// coherence `sin(k d_ij) / (k d_ij)` (Habets & Gannot 2007), coloured per `colour`.
#[allow(clippy::needless_range_loop)] // bins index several spectra at once
fn diffuse_noise(
    mics: &[Vector3<f64>],
    colour: Colour,
    fs: f64,
    c: f64,
    len: usize,
    rng: &mut ChaCha8Rng,
) -> Vec<Vec<f64>> {
    let m = mics.len();
    let n = len.next_power_of_two().max(2);
    let bins = n / 2 + 1;
    let mut spectra = vec![vec![Complex64::new(0.0, 0.0); bins]; m];
    for k in 1..bins - 1 {
        let f = k as f64 * fs / n as f64;
        let gain = match colour {
            Colour::White => 1.0,
            Colour::Pink => {
                if f < 50.0 {
                    0.0
                } else {
                    (50.0 / f).sqrt()
                }
            }
        };
        let wave = std::f64::consts::TAU * f / c;
        let coherence = DMatrix::from_fn(m, m, |i, j| {
            let x = wave * (mics[i] - mics[j]).norm();
            let g = if x.abs() < 1e-9 { 1.0 } else { x.sin() / x };
            if i == j {
                g + 1e-6
            } else {
                g
            }
        });
        let l = coherence
            .cholesky()
            .map(|ch| ch.l())
            .unwrap_or_else(|| DMatrix::identity(m, m));
        let z: Vec<Complex64> = (0..m)
            .map(|_| {
                let (re, im): (f64, f64) = (StandardNormal.sample(rng), StandardNormal.sample(rng));
                Complex64::new(re, im)
            })
            .collect();
        for i in 0..m {
            let mut acc = Complex64::new(0.0, 0.0);
            for (j, zj) in z.iter().enumerate().take(i + 1) {
                acc += zj * l[(i, j)];
            }
            spectra[i][k] = acc * gain;
        }
    }
    let inv = RealFftPlanner::<f64>::new().plan_fft_inverse(n);
    spectra
        .into_iter()
        .map(|mut s| {
            let mut y = vec![0.0; n];
            inv.process(&mut s, &mut y).expect("sizes match");
            y.truncate(len);
            y
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diffuse_noise_has_the_diffuse_coherence() {
        // Two mics 10 cm apart: kd = 2 pi f d / c is 1.832 at 1 kHz and 5.496 at 3 kHz, so
        // the coherence sin(kd)/(kd) is 0.527 and -0.129.
        let mics = vec![Vector3::new(0.0, 0.0, 0.0), Vector3::new(0.1, 0.0, 0.0)];
        let fs = 16000.0;
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let field = diffuse_noise(&mics, Colour::White, fs, 343.0, 1 << 18, &mut rng);
        // Welch estimate of the real part of the coherence in 256-sample blocks.
        let n = 256;
        let fwd = RealFftPlanner::<f64>::new().plan_fft_forward(n);
        let mut sxy = vec![Complex64::new(0.0, 0.0); n / 2 + 1];
        let (mut sxx, mut syy) = (vec![0.0; n / 2 + 1], vec![0.0; n / 2 + 1]);
        for b in 0..(1 << 18) / n {
            let mut a = field[0][b * n..(b + 1) * n].to_vec();
            let mut c = field[1][b * n..(b + 1) * n].to_vec();
            let (mut fa, mut fc) = (fwd.make_output_vec(), fwd.make_output_vec());
            fwd.process(&mut a, &mut fa).unwrap();
            fwd.process(&mut c, &mut fc).unwrap();
            for k in 0..=n / 2 {
                sxy[k] += fa[k] * fc[k].conj();
                sxx[k] += fa[k].norm_sqr();
                syy[k] += fc[k].norm_sqr();
            }
        }
        for (hz, expect) in [(1000.0, 0.527), (3000.0, -0.129)] {
            let k = (hz / fs * n as f64) as usize;
            let coh = sxy[k].re / (sxx[k] * syy[k]).sqrt();
            assert!((coh - expect).abs() < 0.05, "{hz} Hz: {coh} vs {expect}");
        }
    }
}
