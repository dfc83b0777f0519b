//! Direction from delays: the far-field model of the paper's Section III.
//!
//! For microphones `i`, `j` and a unit vector `u` toward a far source, eq. (11)-(12) give
//! `u . x_ij = c dT_ij` with `x_ij = p_j - p_i` and `dT_ij = t_i - t_j` (the lag of the
//! peak of `R_ij`). Stacking one row per pair gives the linear system of eq. (13), solved
//! by least squares through the pseudo-inverse of the difference matrix, computed once
//! per set of live microphones, and normalised (which also removes the dependence on the
//! speed of sound and most of the near-field error, as the paper notes).
//!
//! The paper stacks only the `N-1` pairs `(1, j)`. We stack every pair whose delay the
//! consistency search matched (all `N(N-1)/2` of them), each with its own measured,
//! sub-sample refined lag: when the delays are exact the answer is the same, and with
//! noisy delays the extra rows average the noise down.
//!
//! Planar arrays: the difference matrix has rank 2, so the system is solved in the
//! plane and the out-of-plane component is `sqrt(1 - |u_plane|^2)` on the `side` of
//! the plane. Linear arrays: rank 1, only `cos` of the angle to the axis is known; the
//! direction is reported in the plane of the axis and `side`.

use super::pairs::{pair_count, pair_index};
use crate::geometry::{Geometry, Shape};
use nalgebra::{DMatrix, Matrix2, Matrix3, Vector2, Vector3};

enum Solver {
    /// Rows of the pseudo-inverse (3 x P) stored per pair: `u = sum_p col_p * b_p`.
    Volumetric { cols: Vec<Vector3<f64>> },
    Planar {
        cols: Vec<Vector2<f64>>,
        e1: Vector3<f64>,
        e2: Vector3<f64>,
        normal: Vector3<f64>,
    },
    Linear {
        weights: Vec<f64>,
        axis: Vector3<f64>,
        perp: Vector3<f64>,
    },
}

/// Solves eq. (13) for one set of live microphones. Built once, used every frame.
pub struct DirectionSolver {
    solver: Solver,
    /// Converts a lag in samples to metres: `c / fs`.
    metres_per_sample: f64,
    /// Per pair, in the order of the lags, `x_ab = p_b - p_a` (metres).
    diffs: Vec<Vector3<f64>>,
    /// Per pair, `(p_a, p_b)` from the array centre (metres).
    ends: Vec<(Vector3<f64>, Vector3<f64>)>,
    /// How the least-squares solution errs when every microphone's timing errs
    /// independently by one second (standard deviation): see [`Spread`].
    spread: Spread,
}

/// The covariance of the least-squares solution of eq. (13), before normalisation, when
/// every live microphone's time of arrival errs independently by one second (standard
/// deviation): `c^2 S^-1`, `S` the sum of the outer products of the live microphones'
/// positions about their mean, in the coordinates the array resolves (the least
/// squares over every pair of such lags is the least squares over the microphones).
/// Scaled by a timing variance, it says how far the true direction may lie from the
/// reported one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Spread {
    /// A 3-D array: the covariance of the solution vector (of about unit length, before
    /// normalisation).
    Volumetric(Matrix3<f64>),
    /// A planar array: the covariance of the in-plane part, in the basis `(e1, e2)`;
    /// the out-of-plane part follows from the unit norm on the side of `normal`.
    Planar {
        /// The in-plane part's covariance in the basis `(e1, e2)`.
        cov: Matrix2<f64>,
        /// The plane's first basis vector.
        e1: Vector3<f64>,
        /// Its second (`e1 x e2 = normal`).
        e2: Vector3<f64>,
        /// The unit normal on the reported side.
        normal: Vector3<f64>,
    },
    /// A linear array: the variance of the cosine of the angle to `axis`; the angle
    /// around the axis is not measured (the direction is reported toward `perp`).
    Linear {
        /// The variance of the cosine of the angle to the axis.
        var: f64,
        /// The array's unit axis.
        axis: Vector3<f64>,
        /// The unit vector across the axis toward the reported side.
        perp: Vector3<f64>,
    },
}

/// Source distances (metres) at which a spherical wave is fitted too, so that the fit's
/// residual does not mistake the wavefront curvature of a near source for a bad set of
/// delays.
const NEAR_DISTANCES_M: [f64; 8] = [0.25, 0.35, 0.5, 0.7, 1.0, 1.4, 2.0, 3.0];

