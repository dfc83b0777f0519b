//! How well the geometry explains the delays of the clearest frames: the residual of the
//! far-field least squares (eq. 13) per frame, under the channel order the geometry gives
//! or any other; the length of the solution (1 when the positions' scale is right); the
//! share of delays longer than a pair's spacing allows; and each microphone's share of
//! the misfit.

use super::scan::Frame;
use crate::method::pairs::{pair_count, pair_index};
use nalgebra::{DMatrix, Vector3};

/// A frame's residual is capped at this share of the longest delay (at least
/// [`CAP_SAMPLES`]) when averaged over frames, so that frames of two sources at once,
/// which no direction explains, do not decide.
const CAP_SHARE: f64 = 0.1;
/// The least cap (samples).
const CAP_SAMPLES: f64 = 3.0;
/// A peak out of the geometry's reach counts when it is this many times the best within.
const BEYOND_RATIO: f32 = 1.5;

/// The least squares of one array: `lags ~ D u` with `D` the pairs' position
/// differences in samples.
pub struct Fit {
    /// Microphones.
    m: usize,
    /// `D` (P x 3), row per pair of microphones.
    d: Vec<Vector3<f64>>,
    /// The pseudo-inverse of `D` (3 x P), column per pair.
    pinv: Vec<Vector3<f64>>,
    /// Per pair of microphones, the longest possible delay (samples).
    reach: Vec<f64>,
    /// A frame's residual is counted up to this (samples).
    cap: f64,
    /// The dimensions the positions span (3: a direction has length 1; fewer: its
    /// projection on the array's plane or axis, at most 1).
    dims: usize,
    /// Samples per second.
    rate: f64,
}

impl Fit {
    /// The fit of microphones at `positions` (metres) at `rate` Hz, `speed` m/s.
    pub fn new(positions: &[Vector3<f64>], rate: f64, speed: f64) -> Self {
        let m = positions.len();
        let p = pair_count(m);
        let mut d = vec![Vector3::zeros(); p];
        for a in 0..m {
            for b in a + 1..m {
                d[pair_index(a, b, m)] = (positions[b] - positions[a]) * rate / speed;
            }
        }
        let matrix = DMatrix::from_fn(p, 3, |r, c| d[r][c]);
        let svd = matrix.svd(true, true);
        let largest = svd.singular_values.max();
        let dims = svd
            .singular_values
            .iter()
            .filter(|&&v| v > 1e-6 * largest.max(1e-300))
            .count();
        let pinv = svd
            .pseudo_inverse(1e-9 * largest.max(1e-300))
            .unwrap_or_else(|_| DMatrix::zeros(3, p));
        let reach: Vec<f64> = d.iter().map(|x| x.norm()).collect();
        Fit {
            m,
            cap: (CAP_SHARE * reach.iter().copied().fold(0.0, f64::max)).max(CAP_SAMPLES),
            reach,
            pinv: (0..p)
                .map(|r| Vector3::new(pinv[(0, r)], pinv[(1, r)], pinv[(2, r)]))
                .collect(),
            d,
            dims,
            rate,
        }
    }

    /// The delays (within the geometry's reach) of microphone pairs in `frame` when
    /// microphone `a` is on channel `order[a]` (channels numbered as in the scan, `k` of
    /// them).
    pub fn lags(&self, frame: &Frame, order: &[usize], k: usize, out: &mut Vec<f64>) {
        pair_lags(&frame.near, self.m, order, k, out)
    }
}

/// The peak values `of` (per pair of channels) of microphone pairs when microphone `a`
/// is on channel `order[a]`.
fn pair_values(of: &[f32], m: usize, order: &[usize], k: usize, out: &mut Vec<f32>) {
    out.clear();
    for a in 0..m {
        for b in a + 1..m {
            let (i, j) = (order[a].min(order[b]), order[a].max(order[b]));
            out.push(of[pair_index(i, j, k)]);
        }
    }
}

/// The delays `of` (per pair of channels) of microphone pairs when microphone `a` is on
/// channel `order[a]`.
fn pair_lags(of: &[f64], m: usize, order: &[usize], k: usize, out: &mut Vec<f64>) {
    {
        out.clear();
        for a in 0..m {
            for b in a + 1..m {
                let (i, j) = (order[a], order[b]);
                out.push(if i < j {
                    of[pair_index(i, j, k)]
                } else {
                    -of[pair_index(j, i, k)]
                });
            }
        }
    }
}

impl Fit {
    /// The least-squares solution (about a unit vector when the geometry is right) and
    /// the RMS residual (samples) of `lags`.
    pub fn solve(&self, lags: &[f64]) -> (Vector3<f64>, f64) {
        let w: Vector3<f64> = self.pinv.iter().zip(lags).map(|(c, l)| c * *l).sum();
        let sum: f64 = self
            .d
            .iter()
            .zip(lags)
            .map(|(x, l)| (l - x.dot(&w)).powi(2))
            .sum();
        (w, (sum / lags.len().max(1) as f64).sqrt())
    }

