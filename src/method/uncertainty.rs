//! How far the true direction may lie from a detection's (beyond the paper): the
//! `uncertainty_deg` of docs/interface.md, the half-angle of the cone around the reported
//! direction that holds the true direction with 95% probability.
//!
//! Three parts, from the fit and the geometry:
//!
//! - **How much the microphones' times err** (seconds, standard deviation): the
//!   far-field fit's residual, scaled to an estimate of one microphone's timing error by
//!   its degrees of freedom (`sqrt(P / (P - q)) / sqrt(2)` for `P` pairs and `q`
//!   unknowns), combined with a floor that no misfit shows ([`FLOOR_S`]). A detection with
//!   no fit of its own (a rider, read from single frequency bins) takes [`NO_FIT_S`].
//! - **How much all delays shrink together** (a fraction): on an array smaller than a
//!   correlation peak, the floor's and ceiling's images merge with the direct sound's
//!   peak and pull every delay toward theirs. A planar array reads it as a higher
//!   elevation, a linear one as a direction nearer broadside ([`merge_share`]). A 3-D
//!   array's normalisation removes a common shrink, but the nearer image pulls its
//!   direction up or down ([`IMAGE_RISE`]).
//! - **What that does to the direction**: through the least squares of eq. (13)
//!   ([`Spread`]), mapped onto the sphere the way the direction is: normalised for a 3-D
//!   array; for a planar array the in-plane part, with the out-of-plane part from the
//!   unit norm (near the plane, where a small in-plane error is a large elevation error,
//!   the cone widens); for a linear array the angle to the axis, with the half-circle
//!   around the axis that such an array cannot tell apart.
//!
//! Planar and linear arrays cannot tell a direction from its mirror image; the cone
//! holds the true direction taken onto the `side` the geometry reports (docs/interface.md).
//! The constants were measured on simulated rooms with known truth and checked on
//! others (docs/method.md, "Uncertainty").

use crate::method::paper::direction::{DirectionSolver, Spread};
use nalgebra::{Matrix3, Vector2, Vector3};

/// The timing error (seconds, standard deviation per microphone) the residual cannot
/// see: reflections shift every pair's peak alike, which no plane wave's misfit shows.
pub(crate) const FLOOR_S: f64 = 6e-6;
/// The timing error (seconds) of a detection with no fit of its own (a rider).
pub(crate) const NO_FIT_S: f64 = 20e-6;
/// The fraction by which the delays of an array much smaller than a correlation peak may
/// all shrink together: the floor's and ceiling's images fall within the direct sound's
/// peak and pull every delay toward theirs (docs/method.md, "Uncertainty").
pub(crate) const MERGE_SHARE: f64 = 0.2;
/// How far the floor's or ceiling's image lies from the direct sound, in the vertical
/// component of the unit direction, as it pulls a 3-D array's direction: a share
/// [`MERGE_SHARE`] of it merged moves the direction up or down by that share of this
/// (docs/method.md, "Uncertainty").
pub(crate) const IMAGE_RISE: f64 = 0.3;
/// The width (seconds) of a speech correlation peak, over which images merge with the
/// direct sound: an array of this aperture keeps `exp(-1)` of [`MERGE_SHARE`].
pub(crate) const PEAK_S: f64 = 0.5e-3;

/// `--every-frame`'s rows under the detection threshold: at a margin under
/// [`WIDEN_BELOW`] the fit's cone is widened by `(WIDEN_BELOW / margin)^2` (the share of
/// rows the fit's cone held fell from 95% to 80% between margins 0.6 and 0.35 on nine
/// arrays); under [`GROSS_BELOW`] a frame peaks at a reflection or at the noise as often
/// as at the source, and the cone grows toward the whole sphere, reached at
/// [`ANYWHERE_BELOW`] (docs/method.md, "Uncertainty").
pub(crate) const WIDEN_BELOW: f64 = 0.6;
/// See [`WIDEN_BELOW`].
pub(crate) const GROSS_BELOW: f64 = 0.3;
/// See [`WIDEN_BELOW`].
pub(crate) const ANYWHERE_BELOW: f64 = 0.1;

/// The cone (degrees) of a row kept whatever it scores (`--every-frame`): the fit's cone
/// `fit_deg` widened for a `margin` over the detection threshold under [`WIDEN_BELOW`].
pub(crate) fn unvouched_cone_deg(fit_deg: f64, margin: f64) -> f64 {
    if margin >= WIDEN_BELOW {
        return fit_deg;
    }
    let widened = fit_deg * (WIDEN_BELOW / margin.max(1e-9)).powi(2);
    let gross = 180.0 * ((GROSS_BELOW - margin) / (GROSS_BELOW - ANYWHERE_BELOW)).clamp(0.0, 1.0);
    widened.max(gross).min(180.0)
}

