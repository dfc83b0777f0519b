//! Array geometry: the microphone positions `p_i` behind the difference vectors
//! `x_ij = p_j - p_i` of the paper's eq. (9)-(13), read from the TOML file described in
//! docs/interface.md ("Geometry file"), validated, and classified as 3-D, planar or linear.
//!
//! A 3-D array determines the full direction (eq. 13 has rank 3). A planar array only
//! determines the in-plane part of the direction; the out-of-plane part comes from
//! `|u| = 1` and is reported on the `side` of the plane. A linear array only determines
//! the angle to its axis; the direction is reported in the plane spanned by the axis and
//! `side`.

mod angles;
mod orientation;
mod shape;
pub(crate) mod units;

pub use angles::{angle_between_deg, angles_deg, unit_from_angles};

pub use shape::Shape;
use shape::{classify, orient};

use crate::text::{io_reason, read_text};
use nalgebra::Vector3;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// What kind of audio file `path` starts like (`WAV`, `FLAC`), if it does: a recording
/// given where a geometry was expected.
fn audio_kind(path: &Path) -> Option<&'static str> {
    use std::io::Read;
    let mut head = [0u8; 12];
    let mut file = std::fs::File::open(path).ok()?;
    let n = file.read(&mut head).ok()?;
    let head = &head[..n];
    if (head.starts_with(b"RIFF") || head.starts_with(b"RF64") || head.starts_with(b"BW64"))
        && head.get(8..12) == Some(b"WAVE")
    {
        Some("WAV")
    } else if head.starts_with(b"fLaC") {
        Some("FLAC")
    } else {
        None
    }
}

/// The 1-based line a TOML parse error points at, when it points at one.
pub(crate) fn toml_line(text: &str, e: &toml::de::Error) -> Option<usize> {
    e.span()
        .map(|span| text[..span.start.min(text.len())].lines().count().max(1))
}

/// Why a geometry cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum GeometryError {
    /// The file could not be read.
    #[error("{}: cannot read geometry file: {}", path.display(), io_reason(error))]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// An error in a file, with the file's name.
    #[error("{}: {error}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong in it.
        error: Box<GeometryError>,
    },
    /// Not valid TOML, or not the geometry schema (docs/interface.md, "Geometry file").
    #[error("invalid geometry TOML{}: {message}", line.map(|l| format!(" at line {l}")).unwrap_or_default())]
    Toml {
        /// 1-based line of the error, when known.
        line: Option<usize>,
        /// The parser's message.
        message: String,
    },
    /// Valid TOML describing an array that cannot be used.
    #[error("{0}")]
    Invalid(String),
}

type Result<T> = std::result::Result<T, GeometryError>;

/// Default speed of sound in m/s (dry air at about 20 degrees C; docs/interface.md).
pub(crate) const DEFAULT_SPEED_OF_SOUND: f64 = 343.0;
/// The speeds of sound accepted anywhere (m/s): from below any gas's at room temperature
/// to above water's and most solids'. Outside it, the delays between microphones are
/// not what a recording holds (and their arithmetic overflows near 0).
pub(crate) const SPEED_OF_SOUND_RANGE: (f64, f64) = (50.0, 5000.0);

/// Whether `c` m/s is within [`SPEED_OF_SOUND_RANGE`].
pub(crate) fn speed_of_sound_ok(c: f64) -> bool {
    c.is_finite() && (SPEED_OF_SOUND_RANGE.0..=SPEED_OF_SOUND_RANGE.1).contains(&c)
}