    /// The RMS residual (samples) of `lags` against the nearest direction a far source
    /// can have: the least-squares solution brought to length 1 (3-D arrays) or to at
    /// most 1 (a plane's or a line's projection). Unbounded solutions would let any
    /// order whose positions are a linear image of the true ones fit as well (a box's
    /// corners under a shear), which sound from afar cannot do.
    pub fn residual(&self, lags: &[f64]) -> f64 {
        let (w, _) = self.solve(lags);
        let n = w.norm();
        let w = if n > 1e-12 && (self.dims == 3 || n > 1.0) {
            w / n
        } else {
            w
        };
        let sum: f64 = self
            .d
            .iter()
            .zip(lags)
            .map(|(x, l)| (l - x.dot(&w)).powi(2))
            .sum();
        (sum / lags.len().max(1) as f64).sqrt()
    }

    /// The longest delay the geometry allows (samples).
    pub fn longest(&self) -> f64 {
        self.reach.iter().copied().fold(0.0, f64::max)
    }

    /// The sample rate the delays are counted at (Hz).
    pub fn rate(&self) -> f64 {
        self.rate
    }

    /// Each frame's residual (capped) under `order`.
    pub fn residuals(
        &self,
        frames: &[Frame],
        order: &[usize],
        k: usize,
        buf: &mut Vec<f64>,
    ) -> Vec<f64> {
        frames
            .iter()
            .map(|f| {
                self.lags(f, order, k, buf);
                self.residual(buf).min(self.cap)
            })
            .collect()
    }

    /// How far (a chord on the unit sphere) the direction the delays of `frame` give
    /// under `order` is from `u`, as far as the array can see: a plane's or a line's
    /// array compares the projections on its plane or axis (it cannot tell a direction
    /// from its mirror image across them).
    pub fn distance_to(&self, frame: &Frame, order: &[usize], k: usize, u: &Vector3<f64>) -> f64 {
        let mut buf = Vec::new();
        self.lags(frame, order, k, &mut buf);
        let w = self.solve(&buf).0;
        // The projection of u on the array's span: the solution of u's own delays.
        let own: Vec<f64> = self.d.iter().map(|x| x.dot(u)).collect();
        let pu = self.solve(&own).0;
        let w = if self.dims == 3 && w.norm() > 1e-12 {
            w.normalize()
        } else {
            w
        };
        (w - pu).norm()
    }

    /// The mean over `frames` of each frame's residual (capped) under `order`.
    pub fn score(&self, frames: &[Frame], order: &[usize], k: usize, buf: &mut Vec<f64>) -> f64 {
        let total: f64 = frames
            .iter()
            .map(|f| {
                self.lags(f, order, k, buf);
                self.residual(buf).min(self.cap)
            })
            .sum();
        total / frames.len().max(1) as f64
    }

    /// The share of the pairs' delays in `frames` (under `order`) longer than their
    /// spacing allows by more than a sample, where the peak out of reach is also much
    /// higher ([`BEYOND_RATIO`] times) than the best within it: a reflection can peak out of
    /// reach now and then, a source heard through a geometry that is too small always.
    pub fn beyond_share(&self, frames: &[Frame], order: &[usize], k: usize) -> f64 {
        let (mut lags, mut far, mut near) = (Vec::new(), Vec::new(), Vec::new());
        let (mut beyond, mut all) = (0usize, 0usize);
        for f in frames {
            pair_lags(&f.lags, self.m, order, k, &mut lags);
            pair_values(&f.peaks, self.m, order, k, &mut far);
            pair_values(&f.near_peaks, self.m, order, k, &mut near);
            for p in 0..lags.len() {
                beyond += usize::from(
                    lags[p].abs() > self.reach[p] + 1.0
                        && far[p].abs() > BEYOND_RATIO * near[p].abs(),
                );
                all += 1;
            }
        }
        beyond as f64 / all.max(1) as f64
    }

    /// A high quantile (0.9) of the solutions' lengths over `frames`: about 1 when the
    /// positions' scale is right (the sources near the plane of a planar array, or the
    /// axis of a linear one, reach it), much less when the positions are too large.
    pub fn length(&self, frames: &[Frame], order: &[usize], k: usize) -> f64 {
        let mut buf = Vec::new();
        let mut lengths: Vec<f64> = frames
            .iter()
            .map(|f| {
                self.lags(f, order, k, &mut buf);
                self.solve(&buf).0.norm()
            })
            .collect();
        lengths.sort_by(f64::total_cmp);
        lengths
            .get(((lengths.len() as f64 * 0.9) as usize).min(lengths.len().saturating_sub(1)))
            .copied()
            .unwrap_or(0.0)
    }
}

/// Every ordering of `0..n` (Heap's algorithm), `visit` called with each; for more than
/// `max_full` items, only those that swap two.
pub fn orderings(base: &[usize], max_full: usize, mut visit: impl FnMut(&[usize])) {
    let n = base.len();
    let mut a = base.to_vec();
    visit(&a);
    if n > max_full {
        for i in 0..n {
            for j in i + 1..n {
                a.swap(i, j);
                visit(&a);
                a.swap(i, j);
            }
        }
        return;
    }
    let mut c = vec![0usize; n];
    let mut i = 0;
    while i < n {
        if c[i] < i {
            if i % 2 == 0 {
                a.swap(0, i);
            } else {
                a.swap(c[i], i);
            }
            visit(&a);
            c[i] += 1;
            i = 0;
        } else {
            c[i] = 0;
            i += 1;
        }
    }
}
