//! The accuracy benchmark's scenes: simulated after the paper's experiments, analysed
//! and scored. `cargo bench --bench accuracy` runs it in full and prints the markdown
//! tables committed in `docs/accuracy.md`; `tests/integration/benchmark.rs` runs a reduced version.
//!
//! Every case is a recording of one signal type with 8 events (or fewer in the reduced
//! runs), one per horizontal angle, each 0.8 s long with 0.5 s gaps, after 1 s of
//! background. It is written to a WAV file, analysed by [`Analysis`] exactly as
//! `ssl analyze` would, and scored by [`evaluate`].

use nalgebra::Vector3;
use ssl::evaluate::{evaluate, Report};
use ssl::sim::scene::{
    ArraySpec, Colour, DiffuseSpec, FanSpec, NoiseSpec, RoomSpec, SampleFormat, SceneFile,
    SignalKind, SourceSpec,
};
use ssl::sim::{simulate, write_wav, Encoding};
use ssl::track::TrackParams;
use ssl::{DetectionRecord, Geometry, Params, Truth};
use std::error::Error;
use std::path::{Path, PathBuf};

type Result<T> = std::result::Result<T, Box<dyn Error>>;

/// The paper's Table I: (distance m, elevation deg, the paper's mean angular error deg).
pub const TABLE_I: [(f64, f64, f64); 4] = [
    (3.0, -7.0, 1.7),
    (3.0, 8.0, 3.0),
    (1.5, -13.0, 3.1),
    (0.9, 24.0, 3.3),
];

/// The source signals of the benchmark.
pub const SIGNALS: [SignalKind; 3] = [SignalKind::Speech, SignalKind::Clicks, SignalKind::White];

/// A lab-like room: 8 x 7 x 3 m, the array centre 0.8 m above the floor (a robot), a fan
/// near the ceiling in a corner plus weaker diffuse noise.
#[derive(Debug, Clone)]
pub struct Lab {
    /// `None`: free field.
    pub rt60: Option<f64>,
    pub snr_db: f64,
    /// Point fan and diffuse noise (`false`: sensor noise only).
    pub fan: bool,
}

impl Default for Lab {
    fn default() -> Self {
        Lab {
            rt60: Some(0.35),
            snr_db: 10.0,
            fan: true,
        }
    }
}

/// Holds the working files of a benchmark run (the array geometry and the recordings).
pub struct Bench {
    dir: tempfile::TempDir,
}

impl Bench {
    pub fn new() -> Result<Self> {
        let dir = tempfile::tempdir()?;
        std::fs::copy(super::testdata("prism.toml"), dir.path().join("prism.toml"))?;
        Ok(Bench { dir })
    }

    /// The scene: `azimuths` events of `signal` at `distance` and `elevation` from the array.
    pub fn scene(
        &self,
        lab: &Lab,
        signal: SignalKind,
        distance: f64,
        elevation: f64,
        azimuths: &[f64],
        seed: u64,
    ) -> SceneFile {
        let sources = azimuths
            .iter()
            .enumerate()
            .map(|(i, &az)| {
                let start = 1.0 + 1.3 * i as f64;
                SourceSpec {
                    position: None,
                    azimuth_deg: Some(az),
                    elevation_deg: Some(elevation),
                    distance: Some(distance),
                    signal,
                    // Clicks are 2 ms transients: their level is the RMS during a click.
                    level_db: if signal == SignalKind::Clicks {
                        -14.0
                    } else {
                        -26.0
                    },
                    active: Some(vec![[start, start + 0.8]]),
                    rate: Some(8.0),
                    frequency: None,
                    file: None,
                    turn_deg_per_s: None,
                }
            })
            .collect();
        SceneFile {
            sample_rate: 48000,
            duration: 1.0 + 1.3 * azimuths.len() as f64,
            seed,
            format: SampleFormat::Float32,
            speed_of_sound: None,
            room: lab.rt60.map(|rt60| RoomSpec {
                dimensions: [8.0, 7.0, 3.0],
                rt60: Some(rt60),
                absorption: None,
            }),
            array: ArraySpec {
                geometry: PathBuf::from("prism.toml"),
                position: [4.0, 3.5, 0.8],
                yaw_deg: 0.0,
            },
            source: sources,
            noise: Some(NoiseSpec {
                snr_db: lab.snr_db,
                sensor_db: Some(-70.0),
                fan: if lab.fan {
                    vec![FanSpec {
                        position: [7.6, 6.6, 2.7],
                        signal: Colour::Pink,
                        weight_db: 0.0,
                    }]
                } else {
                    vec![]
                },
                diffuse: lab.fan.then_some(DiffuseSpec {
                    signal: Colour::Pink,
                    weight_db: -6.0,
                }),
            }),
        }
    }

    /// Simulates a scene to a WAV file; returns its path and truth.
    pub fn record(&self, scene: &SceneFile, name: &str) -> Result<(PathBuf, Truth)> {
        let sim = simulate(scene, self.dir.path())?;
        let path = self.dir.path().join(format!("{name}.wav"));
        write_wav(&path, &sim.channels, sim.sample_rate, Encoding::Float32)?;
        Ok((path, sim.truth))
    }

    /// Analyses a recording with `params`: its records (every frame's detections).
    pub fn records(&self, wav: &Path, params: &Params) -> Result<Vec<DetectionRecord>> {
        self.records_tracked(wav, params, None)
    }

