//! One recording through the method: open a source, check it against the geometry, and
//! stream its frames through the method's analyzer, reading the next block while the thread
//! pool analyses the current one.

use crate::geometry::Geometry;
use crate::method::frames::FrameBlock;
use crate::method::{Detection, Engine, Params, ParamsError, Threshold};
use crate::stream::source::{Channels, Framer, SampleSource};
use crate::stream::wpe::{Filtered, Wpe};
use crate::stream::{AudioStream, ClockOrigin, InputError, Summary, Warning};
use std::io::Read;
use std::ops::ControlFlow;
use std::time::{Duration, Instant};

/// Pairs that heard a clear sound needed before their delays are judged against the
/// geometry, and the share of them peaking past its longest delays that draws a warning:
/// on 27 fresh scenes of nine arrays in rooms (benches/uncertainty.py, seed 300) with
/// their right geometry, at most 0.25% did; with the positions 20% too small, 10-18% on
/// the arrays whose delays span tens of samples (smaller arrays cannot show it: `ssl
/// check` can).
const BEYOND_MIN_PAIRS: u64 = 100;
const BEYOND_SHARE: f64 = 0.03;
/// A band whose bins let a perfectly coherent source stand less than this many times the
/// calibrated threshold's chance allowance above chance is called narrow: real sources,
/// with reverberation and noise, are half as coherent or less.
const NARROW_BAND_MARGIN: f64 = 2.0;
/// Below this largest delay (samples), the array's delays are called coarse.
pub(crate) const COARSE_DELAY_SAMPLES: f64 = 10.0;

/// A recording opened for analysis with one geometry and set of parameters.
///
/// Every entry point (a WAV path, WAV bytes from a reader, channels in memory) ends in
/// the same [`Analysis::run`], and gives the same detections for the same samples on any
/// number of threads.
///
/// The analysis runs on the threads of the current rayon pool (choose them with
/// `rayon::ThreadPool::install`); create it in the pool it will run in, since that sizes
/// its per-thread buffers.
pub struct Analysis<S> {
    source: S,
    framer: Framer,
    analyzer: Engine,
    /// The input's dereverberation, with [`Room::wpe`](crate::method::Room::wpe).
    wpe: Option<Wpe>,
}

/// Why a recording could not be analysed (or not to its end): the file's name and what
/// went wrong.
#[derive(Debug, thiserror::Error)]
#[error("{file}: {kind}")]
pub struct AnalysisError {
    /// The input's name (path, `<stdin>`, or the caller's).
    pub file: String,
    /// What went wrong.
    pub kind: ErrorKind,
}

