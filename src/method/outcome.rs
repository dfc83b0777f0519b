//! What the method makes of a frame: a detection or the reason there is none, the run's
//! counters, and the time spent in each stage.

use super::beyond::MAX_SOURCES;
use nalgebra::Vector3;
use std::time::{Duration, Instant};

/// One detected source in one frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Detection {
    /// Frame index (frame `i` starts at sample `i * N / 2`).
    pub frame: u64,
    /// Centre of the frame, seconds from the start of the recording.
    pub time_s: f64,
    /// `atan2(y, x)` in degrees, in (-180, 180] (docs/interface.md, "Directions").
    pub azimuth_deg: f64,
    /// `asin(z)` in degrees.
    pub elevation_deg: f64,
    /// Unit vector from the array centre toward the source.
    pub direction: Vector3<f64>,
    /// Summed weighted correlation of the chosen delay set, one term per pair (at most 1
    /// each with plain PHAT; the SNR weighting gives bins that stand out of the noise
    /// more, so a strong source scores several per pair).
    pub score: f64,
    /// Microphones that took part (dead channels are left out).
    pub mics: usize,
    /// The score over the frame's detection threshold. Under 1: a candidate, reported
    /// only with [`Talkers::candidates`](crate::method::Talkers::candidates) under 1, for a
    /// [`Tracker`](crate::track::Tracker) to confirm or drop (infinite with a threshold
    /// of 0).
    pub margin: f64,
    /// The largest margin this source reached in the frame: [`Detection::margin`], or
    /// that of the same direction in the frame's own correlations when they were
    /// searched too and scored it higher (further sources, docs/method.md): a
    /// knock fills one frame of the average, and passes the threshold only in its own.
    /// What a tracker weighs as evidence.
    pub peak_margin: f64,
    /// The half-angle (degrees) of the cone around [`Detection::direction`] that holds
    /// the true direction with 95% probability, from the fit and the geometry
    /// (docs/interface.md, "Detections"; docs/method.md, "Uncertainty").
    pub uncertainty_deg: f64,
    /// A rider: from a frame that gave nothing down to
    /// [`Talkers::candidates`](crate::method::Talkers::candidates), found in its own correlations
    /// down to [`Talkers::riders`](crate::method::Talkers::riders); a tracker only lets it add a row to a
    /// talking track (see [`track`](crate::track)).
    pub rider: bool,
    /// Seconds from the centre of the first frame whose correlations gave the direction
    /// to this one's (0: this frame's own; the frames averaged before it otherwise): the
    /// direction is that span's, so a moving source's lags `span_s / 2` behind
    /// [`Detection::time_s`], which the tracker's smoother takes out.
    pub span_s: f64,
    /// From the accumulated look (the longer average's best direction in a frame that
    /// gave nothing, its margin over that average's threshold): a tracker weighs it by
    /// the accumulated looks' own law (see [`track`](crate::track)).
    pub accumulated: bool,
}

/// A frame's detections, strongest first (at most 4).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Detections {
    count: usize,
    items: [Detection; MAX_SOURCES],
}

impl Detections {
    /// One detection.
    pub fn one(d: Detection) -> Self {
        let mut all = Detections::default();
        all.push(d);
        all
    }

    /// Adds `d` (ignored when full).
    pub fn push(&mut self, d: Detection) {
        if self.count < MAX_SOURCES {
            self.items[self.count] = d;
            self.count += 1;
        }
    }

    /// Every detection's [`Detection::span_s`] set to `span_s`.
    pub(crate) fn spanning(mut self, span_s: f64) -> Self {
        self.items[..self.count]
            .iter_mut()
            .for_each(|d| d.span_s = span_s);
        self
    }

    /// How many.
    pub fn len(&self) -> usize {
        self.count
    }

    /// None at all.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The detections, strongest first.
    pub fn as_slice(&self) -> &[Detection] {
        &self.items[..self.count]
    }

    /// Raises to `d`'s margin the [`Detection::peak_margin`] of each detection within
    /// `within_deg` of it.
    pub fn raise_peaks(&mut self, d: &Detection, within_deg: f64) {
        for f in &mut self.items[..self.count] {
            if f.direction.angle(&d.direction).to_degrees() <= within_deg {
                f.peak_margin = f.peak_margin.max(d.margin);
            }
        }
    }

