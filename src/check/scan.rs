//! One pass over a recording for `ssl check`: each channel's level, clipping and
//! constancy, the correlation of every two channels at lag 0 (duplicates), and, for the
//! frames where one sound is clearest, every pair's delay and the sign of its peak
//! (plain PHAT over the whole lag range, so that delays beyond the geometry's reach are
//! seen). Memory is bounded: the clearest frames are kept in a heap of fixed size.

use crate::stream::{InputError, SampleSource};
use realfft::num_complex::Complex;
use realfft::RealFftPlanner;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// At most this many seconds are read: enough for a clear sound, bounded for an archive.
pub(crate) const MAX_SECONDS: f64 = 600.0;
/// The clearest frames kept.
pub(crate) const KEPT_FRAMES: usize = 300;
/// A frame counts as clear when its pairs' PHAT peaks reach this on average (plain
/// PHAT peaks at 1; incoherent noise in a 1024-point frame at about 0.12).
pub(crate) const CLEAR_PEAK: f32 = 0.05;
/// How fast a bin's background floor may rise, per frame.
const FLOOR_RISE: f32 = 1.05;
/// A sample this close to full scale counts as clipped.
pub(crate) const CLIP_LEVEL: f32 = 0.999;

/// Per channel, what the pass measured.
#[derive(Debug, Clone, Default)]
pub struct ChannelStats {
    /// Sum of squares.
    pub energy: f64,
    /// Samples at or beyond [`CLIP_LEVEL`].
    pub clipped: u64,
    /// Smallest and largest sample.
    pub min: f32,
    /// Largest sample.
    pub max: f32,
}

/// One clear frame: per pair of channels `(i, j)`, `i < j`, in the order of
/// [`crate::method::pairs::pair_index`], the delay `t_i - t_j` in samples and the signed
/// value of the PHAT peak, over the whole lag range and within the geometry's reach.
#[derive(Debug, Clone)]
pub struct Frame {
    /// How clear: the pairs' mean |peak| within reach.
    pub clarity: f32,
    /// Where the frame starts in the recording (seconds).
    pub start_s: f64,
    /// Delays of the highest peaks (samples).
    pub lags: Vec<f64>,
    /// Their values (negative: the pair's channels are of opposite polarity).
    pub peaks: Vec<f32>,
    /// Delays of the highest peaks within reach (samples).
    pub near: Vec<f64>,
    /// Their values.
    pub near_peaks: Vec<f32>,
}

impl PartialEq for Frame {
    fn eq(&self, o: &Self) -> bool {
        self.clarity == o.clarity
    }
}
impl Eq for Frame {}
impl PartialOrd for Frame {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Frame {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.clarity.total_cmp(&o.clarity)
    }
}

/// What one pass found.
#[derive(Debug, Clone)]
pub struct Scan {
    /// Sample frames read.
    pub samples: u64,
    /// Per channel.
    pub channels: Vec<ChannelStats>,
    /// `sum x_i x_j` over the samples read, per pair of channels.
    pub cross: Vec<f64>,
    /// The clearest frames, clearest first.
    pub frames: Vec<Frame>,
}

/// The lag (index into `corr`, `n` long, lag `i` or `i - n`) of the highest |value|,
/// within `reach` samples of 0 when given, and that value over `n`.
fn peak(corr: &[f32], n: usize, reach: Option<usize>) -> (usize, f32) {
    let r = reach.unwrap_or(n / 2).min(n / 2 - 1);
    (0..=r)
        .chain(n - r..n)
        .map(|i| (i, corr[i]))
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .map(|(i, v)| (i, v / n as f32))
        .unwrap_or((0, 0.0))
}

/// The lag (samples, in (-n/2, n/2]) of the peak at index `at`, refined by a parabola
/// through |r| at its neighbours.
fn refined(corr: &[f32], n: usize, at: usize) -> f64 {
    let y = |d: isize| corr[(at as isize + d).rem_euclid(n as isize) as usize].abs() as f64;
    let (ym, y0, yp) = (y(-1), y(0), y(1));
    let denom = ym - 2.0 * y0 + yp;
    let frac = if denom.abs() > 1e-12 {
        (0.5 * (ym - yp) / denom).clamp(-0.5, 0.5)
    } else {
        0.0
    };
    let lag = at as f64 + frac;
    if lag > n as f64 / 2.0 {
        lag - n as f64
    } else {
        lag
    }
}