impl DirectionSolver {
    /// `mask` selects the live microphones (bit `i` = mic `i` of `geometry`). `None`
    /// when fewer than two are live or the system cannot be solved.
    pub fn new(geometry: &Geometry, mask: u64, sample_rate: f64, speed: f64) -> Option<Self> {
        let live: Vec<usize> = (0..geometry.mics.len())
            .filter(|i| mask & (1u64 << i) != 0)
            .collect();
        let k = live.len();
        if k < 2 {
            return None;
        }
        let p = pair_count(k);
        let mut d = DMatrix::<f64>::zeros(p, 3);
        for a in 0..k {
            for b in a + 1..k {
                let row = pair_index(a, b, k);
                let x = geometry.mics[live[b]].position - geometry.mics[live[a]].position;
                for c in 0..3 {
                    d[(row, c)] = x[c];
                }
            }
        }
        let diffs = (0..p)
            .map(|r| Vector3::new(d[(r, 0)], d[(r, 1)], d[(r, 2)]))
            .collect();
        let at = |i: usize| geometry.mics[live[i]].position - geometry.centre;
        let mut ends = vec![(Vector3::zeros(), Vector3::zeros()); p];
        for a in 0..k {
            for b in a + 1..k {
                ends[pair_index(a, b, k)] = (at(a), at(b));
            }
        }
        let shape = geometry.subset_shape(mask).ok()?;
        let s2 = speed * speed;
        let mean = live
            .iter()
            .map(|&i| geometry.mics[i].position)
            .sum::<Vector3<f64>>()
            / k as f64;
        let scatter: Matrix3<f64> = live
            .iter()
            .map(|&i| {
                let q = geometry.mics[i].position - mean;
                q * q.transpose()
            })
            .sum();
        let (solver, spread) = match shape {
            Shape::Volumetric => {
                let inv = scatter.try_inverse()?;
                let pinv = d.pseudo_inverse(1e-12).ok()?;
                let solver = Solver::Volumetric {
                    cols: (0..p)
                        .map(|r| Vector3::new(pinv[(0, r)], pinv[(1, r)], pinv[(2, r)]))
                        .collect(),
                };
                (solver, Spread::Volumetric(inv * s2))
            }
            Shape::Planar { normal } => {
                let (e1, e2) = plane_basis(&normal);
                let mut dp = DMatrix::<f64>::zeros(p, 2);
                for r in 0..p {
                    let row = Vector3::new(d[(r, 0)], d[(r, 1)], d[(r, 2)]);
                    dp[(r, 0)] = row.dot(&e1);
                    dp[(r, 1)] = row.dot(&e2);
                }
                let basis = nalgebra::Matrix3x2::from_columns(&[e1, e2]);
                let inv = (basis.transpose() * scatter * basis).try_inverse()?;
                let pinv = dp.pseudo_inverse(1e-12).ok()?;
                let solver = Solver::Planar {
                    cols: (0..p)
                        .map(|r| Vector2::new(pinv[(0, r)], pinv[(1, r)]))
                        .collect(),
                    e1,
                    e2,
                    normal,
                };
                let spread = Spread::Planar {
                    cov: inv * s2,
                    e1,
                    e2,
                    normal,
                };
                (solver, spread)
            }
            Shape::Linear { axis } => {
                let proj: Vec<f64> = (0..p)
                    .map(|r| Vector3::new(d[(r, 0)], d[(r, 1)], d[(r, 2)]).dot(&axis))
                    .collect();
                let norm2: f64 = proj.iter().map(|v| v * v).sum();
                let side = geometry.side;
                let perp = (side - axis * axis.dot(&side)).normalize();
                let solver = Solver::Linear {
                    weights: proj.iter().map(|v| v / norm2).collect(),
                    axis,
                    perp,
                };
                let var = s2 / axis.dot(&(scatter * axis));
                (solver, Spread::Linear { var, axis, perp })
            }
        };
        Some(DirectionSolver {
            solver,
            metres_per_sample: speed / sample_rate,
            diffs,
            ends,
            spread,
        })
    }

    /// How the solution errs per sample of lag error (see [`Spread`]).
    pub fn spread(&self) -> &Spread {
        &self.spread
    }

    /// How many numbers the far-field fit determines: 3, 2 or 1 (3-D, planar, linear).
    pub fn unknowns(&self) -> usize {
        match self.solver {
            Solver::Volumetric { .. } => 3,
            Solver::Planar { .. } => 2,
            Solver::Linear { .. } => 1,
        }
    }

    /// How many pairs the fit stacks.
    pub fn pairs(&self) -> usize {
        self.diffs.len()
    }

