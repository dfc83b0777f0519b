//! Dereverberation of the input by multichannel linear prediction (`--wpe`, beyond the
//! paper; off by default).
//!
//! In a reverberant room most frames of a sustained sound hold more of its reverberation
//! than of its direct path, and the method finds nothing above the noise estimate in them
//! (docs/tracking.md, "What was tried": one talker alone, 2 m from the prism at RT60
//! 0.45 s, gave a detection in 85 of its 309 frames; 200 were steady). Weighted
//! prediction error (WPE; Nakatani et al. 2010, online as in Caroselli et al. 2017)
//! predicts the late reverberation of every microphone from the frames before it over
//! all the microphones and subtracts it, leaving the direct path and the early
//! reflections:
//!
//! - **Frames:** about 20 ms ([`frame_size`]), a hop of a quarter frame, periodic Hann
//!   analysis and synthesis windows (whose squares add up to 3/2 at that hop), so the
//!   signal is resynthesised unchanged where nothing is subtracted.
//! - **Prediction:** in every bin below [`MAX_HZ`], the current frame of each microphone
//!   from the frames [`DELAY`] to [`DELAY`]` + `[`TAPS`]` - 1` hops before it, weighted by
//!   the inverse of the frame's power (mean over the microphones of this frame and the
//!   last), by recursive least squares with forgetting factor [`FORGET`].
//! - **Do no harm:** a bin whose prediction would raise the frame's power instead of
//!   lowering it is left as it was: the filter learned on one talker predicts nothing of
//!   the next one's onset (without this, the tracking benchmark's meetings recalled 50-92%
//!   of their turns with up to 49 false events a minute; with it, all of them and none).
//! - **Warm-up:** the filter learns from the first [`WARM_UP_S`] of the input, then
//!   filters from the start again (those seconds are kept in memory), so a steady source
//!   does not change while it learns (see [`WARM_UP_S`]); a live source's first rows
//!   therefore come that much later. From the start, the share of the prediction taken
//!   out rises over [`RAMP_S`], so that the analysis learns a steady source's new sound
//!   as it comes.
//!
//! Measured on twelve two-talker scenes outside the repository (prism, 6 x 5 x 2.8 m,
//! RT60 0.45 s, fan and diffuse noise): 589 of 792 windows with both talkers' rows
//! instead of 535, no false event, the rows' errors unchanged or lower; the bins above
//! 4 kHz left alone because the whole band made a fan near the ceiling a source (296
//! rows). It costs about 15 times the rest of the analysis (docs/method.md, "Performance"), so it
//! is an option.
//!
//! The filter runs on the samples in order, before the framer; each bin is a filter of
//! its own, and the bins share the threads, so the output does not depend on the thread
//! count. Its memory is fixed (a few KB per bin, and the
//! warm-up's seconds). Channels the geometry does not use go through as they are, as
//! does a microphone whose channel stays at one value (a dead microphone stays dead for
//! the analysis), all delayed alike by `frame - hop` samples and given back in step, so
//! no time moves.

mod predictor;

use super::{InputError, SampleSource};
use crate::method::Window;
use predictor::Bin;
use rayon::prelude::*;
use realfft::num_complex::{Complex32, Complex64};
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use std::sync::Arc;

/// Bins up to this frequency (Hz) are dereverberated, the others left alone.
pub const MAX_HZ: f64 = 4000.0;

/// Past frames each prediction reads.
pub const TAPS: usize = 6;

/// Hops between the current frame and the newest frame it is predicted from (2: half a
/// frame, about 10 ms).
pub const DELAY: usize = 2;

/// Forgetting factor of the recursive least squares, per hop (about 0.5 s at 48 kHz).
pub const FORGET: f64 = 0.99;

/// Seconds of the input the filter learns from before it starts, then filters again from
/// the start: while it learns, a steady source's output changes, and the coherent
/// background learned from the first frames no longer fits it (a fan 0.9 m from the
/// prism at 16 kHz made a track in the first 5 s of the field benchmark's near-fan
/// minutes, 28.6 false detections a minute, none with this).
pub const WARM_UP_S: f64 = 2.0;

/// Seconds over which the share of the prediction taken out rises from none to all at
/// the start of the input: the coherent background subtracted from the correlations
/// (the background stage, learned over about 2 s) follows a steady source as it
/// turns from reverberant to direct. At once, a fan on the table 0.9 m from the prism at
/// 16 kHz was reported in the first second of the field benchmark's near-fan minute (9
/// rows; 0 with this, and 0 without `--wpe`).
pub const RAMP_S: f64 = 2.0;

