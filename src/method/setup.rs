//! What a run of the method needs that does not change during it: the parameters
//! checked against the array and the sample rate ([`Params`]), and what follows from
//! them (frame size, lag ranges, thresholds, the correlation windows' layout).

use super::background::GATE;
use super::dereverb::DiffuseCoherence;
use super::pairs::{pair_count, pair_index};
use super::params::{default_frame_size, frame_size_for_ms, Params, ParamsError};
use super::threshold::{
    chance_sigma, diffuse_coherence, steady_weight, DIFFUSE_MARGIN, STEADY_FRAME,
};
use super::votes::BinVotes;
use crate::geometry::Geometry;

/// What the method needs that does not change during a run: the parameters checked
/// against the array and the sample rate, and what follows from them.
#[derive(Debug, Clone)]
pub(crate) struct Setup {
    pub geometry: Geometry,
    pub params: Params,
    /// Frame size N.
    pub n: usize,
    /// Hop between frames, N / 2.
    pub hop: usize,
    /// Sample rate (Hz).
    pub rate: f64,
    /// Speed of sound (m/s).
    pub speed: f64,
    /// Lag search range per pair of the array (samples).
    pub max_lag: Vec<usize>,
    /// The threshold per pair a diffuse background calls for (the `threshold` module).
    pub diffuse_floor: f64,
    /// A frame whose weights' ceiling is under this has nothing above the noise
    /// estimate (the `threshold` module's steady frames).
    pub steady_ceiling: f64,
    /// A frame whose weights' ceiling is under this may teach the coherent background
    /// ([`super::background`]).
    pub background_gate: f64,
    /// When the diffuse part is removed from the cross-spectra ([`Params::dereverb`]
    /// for this array): every pair's diffuse coherence at every bin.
    pub dereverb: Option<DiffuseCoherence>,
    /// Where each pair's correlation window starts in a frame's windows (pairs in the
    /// order of [`pair_index`] over all microphones; each holds the lags searched and
    /// their two neighbours, `2 max_lag + 3` values), and their total length.
    pub window_starts: Vec<usize>,
    pub windows_len: usize,
    /// The bins' solvers when they vote ([`Params::bin_votes`] with a tracker, on an
    /// array small enough).
    pub votes: Option<BinVotes>,
}

impl Setup {
    /// A frame's detection threshold per pair, from its weights `w_e(k)`.
    pub fn threshold_per_pair(&self, weights: &[f32]) -> f64 {
        self.threshold_per_pair_spread(weights, 1.0)
    }

    /// [`Setup::threshold_per_pair`] of an average whose chance fluctuation is `spread`
    /// times a frame's (the calibrated threshold's chance part scales with it; a fixed
    /// threshold does not).
    pub fn threshold_per_pair_spread(&self, weights: &[f32], spread: f64) -> f64 {
        match self.params.threshold_sigmas {
            Some(z) => self.diffuse_floor + z * chance_sigma(weights, self.n) * spread,
            None => self.params.min_score_per_pair,
        }
    }

    pub fn new(
        geometry: &Geometry,
        sample_rate: u32,
        params: &Params,
    ) -> Result<Self, ParamsError> {
        params.check()?;
        let n = params.frame_size.unwrap_or_else(|| match params.frame_ms {
            Some(ms) => frame_size_for_ms(ms, sample_rate),
            None => default_frame_size(sample_rate),
        });
        let mut params = params.clone();
        if let Some(us) = params.tolerance_us {
            // Not under one sample: at low rates the peaks' own error is that large.
            params.tolerance = (us * sample_rate as f64 / 1e6).max(1.0) as f32;
        }
        let speed = params.speed_of_sound.unwrap_or(geometry.speed_of_sound);
        let rate = sample_rate as f64;
        let mics = geometry.mics.len();
        let mut max_lag = vec![0; pair_count(mics)];
        let mut widest = 0;
        for a in 0..mics {
            for b in a + 1..mics {
                let lag = lag_range(geometry.max_lag_samples(a, b, rate, speed));
                max_lag[pair_index(a, b, mics)] = lag;
                widest = widest.max(lag);
            }
        }
        if widest + 2 > n / 2 {
            return Err(ParamsError::FrameTooShort {
                delay: widest,
                sample_rate,
                frame_size: n,
                needed: ((widest + 2) * 2).next_power_of_two(),
            });
        }
        let diffuse_floor = DIFFUSE_MARGIN * diffuse_coherence(geometry, n, rate, speed);
        // In the units of `peak_ceiling`: E times the interpolation's overshoot.
        let steady_ceiling = {
            let w = steady_weight(params.alpha, params.reverb_level);
            STEADY_FRAME * w * w * params.interpolation.overshoot() * (1.0 + 1e-3)
        };
        let background_gate = {
            let w = steady_weight(params.alpha, params.reverb_level);
            GATE * w * w * params.interpolation.overshoot() * (1.0 + 1e-3)
        };
        let dereverb = params
            .dereverb
            .applies(&geometry.shape)
            .then(|| DiffuseCoherence::new(geometry, n, rate, speed));
        let votes = params
            .bin_votes_on()
            .then(|| BinVotes::new(geometry, n, rate, speed))
            .flatten();
        let mut windows_len = 0;
        let window_starts = max_lag
            .iter()
            .map(|&h| {
                let here = windows_len;
                windows_len += 2 * h + 3;
                here
            })
            .collect();
        Ok(Setup {
            geometry: geometry.clone(),
            params,
            n,
            hop: n / 2,
            rate,
            speed,
            max_lag,
            diffuse_floor,
            steady_ceiling,
            background_gate,
            dereverb,
            window_starts,
            windows_len,
            votes,
        })
    }

    /// Bins of a real spectrum, `N/2 + 1`.
    pub fn bins(&self) -> usize {
        self.n / 2 + 1
    }

    /// Number of microphones.
    pub fn mics(&self) -> usize {
        self.geometry.mics.len()
    }
}

/// The lags searched for a pair whose largest physical delay is `max_delay` samples: 3%
/// more (the speed of sound varies about that much between 0 and 40 C) and one sample
/// for the peak's neighbours.
fn lag_range(max_delay: f64) -> usize {
    (max_delay * 1.03).ceil() as usize + 1
}
