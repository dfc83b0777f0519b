//! The coherent background, subtracted from every pair's correlation (beyond the paper).
//!
//! The noise estimate of eq. (4)-(5) is a power per bin: it tells how loud the background
//! is, not where it comes from. A steady point source heard mostly directly (a fan on
//! the table next to the array) keeps the same delays in every frame, and its weighted
//! correlations peak there frame after frame above any threshold that lets speech
//! through. So each pair's correlation, at the lags searched, is also estimated for
//! the background, and its positive part is subtracted before the peaks (eq. 7):
//!
//! - the estimate learns from frames with nothing above the noise estimate (their
//!   weights' ceiling within [`GATE`] times that of a frame at the noise level; a steady
//!   fan's frames measure 1.3-1.8 times), one
//!   frame in [`STRIDE`] (so that the frames it needs are few enough to correlate even
//!   when no detection needs them): a running mean at first, then an exponential
//!   average over [`Room::background_s`](crate::method::Room::background_s);
//! - only the positive part is subtracted, so no value grows: the ceilings and bounds
//!   that leave out correlations stay exact, and a source where the background has
//!   nothing is scored as before.
//!
//! A source in the direction of a steady background loses the background's share there.
//! Measured in docs/field.md.

use super::threshold::{steady_weight, STEADY_FRAME};
use crate::method::layout::Layout;
use crate::method::paper::pairs::{pair_count, pair_index};
use crate::method::params::Params;
use crate::method::state::{Correlated, FrameState};
use multiversion::multiversion;

/// A frame teaches the background when its weights' ceiling is within this many times
/// that of a frame at the noise level: the frames that give no detection because they
/// hold nothing above the noise estimate ([`STEADY_FRAME`]). Measured on the prism's
/// real-speech grid and a fan next to the array in free field: 2.0 lost more speech
/// events at 0 dB SNR (50% against 62% at RT60 0.2 s), 1.2 taught too rarely and let the
/// fan through in 263 of 750 frames.
pub(crate) const GATE: f64 = STEADY_FRAME;

/// One frame in this many of those within [`GATE`] teaches the background (4 cost 4% more
/// time on the 10-minute recording of docs/speed.md than 8, for no gain measured).
pub(crate) const STRIDE: u64 = 8;

/// In a steady room the estimate has learnt from four frames after this many (32 at
/// [`STRIDE`] 8: 0.5 s at 16 kHz, 0.34 s at 48 kHz); before that a steady source beside
/// the array is not yet removed, and a tracker takes what is under the threshold as
/// telling nothing ([`Tracker::looking`](crate::track::Tracker::looking)). A fan 0.9 m
/// from the array gave a false source in its first 0.6 s otherwise (docs/tracking.md);
/// waiting the whole time constant lost talkers who start 1 s into a recording.
pub const WARMUP_FRAMES: u64 = 4 * STRIDE;

/// The ceiling under which a frame's weights let it teach the background ([`GATE`] times
/// a frame at the noise level), in the units of `peak_ceiling`.
pub fn gate(params: &Params) -> f64 {
    let w = steady_weight(
        params.weighting.alpha as f32,
        params.weighting.reverb_share(),
    );
    GATE * w * w * params.peaks.refinement().overshoot() * (1.0 + 1e-3)
}

/// Every pair's background correlation at the lags searched, laid out as the frames'
/// windows ([`Layout::window_starts`]).
pub(crate) struct Background {
    windows: Vec<f32>,
    /// Frames learned from, per pair.
    learned: Vec<u32>,
    /// The smallest weight of a new frame in the average.
    floor: f32,
}

impl Background {
    /// An empty estimate, or `None` when the parameters leave it out.
    pub fn new(setup: &Layout) -> Option<Self> {
        let tau = setup.params.room.background_tau_s()?;
        let hop_s = setup.hop as f64 / setup.rate;
        Some(Background {
            windows: vec![0.0; setup.windows_len],
            learned: vec![0; pair_count(setup.mics())],
            floor: (STRIDE as f64 * hop_s / tau).min(1.0) as f32,
        })
    }

    /// Whether frame `index` teaches the background (it must then be correlated).
    pub fn teaches(params: &Params, gate: f64, state: &FrameState, index: u64) -> bool {
        params.room.background_tau_s().is_some() && index % STRIDE == 0 && state.ceiling <= gate
    }

    /// In frame order: subtracts the background from each correlated frame's windows,
    /// then learns from the frames that teach it (marked by [`Background::teaches`]).
    pub fn apply(&mut self, setup: &Layout, states: &mut [FrameState]) {
        let mics = setup.mics();
        for state in states.iter_mut() {
            if state.correlated != Correlated::Yes {
                continue;
            }
            let teach = state.teaches;
            let live = &state.live;
            for (i, &a) in live.iter().enumerate() {
                for &b in &live[i + 1..] {
                    let pair = pair_index(a, b, mics);
                    let start = setup.window_starts[pair];
                    let len = 2 * setup.max_lag[pair] + 3;
                    let known = &mut self.windows[start..start + len];
                    let frame = &mut state.windows[start..start + len];
                    let learned = self.learned[pair];
                    if !teach {
                        if learned > 0 {
                            subtract(frame, known);
                        }
                        continue;
                    }
                    self.learned[pair] += 1;
                    let share = (1.0 / (learned as f32 + 1.0)).max(self.floor);
                    for (k, f) in known.iter_mut().zip(frame.iter_mut()) {
                        let raw = *f;
                        if learned > 0 {
                            *f = raw - k.max(0.0);
                        }
                        *k += share * (raw - *k);
                    }
                }
            }
        }
    }
}

/// `frame[i] -= max(known[i], 0)`: a frame that does not teach the background only loses
/// it (a loop the compiler vectorises).
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn subtract(frame: &mut [f32], known: &[f32]) {
    for (f, k) in frame.iter_mut().zip(known) {
        *f -= k.max(0.0);
    }
}