    /// Marks every detection a rider.
    pub fn riders(mut self) -> Self {
        self.items[..self.count]
            .iter_mut()
            .for_each(|d| d.rider = true);
        self
    }
}

/// How a frame ended.
#[derive(Debug, Clone, Copy, PartialEq)]
// Outcomes live in a buffer planned once per block: a boxed variant would allocate a
// frame.
#[allow(clippy::large_enum_variant)]
pub(crate) enum Outcome {
    /// Every channel constant.
    Silent,
    /// Fewer than two live microphones, or no direction from the delays.
    Unsolved,
    /// No consistent set of delays (`true`: the search hit its budget).
    Inconsistent(bool),
    /// The best set scored under the threshold, or no set could reach it (the frame was
    /// decided by the weights' ceiling, see `peak_ceiling`).
    /// `true`: the search hit its budget; then the best set's score per pair when the
    /// frame was searched (`true`), else the most it could have scored per pair.
    BelowThreshold(bool, f64, bool),
    /// One detection or more (`true`: the search hit its budget).
    Detected(Detections, bool),
}

/// Counters a run reports at the end.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FrameStats {
    /// Frames analysed.
    pub frames: u64,
    /// Frames with a detection.
    pub detections: u64,
    /// Detections beyond the first in their frame (several sources at once).
    pub extra_detections: u64,
    /// Frames where every channel was constant (digital silence).
    pub silent_frames: u64,
    /// Per mic: frames where it was constant while others carried signal.
    pub dead_frames: Vec<u64>,
    /// Frames whose search stopped at the search's budget.
    pub budget_frames: u64,
    /// Frames with no consistent delay set (among the frames that could reach the
    /// threshold).
    pub inconsistent_frames: u64,
    /// Frames whose best set scored below the threshold, or that the weights' ceiling
    /// showed could not reach it before every pair was correlated (those are not
    /// searched, so whether they held a consistent set is not known).
    pub below_threshold_frames: u64,
    /// The highest score per microphone pair of any consistent set that was searched
    /// (`None` when the weights ruled out every frame before its search).
    pub best_score_per_pair: Option<f64>,
    /// For frames decided by the weights' ceiling before their search: the most any of
    /// them could have scored per microphone pair.
    pub best_bound_per_pair: Option<f64>,
    /// Pairs, over the frames with sound above the noise, whose correlation reached the
    /// frame's threshold per pair (`src/method/beyond/edges.rs`).
    pub strong_pairs: u64,
    /// Of those, the pairs whose correlation was largest at the edge of the lags the
    /// geometry allows: delays longer than the geometry's.
    pub edge_pairs: u64,
    /// The lowest and highest mean power of a frame with signal, over the recording:
    /// close together when the recording is steady from start to end.
    pub power_range: Option<(f64, f64)>,
}

impl FrameStats {
    /// Counts a frame's outcome and returns its detections.
    pub(crate) fn tally(&mut self, outcome: Outcome) -> Detections {
        let budget = match outcome {
            Outcome::Inconsistent(b) => {
                self.inconsistent_frames += 1;
                b
            }
            Outcome::BelowThreshold(b, per_pair, searched) => {
                self.below_threshold_frames += 1;
                let best = if searched {
                    &mut self.best_score_per_pair
                } else {
                    &mut self.best_bound_per_pair
                };
                *best = Some(best.map_or(per_pair, |b| b.max(per_pair)));
                b
            }
            Outcome::Detected(found, b) => {
                self.detections += 1;
                self.extra_detections += found.len() as u64 - 1;
                for d in found.as_slice() {
                    let p = d.score / crate::method::paper::pairs::pair_count(d.mics) as f64;
                    self.best_score_per_pair =
                        Some(self.best_score_per_pair.map_or(p, |b| b.max(p)));
                }
                b
            }
            Outcome::Silent | Outcome::Unsolved => false,
        };
        if budget {
            self.budget_frames += 1;
        }
        match outcome {
            Outcome::Detected(found, _) => found,
            _ => Detections::default(),
        }
    }
}

