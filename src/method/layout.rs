//! What every stage of a run reads and none changes: the parameters checked against the
//! array and the sample rate, the frame size, the lags searched per pair, and where each
//! pair's correlation window lies in a frame's windows. The stages' own plans (the
//! threshold's floors, the diffuse coherences, the bins' solvers) are built by their
//! stages; the engine's [`Setup`](super::engine::setup::Setup) holds them beside this.

use super::beyond::steered::steer_tolerance;
use super::paper::correlation::weight_energy;
use super::paper::frames::FrameSize;
use super::paper::pairs::{pair_count, pair_index};
use super::paper::search::Tolerance;
use super::params::{
    default_frame_size, frame_size_for_ms, Params, ParamsError, MAX_FRAME_SIZE, MIN_BAND_BINS,
};
use crate::geometry::Geometry;

/// The frame layout of a run (see the module).
#[derive(Debug, Clone)]
pub(crate) struct Layout {
    pub geometry: Geometry,
    /// The parameters.
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
    /// Where each pair's correlation window starts in a frame's windows (pairs in the
    /// order of [`pair_index`] over all microphones; each holds the lags searched and
    /// their two neighbours, `2 max_lag + 3` values), and their total length.
    pub window_starts: Vec<usize>,
    pub windows_len: usize,
    /// The bins analysed, `first..=last` (`--band`; all of `0..=N/2` without one).
    pub band: (usize, usize),
    /// The consistency tolerance of eq. (8) in samples at this rate.
    pub tolerance: f32,
    /// How far (samples) a pair's peak may lie from a steered direction's delay
    /// ([`steer_tolerance`]).
    pub steer_tolerance: f32,
}

impl Layout {
    /// The residual gate (microseconds, `None`: off) and the speed of sound (m/s) it is
    /// read at.
    pub fn gate(&self) -> (Option<f64>, f64) {
        (self.params.room.gate_us(), self.speed)
    }

    /// `params` checked against `geometry` at `sample_rate`, and the layout they give.
    pub fn new(
        geometry: &Geometry,
        sample_rate: u32,
        params: &Params,
    ) -> Result<Self, ParamsError> {
        params.check()?;
        if let FrameSize::Ms(ms) = params.framing.size {
            // The nearest power of two, which must be a frame size (not clamped to one).
            let p = (ms * sample_rate as f64 / 1000.0).log2().round();
            if !(4.0..=MAX_FRAME_SIZE.trailing_zeros() as f64).contains(&p) {
                return Err(ParamsError::FrameMsRange { ms, sample_rate });
            }
        }
        let n = match params.framing.size {
            FrameSize::Samples(n) => n,
            FrameSize::Ms(ms) => frame_size_for_ms(ms, sample_rate),
            FrameSize::Auto => default_frame_size(sample_rate),
        };
        let params = params.clone();
        let tolerance = match params.tolerance {
            // Not under one sample: at low rates the peaks' own error is that large.
            Tolerance::Us(us) => (us * sample_rate as f64 / 1e6).max(1.0) as f32,
            Tolerance::Samples(s) => s as f32,
        };
        let speed = params.speed_of_sound.unwrap_or(geometry.speed_of_sound);
        let rate = sample_rate as f64;
        let mics = geometry.mics.len();
        let mut max_lag = vec![0; pair_count(mics)];
        let mut widest = 0;
        let mut longest = 0.0f64;
        for a in 0..mics {
            for b in a + 1..mics {
                let delay = geometry.max_lag_samples(a, b, rate, speed);
                longest = longest.max(delay);
                let lag = lag_range(delay);
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
        let band = match params.weighting.band_hz {
            None => (0, n / 2),
            Some((low, high)) => {
                let per_bin = rate / n as f64;
                let first = (low / per_bin).ceil().min((n / 2 + 1) as f64) as usize;
                let last = ((high / per_bin).floor() as usize).min(n / 2);
                let bins = (last + 1).saturating_sub(first);
                if bins < MIN_BAND_BINS {
                    return Err(ParamsError::BandTooNarrow {
                        low,
                        high,
                        bins,
                        sample_rate,
                        frame_size: n,
                    });
                }
                (first, last)
            }
        };
        let mut windows_len = 0;
        let window_starts = max_lag
            .iter()
            .map(|&h| {
                let here = windows_len;
                windows_len += 2 * h + 3;
                here
            })
            .collect();
        let steer_tolerance = steer_tolerance(tolerance, longest, params.steered);
        Ok(Layout {
            geometry: geometry.clone(),
            params,
            n,
            hop: n / 2,
            rate,
            speed,
            max_lag,
            window_starts,
            windows_len,
            band,
            tolerance,
            steer_tolerance,
        })
    }

    /// Bins of a real spectrum, `N/2 + 1`.
    pub fn bins(&self) -> usize {
        self.n / 2 + 1
    }

    /// The share of eq. (6)'s energy `E = (1/N) sum_k w_e(k)^2` that a flat spectrum
    /// keeps in the band: 1 without one. Levels set for the whole band (the steady
    /// frame, the background's gate, the diffuse floor) scale with it.
    pub fn band_share(&self) -> f64 {
        let (first, last) = self.band;
        let kept = (0..=self.n / 2).map(|k| f64::from(u8::from((first..=last).contains(&k))));
        weight_energy(kept, self.n)
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