/// What went wrong with a recording.
#[derive(Debug, thiserror::Error)]
pub enum ErrorKind {
    /// The samples could not be read.
    #[error(transparent)]
    Input(#[from] InputError),
    /// The parameters do not suit the array at this sample rate.
    #[error(transparent)]
    Params(#[from] ParamsError),
    /// `--start` and `--end` leave less than one frame of the recording.
    #[error("--start {start_s} s{} leaves {:.1} ms of this {:.3} s recording, less than one analysis frame of {frame_size} samples", end_s.map_or(String::new(), |e| format!(" and --end {e} s")), *samples as f64 * 1000.0 / *sample_rate as f64, *total as f64 / *sample_rate as f64)]
    SpanTooShort {
        /// The start asked for (seconds).
        start_s: f64,
        /// The end asked for (seconds).
        end_s: Option<f64>,
        /// Sample frames in the span.
        samples: u64,
        /// Sample frames in the recording.
        total: u64,
        /// The frame size N.
        frame_size: usize,
        /// The sample rate (Hz).
        sample_rate: u32,
    },
    /// Without `channel` keys, the recording must have one channel per microphone.
    #[error("the file has {channels} channel(s) but the geometry has {mics} microphones; {}", if channels > mics { "add a `channel = N` key to each [[mic]] to say which channels to use" } else { "is this the right geometry for this recording?" })]
    ChannelCount {
        /// Channels in the recording.
        channels: usize,
        /// Microphones in the geometry.
        mics: usize,
    },
    /// A `channel` key names a channel the recording does not have.
    #[error("the geometry assigns channel {channel} but the file has {channels} channel(s) (0 to {})", channels - 1)]
    MissingChannel {
        /// The channel asked for.
        channel: usize,
        /// Channels in the recording.
        channels: usize,
    },
    /// `--clock` asks for wall-clock times the recording does not give.
    #[error("--clock needs the recording's start time, and {0}")]
    NoClock(String),
    /// The recording holds no complete frame.
    #[error("the recording is {samples} samples ({:.1} ms) long, shorter than one analysis frame of {frame_size} samples ({:.1} ms)", *samples as f64 * 1000.0 / *sample_rate as f64, *frame_size as f64 * 1000.0 / *sample_rate as f64)]
    TooShort {
        /// Sample frames in the recording.
        samples: u64,
        /// The frame size N.
        frame_size: usize,
        /// Sample rate (Hz).
        sample_rate: u32,
    },
}

impl Analysis<AudioStream> {
    /// Opens the WAV or FLAC file at `path` (`-` for standard input) and checks it
    /// against `geometry`.
    pub fn open(path: &str, geometry: &Geometry, params: &Params) -> Result<Self, AnalysisError> {
        let name = if path == "-" { "<stdin>" } else { path };
        let stream = AudioStream::open(path).map_err(|e| fail(name, e.into()))?;
        Self::new(stream, geometry, params)
    }

    /// Reads the open file `file`, named `name` in messages and rows.
    pub fn open_file(
        name: &str,
        file: std::fs::File,
        geometry: &Geometry,
        params: &Params,
    ) -> Result<Self, AnalysisError> {
        let stream = AudioStream::from_file(name, file).map_err(|e| fail(name, e.into()))?;
        Self::new(stream, geometry, params)
    }

    /// Reads WAV or FLAC bytes from `reader` (a pipe, a socket, a buffer), named `name`
    /// in messages.
    pub fn from_reader(
        name: &str,
        reader: impl Read + 'static,
        geometry: &Geometry,
        params: &Params,
    ) -> Result<Self, AnalysisError> {
        let stream = AudioStream::from_reader(name, Box::new(reader), None)
            .map_err(|e| fail(name, e.into()))?;
        Self::new(stream, geometry, params)
    }
}

impl<'a> Analysis<Channels<'a>> {
    /// Channels already in memory (`channels[c]` is channel `c`, all of one length).
    pub fn from_channels(
        name: &str,
        channels: Vec<&'a [f32]>,
        sample_rate: u32,
        geometry: &Geometry,
        params: &Params,
    ) -> Result<Self, AnalysisError> {
        let source =
            Channels::new(name, channels, sample_rate).map_err(|e| fail(name, e.into()))?;
        Self::new(source, geometry, params)
    }
}

impl<S: SampleSource> Analysis<S> {
    /// Checks `source` against `geometry` and plans the method for its sample rate.
    pub fn new(source: S, geometry: &Geometry, params: &Params) -> Result<Self, AnalysisError> {
        let name = source.name().to_string();
        let (channels, mics) = (source.channels(), geometry.mics.len());
        if geometry.explicit_channels {
            if let Some(m) = geometry.mics.iter().find(|m| m.channel >= channels) {
                let channel = m.channel;
                return Err(fail(&name, ErrorKind::MissingChannel { channel, channels }));
            }
        } else if channels != mics {
            return Err(fail(&name, ErrorKind::ChannelCount { channels, mics }));
        }
        let sample_rate = source.sample_rate();
        let analyzer =
            Engine::new(geometry, sample_rate, params).map_err(|e| fail(&name, e.into()))?;
        if params.room.wpe {
            let bytes = crate::stream::wpe::filter_bytes(geometry.mics.len(), sample_rate);
            if bytes > crate::stream::wpe::MAX_BYTES {
                let e = crate::method::ParamsError::WpeTooLarge {
                    mics: geometry.mics.len(),
                    sample_rate,
                    mb: bytes / 1048576.0,
                    max_mb: (crate::stream::wpe::MAX_BYTES / 1048576.0) as usize,
                };
                return Err(fail(&name, ErrorKind::Params(e)));
            }
        }
        let n = analyzer.frame_size();
        // `--start` and `--end`: the first frame and the sample frames read from it.
        let hop = analyzer.hop() as u64;
        let first = (params.framing.start_s * sample_rate as f64 / hop as f64).floor() as u64;
        let limit = params
            .framing
            .end_s
            .map(|e| ((e * sample_rate as f64).round() as u64).saturating_sub(first * hop));
        let span = |total: u64| {
            let after = total.saturating_sub(first * hop);
            limit.map_or(after, |l| after.min(l))
        };
        let spanned = params.framing.start_s > 0.0 || params.framing.end_s.is_some();
        if let Some(total) = source.frames().filter(|&f| spanned && span(f) < n as u64) {
            let kind = ErrorKind::SpanTooShort {
                start_s: params.framing.start_s,
                end_s: params.framing.end_s,
                samples: span(total),
                total,
                frame_size: n,
                sample_rate,
            };
            return Err(fail(&name, kind));
        }
        if let Some(samples) = source.frames().map(span).filter(|&f| f < n as u64) {
            let kind = ErrorKind::TooShort {
                samples,
                frame_size: n,
                sample_rate,
            };
            return Err(fail(&name, kind));
        }
        let framer = Framer::new(
            n,
            geometry.mics.iter().map(|m| m.channel).collect(),
            channels,
            analyzer.priming_frames(),
        )
        .span(first, limit);
        let wpe = params.room.wpe.then(|| {
            let mics = geometry.mics.iter().map(|m| m.channel).collect();
            Wpe::new(channels, mics, sample_rate)
        });
        Ok(Analysis {
            source,
            framer,
            analyzer,
            wpe,
        })
    }

    /// The input's name.
    pub fn name(&self) -> &str {
        self.source.name()
    }

    /// The frame size N.
    pub fn frame_size(&self) -> usize {
        self.analyzer.frame_size()
    }

    /// The recording's sample rate (Hz).
    pub fn sample_rate(&self) -> u32 {
        self.source.sample_rate()
    }

    /// When the first sample was recorded, on the recorder's clock, or why that is not
    /// known (a Broadcast WAV `bext` chunk's dated time reference; `--clock`).
    pub fn clock_origin(&self) -> Result<ClockOrigin, AnalysisError> {
        let rate = self.source.sample_rate();
        let why = match (self.source.clock_origin(), self.source.time_reference()) {
            (Some(origin), _) => return Ok(origin),
            (None, Some(r)) if !r.within_a_year(rate) => {
                let why = format!(
                    "its bext chunk's time reference ({} samples, {:.0} days at {rate} Hz) is not a time: it counts samples from its date's midnight, and this is more than a year",
                    r.samples,
                    r.samples as f64 / rate.max(1) as f64 / 86_400.0
                );
                return Err(fail(self.name(), ErrorKind::NoClock(why)));
            }
            (None, Some(_)) => "its bext chunk's origination date is not a date (yyyy-mm-dd)",
            (None, None) => "it has no Broadcast WAV bext chunk before its data (one is written by field recorders and by `bwfmetaedit --Timereference`)",
        };
        Err(fail(self.name(), ErrorKind::NoClock(why.into())))
    }

    /// The recording's length in seconds, when known in advance.
    pub fn duration_s(&self) -> Option<f64> {
        self.source
            .frames()
            .map(|f| f as f64 / self.source.sample_rate() as f64)
    }

    /// Measures the time spent in each stage (reported in the summary).
    pub fn enable_stage_timing(&mut self) {
        self.analyzer.enable_stage_timing();
    }

    /// Frames the recording will give, when its length is known.
    pub fn total_frames(&self) -> Option<u64> {
        let n = self.analyzer.frame_size() as u64;
        let hop = self.analyzer.hop() as u64;
        self.source
            .frames()
            .map(|f| self.framer.spanned(f))
            .map(|f| if f < n { 0 } else { (f - n) / hop + 1 })
    }

    /// Streams every frame through the method. `sink` sees each frame's index and its
    /// detections (none, one, or with [`Talkers::max_sources`](crate::method::Talkers::max_sources)
    /// over 1 several, strongest first), in frame order; [`ControlFlow::Break`] stops the run (a closed
    /// output). Returns the summary of what was analysed and the error that stopped the
    /// recording, if any (the frames before a read error are analysed first).
    pub fn run(
        mut self,
        mut sink: impl FnMut(u64, &[Detection]) -> ControlFlow<()>,
    ) -> (Summary, Result<(), AnalysisError>) {
        let result = self.run_blocks(&mut sink);
        let summary = self.summary();
        let result = match result {
            Ok(()) if summary.stats.frames == 0 => Err(ErrorKind::TooShort {
                samples: self.framer.samples_read,
                frame_size: summary.frame_size,
                sample_rate: summary.sample_rate,
            }),
            Ok(()) => Ok(()),
            Err(e) => Err(e.into()),
        };
        (
            summary,
            result.map_err(|kind| fail(self.source.name(), kind)),
        )
    }

    fn run_blocks(
        &mut self,
        sink: &mut dyn FnMut(u64, &[Detection]) -> ControlFlow<()>,
    ) -> Result<(), InputError> {
        let mut read = Duration::ZERO;
        let result = self.read_and_analyse(sink, &mut read);
        self.analyzer.add_time(|t| &mut t.read, read);
        result
    }

    /// [`Analysis::run_blocks`], adding the time spent reading to `read` when stage
    /// timing is on.
    fn read_and_analyse(
        &mut self,
        sink: &mut dyn FnMut(u64, &[Detection]) -> ControlFlow<()>,
        read: &mut Duration,
    ) -> Result<(), InputError> {
        let mut current = self.analyzer.block();
        let mut next = self.analyzer.block();
        let live = self.source.is_live();
        let timing = self.analyzer.stage_times().is_some();
        let (framer, source, wpe) = (&mut self.framer, &mut self.source, &mut self.wpe);
        // Through the dereverberation, when on.
        let mut fill = |framer: &mut Framer, block: &mut FrameBlock| {
            let clock = timing.then(Instant::now);
            let result = match wpe.as_mut() {
                Some(filter) => {
                    let source = &mut *source;
                    framer.fill(&mut Filtered { filter, source }, block)
                }
                None => framer.fill(&mut *source, block),
            };
            *read += clock.map_or(Duration::ZERO, |c| c.elapsed());
            result
        };
        let mut error = fill(framer, &mut current);
        while current.count > 0 {
            let mut next_error = None;
            // A live source is read after the frames at hand are handed on: reading ahead
            // would hold them until more audio arrives.
            let (first, detections) = self.analyzer.analyse(&current, || {
                if !live {
                    next_error = fill(framer, &mut next);
                }
            });
            for (detection, index) in detections.iter().zip(first..) {
                if sink(index, detection.as_slice()).is_break() {
                    return Ok(());
                }
            }
            // A read error (a truncated file) ends the run after the frames read before it.
            if error.is_some() {
                break;
            }
            if live {
                next_error = fill(framer, &mut next);
            }
            error = next_error;
            std::mem::swap(&mut current, &mut next);
        }
        // The last frames, which waited for frames after them.
        let (first, detections) = self.analyzer.finish();
        for (detection, index) in detections.iter().zip(first..) {
            if sink(index, detection.as_slice()).is_break() {
                return Ok(());
            }
        }
        error.map_or(Ok(()), Err)
    }

    fn summary(&self) -> Summary {
        let stats = self.analyzer.stats().clone();
        let mut warnings: Vec<Warning> = self
            .source
            .notes()
            .into_iter()
            .map(Warning::Input)
            .collect();
        if stats.frames > 0 && stats.silent_frames == stats.frames {
            warnings.push(Warning::Silence);
        }
        for (mic, &frames) in stats.dead_frames.iter().enumerate() {
            if frames > 0 {
                warnings.push(Warning::DeadMic {
                    mic,
                    channel: self.framer.channel_of(mic),
                    frames,
                    of: stats.frames,
                });
            }
        }
        let largest = self.analyzer.largest_delay_samples();
        if largest < COARSE_DELAY_SAMPLES {
            warnings.push(Warning::CoarseDelays {
                samples: largest,
                sample_rate: self.source.sample_rate(),
            });
        }
        let params = self.analyzer.params();
        let bins = self.analyzer.band_bins();
        let sigmas = match params.threshold {
            Threshold::Calibrated { sigmas } => {
                Some(sigmas).filter(|_| params.weighting.band_hz.is_some())
            }
            Threshold::Fixed { .. } => None,
        };
        if let Some(sigmas) = sigmas.filter(|z| (2.0 * bins as f64).sqrt() < NARROW_BAND_MARGIN * z)
        {
            warnings.push(Warning::NarrowBand {
                bins,
                sigmas,
                frame_size: self.frame_size(),
                sample_rate: self.source.sample_rate(),
            });
        }
        if stats.frames >= 10
            && stats.silent_frames < stats.frames
            && stats.detections * 100 < stats.frames
        {
            warnings.push(Warning::FewDetections {
                detections: stats.detections,
                frames: stats.frames,
                best_per_pair: stats.best_score_per_pair,
                bound_per_pair: stats.best_bound_per_pair,
                threshold_per_pair: match params.threshold {
                    Threshold::Fixed { per_pair } => Some(per_pair),
                    Threshold::Calibrated { .. } => None,
                },
                steady: params.weighting.on
                    && stats.power_range.is_some_and(|(lo, hi)| hi <= 4.0 * lo),
            });
        }
        if stats.strong_pairs >= BEYOND_MIN_PAIRS
            && stats.edge_pairs as f64 >= BEYOND_SHARE * stats.strong_pairs as f64
        {
            warnings.push(Warning::BeyondGeometry {
                pairs: stats.strong_pairs,
                beyond: stats.edge_pairs,
            });
        }
        if stats.budget_frames > 0 {
            warnings.push(Warning::SearchBudget {
                frames: stats.budget_frames,
            });
        }
        Summary {
            name: self.source.name().to_string(),
            format: self.source.describe(),
            channels: self.source.channels(),
            sample_rate: self.source.sample_rate(),
            frame_size: self.analyzer.frame_size(),
            stage_times: self.analyzer.stage_times().cloned(),
            stats,
            warnings,
        }
    }
}

fn fail(name: &str, kind: ErrorKind) -> AnalysisError {
    AnalysisError {
        file: name.to_string(),
        kind,
    }
}