/// The frame size at `rate`: the power of two at or above 20 ms (1024 at 48 kHz, 512 at
/// 16 kHz, 256 at 8 kHz).
pub fn frame_size(rate: u32) -> usize {
    ((0.02 * rate as f64) as usize).next_power_of_two().max(64)
}

/// The most memory the filters may take (bytes): 32 microphones at any rate (51 MB at
/// 48 kHz, 127 MB of process measured; 0.2x real time); 64 at 48 kHz would take 203 MB
/// of filters (391 MB measured, and 20 times slower than real time).
pub const MAX_BYTES: f64 = 128.0 * 1024.0 * 1024.0;

/// The memory the filters of `mics` microphones at `rate` take (bytes): per bin up to
/// [`MAX_HZ`], a predictor whose inverse correlation is (mics x [`TAPS`]) squared
/// complex numbers, with its vectors.
pub fn filter_bytes(mics: usize, rate: u32) -> f64 {
    let n = frame_size(rate);
    let bins = ((MAX_HZ * n as f64 / rate as f64) as usize + 1).min(n / 2 + 1) as f64;
    let l = (mics * TAPS) as f64;
    bins * 16.0 * (l * l + l * mics as f64 + 4.0 * l + (mics * (DELAY + TAPS)) as f64)
}

/// The filter over a stream of interleaved samples.
pub struct Wpe {
    n: usize,
    hop: usize,
    channels: usize,
    /// The channel of each microphone, in the geometry's order.
    mics: Vec<usize>,
    /// Per channel, whether it is a microphone's.
    filtered: Vec<bool>,
    window: Vec<f32>,
    forward: Arc<dyn RealToComplex<f32>>,
    inverse: Arc<dyn ComplexToReal<f32>>,
    /// Per channel, the current frame's n input samples (the newest hop still filling).
    input: Vec<Vec<f32>>,
    /// Per channel, how many of its newest samples are equal (the time before the start
    /// and after the end counts as the first and the last sample).
    constant_run: Vec<usize>,
    /// The last sample frame pushed (repeated after the end).
    last: Vec<f32>,
    /// Per channel, the overlap-add of the frames so far.
    sum: Vec<Vec<f32>>,
    /// Input samples of the newest hop so far.
    fresh: usize,
    /// Output ready to give, interleaved, from `ready_at`.
    ready: Vec<f32>,
    ready_at: usize,
    /// Output samples still to drop at the start (the latency, `n - hop`).
    latency: usize,
    read: u64,
    given: u64,
    ended: bool,
    /// A read error, given once the samples read before it have been.
    error: Option<InputError>,
    /// The first [`WARM_UP_S`] of the input, learned from and then filtered, from
    /// `replay_at`; `None` before the start.
    replay: Option<Vec<f32>>,
    replay_at: usize,
    /// A read error met while warming up, for after the replay.
    pending: Option<InputError>,
    rate: u32,
    bins: Vec<Bin>,
    spectra: Vec<Vec<Complex32>>,
    time: Vec<f32>,
    windowed: Vec<f32>,
    /// Per bin, its frame of every microphone (`bins` rows of `mics`).
    y: Vec<Complex64>,
    chunk: Vec<f32>,
}

impl Wpe {
    /// A filter for `channels` interleaved channels at `rate`, dereverberating the
    /// channels in `mics` (the geometry's, in its order).
    pub fn new(channels: usize, mics: Vec<usize>, rate: u32) -> Self {
        let n = frame_size(rate);
        let hop = n / 4;
        let mut planner = RealFftPlanner::<f32>::new();
        let window = Window::Hann.coefficients(n);
        let bins = ((MAX_HZ * n as f64 / rate as f64) as usize + 1).min(n / 2 + 1);
        let mut filtered = vec![false; channels];
        for &c in &mics {
            filtered[c] = true;
        }
        Wpe {
            n,
            hop,
            channels,
            filtered,
            window,
            forward: planner.plan_fft_forward(n),
            inverse: planner.plan_fft_inverse(n),
            input: vec![vec![0.0; n]; channels],
            constant_run: vec![0; channels],
            last: Vec::new(),
            sum: vec![vec![0.0; n]; channels],
            fresh: 0,
            ready: Vec::new(),
            ready_at: 0,
            latency: n - hop,
            read: 0,
            given: 0,
            ended: false,
            error: None,
            replay: None,
            replay_at: 0,
            pending: None,
            rate,
            bins: (0..bins).map(|_| Bin::new(mics.len())).collect(),
            spectra: vec![vec![Complex32::default(); n / 2 + 1]; mics.len()],
            time: vec![0.0; n],
            windowed: vec![0.0; n],
            y: vec![Complex64::default(); bins * mics.len()],
            chunk: Vec::new(),
            mics,
        }
    }