/// `sqrt` of the 95% quantile of chi-squared with 2 degrees of freedom: a 2-D normal
/// lies within this many standard deviations (Mahalanobis) with 95% probability.
const K2: f64 = 2.447_746_830_680_816;
/// The same for one degree of freedom.
const K1: f64 = 1.959_963_984_540_054;
/// Points on the boundary of a planar array's error ellipse.
const ELLIPSE_POINTS: usize = 24;

/// The timing error (seconds, standard deviation per microphone) of a detection whose
/// far-field fit left `residual_m` (RMS over pairs, metres; `None`: no fit of its own).
/// A pair's lag is the difference of two microphones' times, so its variance is twice
/// theirs.
pub(crate) fn timing_sigma(solver: &DirectionSolver, residual_m: Option<f64>, speed: f64) -> f64 {
    let Some(r) = residual_m else {
        return NO_FIT_S;
    };
    let (p, q) = (solver.pairs(), solver.unknowns());
    let estimate = if p > q {
        r / speed * (p as f64 / (p - q) as f64).sqrt() / std::f64::consts::SQRT_2
    } else {
        0.0
    };
    FLOOR_S.hypot(estimate)
}

/// The fraction (standard deviation) by which all of an array's delays may shrink
/// together: [`MERGE_SHARE`] for an array much smaller than a correlation peak, falling
/// off as `exp(-(T / PEAK_S)^2)` with its aperture `T` in seconds.
pub(crate) fn merge_share(solver: &DirectionSolver, speed: f64) -> f64 {
    MERGE_SHARE * (-(solver.aperture_m() / speed / PEAK_S).powi(2)).exp()
}

/// The half-angle (degrees) of the 95% cone around `u` when every microphone's timing
/// errs by `sigma` seconds and all delays shrink together by a fraction `shrink`
/// (standard deviations): on a 3-D array, whose normalisation undoes a shrink, that
/// share of a vertical image pulls the direction by `shrink * IMAGE_RISE`.
pub(crate) fn cone_deg(spread: &Spread, u: &Vector3<f64>, sigma: f64, shrink: f64) -> f64 {
    let var = sigma * sigma;
    let deg = match spread {
        Spread::Volumetric(cov) => {
            // The error across the direction, along its worst axis: a ball of that
            // radius around the tip of the (unit) solution subtends asin(radius); one
            // that holds the origin leaves any direction possible.
            let across = Matrix3::identity() - u * u.transpose();
            // The share of the floor's or ceiling's image merged with the direct
            // sound pulls the direction up or down, across it (docs/interface.md: z up).
            let up = across * Vector3::z() * (shrink * IMAGE_RISE);
            let cov = across * (cov * var) * across + up * up.transpose();
            let worst = cov.symmetric_eigenvalues().max().max(0.0);
            let radius = K2 * worst.sqrt();
            if radius >= 1.0 {
                180.0
            } else {
                radius.asin().to_degrees()
            }
        }
        Spread::Planar {
            cov,
            e1,
            e2,
            normal,
        } => {
            let v = Vector2::new(u.dot(e1), u.dot(e2));
            let eigen = (cov * var + v * v.transpose() * (shrink * shrink)).symmetric_eigen();
            let onto = |p: Vector2<f64>| {
                let r2 = p.norm_squared();
                let inplane = e1 * p.x + e2 * p.y;
                if r2 >= 1.0 {
                    inplane / r2.sqrt()
                } else {
                    inplane + normal * (1.0 - r2).sqrt()
                }
            };
            // Both unit vectors: the farthest point has the least dot product.
            let (a, b) = (
                eigen.eigenvectors.column(0) * (K2 * eigen.eigenvalues[0].max(0.0).sqrt()),
                eigen.eigenvectors.column(1) * (K2 * eigen.eigenvalues[1].max(0.0).sqrt()),
            );
            let nearest = (0..ELLIPSE_POINTS)
                .map(|i| {
                    let (sin, cos) =
                        (std::f64::consts::TAU * i as f64 / ELLIPSE_POINTS as f64).sin_cos();
                    onto(v + a * cos + b * sin).dot(u)
                })
                .fold(1.0, f64::min);
            nearest.clamp(-1.0, 1.0).acos().to_degrees()
        }
        Spread::Linear {
            var: unit, axis, ..
        } => {
            // The true direction makes an angle with the axis whose cosine lies within
            // K1 standard deviations of the measured one, anywhere on the half-circle
            // around the axis on the reported side: farthest a quarter turn around.
            let c = u.dot(axis).clamp(-1.0, 1.0);
            let half = K1 * (unit * var + (shrink * c).powi(2)).sqrt();
            let (lo, hi) = ((c - half).max(-1.0), (c + half).min(1.0));
            (c * lo).min(c * hi).clamp(-1.0, 1.0).acos().to_degrees()
        }
    };
    deg.clamp(0.0, 180.0)
}

