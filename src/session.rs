//! One recording through the pipeline: open, check against the geometry, stream frames.

use crate::audio::{Framer, WavFormat, WavStream};
use crate::geometry::Geometry;
use crate::pipeline::{Analyzer, Detection, FrameStats, Params, PRIMING_S};
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

    pub fn analyzer(&self) -> &Analyzer {
        &self.analyzer
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

    /// Streams every frame through the analyzer. `sink` sees each frame's index and its
    /// detection, if any; an error from `sink` (a closed pipe) stops the run. Returns the
    /// summary of what was analysed and the error that stopped the file, if any.
    pub fn run(
        mut self,
        mut sink: impl FnMut(u64, Option<&Detection>) -> Result<()>,
    ) -> (FileSummary, Result<()>) {
        let result = (|| -> Result<()> {
            // Prime the noise estimate with the first frames, then analyse them too.
            let hop_s = self.analyzer.hop() as f64 / self.stream.format.sample_rate as f64;
            let priming = (PRIMING_S / hop_s).ceil() as usize;
            let mut first: Vec<(u64, Vec<f32>)> = Vec::with_capacity(priming);
            while first.len() < priming {
                match self.framer.next_frame(&mut self.stream)? {
                    Some((index, frame)) => first.push((index, frame.to_vec())),
                    None => break,
                }
            }
            for (_, frame) in &first {
                self.analyzer.prime(frame);
            }
            for (index, frame) in &first {
                let det = self.analyzer.process(*index, frame);
                sink(*index, det.as_ref())?;
            }
            drop(first);
            while let Some((index, frame)) = self.framer.next_frame(&mut self.stream)? {
                let det = self.analyzer.process(index, frame);
                sink(index, det.as_ref())?;
            }
            Ok(())
        })();
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
                let mic = &self.analyzer_geometry_channel(m);
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

    fn analyzer_geometry_channel(&self, mic: usize) -> usize {
        self.framer.channel_of(mic)
    }
}

fn too_short(name: &str, frames: u64, n: usize, rate: u32) -> String {
    format!(
        "{name}: the recording is {frames} samples ({:.1} ms) long, shorter than one analysis frame of {n} samples ({:.1} ms); use a smaller --frame-size",
        frames as f64 * 1000.0 / rate as f64,
        n as f64 * 1000.0 / rate as f64
    )
}
