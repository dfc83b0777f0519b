//! The whole path `ssl analyze` runs, as one type: [`Localizer`].
//!
//! A localizer holds an array and its [`Settings`]; each recording it opens (a WAV file,
//! WAV bytes from any reader, channels in memory, or any [`SampleSource`]) streams
//! through the method ([`Analysis`]), then the tracker and its smoother, and comes out
//! as the rows and events `ssl analyze` writes, in order, with the frames' times
//! (docs/interface.md, "Frames and time"). The command line, the benchmarks and the
//! tests all go through it.
//!
//! ```
//! use ssl::localize::{Localizer, Output};
//! use ssl::Config;
//! use ssl::Geometry;
//!
//! let geometry = Geometry::from_file("testdata/prism.toml".as_ref())?;
//! let localizer = Localizer::new(geometry, &Config::default())?;
//! let mut rows = Vec::new();
//! let (report, result) = localizer.open("testdata/example.wav")?.run(|out| {
//!     if let Output::Row(row) = out {
//!         rows.push(row);
//!     }
//!     Ok(())
//! });
//! result?;
//! // The example's first source is at azimuth 30, elevation 10, tracked as source 1.
//! assert!((rows[0].azimuth_deg - 30.0).abs() < 1.0 && rows[0].source == Some(1));
//! assert_eq!(report.tracking.map(|t| t.rows as usize), Some(rows.len()));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod analysis;

pub use analysis::{Analysis, AnalysisError, ErrorKind};

use crate::config::{Config, Settings, SettingsError};
use crate::geometry::Geometry;
use crate::method::{Detection, Params};
use crate::record::{
    DetectionRecord, EventRecord, OutputError, RunMetadata, SourceRecord, Sources,
};
use crate::stream::{AudioStream, Channels, ClockOrigin, SampleSource, Summary};
use crate::track::{TrackParams, TrackStats, Tracker};
use std::io::Read;
use std::ops::ControlFlow;
use std::time::{Duration, Instant};

/// An array and what to run on it: opens recordings and runs each through the method,
/// the tracker and the smoother, as `ssl analyze` does.
#[derive(Debug, Clone)]
pub struct Localizer {
    geometry: Geometry,
    /// The configuration, resolved (`None`: settings tuned beyond it).
    config: Option<Config>,
    settings: Settings,
    /// Rows and events carry wall-clock times (`--clock`).
    clock: bool,
}

impl Localizer {
    /// A localizer of `geometry` with `config` (resolved and checked once, here).
    pub fn new(geometry: Geometry, config: &Config) -> Result<Self, SettingsError> {
        let mut localizer =
            Self::with_settings(geometry, config.settings()?)?.with_clock(config.clock);
        localizer.config = Some(config.resolved());
        Ok(localizer)
    }

    /// The same, with rows and events carrying wall-clock times from each recording's
    /// Broadcast WAV time reference (`--clock`): a recording without one is an error.
    pub fn with_clock(mut self, clock: bool) -> Self {
        self.clock = clock;
        if let Some(c) = &mut self.config {
            c.clock = clock;
        }
        self
    }

    /// A localizer of `geometry` with settings already resolved (for tuning what
    /// [`Config`] does not reach), checked again: their fields may have changed since
    /// [`Settings::new`]. Its results' metadata records no configuration.
    pub fn with_settings(geometry: Geometry, settings: Settings) -> Result<Self, SettingsError> {
        let settings = Settings::new(settings.method, settings.track)?;
        Ok(Localizer {
            geometry,
            config: None,
            settings,
            clock: false,
        })
    }

    /// The array.
    pub fn geometry(&self) -> &Geometry {
        &self.geometry
    }

    /// The method's parameters.
    pub fn params(&self) -> &Params {
        &self.settings.method
    }

    /// The tracker's parameters, or `None` for every frame's detection.
    pub fn tracking(&self) -> Option<&TrackParams> {
        self.settings.track.as_ref()
    }

    /// The configuration, resolved ([`Config::resolved`]), or `None` for settings tuned
    /// beyond it ([`Localizer::with_settings`]).
    pub fn config(&self) -> Option<&Config> {
        self.config.as_ref()
    }

    /// The JSON document's metadata of a run, the geometry read from `geometry_file`:
    /// the configuration resolved, with the speed of sound used.
    pub fn metadata(&self, geometry_file: &str) -> RunMetadata {
        let config = self.config.clone().map(|mut c| {
            c.speed_of_sound.get_or_insert(self.geometry.speed_of_sound);
            c
        });
        RunMetadata::new(&self.geometry, geometry_file, config, self.clock)
    }

