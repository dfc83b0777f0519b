//! Rendering a scene: place the array in the room, render each source through the
//! room's impulse responses ([`room`](super::room), one source in `source.rs`), add the
//! noise, and write down the truth. Same scene and seed, same samples.

use super::limits::{check_cost, check_scene, MAX_DISTANCE_M};
use super::noise::{add_normalised, colour_noise, diffuse_noise, mean_power};
use super::placed::{convolve, Placed};
use super::scene::{NoiseSpec, SampleFormat, SceneFile};
use super::source::{self, source_position};
use super::SceneError;
use crate::geometry::angles_deg;
use crate::record::{Truth, TruthArray, TruthFan, TruthNoise, TruthRoom};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::path::Path;

/// A rendered scene: the channels and their truth.
pub struct Simulation {
    /// Sample rate (Hz).
    pub sample_rate: u32,
    /// The sample format the scene asks for.
    pub format: SampleFormat,
    /// One channel per microphone, in geometry order.
    pub channels: Vec<Vec<f32>>,
    /// What is where, and when.
    pub truth: Truth,
}

/// Reads and renders a scene file; relative paths in it are relative to its folder.
pub fn simulate_file(path: &Path) -> Result<Simulation, SceneError> {
    simulate_read(&SceneFile::from_file(path)?, path)
}

/// Renders `scene`, read from the file `path` (which resolves its relative paths and
/// names it in errors).
pub(crate) fn simulate_read(scene: &SceneFile, path: &Path) -> Result<Simulation, SceneError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    simulate(scene, dir).map_err(|error| SceneError::File {
        path: path.to_path_buf(),
        error: Box::new(error),
    })
}

