//! The JSON document's metadata: the tool, the array as understood, the parameters, and
//! one entry per input file (docs/interface.md, "Detections").

use super::fixed;
use crate::config::Config;
use crate::geometry::{Geometry, Shape};
use crate::stream::Summary;
use serde::{Deserialize, Serialize};

/// The run's metadata, in the order the JSON document carries it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunMetadata {
    /// This tool and its version.
    pub tool: Tool,
    /// The array as the tool understood it.
    pub geometry: GeometryInfo,
    /// The configuration the run resolved ([`Config::resolved`], with the speed of sound
    /// used), or null for settings tuned beyond one.
    pub parameters: Option<Config>,
    /// Whether rows and events carry wall-clock times (also in `parameters`).
    #[serde(skip)]
    clock: bool,
}

/// A tool's name and version.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Tool {
    /// `ssl`.
    pub name: String,
    /// The crate's version.
    pub version: String,
}

impl Default for Tool {
    fn default() -> Self {
        Tool {
            name: "ssl".into(),
            version: env!("CARGO_PKG_VERSION").into(),
        }
    }
}

/// What the tool understood of the geometry, including the ambiguity it resolves.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GeometryInfo {
    /// The geometry file, as given.
    pub file: String,
    /// The array's `name`.
    pub name: Option<String>,
    /// Number of microphones.
    pub microphones: usize,
    /// The geometry's speed of sound (m/s).
    pub speed_of_sound: f64,
    /// The array centre (mean of the positions) in the array frame, metres.
    pub centre: [f64; 3],
    /// The rotation from the array frame to the room frame, as rows (`v_room = R
    /// v_array`), when the geometry gives an `[orientation]`: directions, `side` and the
    /// note's axes are then in the room frame; `mics` and `centre` stay as the file
    /// gives them.
    #[serde(default)]
    pub orientation: Option<[[f64; 3]; 3]>,
    /// `3-D`, `planar` or `linear`.
    pub shape: String,
    /// The side directions are reported on (planar and linear arrays).
    pub side: Option<[f64; 3]>,
    /// What the array cannot tell, for planar and linear arrays.
    pub note: Option<String>,
    /// The microphones.
    pub mics: Vec<MicInfo>,
}

/// One microphone of [`GeometryInfo`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MicInfo {
    /// Position in the array frame, as the file gives it (metres).
    pub position: [f64; 3],
    /// 0-based channel in the recording.
    pub channel: usize,
}

impl RunMetadata {
    /// The metadata of a run with `geometry` (read from `geometry_file`) and `config`
    /// (`None`: settings tuned beyond a configuration), rows carrying wall-clock times
    /// or not.
    pub fn new(
        geometry: &Geometry,
        geometry_file: &str,
        config: Option<Config>,
        clock: bool,
    ) -> Self {
        RunMetadata {
            tool: Tool::default(),
            geometry: GeometryInfo::new(geometry, geometry_file),
            parameters: config,
            clock,
        }
    }

    /// Whether rows and events carry wall-clock times (`--clock`).
    pub fn clock(&self) -> bool {
        self.clock
    }
}

impl GeometryInfo {
    /// `geometry`, read from `file`.
    pub fn new(g: &Geometry, file: &str) -> Self {
        GeometryInfo {
            file: file.to_string(),
            name: g.name.clone(),
            microphones: g.mics.len(),
            speed_of_sound: g.speed_of_sound,
            centre: {
                let c = g.orientation.map_or(g.centre, |r| r.transpose() * g.centre);
                [c.x, c.y, c.z].map(|v| fixed(v, 9))
            },
            orientation: g
                .orientation
                .map(|r| [0, 1, 2].map(|i| [0, 1, 2].map(|j| fixed(r[(i, j)], 12)))),
            shape: g.shape.label().to_string(),
            side: match g.shape {
                Shape::Volumetric => None,
                _ => Some([g.side.x, g.side.y, g.side.z]),
            },
            note: ambiguity_note(g),
            mics: g
                .mics
                .iter()
                .enumerate()
                .map(|(i, m)| {
                    let p = g.array_position(i);
                    let p = [p.x, p.y, p.z];
                    MicInfo {
                        // Back from the room frame: round off the rotation's last bits.
                        position: match g.orientation {
                            Some(_) => p.map(|v| fixed(v, 12)),
                            None => p,
                        },
                        channel: m.channel,
                    }
                })
                .collect(),
        }
    }
}

