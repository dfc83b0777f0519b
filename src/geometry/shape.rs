//! What an array's shape lets it resolve: 3-D, planar or linear, and the `side` that
//! picks one of the directions a planar or linear array cannot tell apart
//! (docs/interface.md, "Geometry file").

use super::{GeometryError, FLATNESS};
use crate::text::fixed;
use nalgebra::{Matrix3, SymmetricEigen, Vector3};

type Result<T> = std::result::Result<T, GeometryError>;

/// What a set of microphone positions can resolve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// All microphones on one line (unit axis vector): only the angle to the axis is known.
    Linear {
        /// Unit vector along the array.
        axis: Vector3<f64>,
    },
    /// All microphones in one plane (unit normal, oriented toward `side`): up/down ambiguous.
    Planar {
        /// Unit normal of the plane, on the `side` directions are reported on.
        normal: Vector3<f64>,
    },
    /// Microphones span 3-D space: the full direction is determined.
    Volumetric,
}

impl Shape {
    /// The same shape seen through `rotation` (array frame to room frame).
    pub fn rotated(&self, rotation: &nalgebra::Matrix3<f64>) -> Shape {
        match *self {
            Shape::Linear { axis } => Shape::Linear {
                axis: rotation * axis,
            },
            Shape::Planar { normal } => Shape::Planar {
                normal: rotation * normal,
            },
            Shape::Volumetric => Shape::Volumetric,
        }
    }

    /// `3-D`, `planar` or `linear`.
    pub fn label(&self) -> &'static str {
        match self {
            Shape::Linear { .. } => "linear",
            Shape::Planar { .. } => "planar",
            Shape::Volumetric => "3-D",
        }
    }
}

/// Classifies positions by the spread of their principal axes: the square roots of the
/// eigenvalues of the scatter matrix. An axis whose spread is below [`FLATNESS`] times
/// the largest counts as flat: solving it in 3-D would amplify timing noise on it by
/// the inverse of that ratio.
pub(super) fn classify(positions: &[Vector3<f64>]) -> RawShape {
    let n = positions.len() as f64;
    let centre = positions.iter().sum::<Vector3<f64>>() / n;
    let mut scatter = Matrix3::zeros();
    for p in positions {
        let d = p - centre;
        scatter += d * d.transpose();
    }
    let eig = SymmetricEigen::new(scatter);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let spread = |k: usize| eig.eigenvalues[order[k]].max(0.0).sqrt();
    let axis = |k: usize| eig.eigenvectors.column(order[k]).into_owned().normalize();
    if spread(1) < FLATNESS * spread(0) {
        RawShape::Linear(axis(0))
    } else if spread(2) < FLATNESS * spread(0) {
        RawShape::Planar(axis(2))
    } else {
        RawShape::Volumetric
    }
}

pub(super) enum RawShape {
    Linear(Vector3<f64>),
    Planar(Vector3<f64>),
    Volumetric,
}

/// Applies the `side` rules of docs/interface.md: a planar array reports directions on the side of
/// its plane that `side` points to (default +z; +x when the plane contains the z axis;
/// +y when it contains both); a linear array reports directions in the plane of its axis
/// and `side`, on `side`'s side (default +x; +y when the array lies along x).
pub(super) fn orient(raw: RawShape, side: Option<Vector3<f64>>) -> Result<(Shape, Vector3<f64>)> {
    const PARALLEL: f64 = 1e-6;
    let (x, y, z) = (Vector3::x(), Vector3::y(), Vector3::z());
    match raw {
        RawShape::Volumetric => Ok((Shape::Volumetric, side.unwrap_or(z))),
        RawShape::Planar(n) => {
            let s = match side {
                Some(s) => {
                    if n.dot(&s).abs() < PARALLEL * s.norm() {
                        fail!(
GeometryError::Invalid,
                            "side {:?} lies in the plane of this planar array: it must point out of the plane (normal {:?})",
                            s.as_slice(),
                            round3(&n)
                        );
                    }
                    s
                }
                None => [z, x, y]
                    .into_iter()
                    .find(|c| n.dot(c).abs() > PARALLEL)
                    .expect("a unit normal is not orthogonal to all three axes"),
            };
            let normal = if n.dot(&s) < 0.0 { -n } else { n };
            Ok((Shape::Planar { normal }, s))
        }
        RawShape::Linear(a) => {
            let s = match side {
                Some(s) => {
                    if (s - a * a.dot(&s)).norm() < PARALLEL * s.norm() {
                        fail!(
GeometryError::Invalid,
                            "side {:?} is parallel to the axis of this linear array: it must point away from the axis",
                            s.as_slice()
                        );
                    }
                    s
                }
                None => {
                    if (x - a * a.dot(&x)).norm() > 1e-3 {
                        x
                    } else {
                        y
                    }
                }
            };
            Ok((Shape::Linear { axis: a }, s))
        }
    }
}

fn round3(v: &Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z].map(|c| fixed(c, 3))
}
