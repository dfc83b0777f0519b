//! The least-squares slope of unit directions over time, and its standard error (beyond
//! the paper): whether a track turns ([`motion`](super::motion)) and along what the
//! smoother turns its rows ([`smoother`](super::smoother)) both ask whether the slope
//! stands out of the directions' scatter.
//!
//! Directions that share frames tell less than as many independent ones: a detection's
//! direction is that of the frames averaged up to it
//! ([`Detection::span_s`](crate::method::Detection::span_s), six frames at the
//! defaults), so the scatter is counted once per span of frames, not once per direction.

use nalgebra::{Matrix3, Vector3};

/// Running sums for the slope of directions over time (times from the first one's);
/// no allocation.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Slope {
    n: f64,
    t0: Option<f64>,
    st: f64,
    stt: f64,
    su: Vector3<f64>,
    stu: Vector3<f64>,
    suu: Matrix3<f64>,
    /// The directions' spans summed, the last one's time, and the smallest step between
    /// two (0 until there are two).
    span: f64,
    last: f64,
    step: f64,
}

impl Slope {
    /// Direction `u` heard at `time_s`, averaged over frames spanning `span_s` (in time
    /// order).
    pub fn add(&mut self, time_s: f64, u: &Vector3<f64>, span_s: f64) {
        let t0 = *self.t0.get_or_insert(time_s);
        let t = time_s - t0;
        if self.n > 0.0 && t > self.last {
            self.step = if self.step > 0.0 {
                self.step.min(t - self.last)
            } else {
                t - self.last
            };
        }
        self.last = t;
        self.n += 1.0;
        self.st += t;
        self.stt += t * t;
        self.su += u;
        self.stu += u * t;
        self.suu += u * u.transpose();
        self.span += span_s;
    }

    /// The variance of their times (seconds squared; 0 with none).
    pub fn time_variance(&self) -> f64 {
        if self.n == 0.0 {
            return 0.0;
        }
        let mean_t = self.st / self.n;
        self.stt / self.n - mean_t * mean_t
    }

    /// The least-squares line: the mean direction (not normalised) and the slope (per
    /// second); `None` under two directions or with no spread in time.
    pub fn line(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        let var_t = self.time_variance();
        if self.n < 2.0 || var_t <= 0.0 {
            return None;
        }
        let (mean_t, mean_u) = (self.st / self.n, self.su / self.n);
        Some((mean_u, (self.stu / self.n - mean_u * mean_t) / var_t))
    }

    /// The standard error (per second) of the slope across direction `u`: from the
    /// residuals along `u`'s turn in the plane for a planar array (normal `plane`, whose
    /// angle out of it scatters more and is not turned), else along both axes across
    /// `u`; `None` under three directions.
    pub fn standard_error(&self, u: &Vector3<f64>, plane: Option<Vector3<f64>>) -> Option<f64> {
        let n = self.n;
        let (mean_u, slope) = self.line().filter(|_| n >= 3.0)?;
        let var_t = self.time_variance();
        let (axes, count) = match plane {
            Some(normal) => ([normal.cross(u).try_normalize(1e-9)?, Vector3::zeros()], 1),
            None => {
                let a = u
                    .cross(&Vector3::z())
                    .try_normalize(1e-9)
                    .unwrap_or_else(Vector3::x);
                ([a, u.cross(&a)], 2)
            }
        };
        let rss: f64 = axes[..count]
            .iter()
            .map(|e| {
                let (m, b) = (e.dot(&mean_u), e.dot(&slope));
                (e.dot(&(self.suu * e)) - n * m * m - b * b * n * var_t).max(0.0)
            })
            .sum();
        let frames_per_direction = if self.step > 0.0 {
            1.0 + self.span / n / self.step
        } else {
            1.0
        };
        let sigma2 = rss / (count as f64 * (n - 2.0));
        Some((sigma2 * frames_per_direction / (n * var_t)).sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::unit_from_angles;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Directions turning at `rate_deg_s` about z, scattered by `noise` (radians, each
    /// axis), every 10 ms for `seconds`.
    fn walk(rate_deg_s: f64, noise: f64, seconds: f64, seed: u64) -> Slope {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut s = Slope::default();
        for k in 0..(seconds / 0.01) as usize {
            let t = 5.0 + k as f64 * 0.01;
            let mut jitter = || {
                if noise > 0.0 {
                    rng.random_range(-noise..noise)
                } else {
                    0.0
                }
            };
            let jitter = Vector3::new(jitter(), jitter(), jitter());
            let u = (unit_from_angles(rate_deg_s * t, 10.0) + jitter).normalize();
            s.add(t, &u, 0.0);
        }
        s
    }

    #[test]
    fn the_slope_is_the_turn_and_its_standard_error_the_scatters() {
        // 20 deg/s at 10 deg of elevation without noise: the slope is the turn.
        let s = walk(20.0, 0.0, 0.5, 1);
        let (mean, slope) = s.line().expect("a line");
        let rate = mean.normalize().cross(&slope).norm().to_degrees();
        assert!(
            (rate - 20.0 * 10f64.to_radians().cos()).abs() < 0.2,
            "{rate}"
        );
        // Only the arc's curvature is left for residuals: the turn stands far out.
        let se = s.standard_error(&mean.normalize(), None).unwrap();
        assert!(rate.to_radians() > 20.0 * se, "{rate} deg/s, {se} rad/s");
        // Still directions scattered uniformly by +-0.01 (sd 0.0058 per axis): over
        // many draws the slope across the direction (two axes) is within two standard
        // errors as often as a 2-D normal is within two deviations (86%).
        let mut within = 0;
        for seed in 0..400 {
            let s = walk(0.0, 0.01, 0.5, seed);
            let (mean, slope) = s.line().unwrap();
            let u = mean.normalize();
            let across = (slope - u * u.dot(&slope)).norm();
            within += (across <= 2.0 * s.standard_error(&u, None).unwrap()) as usize;
        }
        assert!((320..=370).contains(&within), "{within} of 400");
        // In the plane of a planar array: only the turn about its normal counts.
        let s = walk(0.0, 0.01, 0.5, 9);
        let u = s.line().unwrap().0.normalize();
        assert!(s.standard_error(&u, Some(Vector3::z())).is_some());
        assert!(s
            .standard_error(&Vector3::z(), Some(Vector3::z()))
            .is_none());
    }

    #[test]
    fn directions_that_share_frames_count_once_per_span() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let (mut own, mut shared) = (Slope::default(), Slope::default());
        for k in 0..50 {
            let t = k as f64 * 0.01;
            let u =
                (Vector3::x() + Vector3::new(0.0, rng.random_range(-0.01..0.01), 0.0)).normalize();
            own.add(t, &u, 0.0);
            shared.add(t, &u, 0.05);
        }
        let (a, b) = (
            own.standard_error(&Vector3::x(), None).unwrap(),
            shared.standard_error(&Vector3::x(), None).unwrap(),
        );
        // Each direction averages 6 steps' frames: sqrt(6) times the error.
        assert!((b / a - 6f64.sqrt()).abs() < 1e-9, "{a} {b}");
    }
}