/// Time spent in each stage (measured only when stage timing is on: `ssl analyze
/// --timings`). With several threads, the stages after the noise estimate add up the
/// threads' time.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StageTimes {
    /// Reading, decoding and framing the audio (with `--wpe`, its dereverberation too).
    pub read: Duration,
    /// Live-channel check, forward FFTs, mean power spectrum.
    pub spectra: Duration,
    /// The noise estimate `X_n(k)`, in frame order.
    pub noise: Duration,
    /// Weights (eq. 4-5) and whitening.
    pub weighting: Duration,
    /// Cross-spectra and inverse FFTs of every pair (eq. 6), with `--dereverb` its
    /// diffuse part removed.
    pub correlation: Duration,
    /// The coherent background subtracted from the correlations, in frame order.
    pub background: Duration,
    /// Averaging each pair's correlation over the frame's span, and its M highest peaks
    /// (eq. 7).
    pub peaks: Duration,
    /// The consistency search (eq. 8).
    pub search: Duration,
    /// Direction (eq. 13) and the detection record.
    pub direction: Duration,
    /// The steered response: a direction the search did not give, further sources.
    pub steered: Duration,
    /// Each talker's learned pattern removed before a second look, in frame order.
    pub patterns: Duration,
    /// The tracker: tracks, their confirmation and events.
    pub tracking: Duration,
    /// Formatting and writing rows, events and sources.
    pub output: Duration,
    /// Pair correlations computed.
    pub correlated_pairs: u64,
    /// Pair correlations left out because the weights' ceiling proved that the frame
    /// could not reach the detection threshold (see
    /// `peak_ceiling`).
    pub skipped_pairs: u64,
}

impl StageTimes {
    /// Adds another record's times and counts to this one.
    pub fn add(&mut self, other: &StageTimes) {
        for ((_, mine), (_, theirs)) in self.stages_mut().into_iter().zip(other.stages()) {
            *mine += theirs;
        }
        self.correlated_pairs += other.correlated_pairs;
        self.skipped_pairs += other.skipped_pairs;
    }

    /// The stages' times summed.
    pub fn total(&self) -> Duration {
        self.stages().iter().map(|(_, d)| *d).sum()
    }
}

/// `StageTimes::stages` and `stages_mut` from one list of the stages: each one's name
/// (as `--timings` prints it) and field.
macro_rules! stage_list {
    ($($name:literal => $field:ident),* $(,)?) => {
        impl StageTimes {
            /// Each stage's name (as `--timings` prints it) and time, in the order a
            /// frame meets them.
            pub fn stages(&self) -> [(&'static str, Duration); 13] {
                [$(($name, self.$field)),*]
            }

            fn stages_mut(&mut self) -> [(&'static str, &mut Duration); 13] {
                [$(($name, &mut self.$field)),*]
            }
        }
    };
}

stage_list! {
    "read" => read,
    "spectra" => spectra,
    "noise" => noise,
    "weighting" => weighting,
    "correlation" => correlation,
    "background" => background,
    "peaks" => peaks,
    "search" => search,
    "direction" => direction,
    "steered" => steered,
    "patterns" => patterns,
    "tracking" => tracking,
    "output" => output,
}

/// Stage timing inside one frame (a no-op without a [`StageTimes`]).
pub(crate) struct Clock<'a> {
    times: Option<&'a mut StageTimes>,
    last: Option<Instant>,
}

impl<'a> Clock<'a> {
    pub fn new(times: Option<&'a mut StageTimes>) -> Self {
        let last = times.is_some().then(Instant::now);
        Clock { times, last }
    }

    /// Adds the time since the last charge to the stage `pick` selects.
    pub fn charge(&mut self, pick: fn(&mut StageTimes) -> &mut Duration) {
        if let (Some(t), Some(times)) = (self.last.as_mut(), self.times.as_deref_mut()) {
            let now = Instant::now();
            *pick(times) += now - *t;
            *t = now;
        }
    }

    /// Counts pair correlations computed and skipped.
    pub fn count(&mut self, (correlated, skipped): (usize, usize)) {
        if let Some(times) = self.times.as_deref_mut() {
            times.correlated_pairs += correlated as u64;
            times.skipped_pairs += skipped as u64;
        }
    }
}
