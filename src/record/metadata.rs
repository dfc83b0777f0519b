//! The JSON document's metadata: the tool, the array as understood, the parameters, and
//! one entry per input file (docs/interface.md, "Detections").

use super::fixed;
use crate::geometry::{Geometry, Shape};
use crate::method::pairs::pair_count;
use crate::method::{Interpolation, Params, Window};
use crate::stream::Summary;
use crate::track::TrackParams;
use serde::{Deserialize, Serialize};

/// The run's metadata, in the order the JSON document carries it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunMetadata {
    /// This tool and its version.
    pub tool: Tool,
    /// The array as the tool understood it.
    pub geometry: GeometryInfo,
    /// The method's parameters.
    pub parameters: ParametersInfo,
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

/// The parameters as the JSON document records them: numbers are numbers, written as
/// given (`0.4`, not the nearest single-precision value).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParametersInfo {
    /// Frame size N given on the command line, or `null` for the default of each file's
    /// rate (about 21 ms); each file's entry has the frame size used.
    pub frame_size: Option<usize>,
    /// The frame length asked for in milliseconds, or null.
    pub frame_ms: Option<f64>,
    /// Always `"frame_size / 2"`.
    pub hop: String,
    /// The analysis window.
    pub window: Window,
    /// `alpha` of eq. (4).
    pub alpha: f64,
    /// `gamma` of eq. (5).
    pub gamma: f64,
    /// Spectral weighting on (else plain PHAT).
    pub weighting: bool,
    /// Peaks M per pair.
    pub peaks: usize,
    /// Consistency tolerance (samples).
    pub tolerance_samples: f64,
    /// Sub-sample refinement of the peaks.
    pub interpolation: Interpolation,
    /// Speed of sound used (m/s).
    pub speed_of_sound: f64,
    /// Fixed detection threshold per microphone pair, or null for the calibrated one.
    pub min_score_per_pair: Option<f64>,
    /// The fixed threshold a frame with every microphone live needs:
    /// `min_score_per_pair` times the array's pairs (null with the calibrated one).
    pub min_score: Option<f64>,
    /// The calibrated threshold's allowance for chance (standard deviations), or null
    /// with a fixed threshold.
    pub threshold_sigmas: Option<f64>,
    /// Share of late reverberation in the noise estimate (0: none).
    pub reverb_level: f64,
    /// The consistency tolerance in microseconds, when given so (it then replaces
    /// `tolerance_samples` at each file's rate).
    pub tolerance_us: Option<f64>,
    /// The residual gate in microseconds, or null for none.
    pub residual_gate_us: Option<f64>,
    /// Frames each pair's correlation is averaged over (1: none).
    pub average_frames: usize,
    /// Time constant of the steady background subtracted from the correlations
    /// (seconds), or null for none.
    pub background_s: Option<f64>,
    /// Whether the steered response is on (directions from most pairs, and further
    /// sources).
    pub steered: bool,
    /// The most sources one frame gives.
    pub max_sources: usize,
    /// Whether further sources come from each frame's own correlations too.
    pub frame_sources: bool,
    /// Time constant (seconds) of the average each talker's learned pattern is removed
    /// from before a second look for others, or null for none (it applies to arrays
    /// whose longest delay is 8 samples or more at the file's rate).
    pub patterns_s: Option<f64>,
    /// Candidates are reported down to this share of the threshold, for the tracker (1:
    /// none).
    pub candidates: f64,
    /// A frame that gives nothing down to `candidates` has its own correlations searched
    /// again down to this share, for riders (1: none; a document written before them has
    /// none).
    #[serde(default = "no_riders")]
    pub riders: f64,
    /// Whether the reverberation's diffuse part is removed from the cross-spectra for
    /// this array (`--dereverb`: by default for planar and linear arrays).
    #[serde(default)]
    pub dereverb: bool,
    /// Whether the input was dereverberated by multichannel linear prediction (`--wpe`;
    /// a document written before it has none: false).
    #[serde(default)]
    pub wpe: bool,
    /// Where the analysis started (seconds; `--start`, rounded down to a hop).
    #[serde(default)]
    pub start_s: f64,
    /// Where it ended (seconds; `--end`), or `None` at the end of the recording.
    #[serde(default)]
    pub end_s: Option<f64>,
    /// The frequencies analysed, `[low, high]` in Hz (`--band`), or `None`: all.
    #[serde(default)]
    pub band_hz: Option<[f64; 2]>,
    /// Whether the directions of single frequency bins give riders (`--no-bin-votes`
    /// turns them off; a document written before them has none: false).
    #[serde(default)]
    pub bin_votes: bool,
    /// The tracker's parameters, or null with tracking off.
    pub track: Option<TrackParams>,
    /// Whether rows and events carry wall-clock times (`--clock`).
    #[serde(default)]
    pub clock: bool,
}

/// A single-precision parameter as it was written (`0.4`), not as its nearest double.
fn as_given(v: f32) -> f64 {
    v.to_string().parse().unwrap_or(v as f64)
}

impl RunMetadata {
    /// The metadata of a run with `geometry` (read from `geometry_file`) and `params`.
    pub fn new(geometry: &Geometry, geometry_file: &str, params: &Params) -> Self {
        let fixed = params
            .threshold_sigmas
            .is_none()
            .then_some(params.min_score_per_pair);
        RunMetadata {
            tool: Tool::default(),
            geometry: GeometryInfo::new(geometry, geometry_file),
            parameters: ParametersInfo {
                frame_size: params.frame_size,
                frame_ms: params.frame_ms,
                hop: "frame_size / 2".into(),
                window: params.window,
                alpha: as_given(params.alpha),
                gamma: as_given(params.gamma),
                weighting: params.weighting,
                peaks: params.peaks,
                tolerance_samples: as_given(params.tolerance),
                interpolation: params.interpolation,
                speed_of_sound: params.speed_of_sound.unwrap_or(geometry.speed_of_sound),
                min_score_per_pair: fixed,
                min_score: fixed.map(|m| m * pair_count(geometry.mics.len()) as f64),
                threshold_sigmas: params.threshold_sigmas,
                reverb_level: as_given(params.reverb_level),
                tolerance_us: params.tolerance_us,
                residual_gate_us: params.residual_gate_us,
                average_frames: params.average_frames,
                background_s: params.background_s,
                steered: params.steered,
                max_sources: params.max_sources,
                frame_sources: params.frame_sources,
                patterns_s: params.patterns_s,
                candidates: params.candidates,
                riders: params.riders,
                dereverb: params.dereverb.applies(&geometry.shape),
                wpe: params.wpe,
                start_s: params.start_s,
                end_s: params.end_s,
                band_hz: params.band_hz.map(|(l, h)| [l, h]),
                bin_votes: params.bin_votes_on(),
                track: None,
                clock: false,
            },
        }
    }

    /// The same, with tracking by `track` (or off).
    pub fn with_tracking(mut self, track: Option<TrackParams>) -> Self {
        self.parameters.track = track;
        self
    }

    /// The same, with wall-clock times on rows and events (`--clock`) or not.
    pub fn with_clock(mut self, clock: bool) -> Self {
        self.parameters.clock = clock;
        self
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
pub fn ambiguity_note(g: &Geometry) -> Option<String> {
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

/// Riders' share in a document written before them: none.
fn no_riders() -> f64 {
    1.0
}