    /// Samples in, one sample frame (`channels` values) at a time.
    fn push(&mut self, frame: &[f32]) {
        let at = self.n - self.hop + self.fresh;
        let first = self.last.is_empty();
        for (c, &x) in frame.iter().enumerate() {
            self.constant_run[c] = if first {
                // The three hops before the start are as the first sample.
                3 * self.hop + 1
            } else if self.last[c] == x {
                self.constant_run[c] + 1
            } else {
                1
            };
            self.input[c][at] = x;
        }
        self.last.clear();
        self.last.extend_from_slice(frame);
        self.fresh += 1;
        if self.fresh == self.hop {
            self.fresh = 0;
            self.frame();
            for input in &mut self.input {
                input.copy_within(self.hop.., 0);
            }
        }
    }

    /// The current frame through the filter, overlap-added; the first hop of the sum is
    /// then complete and handed on.
    fn frame(&mut self) {
        let (n, hop) = (self.n, self.hop);
        // The share of the prediction taken out: all while warming up (whose output is
        // not given), then from none at the start to all after RAMP_S.
        let share = if self.replay.is_none() {
            1.0
        } else {
            (self.read as f64 / (RAMP_S * self.rate as f64)).min(1.0)
        };
        for (i, &c) in self.mics.iter().enumerate() {
            for ((w, &x), &h) in self
                .windowed
                .iter_mut()
                .zip(&self.input[c])
                .zip(&self.window)
            {
                *w = x * h;
            }
            self.forward
                .process(&mut self.windowed, &mut self.spectra[i])
                .expect("buffers sized by the plan");
        }
        let m = self.mics.len();
        for (k, y) in self.y.chunks_exact_mut(m).enumerate() {
            for (y, s) in y.iter_mut().zip(&self.spectra) {
                *y = Complex64::new(s[k].re as f64, s[k].im as f64);
            }
        }
        // Every bin is its own filter: they share the threads, and the output does not
        // depend on how many there are.
        if rayon::current_num_threads() > 1 {
            self.bins
                .par_iter_mut()
                .zip(self.y.par_chunks_exact_mut(m))
                .for_each(|(bin, y)| bin.step(y, share));
        } else {
            for (bin, y) in self.bins.iter_mut().zip(self.y.chunks_exact_mut(m)) {
                bin.step(y, share);
            }
        }
        for (k, y) in self.y.chunks_exact(m).enumerate() {
            for (y, s) in y.iter().zip(self.spectra.iter_mut()) {
                s[k] = Complex32::new(y.re as f32, y.im as f32);
            }
        }
        if self.replay.is_none() {
            // Warming up: the filter learns, nothing is given.
            return;
        }
        // realfft does not normalise; the squared windows add up to 3/2.
        let scale = 1.0 / (n as f32 * 1.5);
        for (i, &c) in self.mics.iter().enumerate() {
            let spectrum = &mut self.spectra[i];
            spectrum[0].im = 0.0;
            spectrum[n / 2].im = 0.0;
            self.inverse
                .process(spectrum, &mut self.time)
                .expect("buffers sized by the plan");
            for ((s, &t), &h) in self.sum[c].iter_mut().zip(&self.time).zip(&self.window) {
                *s += t * h * scale;
            }
        }
        // The first hop is complete: the samples at the start of the current frame. A
        // channel that is not a microphone's, or has not changed over every frame that
        // overlaps that hop, gives its input as it was.
        for c in 0..self.channels {
            if !self.filtered[c] || self.constant_run[c] >= n + 3 * hop {
                self.sum[c][..hop].copy_from_slice(&self.input[c][..hop]);
            }
        }
        for t in 0..hop {
            if self.latency > 0 {
                self.latency -= 1;
                continue;
            }
            if self.given == self.read {
                break;
            }
            self.ready.extend(self.sum.iter().map(|s| s[t]));
            self.given += 1;
        }
        for s in &mut self.sum {
            s.copy_within(hop.., 0);
            s[n - hop..].fill(0.0);
        }
    }

    /// The last sample repeated after the end, until every sample read has been given
    /// (so a channel that ends constant stays so).
    fn finish(&mut self) {
        let last = self.last.clone();
        while self.given < self.read && !last.is_empty() {
            self.push(&last);
        }
    }