    /// The largest spacing of the live microphones (metres).
    pub fn aperture_m(&self) -> f64 {
        self.diffs.iter().map(|x| x.norm()).fold(0.0, f64::max)
    }

    /// The unit direction from pair lags in samples (`lags[pair_index(a, b, k)]` is the
    /// lag of the peak of `R_ab`). `None` when the system gives no direction (zero vector).
    pub fn solve(&self, lags: &[f64]) -> Option<Vector3<f64>> {
        let s = self.metres_per_sample;
        let u = match &self.solver {
            Solver::Volumetric { cols } => {
                let u: Vector3<f64> = cols.iter().zip(lags).map(|(c, l)| c * (l * s)).sum();
                let n = u.norm();
                if n.is_nan() || n <= 1e-12 {
                    return None;
                }
                u / n
            }
            Solver::Planar {
                cols,
                e1,
                e2,
                normal,
            } => {
                let v: Vector2<f64> = cols.iter().zip(lags).map(|(c, l)| c * (l * s)).sum();
                let r2 = v.norm_squared();
                let inplane = e1 * v.x + e2 * v.y;
                if r2 >= 1.0 {
                    inplane / r2.sqrt()
                } else {
                    inplane + normal * (1.0 - r2).sqrt()
                }
            }
            Solver::Linear {
                weights,
                axis,
                perp,
            } => {
                let c: f64 = weights.iter().zip(lags).map(|(w, l)| w * l * s).sum();
                let c = c.clamp(-1.0, 1.0);
                axis * c + perp * (1.0 - c * c).sqrt()
            }
        };
        u.iter().all(|v| v.is_finite()).then_some(u)
    }
}

impl DirectionSolver {
    /// How well one source explains the lags: the RMS over pairs of the difference
    /// between each measured path difference (`lag * c / fs`) and the one the model
    /// implies, in metres, for the best of the far-field model (the least-squares
    /// solution of eq. (13), `u . x_ab`, before normalisation) and spherical waves from
    /// a few distances along `u`, the direction [`DirectionSolver::solve`] gave for these
    /// lags. Delays of one source fit to within the peaks' precision; a set that mixes a
    /// source's delays with a reflection's does not.
    pub fn residual_m(&self, lags: &[f64], u: &Vector3<f64>) -> f64 {
        let far = self.far_field_residual_m(lags);
        let s = self.metres_per_sample;
        NEAR_DISTANCES_M
            .iter()
            .map(|&r| {
                let source = u * r;
                let sum: f64 = self
                    .ends
                    .iter()
                    .zip(lags)
                    .map(|((a, b), l)| {
                        let predicted = (source - a).norm() - (source - b).norm();
                        (l * s - predicted).powi(2)
                    })
                    .sum();
                (sum / self.ends.len().max(1) as f64).sqrt()
            })
            .fold(far, f64::min)
    }

    /// The far-field part of [`DirectionSolver::residual_m`].
    fn far_field_residual_m(&self, lags: &[f64]) -> f64 {
        let s = self.metres_per_sample;
        let u: Vector3<f64> = match &self.solver {
            Solver::Volumetric { cols } => cols.iter().zip(lags).map(|(c, l)| c * (l * s)).sum(),
            Solver::Planar { cols, e1, e2, .. } => {
                let v: Vector2<f64> = cols.iter().zip(lags).map(|(c, l)| c * (l * s)).sum();
                e1 * v.x + e2 * v.y
            }
            Solver::Linear { weights, axis, .. } => {
                axis * weights
                    .iter()
                    .zip(lags)
                    .map(|(w, l)| w * l * s)
                    .sum::<f64>()
            }
        };
        let sum: f64 = self
            .diffs
            .iter()
            .zip(lags)
            .map(|(x, l)| (l * s - u.dot(x)).powi(2))
            .sum();
        (sum / self.diffs.len().max(1) as f64).sqrt()
    }
}

