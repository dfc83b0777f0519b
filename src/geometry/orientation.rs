//! The array's pose in the room (docs/interface.md, "Geometry file", `[orientation]`):
//! a rotation from the array frame, in which the positions are written, to the room
//! frame, in which directions are reported. Given as yaw, pitch and roll in degrees or as
//! a 3x3 matrix.

use super::GeometryError;
use crate::text::{fixed, BriefNumber};
use nalgebra::{Matrix3, Vector3};
use serde::Deserialize;

/// How far a given matrix may be from a rotation (largest entry of `M^T M - I`, and of
/// `det M - 1`): matrices written with 4 decimals pass, a scaled or sheared one does not.
const ROTATION_TOLERANCE: f64 = 1e-3;

/// The `[orientation]` table as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct OrientationEntry {
    yaw_deg: Option<f64>,
    pitch_deg: Option<f64>,
    roll_deg: Option<f64>,
    #[serde(default, deserialize_with = "rows_opt")]
    matrix: Option<[[f64; 3]; 3]>,
}

/// `[orientation]` as a table only: serde would read a list `[1, 2, 3]` as yaw, pitch
/// and roll by position, which the file format does not mean.
pub(super) fn table_only<'de, D>(d: D) -> Result<Option<OrientationEntry>, D::Error>
where
    D: serde::Deserializer<'de>,
{
    struct Table;
    impl<'de> serde::de::Visitor<'de> for Table {
        type Value = OrientationEntry;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a table [orientation] with yaw_deg, pitch_deg and roll_deg, or matrix")
        }
        fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<Self::Value, A::Error> {
            OrientationEntry::deserialize(serde::de::value::MapAccessDeserializer::new(map))
        }
    }
    d.deserialize_map(Table).map(Some)
}

fn rows_opt<'de, D>(d: D) -> Result<Option<[[f64; 3]; 3]>, D::Error>
where
    D: serde::Deserializer<'de>,
{
    use serde::de::Error;
    let rows: Option<Vec<Vec<f64>>> = Deserialize::deserialize(d)?;
    let Some(rows) = rows else { return Ok(None) };
    if rows.len() != 3 || rows.iter().any(|r| r.len() != 3) {
        return Err(D::Error::custom(format!(
            "matrix must be 3 rows of 3 numbers, got {} row(s) of {:?} numbers",
            rows.len(),
            rows.iter().map(Vec::len).collect::<Vec<_>>()
        )));
    }
    Ok(Some(
        [0, 1, 2].map(|i| [rows[i][0], rows[i][1], rows[i][2]]),
    ))
}

/// The rotation from the array frame to the room frame: `v_room = R v_array`.
pub fn from_angles(yaw_deg: f64, pitch_deg: f64, roll_deg: f64) -> Matrix3<f64> {
    let (y, p, r) = (
        yaw_deg.to_radians(),
        pitch_deg.to_radians(),
        roll_deg.to_radians(),
    );
    // Roll about x lifts +y toward +z; pitch about y lifts +x toward +z (a rotation of
    // -pitch about +y); yaw about z turns +x toward +y. Applied in that order.
    let roll = nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), r);
    let pitch = nalgebra::Rotation3::from_axis_angle(&Vector3::y_axis(), -p);
    let yaw = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), y);
    (yaw * pitch * roll).into_inner()
}

