//! What the analyzer does in frame order between the parallel stages: the noise estimate
//! `X_n(k)` of eq. (4)-(5), which depends on every earlier frame (with the optional
//! late-reverberation term), and the run's counters.

use super::setup::Setup;
use crate::method::outcome::FrameStats;
use crate::method::paper::frames::BLOCK;
use crate::method::paper::weighting::NoiseEstimator;
use crate::method::params::{PRIMING_S, REVERB_TAU_S};
use crate::method::state::FrameState;

/// What depends on every earlier frame: the noise estimate and the counters.
pub(crate) struct Sequential {
    noise: NoiseEstimator,
    pub stats: FrameStats,
    /// Frames of the next block to fold into the noise estimate before it is weighed.
    pub priming: usize,
    /// The late-reverberation estimate added to `X_n(k)` (see [`Weighting::reverb_level`](crate::method::Weighting::reverb_level)).
    reverb: Vec<f32>,
    /// Its smoothing coefficient per frame and its share of `X(k)`.
    reverb_settings: Option<(f32, f32)>,
}

impl Sequential {
    /// The state before the first frame of a recording.
    pub fn new(setup: &Setup) -> Self {
        let hop_s = setup.hop as f64 / setup.rate;
        Sequential {
            noise: NoiseEstimator::new(setup.bins(), hop_s, setup.params.noise),
            stats: FrameStats {
                dead_frames: vec![0; setup.mics()],
                ..Default::default()
            },
            priming: ((PRIMING_S / hop_s).ceil() as usize).min(BLOCK),
            reverb: vec![0.0; setup.bins()],
            reverb_settings: (setup.params.weighting.reverb_share() > 0.0).then(|| {
                (
                    (-hop_s / REVERB_TAU_S).exp() as f32,
                    setup.params.weighting.reverb_share(),
                )
            }),
        }
    }

    /// Folds a frame's `X(k)` into the late-reverberation estimate.
    fn fold_reverb(&mut self, power: &[f32]) {
        if let Some((keep, share)) = self.reverb_settings {
            for (r, &x) in self.reverb.iter_mut().zip(power) {
                *r = keep * *r + (1.0 - keep) * share * x;
            }
        }
    }

    /// Gives each frame of a block the noise estimate of the frames before it (for its
    /// weights, eq. 4-5; only with `weighting`), then updates the estimate with its
    /// `X(k)`; primed frames are folded in first and not again. Counts silent frames and
    /// dead microphones.
    pub fn estimate_noise(&mut self, weighting: bool, states: &mut [FrameState], live: &[bool]) {
        let primed = std::mem::take(&mut self.priming).min(states.len());
        for (state, _) in states[..primed].iter().zip(live).filter(|(_, &l)| l) {
            self.noise.update(&state.power);
            self.fold_reverb(&state.power);
        }
        for (i, (state, &live)) in states.iter_mut().zip(live).enumerate() {
            self.stats.frames += 1;
            if !live {
                self.stats.silent_frames += 1;
                continue;
            }
            let power = state.power.iter().map(|&p| p as f64).sum::<f64>();
            self.stats.power_range = Some(match self.stats.power_range {
                Some((lo, hi)) => (lo.min(power), hi.max(power)),
                None => (power, power),
            });
            for (m, dead) in self.stats.dead_frames.iter_mut().enumerate() {
                if !state.live.contains(&m) {
                    *dead += 1;
                }
            }
            if !self.noise.started() {
                self.noise.start(&state.power);
            }
            if weighting {
                state.noise.copy_from_slice(self.noise.noise());
                if self.reverb_settings.is_some() {
                    for (n, r) in state.noise.iter_mut().zip(&self.reverb) {
                        *n += r;
                    }
                }
            }
            if i >= primed {
                self.noise.update(&state.power);
                self.fold_reverb(&state.power);
            }
        }
    }
}
