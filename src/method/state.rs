//! One frame's state between the stages of [`super::engine::worker`], and what a span of them
//! bounds.

use super::layout::Layout;
use nalgebra::Vector3;
use realfft::num_complex::Complex32;

/// One frame between the stages: its live microphones, spectra, `X(k)`, the noise
/// estimate `X_n(k)` of the frames before it, its weights, and its correlations.
pub(crate) struct FrameState {
    pub live: Vec<usize>,
    pub(super) spectra: Vec<Vec<Complex32>>,
    pub power: Vec<f32>,
    pub noise: Vec<f32>,
    /// `w_e(k)` (all 1 without weighting).
    pub(super) weights: Vec<f32>,
    /// The most any correlation value (or refined peak) its own weights allow.
    pub ceiling: f64,
    /// The most any of its correlation values (or refined peaks) can be: `ceiling`, or
    /// with the diffuse part removed, that of the weights averaged over the frames its
    /// cross-spectra sum ([`super::beyond::dereverb`]).
    pub reach: f64,
    /// The frame's detection threshold per pair.
    pub threshold: f64,
    /// What a pair's correlation must reach to count as a clear sound in the diagnostic
    /// of delays beyond the geometry ([`super::beyond::edges`]): the threshold, and at
    /// least the calibrated one whatever threshold detects.
    pub clear: f64,
    /// The lowest score per pair of a candidate: the threshold times
    /// [`Params::candidates`](super::Params::candidates). Everything that rules frames
    /// out compares with this.
    pub floor: f64,
    /// The lowest score per pair of a rider: the threshold times
    /// [`Params::riders`](super::Params::riders) (at most [`FrameState::floor`]). Only a
    /// frame that gives nothing down to the floor is searched down to this.
    pub rider_floor: f64,
    /// With the calibrated threshold: nothing in the frame stands above the noise
    /// estimate (see [`super::beyond::threshold`]); such a frame gives no detection.
    pub steady: bool,
    /// Bit `m` set when microphone `m` is live.
    pub(super) mask: u64,
    /// Every pair's correlation at the lags searched and their two neighbours, one pair
    /// after another in the order of [`pair_index`] over all microphones (see
    /// [`Layout::window_starts`]); read only when `correlated` is `Correlated::Yes`.
    pub(super) windows: Vec<f32>,
    pub correlated: Correlated,
    /// The coherent background learns from this frame ([`super::beyond::background`]): it is
    /// correlated in full even when no detection needs it.
    pub teaches: bool,
    /// The directions of its bins ([`super::beyond::votes`]), when they vote.
    pub(crate) votes: Vec<Vote>,
    /// Its pairs that peak past the lags the geometry allows ([`super::beyond::edges`]).
    pub(crate) edges: super::beyond::edges::Edges,
}

/// One bin's vote ([`super::beyond::votes`]): its direction and weight.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Vote {
    pub direction: Vector3<f64>,
    /// Azimuth in the array's plane (planar arrays), radians.
    pub azimuth: f64,
    pub weight: f64,
}

/// Whether a frame's correlations were computed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Correlated {
    /// Not live, or before the start of the recording.
    No,
    /// Left out: no frame that averages this one can reach the threshold.
    Skipped,
    /// Stopped part way, when the frame (averaged with no other) was shown unable to
    /// reach the threshold; the most it could have scored.
    Stopped(f64),
    Yes,
}

impl FrameState {
    pub fn new(setup: &Layout) -> Self {
        let mics = setup.mics();
        FrameState {
            live: Vec::with_capacity(mics),
            spectra: vec![vec![Complex32::default(); setup.bins()]; mics],
            power: vec![0.0; setup.bins()],
            noise: vec![0.0; setup.bins()],
            weights: vec![1.0; setup.bins()],
            ceiling: 0.0,
            reach: 0.0,
            threshold: 0.0,
            clear: 0.0,
            floor: 0.0,
            rider_floor: 0.0,
            steady: false,
            mask: 0,
            windows: vec![0.0; setup.windows_len],
            correlated: Correlated::No,
            teaches: false,
            votes: Vec::new(),
            edges: Default::default(),
        }
    }
}

/// The most any pair's averaged correlation can be over the last frame of `span`: the
/// mean reach of its live frames.
pub(crate) fn span_ceiling(span: &[FrameState]) -> f64 {
    let (sum, count) = span
        .iter()
        .filter(|f| !f.live.is_empty())
        .fold((0.0, 0.0), |(s, c), f| (s + f.reach, c + 1.0));
    if count > 0.0 {
        sum / count
    } else {
        0.0
    }
}