    /// Learns from the first [`WARM_UP_S`] of `source`, then rewinds to its start with
    /// what it learned: they are read again from memory.
    fn warm_up(&mut self, source: &mut dyn SampleSource) {
        let ch = self.channels;
        let want = (WARM_UP_S * self.rate as f64) as usize * ch;
        // Grown as samples come, not reserved: a header may promise what never comes.
        let mut first = Vec::new();
        let mut chunk = vec![0.0; 4096 * ch];
        while first.len() < want {
            match source.read(&mut chunk) {
                Ok(0) => break,
                Ok(got) => first.extend_from_slice(&chunk[..got * ch]),
                Err(e) => {
                    self.pending = Some(e);
                    break;
                }
            }
        }
        for frame in first.chunks_exact(ch) {
            self.push(frame);
        }
        // Back to the start, the filter kept.
        let n = self.n;
        for c in 0..ch {
            self.input[c].fill(0.0);
            self.sum[c].fill(0.0);
        }
        self.constant_run.fill(0);
        self.last.clear();
        self.fresh = 0;
        self.ready.clear();
        self.ready_at = 0;
        self.latency = n - self.hop;
        self.bins.iter_mut().for_each(Bin::rewind);
        self.replay = Some(first);
    }

    /// The next samples: the warm-up's again, then the source's.
    fn next(
        &mut self,
        source: &mut dyn SampleSource,
        chunk: &mut [f32],
    ) -> Result<usize, InputError> {
        let ch = self.channels;
        let replay = self.replay.as_ref().expect("warmed up");
        if self.replay_at < replay.len() {
            let count = ((replay.len() - self.replay_at) / ch).min(chunk.len() / ch);
            chunk[..count * ch]
                .copy_from_slice(&replay[self.replay_at..self.replay_at + count * ch]);
            self.replay_at += count * ch;
            if self.replay_at == replay.len() {
                // Replayed: its memory back.
                self.replay = Some(Vec::new());
                self.replay_at = 0;
            }
            return Ok(count);
        }
        if let Some(e) = self.pending.take() {
            return Err(e);
        }
        source.read(chunk)
    }

    /// Reads up to `out.len() / channels` sample frames of `source` through the filter,
    /// as [`SampleSource::read`] does; 0 at the end. A read error comes after the
    /// samples read before it.
    pub fn read(
        &mut self,
        source: &mut dyn SampleSource,
        out: &mut [f32],
    ) -> Result<usize, InputError> {
        let ch = self.channels;
        if self.replay.is_none() {
            self.warm_up(source);
        }
        while self.ready.len() == self.ready_at && !self.ended {
            let mut chunk = std::mem::take(&mut self.chunk);
            chunk.resize(4096 * ch, 0.0);
            let got = match self.next(source, &mut chunk) {
                Ok(got) => got,
                Err(e) => {
                    // The samples before the error first, as without the filter.
                    self.error = Some(e);
                    0
                }
            };
            if got == 0 {
                self.ended = true;
                self.finish();
            } else {
                for frame in chunk[..got * ch].chunks_exact(ch) {
                    self.read += 1;
                    self.push(frame);
                }
            }
            self.chunk = chunk;
        }
        if self.ready.len() == self.ready_at {
            if let Some(e) = self.error.take() {
                return Err(e);
            }
        }
        let count = ((self.ready.len() - self.ready_at) / ch).min(out.len() / ch);
        out[..count * ch].copy_from_slice(&self.ready[self.ready_at..self.ready_at + count * ch]);
        self.ready_at += count * ch;
        if self.ready_at == self.ready.len() {
            self.ready.clear();
            self.ready_at = 0;
        }
        Ok(count)
    }
}

/// `source` read through `filter`.
pub(crate) struct Filtered<'a> {
    pub filter: &'a mut Wpe,
    pub source: &'a mut dyn SampleSource,
}

impl SampleSource for Filtered<'_> {
    fn name(&self) -> &str {
        self.source.name()
    }
    fn channels(&self) -> usize {
        self.source.channels()
    }
    fn sample_rate(&self) -> u32 {
        self.source.sample_rate()
    }
    fn frames(&self) -> Option<u64> {
        self.source.frames()
    }
    fn read(&mut self, out: &mut [f32]) -> Result<usize, InputError> {
        self.filter.read(self.source, out)
    }
    fn is_live(&self) -> bool {
        self.source.is_live()
    }
}

#[cfg(test)]
mod tests;