    /// Opens the WAV or FLAC file at `path` (`-` for standard input).
    pub fn open(&self, path: &str) -> Result<Recording<'_, AudioStream>, AnalysisError> {
        self.recording(Analysis::open(path, &self.geometry, &self.settings.method)?)
    }

    /// Reads the open WAV or FLAC file `file`, named `name` in messages and rows (what
    /// was opened is what is read, whatever happens to the path meanwhile).
    pub fn open_file(
        &self,
        name: &str,
        file: std::fs::File,
    ) -> Result<Recording<'_, AudioStream>, AnalysisError> {
        self.recording(Analysis::open_file(
            name,
            file,
            &self.geometry,
            &self.settings.method,
        )?)
    }

    /// Reads WAV or FLAC bytes from `reader`, named `name` in messages and rows.
    pub fn from_reader(
        &self,
        name: &str,
        reader: impl Read + 'static,
    ) -> Result<Recording<'_, AudioStream>, AnalysisError> {
        let analysis = Analysis::from_reader(name, reader, &self.geometry, &self.settings.method);
        self.recording(analysis?)
    }

    /// Channels already in memory (`channels[c]` is channel `c`, all of one length).
    pub fn from_channels<'a>(
        &'a self,
        name: &str,
        channels: Vec<&'a [f32]>,
        sample_rate: u32,
    ) -> Result<Recording<'a, Channels<'a>>, AnalysisError> {
        let params = &self.settings.method;
        let analysis = Analysis::from_channels(name, channels, sample_rate, &self.geometry, params);
        self.recording(analysis?)
    }

    /// Any source of samples.
    pub fn from_source<S: SampleSource>(
        &self,
        source: S,
    ) -> Result<Recording<'_, S>, AnalysisError> {
        self.recording(Analysis::new(
            source,
            &self.geometry,
            &self.settings.method,
        )?)
    }

    fn recording<S: SampleSource>(
        &self,
        analysis: Analysis<S>,
    ) -> Result<Recording<'_, S>, AnalysisError> {
        let clock = match self.clock {
            true => Some(analysis.clock_origin()?),
            false => None,
        };
        Ok(Recording {
            localizer: self,
            analysis,
            clock,
            timing: false,
        })
    }
}

/// What a recording gives, in order: rows (a detection, with its source when tracked)
/// and, when tracked, events (a source's stretch of activity, given once it has ended).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Output {
    /// A row of `ssl analyze`.
    Row(DetectionRecord),
    /// An event of `ssl analyze --events`.
    Event(EventRecord),
    /// A source of `ssl analyze --sources`: one per track, after the file's last event.
    Source(SourceRecord),
}

/// What a finished (or failed) recording reports.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct RunReport {
    /// The method's summary: format, frames, counters, warnings.
    pub summary: Summary,
    /// What the tracker made of the detections (`None` untracked).
    pub tracking: Option<TrackStats>,
    /// Rows given to the sink.
    pub rows: u64,
}

/// Why a recording's run stopped early.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RunError {
    /// The recording could not be read to its end (the frames before were analysed).
    #[error(transparent)]
    Input(#[from] AnalysisError),
    /// The output refused a record, or a record had a non-finite value.
    #[error(transparent)]
    Output(#[from] OutputError),
}

/// One recording, opened and checked against the array, ready to run.
pub struct Recording<'a, S: SampleSource> {
    localizer: &'a Localizer,
    analysis: Analysis<S>,
    /// When its first sample was recorded, with `--clock`.
    clock: Option<ClockOrigin>,
    /// Whether stage timing is on.
    timing: bool,
}

