//! Directions as angles and unit vectors (docs/interface.md, "Directions"), the one
//! definition every stage, record and score uses.

use nalgebra::Vector3;

/// Azimuth and elevation in degrees (docs/interface.md, "Directions"): azimuth = atan2(y, x) in
/// (-180, 180], elevation = asin(z).
pub fn angles_deg(u: &Vector3<f64>) -> (f64, f64) {
    let mut az = u.y.atan2(u.x).to_degrees();
    if az <= -180.0 {
        az += 360.0;
    }
    let el = u.z.clamp(-1.0, 1.0).asin().to_degrees();
    (az, el)
}

/// The unit vector for an azimuth and elevation in degrees (inverse of [`angles_deg`]).
pub fn unit_from_angles(azimuth_deg: f64, elevation_deg: f64) -> Vector3<f64> {
    let (az, el) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
    Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin())
}

/// Angle between two directions in degrees.
pub fn angle_between_deg(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    // atan2 of cross and dot is accurate at small angles, unlike acos of the dot.
    a.cross(b).norm().atan2(a.dot(b)).to_degrees()
}