/// The uncertainty (degrees) of direction `u` from `solver` with the fit's residual
/// `residual_m` (`None`: no fit of its own), sound travelling at `speed` (m/s).
pub(crate) fn uncertainty_deg(
    solver: &DirectionSolver,
    u: &Vector3<f64>,
    residual_m: Option<f64>,
    speed: f64,
) -> f64 {
    let sigma = timing_sigma(solver, residual_m, speed);
    cone_deg(solver.spread(), u, sigma, merge_share(solver, speed))
}

#[cfg(test)]
mod tests {
    //! The cone against brute force: exact far-field lags with known timing noise on
    //! every microphone, solved as the method solves them, thousands of times; the
    //! true direction must lie in the cone computed at the solved direction about 95%
    //! of the time, no less and not much more.

    use super::*;
    use crate::geometry::Geometry;
    use crate::geometry::{angle_between_deg, unit_from_angles};
    use crate::method::pairs::{pair_count, pair_index};
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    const FS: f64 = 16000.0;
    const C: f64 = 343.0;

    #[test]
    fn an_unvouched_cone_widens_as_the_margin_falls_to_the_whole_sphere() {
        // At and over WIDEN_BELOW: the fit's cone.
        assert_eq!(unvouched_cone_deg(1.5, 0.6), 1.5);
        assert_eq!(unvouched_cone_deg(1.5, f64::INFINITY), 1.5);
        // Widened by (0.6 / margin)^2, then the reflections' floor.
        assert!((unvouched_cone_deg(2.0, 0.3) - 8.0).abs() < 1e-9);
        assert!((unvouched_cone_deg(2.0, 0.2) - 90.0).abs() < 1e-9);
        assert_eq!(unvouched_cone_deg(2.0, 0.1), 180.0);
        assert_eq!(unvouched_cone_deg(2.0, 0.0), 180.0);
        let mut last = 0.0;
        for i in (0..=100).rev() {
            let c = unvouched_cone_deg(3.0, i as f64 / 100.0);
            assert!(c >= last && c <= 180.0, "margin {}: {c}", i as f64 / 100.0);
            last = c;
        }
    }

    /// The share of `trials` noisy solves per direction in `directions` whose truth
    /// (`truth(u)`, from the direction the lags were made for) lies in the cone, and the
    /// median cone. `pull`: the standard deviation of a vertical image's pull on the
    /// direction (the lags are made for `u + z * N(0, pull)`), with `shrink` the share
    /// the cone is told.
    fn coverage(
        positions: &[[f64; 3]],
        directions: &[(f64, f64)],
        sigma_s: f64,
        (pull, shrink): (f64, f64),
        truth: impl Fn(&Vector3<f64>) -> Vector3<f64>,
    ) -> (f64, f64) {
        let g = Geometry::from_positions(positions).unwrap();
        let k = positions.len();
        let solver = DirectionSolver::new(&g, (1u64 << k) - 1, FS, C).unwrap();
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let noise = Normal::new(0.0, sigma_s * FS).unwrap();
        let pulled = Normal::new(0.0, pull.max(1e-12)).unwrap();
        let (mut inside, mut all, mut cones) = (0usize, 0usize, Vec::new());
        for &(az, el) in directions {
            let u = unit_from_angles(az, el);
            for _ in 0..400 {
                // t_i = -u . p_i / c plus noise, in samples; lag_ab = t_a - t_b.
                let heard = u + Vector3::z() * pulled.sample(&mut rng);
                let t: Vec<f64> = g
                    .positions()
                    .iter()
                    .map(|p| -heard.dot(p) / C * FS + noise.sample(&mut rng))
                    .collect();
                let mut lags = vec![0.0; pair_count(k)];
                for a in 0..k {
                    for b in a + 1..k {
                        lags[pair_index(a, b, k)] = t[a] - t[b];
                    }
                }
                let Some(got) = solver.solve(&lags) else {
                    continue;
                };
                let cone = cone_deg(solver.spread(), &got, sigma_s, shrink);
                inside += usize::from(angle_between_deg(&got, &truth(&u)) <= cone);
                all += 1;
                cones.push(cone);
            }
        }
        cones.sort_by(f64::total_cmp);
        (inside as f64 / all as f64, cones[cones.len() / 2])
    }