/// Renders a scene; `dir` resolves relative paths.
pub fn simulate(scene: &SceneFile, dir: &Path) -> Result<Simulation, SceneError> {
    check_scene(scene)?;
    let placed = Placed::new(scene, dir)?;
    check_cost(
        scene,
        placed.mics.len(),
        placed.room.map(|r| r.dims.x * r.dims.y * r.dims.z),
        placed.c * placed.tail_s + farthest(&placed, scene)?,
        placed.c,
    )?;
    let len = (scene.duration * scene.sample_rate as f64).round() as usize;
    let mut rng = ChaCha8Rng::seed_from_u64(scene.seed);
    let mut out = vec![vec![0.0f64; len]; placed.mics.len()];
    let mut sources = Vec::new();
    let mut level_sum = 0.0;
    for (i, s) in scene.source.iter().enumerate() {
        let truth = source::render_source(scene, dir, &placed, (i, s), &mut out, &mut rng)?;
        let level = 10f64.powf(s.level_db / 20.0);
        level_sum += level * level;
        sources.push(truth);
    }
    let noise = match &scene.noise {
        Some(noise) => Some(add_noise(
            scene, noise, &placed, level_sum, &mut out, &mut rng,
        )?),
        None => None,
    };
    let peak = out.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    if !(peak as f32).is_finite() {
        fail!(
            SceneError::Invalid,
            "the scene's levels overflow 32-bit floats (peak {peak:.3e}): lower them"
        );
    }
    if scene.format != SampleFormat::Float32 && peak >= 1.0 {
        fail!(SceneError::Invalid, "the scene clips (peak {peak:.2} of full scale): lower the levels or use format = \"float32\"");
    }
    let truth = Truth {
        tool: Default::default(),
        sample_rate: scene.sample_rate,
        duration_s: scene.duration,
        seed: scene.seed,
        speed_of_sound: placed.c,
        room: placed.room.map(|r| TruthRoom {
            dimensions: [r.dims.x, r.dims.y, r.dims.z],
            rt60_requested: scene.room.as_ref().and_then(|s| s.rt60),
            rt60_measured: r.rt60(),
            rt60_eyring: r.eyring_rt60(),
            reflection_coefficient: r.beta,
        }),
        array: TruthArray {
            geometry: scene.array.geometry.clone(),
            position: scene.array.position,
            yaw_deg: scene.array.yaw_deg,
        },
        sources,
        noise,
        recording: None,
    };
    // A number that is not finite has no sample value (int formats would write 0, a
    // float file NaN, which every reader refuses): no scene that passed its checks
    // gives one, and none is ever written.
    for (c, ch) in out.iter().enumerate() {
        if let Some(k) = ch
            .iter()
            .position(|v| !(v.is_finite() && (*v as f32).is_finite()))
        {
            fail!(
                SceneError::Invalid,
                "the rendered sample {k} of channel {c} is not a finite number; the scene's levels are out of reach"
            );
        }
    }
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

/// Adds fans and diffuse noise, each normalised to unit power, weighted, then scaled
/// together to `snr_db` below the mean source level; then sensor noise.
fn add_noise(
    scene: &SceneFile,
    noise: &NoiseSpec,
    placed: &Placed,
    level_sum: f64,
    out: &mut [Vec<f64>],
    rng: &mut ChaCha8Rng,
) -> Result<TruthNoise, SceneError> {
    let (fs, len) = (placed.fs, out[0].len());
    let mut total = vec![vec![0.0f64; len]; out.len()];
    let mut components = 0;
    for (i, fan) in noise.fan.iter().enumerate() {
        let p = Vector3::from(fan.position);
        placed.check_inside(&format!("fan {}", i + 1), &p)?;
        let responses = placed.responses(&p);
        // Start the fan early so the room is already ringing at time 0.
        let lead = responses[0].len();
        let mut dry = vec![0.0; len + lead];
        colour_noise(fan.signal, fs, &mut dry, rng);
        let wet = convolve(&dry, &responses);
        add_normalised(
            &mut total,
            wet.iter().map(|w| &w[lead..lead + len]).collect(),
            fan.weight_db,
        );
        components += 1;
    }
    if let Some(d) = &noise.diffuse {
        let field = diffuse_noise(&placed.mics, d.signal, fs, placed.c, len, rng);
        add_normalised(
            &mut total,
            field.iter().map(|w| &w[..]).collect(),
            d.weight_db,
        );
        components += 1;
    }
    if components > 0 {
        if level_sum == 0.0 {
            fail!(
                SceneError::Invalid,
                "[noise] snr_db needs at least one [[source]] to be relative to"
            );
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
                let z: f64 = StandardNormal.sample(rng);
                *v += sigma * z;
            }
        }
    }
    Ok(TruthNoise {
        snr_db: noise.snr_db,
        sensor_db: noise.sensor_db,
        fans: noise
            .fan
            .iter()
            .map(|f| {
                let v = placed.rotation.transpose() * (Vector3::from(f.position) - placed.centre);
                let (azimuth_deg, elevation_deg) = angles_deg(&v.normalize());
                TruthFan {
                    position_room: f.position,
                    azimuth_deg,
                    elevation_deg,
                    distance_m: v.norm(),
                }
            })
            .collect(),
        diffuse: noise.diffuse.is_some(),
    })
}

/// How far the farthest source or fan, and the farthest microphone, are from the
/// array centre (metres); each at most [`MAX_DISTANCE_M`].
fn farthest(placed: &Placed, scene: &SceneFile) -> Result<f64, SceneError> {
    let mut far = 0.0f64;
    let fans = scene
        .noise
        .iter()
        .flat_map(|n| &n.fan)
        .map(|f| Ok(Vector3::from(f.position)));
    let sources = scene.source.iter().map(|s| source_position(s, placed));
    for (i, p) in sources.chain(fans).enumerate() {
        let d = (p? - placed.centre).norm();
        if d > MAX_DISTANCE_M {
            fail!(
                SceneError::Invalid,
                "a source or fan (number {} in the scene) is {d:.3e} m from the array; at most {MAX_DISTANCE_M} m is supported",
                i + 1
            );
        }
        far = far.max(d);
    }
    let aperture = placed
        .mics
        .iter()
        .map(|m| (m - placed.centre).norm())
        .fold(0.0, f64::max);
    Ok(far + aperture)
}