impl<S: SampleSource> Recording<'_, S> {
    /// The underlying analysis: its name, frame size, rate, length.
    pub fn analysis(&self) -> &Analysis<S> {
        &self.analysis
    }

    /// Measures the time spent in each stage (reported in the summary).
    pub fn enable_stage_timing(&mut self) {
        self.analysis.enable_stage_timing();
        self.timing = true;
    }

    /// Runs the recording: `sink` gets every row and event in order; an error it
    /// returns stops the run.
    pub fn run(
        self,
        sink: impl FnMut(Output) -> Result<(), OutputError>,
    ) -> (RunReport, Result<(), RunError>) {
        self.run_observed(|_| Ok(()), sink)
    }

    /// [`Recording::run`], with `frame` told each frame's index once it is analysed,
    /// before its rows (a progress bar; an output opened on the first frame); an error
    /// it returns stops the run as the sink's do.
    pub fn run_observed(
        self,
        mut frame: impl FnMut(u64) -> Result<(), OutputError>,
        mut sink: impl FnMut(Output) -> Result<(), OutputError>,
    ) -> (RunReport, Result<(), RunError>) {
        let settings = &self.localizer.settings;
        let geometry = &self.localizer.geometry;
        let name = self.analysis.name().to_string();
        let rate = self.analysis.sample_rate() as f64;
        let clock = self.clock;
        let speed = settings
            .method
            .speed_of_sound
            .unwrap_or(geometry.speed_of_sound);
        // Frame i's centre is at (i + 1) hops (docs/interface.md, "Frames and time").
        let hop = self.analysis.frame_size() as f64 / 2.0 / rate;
        let method = &settings.method;
        let mut tracker = (settings.track.clone()).map(|p| {
            Tracker::for_array(p, geometry, rate, speed).with_evidence_window(
                hop * method.room.average_frames as f64,
                method.talkers.candidate_share(),
                method.talkers.accumulated_share(),
                method.room.background_tau_s().map_or(0.0, |_| {
                    hop * crate::method::beyond::background::WARMUP_FRAMES as f64
                }),
            )
        });
        let mut failure = None;
        // The tracks' events, summed per track for the sources.
        let sources = std::cell::RefCell::new(Sources::default());
        let rows = std::cell::Cell::new(0u64);
        let mut sink = |mut out: Output| {
            match &out {
                Output::Event(e) => sources.borrow_mut().add(e),
                Output::Row(_) => rows.set(rows.get() + 1),
                Output::Source(_) => {}
            }
            if let Some(origin) = &clock {
                match &mut out {
                    Output::Row(r) => r.clock = Some(origin.at(r.time_s)),
                    Output::Event(e) => {
                        e.start_clock = Some(origin.at(e.start_s));
                        e.end_clock = Some(origin.at(e.end_s));
                    }
                    Output::Source(_) => {}
                }
            }
            sink(out)
        };
        // Time in the tracker, and in the output (with stage timing).
        let (mut tracking, mut output) = (Duration::ZERO, Duration::ZERO);
        let lap = |total: &mut Duration, since: Option<Instant>| {
            since.map(|t| {
                let now = Instant::now();
                *total += now - t;
                now
            })
        };
        let timing = self.timing;
        let (mut summary, result) = self.analysis.run(|index, detections| {
            let start = timing.then(Instant::now);
            if let Some(t) = tracker.as_mut() {
                t.push((index as f64 + 1.0) * hop, detections);
            }
            let tracked = lap(&mut tracking, start);
            let emitted =
                frame(index).and_then(|()| emit(&name, tracker.as_mut(), detections, &mut sink));
            lap(&mut output, tracked);
            match emitted {
                Ok(()) => ControlFlow::Continue(()),
                Err(e) => {
                    failure = Some(e);
                    ControlFlow::Break(())
                }
            }
        });
        if let Some(t) = tracker.as_mut() {
            let start = timing.then(Instant::now);
            t.finish();
            lap(&mut tracking, start);
            if failure.is_none() && summary.stats.frames > 0 {
                failure = emit(&name, Some(t), &[], &mut sink).err();
            }
            // Each track over the whole file, from its events.
            if failure.is_none() {
                failure = sources
                    .borrow()
                    .records(&name)
                    .and_then(|all| all.into_iter().try_for_each(|s| sink(Output::Source(s))))
                    .err();
            }
        }
        if let Some(times) = summary.stage_times.as_mut() {
            times.tracking += tracking;
            times.output += output;
        }
        let report = RunReport {
            summary,
            tracking: tracker.as_ref().map(Tracker::stats),
            rows: rows.get(),
        };
        let result = match failure {
            Some(e) => Err(RunError::Output(e)),
            None => result.map_err(RunError::Input),
        };
        (report, result)
    }
}

/// Gives `sink` what the tracker has given out (or, without one, `detections`).
fn emit(
    name: &str,
    tracker: Option<&mut Tracker>,
    detections: &[Detection],
    sink: &mut impl FnMut(Output) -> Result<(), OutputError>,
) -> Result<(), OutputError> {
    let Some(tracker) = tracker else {
        for d in detections {
            sink(Output::Row(DetectionRecord::new(name, d)?))?;
        }
        return Ok(());
    };
    for row in tracker.take_rows() {
        sink(Output::Row(DetectionRecord::tracked(
            name,
            &row.detection,
            row.source,
        )?))?;
    }
    for event in tracker.take_events() {
        sink(Output::Event(EventRecord::new(name, &event)?))?;
    }
    Ok(())
}
