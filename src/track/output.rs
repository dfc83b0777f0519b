//! What the tracker gives out: each row with its track's id, and what it made of a
//! recording (see the [`track`](super) module).

use super::faint::FaintPlace;
use crate::method::Detection;

/// A detection as the tracker gives it out: with its track's id.
#[derive(Debug, Clone, PartialEq)]
pub struct Tracked {
    /// The detection.
    pub detection: Detection,
    /// Its track's id (from 1, never reused within one recording), or `None` for a
    /// detection no track confirmed, given out only with
    /// [`TrackParams::keep_unconfirmed`](super::TrackParams::keep_unconfirmed).
    pub source: Option<u64>,
}

/// What a tracker made of a recording's detections (the JSON document's `files`
/// entries carry it as `tracking`).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TrackStats {
    /// Tracks confirmed (ids given).
    pub tracks: u64,
    /// Detections given out with a track's id.
    pub rows: u64,
    /// Detections no track confirmed: dropped, or given out without an id with
    /// [`TrackParams::keep_unconfirmed`](super::TrackParams::keep_unconfirmed).
    pub unconfirmed: u64,
    /// Of those, the detections of candidates taken for a talking track's floor or
    /// ceiling image (see `image.rs`).
    pub reflections: u64,
    /// The place whose candidates, never confirmed, were heard most (five times or
    /// more): where a source too faint to confirm may be. Not written in the JSON
    /// document.
    #[serde(skip)]
    pub faint: Option<FaintPlace>,
}