/// A speed of sound in m/s (`-c`), within the range every input accepts.
#[cfg(feature = "flags")]
pub(crate) fn speed_of_sound_flag(s: &str) -> std::result::Result<f64, String> {
    let v = crate::flags::parse_f64(s)?;
    if !speed_of_sound_ok(v) {
        let (low, high) = SPEED_OF_SOUND_RANGE;
        return Err(format!(
            "{v:e} m/s is not a speed of sound from {low} to {high} m/s"
        ));
    }
    Ok(v)
}
/// The most microphones an array may have (subsets of live microphones are bit masks).
pub(crate) const MAX_MICS: usize = 64;
/// A spread along an axis below this fraction of the largest spread counts as flat.
pub(crate) const FLATNESS: f64 = 0.02;
/// The largest geometry file read (a file of 64 microphones takes a few kilobytes).
pub(crate) const MAX_FILE_BYTES: u64 = 1 << 20;
/// Two microphones closer than this (metres) are taken as the same position.
const MIN_SPACING_M: f64 = 1e-4;
/// The widest array accepted (metres). Wider is almost always millimetres given as
/// metres, and beyond the method's far-field model anyway.
pub(crate) const MAX_APERTURE_M: f64 = 5.0;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct GeometryFile {
    name: Option<String>,
    speed_of_sound: Option<f64>,
    #[serde(default, deserialize_with = "crate::text::numbers_opt")]
    side: Option<[f64; 3]>,
    #[serde(default, deserialize_with = "orientation::table_only")]
    orientation: Option<orientation::OrientationEntry>,
    #[serde(default)]
    mic: Vec<MicEntry>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MicEntry {
    #[serde(deserialize_with = "crate::text::numbers")]
    position: [f64; 3],
    channel: Option<usize>,
}

/// One microphone: its position (metres) and its 0-based WAV channel.
#[derive(Debug, Clone, PartialEq)]
pub struct Mic {
    /// Position in the frame directions are reported in: the array frame, or the room
    /// frame when the geometry has an orientation (metres).
    pub position: Vector3<f64>,
    /// 0-based channel in the recording.
    pub channel: usize,
}

/// A validated microphone array.
#[derive(Debug, Clone)]
pub struct Geometry {
    /// The array's `name`, if the file gives one.
    pub name: Option<String>,
    /// Speed of sound (m/s).
    pub speed_of_sound: f64,
    /// The microphones, in file order.
    pub mics: Vec<Mic>,
    /// Mean of the microphone positions: directions point from here.
    pub centre: Vector3<f64>,
    /// The side vector used to resolve the planar/linear ambiguity (given or default).
    pub side: Vector3<f64>,
    /// Whether `side` came from the file (`false`: the default of docs/interface.md).
    pub side_given: bool,
    /// 3-D, planar or linear.
    pub shape: Shape,
    /// Whether the file assigned channels explicitly with `channel` keys.
    pub explicit_channels: bool,
    /// Non-fatal remarks about the geometry (shown to the user as warnings).
    pub warnings: Vec<String>,
    /// The rotation from the array frame (the file's positions) to the room frame (the
    /// reported directions), when the file gives an `[orientation]`: every position,
    /// `centre`, `side` and `shape` here is already in the room frame.
    pub orientation: Option<nalgebra::Matrix3<f64>>,
}

impl Geometry {
    /// Reads and validates a geometry TOML file. Errors name the file.
    pub fn from_file(path: &Path) -> Result<Self> {
        if let Some(kind) = audio_kind(path) {
            return Err(GeometryError::File {
                path: path.to_path_buf(),
                error: Box::new(GeometryError::Invalid(format!(
                    "this is a {kind} file, not a geometry (TOML): are the recording and --geometry swapped?"
                ))),
            });
        }
        let text = read_text(path, MAX_FILE_BYTES).map_err(|error| GeometryError::Read {
            path: path.to_path_buf(),
            error,
        })?;
        Self::from_toml_str(&text).map_err(|error| GeometryError::File {
            path: path.to_path_buf(),
            error: Box::new(error),
        })
    }

    /// Parses and validates geometry TOML text.
    pub fn from_toml_str(text: &str) -> Result<Self> {
        let file: GeometryFile = toml::from_str(text).map_err(|e| {
            // toml's messages span several lines with a source excerpt; keep one line.
            GeometryError::Toml {
                line: toml_line(text, &e),
                message: e.message().trim().to_string(),
            }
        })?;
        let explicit = file.mic.iter().filter(|m| m.channel.is_some()).count();
        if explicit != 0 && explicit != file.mic.len() {
            fail!(
                GeometryError::Invalid,
                "{} of {} microphones have a `channel` key: give it to all of them or to none",
                explicit,
                file.mic.len()
            );
        }
        let mics: Vec<Mic> = file
            .mic
            .iter()
            .enumerate()
            .map(|(i, m)| Mic {
                position: Vector3::from(m.position),
                channel: m.channel.unwrap_or(i),
            })
            .collect();
        let rotation = file
            .orientation
            .as_ref()
            .map(orientation::OrientationEntry::rotation)
            .transpose()?;
        let geometry = Self::new(
            file.name,
            mics,
            file.speed_of_sound,
            file.side.map(Vector3::from),
            explicit != 0,
        )?;
        Ok(match rotation {
            Some(r) => geometry.oriented(r),
            None => geometry,
        })
    }

    /// The same array turned by `rotation` (array frame to room frame, a proper
    /// rotation): its positions, centre, side and shape move into the room frame, in
    /// which directions are then reported. The side's default is the array frame's.
    pub fn oriented(mut self, rotation: nalgebra::Matrix3<f64>) -> Self {
        let total = self.orientation.map_or(rotation, |r| rotation * r);
        for m in &mut self.mics {
            m.position = rotation * m.position;
        }
        self.centre = rotation * self.centre;
        self.side = rotation * self.side;
        self.shape = self.shape.rotated(&rotation);
        self.orientation = Some(total);
        self
    }

    /// Microphone `i`'s position in the array frame, as the file gives it.
    pub fn array_position(&self, i: usize) -> Vector3<f64> {
        match self.orientation {
            Some(r) => r.transpose() * self.mics[i].position,
            None => self.mics[i].position,
        }
    }

    /// Builds a geometry from microphone positions with channels in order of appearance.
    pub fn from_positions(positions: &[[f64; 3]]) -> Result<Self> {
        let mics = positions
            .iter()
            .enumerate()
            .map(|(i, p)| Mic {
                position: Vector3::from(*p),
                channel: i,
            })
            .collect();
        Self::new(None, mics, None, None, false)
    }

    /// Validates microphones and options and classifies the array.
    pub fn new(
        name: Option<String>,
        mics: Vec<Mic>,
        speed_of_sound: Option<f64>,
        side: Option<Vector3<f64>>,
        explicit_channels: bool,
    ) -> Result<Self> {
        if let Some(c) = name
            .as_deref()
            .and_then(|n| n.chars().find(|c| c.is_control()))
        {
            fail!(
                GeometryError::Invalid,
                "name holds a control character ({}); a name is plain text, printed as it is",
                c.escape_unicode()
            );
        }
        let mut warnings = Vec::new();
        if mics.len() < 2 {
            fail!(
                GeometryError::Invalid,
                "the array has {} microphone(s); at least 2 `[[mic]]` tables are needed",
                mics.len()
            );
        }
        if mics.len() > MAX_MICS {
            fail!(
                GeometryError::Invalid,
                "the array has {} microphones; at most {MAX_MICS} are supported",
                mics.len()
            );
        }
        for (i, m) in mics.iter().enumerate() {
            if !m.position.iter().all(|v| v.is_finite()) {
                fail!(
                    GeometryError::Invalid,
                    "mic {} has a non-finite position {:?}",
                    i + 1,
                    m.position.as_slice()
                );
            }
        }
        let mut seen = std::collections::HashMap::new();
        for (i, m) in mics.iter().enumerate() {
            if let Some(j) = seen.insert(m.channel, i) {
                fail!(
                    GeometryError::Invalid,
                    "mics {} and {} both use channel {}: each microphone needs its own channel",
                    j + 1,
                    i + 1,
                    m.channel
                );
            }
        }
        let speed = speed_of_sound.unwrap_or(DEFAULT_SPEED_OF_SOUND);
        if !speed_of_sound_ok(speed) {
            let (low, high) = SPEED_OF_SOUND_RANGE;
            fail!(
                GeometryError::Invalid,
                "speed_of_sound must be {low} to {high} m/s, got {speed:e}"
            );
        }
        let mut aperture: f64 = 0.0;
        for i in 0..mics.len() {
            for j in i + 1..mics.len() {
                let d = (mics[j].position - mics[i].position).norm();
                if d == 0.0 {
                    fail!(
                        GeometryError::Invalid,
                        "mics {} and {} have the same position {}",
                        i + 1,
                        j + 1,
                        crate::text::shown3(&mics[i].position.into())
                    );
                }
                if d < MIN_SPACING_M {
                    fail!(
                        GeometryError::Invalid,
                        "mics {} and {} are {} um apart, closer than {} um: no delay between them can be measured (positions in metres? give each microphone its own position)",
                        i + 1,
                        j + 1,
                        crate::text::BriefNumber(crate::text::fixed(d * 1e6, 3)),
                        MIN_SPACING_M * 1e6
                    );
                }
                aperture = aperture.max(d);
            }
        }
        if aperture > MAX_APERTURE_M {
            let hint = units::advice(aperture)
                .map(|a| format!(": {a}"))
                .unwrap_or_default();
            fail!(
                GeometryError::Invalid,
                "microphones are up to {} apart, but positions are in metres and arrays up to {MAX_APERTURE_M} m wide are supported{hint}",
                units::shown_length(aperture)
            );
        }
        if aperture > units::WIDE_APERTURE_M {
            if let Some(a) = units::advice(aperture) {
                warnings.push(format!(
                    "microphones are up to {} apart, an unusually wide array: positions are in metres, and {a}",
                    units::shown_length(aperture)
                ));
            }
        }
        let positions: Vec<Vector3<f64>> = mics.iter().map(|m| m.position).collect();
        let centre = positions.iter().sum::<Vector3<f64>>() / positions.len() as f64;
        if let Some(s) = side {
            if !(s.iter().all(|v| v.is_finite()) && s.norm() > 0.0) {
                fail!(
                    GeometryError::Invalid,
                    "side must be a finite non-zero vector, got {}",
                    crate::text::shown3(&[s.x, s.y, s.z])
                );
            }
        }
        let raw_shape = classify(&positions);
        let (shape, side_vec) = orient(raw_shape, side)?;
        if side.is_some() && shape == Shape::Volumetric {
            warnings
                .push("`side` is ignored: a 3-D array determines the full direction".to_string());
        }
        Ok(Geometry {
            name,
            speed_of_sound: speed,
            mics,
            centre,
            side: side_vec,
            side_given: side.is_some(),
            shape,
            explicit_channels,
            warnings,
            orientation: None,
        })
    }

    /// Microphone positions in geometry order.
    pub fn positions(&self) -> Vec<Vector3<f64>> {
        self.mics.iter().map(|m| m.position).collect()
    }

    /// Distance between mics `i` and `j` (metres).
    pub fn spacing(&self, i: usize, j: usize) -> f64 {
        (self.mics[j].position - self.mics[i].position).norm()
    }

    /// The largest spacing and the pair (0-based) that has it.
    pub fn aperture(&self) -> (f64, usize, usize) {
        let mut best = (0.0, 0, 1);
        for i in 0..self.mics.len() {
            for j in i + 1..self.mics.len() {
                let d = self.spacing(i, j);
                if d > best.0 {
                    best = (d, i, j);
                }
            }
        }
        best
    }

    /// The standard deviation (degrees) of a direction along its least certain axis
    /// when every pair's delay errs independently by one sample at `rate` (standard
    /// deviation), through the far-field least squares of eq. 13: `c / fs` over the root
    /// of the smallest eigenvalue of `D^T D`, `D` the pairs' position differences. A
    /// planar array's axis out of its plane, and a linear array's two across it, which
    /// the geometry does not determine, are left out.
    pub fn direction_spread_deg(&self, rate: f64, speed: f64) -> f64 {
        let n = self.mics.len();
        let mut dtd = nalgebra::Matrix3::<f64>::zeros();
        for i in 0..n {
            for j in i + 1..n {
                let d = self.mics[i].position - self.mics[j].position;
                dtd += d * d.transpose();
            }
        }
        let eigen = dtd.symmetric_eigenvalues();
        let largest = eigen.max();
        let smallest = eigen
            .iter()
            .copied()
            .filter(|&e| e > 1e-9 * largest)
            .fold(f64::INFINITY, f64::min);
        if !smallest.is_finite() || smallest <= 0.0 {
            return 0.0;
        }
        (speed / rate / smallest.sqrt()).to_degrees()
    }

    /// The largest physically possible lag between mics `i` and `j`, in samples at `rate`.
    pub fn max_lag_samples(&self, i: usize, j: usize, rate: f64, speed: f64) -> f64 {
        self.spacing(i, j) * rate / speed
    }

    /// The shape (and orientation) of a subset of the microphones, given as a bit mask.
    /// Used when dead channels leave fewer microphones in a frame.
    pub fn subset_shape(&self, mask: u64) -> Result<Shape> {
        // In the array frame, where the side's default is defined.
        let back = self
            .orientation
            .map_or(nalgebra::Matrix3::identity(), |r| r.transpose());
        let pos: Vec<Vector3<f64>> = (0..self.mics.len())
            .filter(|i| mask & (1u64 << i) != 0)
            .map(|i| back * self.mics[i].position)
            .collect();
        if pos.len() < 2 {
            fail!(GeometryError::Invalid, "fewer than 2 microphones");
        }
        let side = if self.side_given {
            Some(back * self.side)
        } else {
            None
        };
        let shape = orient(classify(&pos), side)?.0;
        Ok(match self.orientation {
            Some(r) => shape.rotated(&r),
            None => shape,
        })
    }
}

#[cfg(test)]
mod tests;
