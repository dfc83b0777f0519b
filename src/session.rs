//! One recording through the pipeline: open, check against the geometry, stream frames.

use crate::audio::{FrameBlock, Framer, WavFormat, WavStream};
use crate::geometry::Geometry;
use crate::pipeline::{
    Analyzer, Detection, FrameState, FrameStats, Outcome, Params, Sequential, Setup, StageTimes,
    Worker, PRIMING_S,
};
use rayon::prelude::*;
use std::sync::Mutex;
use std::time::Instant;

/// Frames analysed together on the thread pool. Memory is bounded by two blocks of audio
/// (16 KB a frame for 8 microphones at N = 1024, as frames share their samples) and one of
/// spectra (33 KB a frame).
pub const BLOCK: usize = 128;
use anyhow::{bail, Result};

/// A recording opened for analysis with one geometry and set of parameters.
pub struct FileAnalysis {
    stream: WavStream,
    framer: Framer,
    analyzer: Analyzer,
}

/// What a finished (or failed) file reports.
#[derive(Debug, Clone)]
pub struct FileSummary {
    pub name: String,
    pub format: WavFormat,
    pub frame_size: usize,
    pub stats: FrameStats,
    /// Time per stage, when stage timing was enabled.
    pub stage_times: Option<crate::pipeline::StageTimes>,
    /// Remarks for the user (dead channels, silence, search budget).
    pub warnings: Vec<String>,
}

impl FileAnalysis {
    /// Opens `path` (`-` for stdin) and checks it against `geometry`.
    pub fn open(path: &str, geometry: &Geometry, params: &Params) -> Result<Self> {
        let stream = WavStream::open(path)?;
        let name = stream.name().to_string();
        let fmt = stream.format.clone();
        let mics = geometry.mics.len();
        if geometry.explicit_channels {
            if let Some(m) = geometry.mics.iter().find(|m| m.channel >= fmt.channels) {
                bail!(
                    "{name}: the geometry assigns channel {} but the file has {} channel(s) (0 to {})",
                    m.channel,
                    fmt.channels,
                    fmt.channels - 1
                );
            }
        } else if fmt.channels != mics {
            bail!(
                "{name}: the file has {} channel(s) but the geometry has {mics} microphones; {}",
                fmt.channels,
                if fmt.channels > mics {
                    "add a `channel = N` key to each [[mic]] to say which channels to use"
                } else {
                    "is this the right geometry for this recording?"
                }
            );
        }
        let analyzer = Analyzer::new(geometry, fmt.sample_rate, params)
            .map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
        let n = analyzer.frame_size();
        if let Some(frames) = fmt.frames {
            if frames < n as u64 {
                bail!("{}", too_short(&name, frames, n, fmt.sample_rate));
            }
        }
        let channels = geometry.mics.iter().map(|m| m.channel).collect();
        let framer = Framer::new(n, channels, fmt.channels);
        Ok(FileAnalysis {
            stream,
            framer,
            analyzer,
        })
    }

    pub fn name(&self) -> &str {
        self.stream.name()
    }

    pub fn format(&self) -> &WavFormat {
        &self.stream.format
    }

    /// Measures the time spent in each stage (reported in the summary).
    pub fn enable_stage_timing(&mut self) {
        self.analyzer.enable_stage_timing();
    }

    /// Frames the file will give, when its length is known.
    pub fn total_frames(&self) -> Option<u64> {
        let n = self.analyzer.frame_size() as u64;
        let hop = self.analyzer.hop() as u64;
        self.stream
            .format
            .frames
            .map(|f| if f < n { 0 } else { (f - n) / hop + 1 })
    }

    /// Streams every frame through the method. `sink` sees each frame's index and its
    /// detection, if any, in frame order; an error from `sink` (a closed pipe) stops the
    /// run. Returns the summary of what was analysed and the error that stopped the file,
    /// if any.
    ///
    /// Frames are analysed in blocks of [`BLOCK`] on the threads of the current rayon
    /// pool: spectra in parallel, the noise estimate and weights in frame order (exactly
    /// as one thread would), correlations, search and direction in parallel, then the
    /// results in order. The output is the same for any number of threads. Stage times,
    /// when enabled, add up the threads' time in stage 3 and the wall time of stages 1
    /// and 2 (run on one thread to compare stages).
    pub fn run(
        mut self,
        mut sink: impl FnMut(u64, Option<&Detection>) -> Result<()>,
    ) -> (FileSummary, Result<()>) {
        let result = self.run_blocks(&mut sink);
        let summary = self.summary();
        let result = match result {
            Ok(()) if summary.stats.frames == 0 => Err(anyhow::anyhow!(too_short(
                &summary.name,
                self.stream.frames_read(),
                summary.frame_size,
                summary.format.sample_rate,
            ))),
            other => other,
        };
        (summary, result)
    }

    /// Frames primed at the start of a file.
    fn priming_frames(&self) -> usize {
        let hop_s = self.analyzer.hop() as f64 / self.stream.format.sample_rate as f64;
        ((PRIMING_S / hop_s).ceil() as usize).min(BLOCK)
    }