impl OrientationEntry {
    /// The rotation this table describes, validated.
    pub(super) fn rotation(&self) -> Result<Matrix3<f64>, GeometryError> {
        let angles = [self.yaw_deg, self.pitch_deg, self.roll_deg];
        let any_angle = angles.iter().any(Option::is_some);
        match (&self.matrix, any_angle) {
            (Some(_), true) => fail!(
                GeometryError::Invalid,
                "[orientation] gives both a matrix and angles: give one or the other"
            ),
            (None, false) => fail!(
                GeometryError::Invalid,
                "[orientation] is empty: give yaw_deg, pitch_deg and roll_deg (any may be left out as 0), or a matrix"
            ),
            (None, true) => {
                let [yaw, pitch, roll] = angles.map(|a| a.unwrap_or(0.0));
                for (name, v) in [("yaw_deg", yaw), ("pitch_deg", pitch), ("roll_deg", roll)] {
                    if !v.is_finite() || v.abs() > 360.0 {
                        fail!(
                            GeometryError::Invalid,
                            "[orientation] {name} must be a finite angle of at most 360 degrees, got {v}"
                        );
                    }
                }
                Ok(from_angles(yaw, pitch, roll))
            }
            (Some(rows), false) => {
                let m = Matrix3::from_fn(|i, j| rows[i][j]);
                if !m.iter().all(|v| v.is_finite()) {
                    fail!(
                        GeometryError::Invalid,
                        "[orientation] matrix holds a non-finite number"
                    );
                }
                let off = (m.transpose() * m - Matrix3::identity()).abs().max();
                let det = m.determinant();
                if off > ROTATION_TOLERANCE || (det - 1.0).abs() > ROTATION_TOLERANCE {
                    fail!(
                        GeometryError::Invalid,
                        "[orientation] matrix is not a rotation (its rows must be orthogonal unit vectors and its determinant 1; it is {}{})",
                        BriefNumber(fixed(det, 4)),
                        if det < 0.0 { ": a mirror image, one axis reversed" } else { "" }
                    );
                }
                Ok(nearest_rotation(m))
            }
        }
    }
}

/// The rotation nearest `m` (its polar factor), so a matrix written with a few decimals
/// rotates without scaling.
fn nearest_rotation(m: Matrix3<f64>) -> Matrix3<f64> {
    let svd = m.svd(true, true);
    let (u, v_t) = (svd.u.expect("asked for"), svd.v_t.expect("asked for"));
    u * v_t
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vector3<f64>, b: Vector3<f64>) -> bool {
        (a - b).norm() < 1e-12
    }

    #[test]
    fn each_angle_turns_the_axis_it_names_the_way_it_says() {
        let s = std::f64::consts::FRAC_1_SQRT_2;
        // Yaw 90: forward becomes left.
        assert!(close(
            from_angles(90.0, 0.0, 0.0) * Vector3::x(),
            Vector3::y()
        ));
        // Pitch 45: forward tilts up.
        assert!(close(
            from_angles(0.0, 45.0, 0.0) * Vector3::x(),
            Vector3::new(s, 0.0, s)
        ));
        // Roll 90: left becomes up.
        assert!(close(
            from_angles(0.0, 0.0, 90.0) * Vector3::y(),
            Vector3::z()
        ));
        // Order: roll, then pitch, then yaw. Pitch 90 then yaw 90 sends forward up and
        // left to... the array's y axis, turned by yaw: -x.
        let r = from_angles(90.0, 90.0, 0.0);
        assert!(close(r * Vector3::x(), Vector3::z()));
        assert!(close(r * Vector3::y(), -Vector3::x()));
    }

    #[test]
    #[allow(clippy::approx_constant)] // A matrix as a person writes it, with 4 decimals.
    fn matrices_are_checked_and_cleaned() {
        let entry = |m: [[f64; 3]; 3]| OrientationEntry {
            yaw_deg: None,
            pitch_deg: None,
            roll_deg: None,
            matrix: Some(m),
        };
        // Yaw 45 written with 4 decimals: accepted, made exactly orthonormal.
        let r = entry([
            [0.7071, -0.7071, 0.0],
            [0.7071, 0.7071, 0.0],
            [0.0, 0.0, 1.0],
        ])
        .rotation()
        .unwrap();
        assert!((r.transpose() * r - Matrix3::identity()).abs().max() < 1e-12);
        assert!((r - from_angles(45.0, 0.0, 0.0)).abs().max() < 1e-4);
        // A mirror and a scale are refused.
        let mirror = entry([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]).rotation();
        assert!(mirror.unwrap_err().to_string().contains("mirror"));
        assert!(entry([[2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
            .rotation()
            .is_err());
    }
}