    fn around() -> Vec<(f64, f64)> {
        let mut v = Vec::new();
        for el in [5.0, 20.0, 45.0, 70.0] {
            for az in [-150.0, -60.0, 0.0, 35.0, 120.0] {
                v.push((az, el));
            }
        }
        v
    }

    #[test]
    fn a_3d_arrays_cone_holds_95_percent() {
        let a = 0.065 / (2.0 * 2f64.sqrt());
        let tetra = [[a, a, a], [a, -a, -a], [-a, a, -a], [-a, -a, a]];
        let (share, median) = coverage(&tetra, &around(), 10e-6, (0.0, 0.0), |u| *u);
        // The cone takes the worst axis of the error ellipse: a little over 95%.
        assert!(
            (0.94..=0.995).contains(&share),
            "{share} (median {median} deg)"
        );
        assert!(median > 1.0 && median < 30.0, "{median}");
    }

    #[test]
    fn a_3d_arrays_cone_holds_a_vertical_images_pull() {
        // A 10 cm sphere-like array at 16 kHz, little timing noise, and the direction
        // pulled up or down as a merged floor or ceiling image pulls it: the share the
        // cone is told, times IMAGE_RISE, is the pull's standard deviation.
        let a = 0.05 / 3f64.sqrt();
        let cube: Vec<[f64; 3]> = (0..8)
            .map(|i| {
                let s = |b: usize| if i >> b & 1 == 1 { a } else { -a };
                [s(0), s(1), s(2)]
            })
            .collect();
        let shrink = 0.15;
        let pull = shrink * IMAGE_RISE;
        let (held, median) = coverage(&cube, &around(), 2e-6, (pull, shrink), |u| *u);
        assert!((0.94..=0.999).contains(&held), "{held} ({median} deg)");
        // Told no share, the cone is the timing's only, and the pull escapes it.
        let (blind, _) = coverage(&cube, &around(), 2e-6, (pull, 0.0), |u| *u);
        assert!(blind < 0.8, "{blind}");
    }

    #[test]
    fn a_planar_arrays_cone_holds_95_percent_and_widens_near_its_plane() {
        let circle: Vec<[f64; 3]> = (0..6)
            .map(|i| {
                let a = i as f64 * std::f64::consts::PI / 3.0;
                [0.0463 * a.cos(), 0.0463 * a.sin(), 0.0]
            })
            .collect();
        // Sources below the plane are reported above it: the truth on that side.
        let up = |u: &Vector3<f64>| Vector3::new(u.x, u.y, u.z.abs());
        let (share, _) = coverage(&circle, &around(), 5e-6, (0.0, 0.0), up);
        assert!((0.93..=0.995).contains(&share), "{share}");
        let (_, near) = coverage(&circle, &[(30.0, 5.0)], 5e-6, (0.0, 0.0), up);
        let (_, high) = coverage(&circle, &[(30.0, 60.0)], 5e-6, (0.0, 0.0), up);
        assert!(
            near > 2.0 * high,
            "near the plane {near} deg, high {high} deg"
        );
    }

    #[test]
    fn a_linear_arrays_cone_holds_the_half_circle_around_its_axis() {
        let line = [
            [-0.07, 0.0, 0.0],
            [-0.02, 0.0, 0.0],
            [0.03, 0.0, 0.0],
            [0.07, 0.0, 0.0],
        ];
        // The worst truth for a reported direction: a quarter turn around the axis
        // (from the +y side the array reports to +z).
        let turned = |u: &Vector3<f64>| {
            let across = (u.y * u.y + u.z * u.z).sqrt();
            Vector3::new(u.x, 0.0, across)
        };
        let dirs: Vec<(f64, f64)> = [10.0, 40.0, 70.0, 100.0, 150.0]
            .iter()
            .map(|&az| (az, 0.0))
            .collect();
        let (share, _) = coverage(&line, &dirs, 10e-6, (0.0, 0.0), turned);
        assert!(share >= 0.95, "{share}");
        // Broadside, the array knows nothing around its axis: a quarter turn either way.
        let (_, broadside) = coverage(&line, &[(90.0, 0.0)], 1e-9, (0.0, 0.0), turned);
        assert!((broadside - 90.0).abs() < 0.5, "{broadside}");
    }
}