/// An orthonormal basis `(e1, e2)` of the plane with unit `normal` (`e1 x e2 = normal`).
pub(crate) fn plane_basis(normal: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let helper = if normal.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = (helper - normal * normal.dot(&helper)).normalize();
    (e1, normal.cross(&e1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{angle_between_deg, angles_deg, unit_from_angles};

    /// Exact far-field lags (samples) for every pair of `positions` and direction `u`.
    fn exact_lags(positions: &[Vector3<f64>], u: &Vector3<f64>, fs: f64, c: f64) -> Vec<f64> {
        let k = positions.len();
        let mut lags = vec![0.0; pair_count(k)];
        for a in 0..k {
            for b in a + 1..k {
                // t_a - t_b with t_i = -u . p_i / c
                lags[pair_index(a, b, k)] = u.dot(&(positions[b] - positions[a])) / c * fs;
            }
        }
        lags
    }

    fn directions() -> Vec<Vector3<f64>> {
        let mut v = Vec::new();
        for el in [-60.0, -20.0, 0.0, 15.0, 45.0, 80.0] {
            for az in [-170.0, -95.0, -30.0, 0.0, 40.0, 90.0, 135.0, 180.0] {
                v.push(unit_from_angles(az, el));
            }
        }
        v
    }

    #[test]
    fn pair_indexing_is_dense() {
        let k = 7;
        let mut seen = vec![false; pair_count(k)];
        for a in 0..k {
            for b in a + 1..k {
                assert!(!seen[pair_index(a, b, k)]);
                seen[pair_index(a, b, k)] = true;
            }
        }
        assert!(seen.into_iter().all(|s| s));
    }

    #[test]
    fn exact_delays_give_exact_directions_3d() {
        let g = Geometry::from_positions(&[
            [0.25, 0.20, 0.18],
            [0.25, -0.20, 0.18],
            [-0.25, 0.20, 0.18],
            [-0.25, -0.20, 0.18],
            [0.25, 0.20, -0.18],
            [0.25, -0.20, -0.18],
            [-0.25, 0.20, -0.18],
            [-0.25, -0.20, -0.18],
        ])
        .unwrap();
        let solver = DirectionSolver::new(&g, 0xff, 48000.0, 343.0).unwrap();
        for u in directions() {
            let lags = exact_lags(&g.positions(), &u, 48000.0, 343.0);
            let got = solver.solve(&lags).unwrap();
            assert!(angle_between_deg(&got, &u) < 0.01, "{u:?} -> {got:?}");
        }
    }

    #[test]
    fn exact_delays_give_exact_directions_planar() {
        // A 6-mic circular array in the horizontal plane, reporting the upper half-space.
        let pos: Vec<[f64; 3]> = (0..6)
            .map(|i| {
                let a = i as f64 * std::f64::consts::PI / 3.0;
                [0.05 * a.cos(), 0.05 * a.sin(), 0.0]
            })
            .collect();
        let g = Geometry::from_positions(&pos).unwrap();
        let solver = DirectionSolver::new(&g, 0x3f, 16000.0, 343.0).unwrap();
        for u in directions() {
            let lags = exact_lags(&g.positions(), &u, 16000.0, 343.0);
            let got = solver.solve(&lags).unwrap();
            // The mirror image below the plane is reported above it.
            let expect = Vector3::new(u.x, u.y, u.z.abs());
            assert!(angle_between_deg(&got, &expect) < 0.01, "{u:?} -> {got:?}");
        }
    }

    #[test]
    fn exact_delays_give_exact_directions_linear() {
        // Along y; the default side (docs/interface.md) for an array not along x is +x.
        let g = Geometry::from_positions(&[
            [0.0, -0.1, 0.0],
            [0.0, 0.0, 0.0],
            [0.0, 0.05, 0.0],
            [0.0, 0.12, 0.0],
        ])
        .unwrap();
        let solver = DirectionSolver::new(&g, 0xf, 48000.0, 343.0).unwrap();
        let axis = match g.shape {
            Shape::Linear { axis } => axis,
            _ => unreachable!(),
        };
        for u in directions() {
            let lags = exact_lags(&g.positions(), &u, 48000.0, 343.0);
            let got = solver.solve(&lags).unwrap();
            // Same angle to the axis, in the axis-x plane, on the +x side.
            let cos = u.dot(&axis);
            let expect = axis * cos + Vector3::x() * (1.0 - cos * cos).sqrt();
            assert!(angle_between_deg(&got, &expect) < 0.01, "{u:?} -> {got:?}");
        }
    }

    #[test]
    fn angles_follow_the_contract() {
        let (az, el) = angles_deg(&Vector3::new(0.0, 1.0, 0.0));
        assert!((az - 90.0).abs() < 1e-12 && el.abs() < 1e-12);
        let (az, _) = angles_deg(&Vector3::new(-1.0, -0.0, 0.0));
        assert_eq!(az, 180.0);
        let (_, el) = angles_deg(&Vector3::new(0.0, 0.0, 1.0));
        assert!((el - 90.0).abs() < 1e-12);
        for u in directions() {
            let (az, el) = angles_deg(&u);
            assert!(az > -180.0 && az <= 180.0);
            assert!(angle_between_deg(&unit_from_angles(az, el), &u) < 1e-9);
        }
    }
}