/// One sentence on what the array cannot tell, or `None` for a 3-D array.
pub(crate) fn ambiguity_note(g: &Geometry) -> Option<String> {
    let s = g.side;
    match g.shape {
        Shape::Volumetric => None,
        Shape::Planar { normal } => Some(format!(
            "planar array: a direction and its mirror image through the array's plane are indistinguishable; directions are reported on the side of the plane that side = [{}, {}, {}] points to (normal [{:.3}, {:.3}, {:.3}]); the elevation is coarse, and reflections from floors and ceilings bias it: trust the azimuth",
            s.x, s.y, s.z, normal.x + 0.0, normal.y + 0.0, normal.z + 0.0
        )),
        Shape::Linear { axis } => Some(format!(
            "linear array: only the angle to the axis [{:.3}, {:.3}, {:.3}] is known; directions are reported in the plane of the axis and side = [{}, {}, {}], on that side",
            axis.x + 0.0, axis.y + 0.0, axis.z + 0.0, s.x, s.y, s.z
        )),
    }
}

/// A file's entry in the JSON document's `files` array: what was analysed, or why not.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FileEntry {
    /// The input, as given.
    pub file: String,
    /// Why it could not be analysed (to its end), if so.
    pub error: Option<String>,
    /// Sample rate (Hz).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub sample_rate: Option<u32>,
    /// Channels in the recording.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub channels: Option<usize>,
    /// Sample format, e.g. `8 ch, 48000 Hz, 16-bit PCM`.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub format: Option<String>,
    /// Frame size N.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub frame_size: Option<usize>,
    /// Frames analysed.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub frames: Option<u64>,
    /// Frames with a detection.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub detections: Option<u64>,
    /// Rows written for the file (docs/interface.md, "Detections").
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub rows: Option<u64>,
    /// Warnings about the recording.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub warnings: Option<Vec<String>>,
    /// What the tracker made of the detections (absent without tracking).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub tracking: Option<crate::track::TrackStats>,
}

impl FileEntry {
    /// The entry of `file`: what its summary says (when it was opened) and its error.
    pub fn new(file: &str, summary: Option<&Summary>, error: Option<String>) -> Self {
        FileEntry {
            file: file.to_string(),
            error,
            sample_rate: summary.map(|s| s.sample_rate),
            channels: summary.map(|s| s.channels),
            format: summary.map(|s| s.format.clone()),
            frame_size: summary.map(|s| s.frame_size),
            frames: summary.map(|s| s.stats.frames),
            detections: summary.map(|s| s.stats.detections),
            rows: None,
            warnings: summary.map(|s| {
                s.warnings
                    .iter()
                    .map(|w| format!("{}: {w}", s.name))
                    .collect()
            }),
            tracking: None,
        }
    }

    /// The entry with the rows written for the file.
    pub fn with_rows(self, rows: u64) -> Self {
        FileEntry {
            rows: Some(rows),
            ..self
        }
    }

    /// The entry with what the tracker made of the file's detections.
    pub fn with_tracking(self, stats: Option<crate::track::TrackStats>) -> Self {
        FileEntry {
            tracking: stats,
            ..self
        }
    }

    /// The entry with one more warning (already naming the file), when there is one.
    pub fn with_warning(mut self, warning: Option<String>) -> Self {
        if let Some(w) = warning {
            self.warnings.get_or_insert_with(Vec::new).push(w);
        }
        self
    }
}
