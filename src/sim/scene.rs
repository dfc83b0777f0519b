//! The scene file of `ssl simulate` (TOML; `testdata/scene.toml` shows every key).
//!
//! Levels: a source's `level_db` is the RMS of its direct sound at the array centre while
//! it is active (dB re full scale). Fans and diffuse noise are scaled together so that
//! the mean source level is `snr_db` above their combined power (averaged over the
//! microphones); `sensor_db` adds independent noise to every channel.

use super::SceneError;
use crate::geometry::toml_line;
use crate::stream::read_text;

/// The largest scene file read.
pub(crate) const MAX_SCENE_BYTES: u64 = 16 << 20;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// A scene: room, array pose, sources and noise, and how to write the recording.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Sample rate (Hz).
    pub sample_rate: u32,
    /// Seconds.
    pub duration: f64,
    /// Random seed: the same scene and seed give the same samples.
    #[serde(default)]
    pub seed: u64,
    /// Sample format of the WAV file.
    #[serde(default)]
    pub format: SampleFormat,
    /// Speed of sound (m/s, default 343).
    pub speed_of_sound: Option<f64>,
    /// No room: free field.
    pub room: Option<RoomSpec>,
    /// Where the array is.
    pub array: ArraySpec,
    /// The sources.
    #[serde(default)]
    pub source: Vec<SourceSpec>,
    /// Fans, diffuse and sensor noise.
    pub noise: Option<NoiseSpec>,
}

/// Sample format of the simulated WAV file.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SampleFormat {
    /// 16-bit PCM.
    #[default]
    Int16,
    /// 24-bit PCM.
    Int24,
    /// 32-bit PCM.
    Int32,
    /// 32-bit float.
    Float32,
}

/// A shoebox room with uniform walls.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoomSpec {
    /// Length (x), width (y), height (z) in metres.
    #[serde(deserialize_with = "crate::text::numbers")]
    pub dimensions: [f64; 3],
    /// Reverberation time (seconds); give this or `absorption`.
    pub rt60: Option<f64>,
    /// Wall energy absorption in (0, 1]; give this or `rt60`.
    pub absorption: Option<f64>,
}

/// The array and where it is.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArraySpec {
    /// Geometry file, relative to the scene file.
    pub geometry: PathBuf,
    /// The array centre in the room (metres).
    #[serde(deserialize_with = "crate::text::numbers")]
    pub position: [f64; 3],
    /// Azimuth of the array's +x axis in the room (degrees).
    #[serde(default)]
    pub yaw_deg: f64,
}

/// A source's signal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SignalKind {
    /// White noise.
    White,
    /// Pink noise.
    Pink,
    /// 2 ms clicks, `rate` per second.
    Clicks,
    /// A pure tone of `frequency` Hz.
    Tone,
    /// Speech-like noise: low-pass noise under a syllable envelope with pauses.
    Speech,
    /// A mono WAV `file` at the scene's rate, looped.
    File,
}

/// One source.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SourceSpec {
    /// Room position (metres); or give `azimuth_deg`, `elevation_deg`, `distance`.
    #[serde(default, deserialize_with = "crate::text::numbers_opt")]
    pub position: Option<[f64; 3]>,
    /// Azimuth from the array, array frame (degrees).
    pub azimuth_deg: Option<f64>,
    /// Elevation from the array (degrees).
    pub elevation_deg: Option<f64>,
    /// Distance from the array centre (metres).
    pub distance: Option<f64>,
    /// The signal.
    pub signal: SignalKind,
    /// RMS of the direct sound at the array centre (dBFS); for clicks, during a click.
    #[serde(default = "default_level")]
    pub level_db: f64,
    /// Active intervals `[start, end]` in seconds (default: the whole scene).
    #[serde(default, deserialize_with = "crate::text::numbers_list_opt")]
    pub active: Option<Vec<[f64; 2]>>,
    /// Clicks per second.
    pub rate: Option<f64>,
    /// Tone frequency (Hz).
    pub frequency: Option<f64>,
    /// Mono WAV file for `signal = "file"`, relative to the scene file.
    pub file: Option<PathBuf>,
    /// A moving source: its azimuth turns at this rate (degrees per second, positive
    /// toward +y) from the start of its first active interval, at its `distance` and
    /// `elevation_deg` from the array centre (needs `azimuth_deg` and `distance`).
    #[serde(default)]
    pub turn_deg_per_s: Option<f64>,
}

fn default_level() -> f64 {
    -26.0
}

/// The colour of a noise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Colour {
    /// Flat spectrum.
    White,
    /// -3 dB per octave.
    #[default]
    Pink,
}

/// The scene's noise.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseSpec {
    /// Mean source level over the fans and diffuse noise together (dB).
    #[serde(default = "default_snr")]
    pub snr_db: f64,
    /// Independent noise in every channel (dBFS).
    pub sensor_db: Option<f64>,
    /// Point noise sources.
    #[serde(default)]
    pub fan: Vec<FanSpec>,
    /// A spherically isotropic noise field.
    pub diffuse: Option<DiffuseSpec>,
}

fn default_snr() -> f64 {
    20.0
}

/// A point noise source in the room.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FanSpec {
    /// Room position (metres).
    #[serde(deserialize_with = "crate::text::numbers")]
    pub position: [f64; 3],
    /// Its colour.
    #[serde(default)]
    pub signal: Colour,
    /// Its weight among the noise components (dB).
    #[serde(default)]
    pub weight_db: f64,
}

/// A diffuse noise field.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiffuseSpec {
    /// Its colour.
    #[serde(default)]
    pub signal: Colour,
    /// Its weight among the noise components (dB).
    #[serde(default)]
    pub weight_db: f64,
}

impl SceneFile {
    /// Every file rendering the scene reads, besides the scene itself: the array's
    /// geometry and the sources' WAV files, resolved against `dir` (the scene's folder).
    /// An output must not be one of them.
    pub fn files_read(&self, dir: &Path) -> Vec<PathBuf> {
        std::iter::once(dir.join(&self.array.geometry))
            .chain(
                self.source
                    .iter()
                    .filter_map(|s| s.file.as_ref().map(|f| dir.join(f))),
            )
            .collect()
    }

    /// Reads a scene file.
    pub fn from_file(path: &Path) -> Result<Self, SceneError> {
        let text = read_text(path, MAX_SCENE_BYTES).map_err(|error| SceneError::Read {
            path: path.to_path_buf(),
            error,
        })?;
        toml::from_str(&text).map_err(|e| SceneError::Toml {
            path: path.to_path_buf(),
            line: toml_line(&text, &e),
            message: e.message().trim().to_string(),
        })
    }
}