    /// Analyses a recording with `params` through a tracker with `track` (else every
    /// frame's detections), as `ssl analyze` does: its records.
    pub fn records_tracked(
        &self,
        wav: &Path,
        params: &Params,
        track: Option<TrackParams>,
    ) -> Result<Vec<DetectionRecord>> {
        let geometry = Geometry::from_file(&self.dir.path().join("prism.toml"))?;
        let name = wav.display().to_string();
        let localizer = super::harness::localizer(&geometry, params, track)?;
        super::harness::rows(localizer.open(&name)?)
    }

    /// Analyses a recording with `params` and scores it.
    pub fn score(&self, wav: &Path, truth: &Truth, params: &Params) -> Result<Report> {
        self.score_tracked(wav, truth, params, None)
    }

    /// Analyses a recording with `params` through a tracker with `track` and scores it.
    pub fn score_tracked(
        &self,
        wav: &Path,
        truth: &Truth,
        params: &Params,
        track: Option<TrackParams>,
    ) -> Result<Report> {
        let records = self.records_tracked(wav, params, track)?;
        Ok(evaluate(
            truth,
            &records,
            truth.rt60_s().map_or(0.0, |t| t / 2.0),
        )?)
    }
}

/// Several reports pooled: detections weighted by count, events and frames summed.
#[derive(Debug, Clone, Default)]
pub struct Pooled {
    pub errors_sum: f64,
    pub detections: usize,
    pub events: usize,
    pub events_detected: usize,
    pub frames: usize,
    pub frames_detected: usize,
    pub false_detections: usize,
    pub background_s: f64,
}

impl Pooled {
    pub fn add(&mut self, r: &Report) {
        for s in &r.sources {
            self.errors_sum += s.mean_error_deg.unwrap_or(0.0) * s.detections as f64;
            self.detections += s.detections;
            self.events += s.events;
            self.events_detected += s.events_detected;
            self.frames += s.active_frames;
            self.frames_detected += s.frames_detected;
        }
        self.false_detections += r.false_detections;
        self.background_s += r.background_s;
    }

    pub fn mean_error(&self) -> f64 {
        if self.detections == 0 {
            f64::NAN
        } else {
            self.errors_sum / self.detections as f64
        }
    }

    pub fn event_rate(&self) -> f64 {
        self.events_detected as f64 / self.events.max(1) as f64
    }

    pub fn frame_rate(&self) -> f64 {
        self.frames_detected as f64 / self.frames.max(1) as f64
    }

    pub fn false_per_minute(&self) -> f64 {
        if self.background_s > 0.0 {
            self.false_detections as f64 / (self.background_s / 60.0)
        } else {
            0.0
        }
    }

    /// "mean error / events detected / frames detected" for a table cell.
    pub fn cell(&self) -> String {
        format!(
            "{:.2} / {:.0}% / {:.0}%",
            self.mean_error(),
            100.0 * self.event_rate(),
            100.0 * self.frame_rate()
        )
    }
}

/// `n` horizontal angles evenly spread, starting 10 degrees off the array's axes.
pub fn azimuths(n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| -170.0 + 10.0 + 360.0 * i as f64 / n as f64)
        .collect()
}

/// The paper's room for real speech (8 x 7 x 3 m, the array centre at [4, 3.5, 0.8] m,
/// `array.toml` beside the scene), its fan near the ceiling in a corner or (`near_fan`)
/// on the table 0.9 m from the array, and diffuse noise 6 dB weaker, together 10 dB
/// below the sources; no source yet.
pub fn speech_room(rate: u32, duration: f64, seed: u64, rt60: f64, near_fan: bool) -> SceneFile {
    SceneFile {
        sample_rate: rate,
        duration,
        seed,
        format: SampleFormat::Float32,
        speed_of_sound: None,
        room: Some(RoomSpec {
            dimensions: [8.0, 7.0, 3.0],
            rt60: Some(rt60),
            absorption: None,
        }),
        array: ArraySpec {
            geometry: "array.toml".into(),
            position: [4.0, 3.5, 0.8],
            yaw_deg: 0.0,
        },
        source: Vec::new(),
        noise: Some(NoiseSpec {
            snr_db: 10.0,
            sensor_db: Some(-70.0),
            fan: vec![FanSpec {
                position: if near_fan {
                    [4.7, 4.0, 0.9]
                } else {
                    [7.6, 6.6, 2.7]
                },
                signal: Colour::Pink,
                weight_db: 0.0,
            }],
            diffuse: Some(DiffuseSpec {
                signal: Colour::Pink,
                weight_db: -6.0,
            }),
        }),
    }
}

/// The mean azimuth error (deg) of the detections while a source is active, against
/// the active source nearest in azimuth: what a planar array measures well whatever
/// the elevation. For a linear array (`axis`), the error in the angle between the
/// direction and the axis, the one angle it measures.
pub fn azimuth_error(
    records: &[DetectionRecord],
    truth: &Truth,
    axis: Option<Vector3<f64>>,
) -> Option<f64> {
    let errors: Vec<f64> = records
        .iter()
        .filter_map(|r| {
            truth
                .sources
                .iter()
                .filter(|s| {
                    s.active
                        .iter()
                        .any(|&[a, b]| r.time_s > a && r.time_s < b + 0.2)
                })
                .map(|s| match axis {
                    Some(a) => {
                        let cone = |u: Vector3<f64>| u.dot(&a).clamp(-1.0, 1.0).acos().to_degrees();
                        (cone(Vector3::new(r.x, r.y, r.z)) - cone(s.direction())).abs()
                    }
                    None => {
                        let d = (r.azimuth_deg - s.azimuth_deg).rem_euclid(360.0);
                        d.min(360.0 - d)
                    }
                })
                .min_by(f64::total_cmp)
        })
        .collect();
    (!errors.is_empty()).then(|| errors.iter().sum::<f64>() / errors.len() as f64)
}
