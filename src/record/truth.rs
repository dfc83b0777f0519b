//! The truth of a simulated recording: what `ssl simulate` writes beside the WAV and
//! `ssl evaluate` scores against (docs/interface.md, "Truth files").

use super::metadata::Tool;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// A simulated recording's truth. Directions are in the array frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    /// The tool that wrote it.
    #[serde(default)]
    pub tool: Tool,
    /// Sample rate (Hz).
    pub sample_rate: u32,
    /// Length of the recording (seconds).
    pub duration_s: f64,
    /// The random seed of the scene.
    #[serde(default)]
    pub seed: u64,
    /// Speed of sound (m/s).
    #[serde(default = "default_speed")]
    pub speed_of_sound: f64,
    /// The room, or `None` in free field.
    #[serde(default)]
    pub room: Option<TruthRoom>,
    /// Where the array was.
    #[serde(default)]
    pub array: TruthArray,
    /// The sources, in scene order.
    pub sources: Vec<TruthSource>,
    /// The noise, when the scene has a `[noise]` table.
    #[serde(default)]
    pub noise: Option<TruthNoise>,
    /// The WAV file this truth belongs to, as written by `ssl simulate`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub recording: Option<String>,
}

fn default_speed() -> f64 {
    343.0
}

/// The simulated room.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TruthRoom {
    /// Length, width, height (metres).
    pub dimensions: [f64; 3],
    /// The RT60 the scene asked for (seconds), if it did.
    pub rt60_requested: Option<f64>,
    /// The RT60 measured on a simulated response (T20, seconds).
    pub rt60_measured: f64,
    /// Eyring's RT60 of the same walls (seconds).
    pub rt60_eyring: f64,
    /// The walls' pressure reflection coefficient.
    pub reflection_coefficient: f64,
}

/// The array's place in the room.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[doc(hidden)]
pub struct TruthArray {
    /// The geometry file, as the scene gives it.
    pub geometry: PathBuf,
    /// The array centre in the room (metres).
    pub position: [f64; 3],
    /// Azimuth of the array's +x axis in the room (degrees).
    pub yaw_deg: f64,
}

/// One source.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthSource {
    /// 0-based index in the scene.
    pub index: usize,
    /// Its signal (`white`, `pink`, `clicks`, `tone`, `speech`, `file`).
    pub signal: String,
    /// RMS of its direct sound at the array centre (dBFS).
    #[serde(default)]
    pub level_db: f64,
    /// Its position in the room (metres).
    #[serde(default)]
    pub position_room: [f64; 3],
    /// Unit vector from the array centre toward it, array frame: x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// Its azimuth (degrees, docs/interface.md conventions).
    pub azimuth_deg: f64,
    /// Its elevation (degrees).
    pub elevation_deg: f64,
    /// Distance from the array centre (metres).
    pub distance_m: Option<f64>,
    /// When it is heard at the array centre: `[start, end]` in seconds.
    pub active: Vec<[f64; 2]>,
    /// A moving source: how fast its azimuth turns (degrees per second, positive toward
    /// +y); its direction above is the one it has at `turn_from_s`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub turn_deg_per_s: Option<f64>,
    /// When a moving source is heard at the array centre from the direction above
    /// (seconds).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub turn_from_s: Option<f64>,
    /// A moving source given by hand (`path` in JSON): its direction at times, `[time_s, azimuth_deg,
    /// elevation_deg]` in time order, followed straight between them (azimuth the short
    /// way round) and held before the first and after the last.
    #[serde(default, rename = "path", skip_serializing_if = "Vec::is_empty")]
    pub waypoints: Vec<[f64; 3]>,
    /// The truth gives its azimuth only (its elevation, unknown, is written 0): it is
    /// scored in azimuth whatever the array.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub azimuth_only: bool,
}

impl TruthSource {
    /// The unit vector toward the source (a moving one's when it starts turning).
    pub fn direction(&self) -> Vector3<f64> {
        Vector3::new(self.x, self.y, self.z).normalize()
    }

    /// The unit vector toward the source at time `t_s` (seconds), as heard at the array
    /// centre: a turning source's direction turned about the array's z axis, a source
    /// with waypoints where they put it.
    pub fn direction_at(&self, t_s: f64) -> Vector3<f64> {
        if self.waypoints.is_empty() {
            turned(&self.direction(), self.turn(), t_s)
        } else {
            along(&self.waypoints, t_s)
        }
    }

    /// Whether it moves (a turn or waypoints).
    pub fn moves(&self) -> bool {
        self.turn().is_some() || self.waypoints.len() > 1
    }

    /// A moving source's turn (degrees per second) and the time it starts from.
    pub fn turn(&self) -> Option<(f64, f64)> {
        self.turn_deg_per_s.zip(self.turn_from_s)
    }
}

/// Direction `u` turned about the z axis by `turn = (deg_per_s, from_s)` at time `t_s`.
pub(crate) fn turned(u: &Vector3<f64>, turn: Option<(f64, f64)>, t_s: f64) -> Vector3<f64> {
    match turn {
        Some((rate, from)) => {
            let (s, c) = (rate * (t_s - from)).to_radians().sin_cos();
            Vector3::new(c * u.x - s * u.y, s * u.x + c * u.y, u.z)
        }
        None => *u,
    }
}

/// The direction at `t_s` along `waypoints` (`[time_s, azimuth_deg, elevation_deg]`, in
/// time order, at least one): straight between the two around it, the azimuth the short
/// way round; the first before them, the last after.
pub(crate) fn along(waypoints: &[[f64; 3]], t_s: f64) -> Vector3<f64> {
    let at = |w: &[f64; 3]| crate::geometry::unit_from_angles(w[1], w[2]);
    let next = waypoints.partition_point(|w| w[0] <= t_s);
    if next == 0 {
        return at(&waypoints[0]);
    }
    if next == waypoints.len() {
        return at(&waypoints[next - 1]);
    }
    let (a, b) = (&waypoints[next - 1], &waypoints[next]);
    let share = if b[0] > a[0] {
        ((t_s - a[0]) / (b[0] - a[0])).clamp(0.0, 1.0)
    } else {
        1.0
    };
    let turn = (b[1] - a[1] + 180.0).rem_euclid(360.0) - 180.0;
    crate::geometry::unit_from_angles(a[1] + share * turn, a[2] + share * (b[2] - a[2]))
}

/// The noise of the scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthNoise {
    /// Mean source level over the fans and diffuse noise together (dB).
    pub snr_db: f64,
    /// Independent noise in each channel (dBFS), if any.
    pub sensor_db: Option<f64>,
    /// Point noise sources.
    pub fans: Vec<TruthFan>,
    /// Whether a diffuse field was added.
    pub diffuse: bool,
}

/// A point noise source.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthFan {
    /// Its position in the room (metres).
    pub position_room: [f64; 3],
    /// Its azimuth from the array (degrees).
    pub azimuth_deg: f64,
    /// Its elevation from the array (degrees).
    pub elevation_deg: f64,
    /// Its distance from the array centre (metres).
    pub distance_m: f64,
}

impl Truth {
    /// The room's measured RT60, if the scene had a room.
    pub fn rt60_s(&self) -> Option<f64> {
        self.room.map(|r| r.rt60_measured)
    }
}
