//! What a score measures (docs/interface.md, "Ground truth of a measured setup"): the
//! 3-D angle, or what the array observes, its azimuth for a planar array (the angle about
//! its normal) and the angle to its axis for a linear one. Scoring a planar array's
//! elevation, which it resolves poorly, or a linear array's angle around its axis, which
//! it does not resolve at all, would count good results as misses.

use crate::geometry::angle_between_deg;
use crate::geometry::{Geometry, Shape};
use nalgebra::Vector3;

/// How far a direction is from the truth.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Metric {
    /// The angle between the two directions.
    #[default]
    ThreeD,
    /// The angle between their projections onto the plane normal to `normal` (a planar
    /// array's plane; the azimuth for a horizontal one).
    Azimuth {
        /// The unit normal of the plane.
        normal: Vector3<f64>,
    },
    /// The difference of their angles to `axis` (a linear array's).
    Axis {
        /// The unit axis.
        axis: Vector3<f64>,
    },
}

impl Metric {
    /// What `geometry` observes: azimuth about a planar array's normal, the angle to a
    /// linear array's axis, else the 3-D angle.
    pub fn of_geometry(geometry: &Geometry) -> Self {
        match geometry.shape {
            Shape::Volumetric => Metric::ThreeD,
            Shape::Planar { normal } => Metric::Azimuth { normal },
            Shape::Linear { axis } => Metric::Axis { axis },
        }
    }

    /// The metric named `asked` (`3d`, `azimuth` or `axis`, as `--metric` names them),
    /// or, when none is, what `geometry` observes (the 3-D angle when no geometry is
    /// known). The azimuth is about a planar `geometry`'s normal, else about z; `axis`
    /// needs a linear `geometry`.
    pub fn asked(asked: Option<&str>, geometry: Option<&Geometry>) -> Result<Self, String> {
        let shape = geometry.map(|g| g.shape);
        Ok(match (asked, shape) {
            (None, Some(_)) => Metric::of_geometry(geometry.expect("a shape")),
            (None, None) | (Some("3d"), _) => Metric::ThreeD,
            (Some("azimuth"), Some(Shape::Planar { normal })) => Metric::Azimuth { normal },
            (Some("azimuth"), _) => Metric::azimuth(),
            (Some("axis"), Some(Shape::Linear { axis })) => Metric::Axis { axis },
            (Some("axis"), _) => return Err("axis needs a linear array's geometry".into()),
            (Some(other), _) => {
                return Err(format!("`{other}` is not a metric: 3d, azimuth or axis"))
            }
        })
    }

    /// The azimuth about the z axis (the `azimuth_deg` of the results).
    pub fn azimuth() -> Self {
        Metric::Azimuth {
            normal: Vector3::z(),
        }
    }

    /// Its name in reports: `3-D angle`, `azimuth` or `angle to the axis`.
    pub fn name(&self) -> &'static str {
        match self {
            Metric::ThreeD => "3-D angle",
            Metric::Azimuth { .. } => "azimuth",
            Metric::Axis { .. } => "angle to the axis",
        }
    }

    /// The error (degrees) of direction `got` against the true `truth`.
    pub fn error_deg(&self, got: &Vector3<f64>, truth: &Vector3<f64>) -> f64 {
        match self {
            Metric::ThreeD => angle_between_deg(got, truth),
            Metric::Azimuth { normal } => {
                let flat = |u: &Vector3<f64>| u - normal * normal.dot(u);
                let (a, b) = (flat(got), flat(truth));
                // Straight along the normal the azimuth is undefined: the 3-D angle.
                if a.norm() < 1e-9 || b.norm() < 1e-9 {
                    angle_between_deg(got, truth)
                } else {
                    angle_between_deg(&a, &b)
                }
            }
            Metric::Axis { axis } => {
                // Directions of any length (an event's is the sum of its rows'): its
                // cosine to the axis from the unit vector.
                let to_axis = |u: &Vector3<f64>| {
                    let cos = u.dot(axis) / u.norm().max(1e-300);
                    cos.clamp(-1.0, 1.0).acos().to_degrees()
                };
                (to_axis(got) - to_axis(truth)).abs()
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::unit_from_angles;

    #[test]
    fn each_metric_measures_what_the_array_observes() {
        let (got, truth) = (unit_from_angles(31.0, 25.0), unit_from_angles(30.0, 10.0));
        assert!((Metric::ThreeD.error_deg(&got, &truth) - 15.0).abs() < 0.5);
        assert!((Metric::azimuth().error_deg(&got, &truth) - 1.0).abs() < 1e-9);
        // A line along x: both at 60 deg from it, one above, one beside.
        let axis = Metric::Axis { axis: Vector3::x() };
        let (a, b) = (
            Vector3::new(0.5, 0.866_025_403_784_438_6, 0.0),
            Vector3::new(0.5, 0.0, 0.866_025_403_784_438_6),
        );
        assert!(axis.error_deg(&a, &b) < 1e-6);
        assert!((axis.error_deg(&Vector3::x(), &b) - 60.0).abs() < 1e-6);
        // An event's direction is the sum of its rows': nine rows at `a` are `a`.
        assert!(axis.error_deg(&(a * 9.0), &b) < 1e-6);
        assert!((axis.error_deg(&(Vector3::x() * 9.0), &b) - 60.0).abs() < 1e-6);
        let g = Geometry::from_positions(&[[0.05, 0.0, 0.0], [-0.05, 0.0, 0.0], [0.0, 0.05, 0.0]])
            .unwrap();
        assert_eq!(Metric::of_geometry(&g).name(), "azimuth");
    }
}