    fn run_blocks(
        &mut self,
        sink: &mut dyn FnMut(u64, Option<&Detection>) -> Result<()>,
    ) -> Result<()> {
        let mut priming = self.priming_frames();
        let (setup, sequential, mut times) = self.analyzer.parts();
        let workers: Vec<Mutex<(Worker, StageTimes)>> = (0..rayon::current_num_threads())
            .map(|_| Mutex::new((Worker::new(setup), StageTimes::default())))
            .collect();
        let (n, mics) = (setup.frame_size(), setup.geometry_mics());
        let mut current = FrameBlock::new(n, mics, BLOCK);
        let mut next = FrameBlock::new(n, mics, BLOCK);
        let mut states: Vec<FrameState> = (0..BLOCK).map(|_| FrameState::new(setup)).collect();
        let mut outcomes = vec![Outcome::Silent; BLOCK];
        let (framer, stream) = (&mut self.framer, &mut self.stream);
        framer.fill(stream, &mut current);
        // With more than one thread, the next block is read and decoded on this thread
        // while the pool analyses the current one.
        let read_ahead = rayon::current_num_threads() > 1;
        loop {
            if current.count == 0 {
                return current.error.take().map_or(Ok(()), Err);
            }
            let mut analyse = || {
                analyse_block(
                    setup,
                    &workers,
                    sequential,
                    times.as_deref_mut(),
                    std::mem::take(&mut priming),
                    &current,
                    &mut states,
                    &mut outcomes,
                )
            };
            if read_ahead {
                rayon::in_place_scope(|scope| {
                    scope.spawn(|_| analyse());
                    framer.fill(stream, &mut next);
                });
            } else {
                analyse();
                framer.fill(stream, &mut next);
            }
            for (&outcome, index) in outcomes[..current.count].iter().zip(current.first..) {
                let det = sequential.tally(outcome);
                sink(index, det.as_ref())?;
            }
            // A read error (a truncated file) ends the run after the frames read before it.
            if let Some(e) = current.error.take() {
                return Err(e);
            }
            std::mem::swap(&mut current, &mut next);
        }
    }

    fn summary(&self) -> FileSummary {
        let stats = self.analyzer.stats().clone();
        let name = self.stream.name().to_string();
        let mut warnings = Vec::new();
        if stats.frames > 0 && stats.silent_frames == stats.frames {
            warnings.push(format!(
                "{name}: every channel is constant (digital silence): no detections"
            ));
        }
        for (m, &dead) in stats.dead_frames.iter().enumerate() {
            if dead > 0 {
                let mic = self.framer.channel_of(m);
                warnings.push(format!(
                    "{name}: mic {} (channel {mic}) is constant (dead or disconnected?) in {dead} of {} frames; it was left out of those frames' pairs",
                    m + 1,
                    stats.frames
                ));
            }
        }
        if stats.budget_frames > 0 {
            warnings.push(format!(
                "{name}: the consistency search hit its node budget in {} frames (best set found so far used); a smaller --tolerance or fewer --peaks avoids this",
                stats.budget_frames
            ));
        }
        FileSummary {
            name,
            format: self.stream.format.clone(),
            frame_size: self.analyzer.frame_size(),
            stage_times: self
                .analyzer
                .timing_enabled()
                .then(|| self.analyzer.stage_times().clone()),
            stats,
            warnings,
        }
    }
}

/// The method over one block: spectra in parallel, the noise estimate in frame order
/// (after priming it with the first `priming` frames), then correlations, peaks, search
/// and direction in parallel, into `outcomes`.
#[allow(clippy::too_many_arguments)]
fn analyse_block(
    setup: &Setup,
    workers: &[Mutex<(Worker, StageTimes)>],
    sequential: &mut Sequential,
    mut times: Option<&mut StageTimes>,
    priming: usize,
    block: &FrameBlock,
    states: &mut [FrameState],
    outcomes: &mut [Outcome],
) {
    let worker = || {
        let i = rayon::current_thread_index().unwrap_or(0) % workers.len();
        workers[i].lock().expect("a worker panicked")
    };
    let count = block.count;
    let mut live = [false; BLOCK];
    // Stage 1: spectra, in parallel.
    let clock = Instant::now();
    states[..count]
        .par_iter_mut()
        .zip(live[..count].par_iter_mut())
        .enumerate()
        .for_each(|(i, (state, live))| {
            *live = worker().0.spectra(setup, block.frame(i), state);
        });
    let stage1 = clock.elapsed();
    // Stage 2: the noise estimate, in frame order.
    for i in 0..priming.min(count) {
        sequential.prime(&states[i], live[i]);
    }
    for i in 0..count {
        live[i] = sequential.weigh(setup, &mut states[i], live[i]);
    }
    if let Some(times) = times.as_deref_mut() {
        times.spectra += stage1;
        times.weighting += clock.elapsed() - stage1;
    }
    // Stage 3: correlations, peaks, search, direction, in parallel.
    let timing = times.is_some();
    outcomes[..count]
        .par_iter_mut()
        .zip(states[..count].par_iter())
        .zip(live[..count].par_iter())
        .enumerate()
        .for_each(|(i, ((outcome, state), &live))| {
            let index = block.first + i as u64;
            *outcome = if live {
                let mut guard = worker();
                let (worker, stage_times) = &mut *guard;
                worker.localize(setup, state, index, timing.then_some(stage_times))
            } else {
                Outcome::Silent
            };
        });
    if let Some(times) = times {
        for w in workers {
            times.add(&std::mem::take(&mut w.lock().expect("a worker panicked").1));
        }
    }
}

fn too_short(name: &str, frames: u64, n: usize, rate: u32) -> String {
    format!(
        "{name}: the recording is {frames} samples ({:.1} ms) long, shorter than one analysis frame of {n} samples ({:.1} ms); use a smaller --frame-size",
        frames as f64 * 1000.0 / rate as f64,
        n as f64 * 1000.0 / rate as f64
    )
}