/// Reads `source` (at most [`MAX_SECONDS`]) in frames of `n` samples; `reach` is the
/// geometry's longest delay (samples) with a margin.
pub fn scan<S: SampleSource>(source: &mut S, n: usize, reach: usize) -> Result<Scan, InputError> {
    let k = source.channels();
    let pairs = k * (k - 1) / 2;
    let limit = (MAX_SECONDS * source.sample_rate() as f64) as u64;
    let mut planner = RealFftPlanner::<f32>::new();
    let forward = planner.plan_fft_forward(n);
    let inverse = planner.plan_fft_inverse(n);
    let window: Vec<f32> = (0..n)
        .map(|i| 0.5 - 0.5 * (std::f32::consts::TAU * i as f32 / n as f32).cos())
        .collect();
    let mut channels = vec![
        ChannelStats {
            min: f32::INFINITY,
            max: f32::NEG_INFINITY,
            ..Default::default()
        };
        k
    ];
    let mut cross = vec![0.0f64; pairs];
    let mut buf = vec![0.0f32; n * k];
    let mut time = vec![0.0f32; n];
    let mut spectra = vec![vec![Complex::new(0.0f32, 0.0); n / 2 + 1]; k];
    let mut product = vec![Complex::new(0.0f32, 0.0); n / 2 + 1];
    let mut corr = vec![0.0f32; n];
    let mut heap: BinaryHeap<Reverse<Frame>> = BinaryHeap::new();
    let mut floor = vec![0.0f32; n / 2 + 1];
    let mut weight = vec![0.0f32; n / 2 + 1];
    let mut frames_seen = 0u64;
    let mut samples = 0u64;
    while samples < limit {
        // One frame (the last one padded with zeros).
        let mut got = 0;
        while got < n {
            let read = source.read(&mut buf[got * k..])?;
            if read == 0 {
                break;
            }
            got += read;
        }
        if got == 0 {
            break;
        }
        buf[got * k..].iter_mut().for_each(|v| *v = 0.0);
        samples += got as u64;
        for (c, st) in channels.iter_mut().enumerate() {
            for t in 0..got {
                let v = buf[t * k + c];
                st.energy += (v as f64) * (v as f64);
                st.clipped += u64::from(v.abs() >= CLIP_LEVEL);
                st.min = st.min.min(v);
                st.max = st.max.max(v);
            }
        }
        let mut p = 0;
        for i in 0..k {
            for j in i + 1..k {
                cross[p] += (0..got)
                    .map(|t| buf[t * k + i] as f64 * buf[t * k + j] as f64)
                    .sum::<f64>();
                p += 1;
            }
        }
        if got < n / 2 {
            break;
        }
        for (c, spectrum) in spectra.iter_mut().enumerate() {
            for t in 0..n {
                time[t] = buf[t * k + c] * window[t];
            }
            forward
                .process(&mut time, spectrum)
                .expect("buffers of the planned size");
        }
        // Each bin weighted by how far it stands out of the background: its mean power
        // over the channels against a running floor (the lowest it has been, rising 5% a
        // frame), `1 - floor / power`. Plain PHAT weighs every bin alike, and at 48 kHz
        // most bins hold no speech.
        for b in 0..=n / 2 {
            let power = spectra.iter().map(|x| x[b].norm_sqr()).sum::<f32>() / k as f32;
            floor[b] = if frames_seen == 0 {
                power
            } else {
                (floor[b] * FLOOR_RISE).min(power)
            };
            weight[b] = if power > 0.0 {
                (1.0 - floor[b] / power).max(0.0)
            } else {
                0.0
            };
        }
        frames_seen += 1;
        let mut lags = Vec::with_capacity(pairs);
        let mut peaks = Vec::with_capacity(pairs);
        let mut near = Vec::with_capacity(pairs);
        let mut near_peaks = Vec::with_capacity(pairs);
        for i in 0..k {
            for j in i + 1..k {
                for (b, out) in product.iter_mut().enumerate() {
                    let x = spectra[i][b] * spectra[j][b].conj();
                    let m = x.norm();
                    *out = if m > 1e-20 {
                        x * (weight[b] / m)
                    } else {
                        Complex::new(0.0, 0.0)
                    };
                }
                product[0].im = 0.0;
                product[n / 2].im = 0.0;
                inverse
                    .process(&mut product, &mut corr)
                    .expect("buffers of the planned size");
                // The highest peak anywhere (delays beyond the geometry's reach are seen),
                // and within the reach (what a fitting array's sources give).
                let (at, value) = peak(&corr, n, None);
                lags.push(refined(&corr, n, at));
                peaks.push(value);
                let (at, value) = peak(&corr, n, Some(reach));
                near.push(refined(&corr, n, at));
                near_peaks.push(value);
            }
        }
        let clarity = near_peaks.iter().map(|v| v.abs()).sum::<f32>() / pairs.max(1) as f32;
        if clarity >= CLEAR_PEAK && channels.len() > 1 {
            heap.push(Reverse(Frame {
                clarity,
                start_s: (samples - got as u64) as f64 / source.sample_rate() as f64,
                lags,
                peaks,
                near,
                near_peaks,
            }));
            if heap.len() > KEPT_FRAMES {
                heap.pop();
            }
        }
        if got < n {
            break;
        }
    }
    let mut frames: Vec<Frame> = heap.into_iter().map(|Reverse(f)| f).collect();
    frames.sort_by(|a, b| b.cmp(a));
    Ok(Scan {
        samples,
        channels,
        cross,
        frames,
    })
}
