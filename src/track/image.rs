//! Vertical reflections: a talker's floor and ceiling images.
//!
//! A room's floor and ceiling mirror a talker straight below and above itself: its
//! images reach the array from the talker's azimuth at another elevation (a talker
//! 1.5 m away, 0.4 m above the array, has its floor image about 55 deg below it and its
//! ceiling image about 55 deg above), a few milliseconds after it, with the same
//! signal. A small array hears them as coherent sources: on the tetrahedron in the
//! tracking benchmark's room, a talker's floor image scored as high as the talker and
//! became a track of its own in three of its turns (docs/tracking.md). The tracker
//! therefore does not start a source at the azimuth of a track that is talking, at an
//! elevation far from it: such a candidate is that track's reflection.
//!
//! The array frame's z axis is taken as vertical (docs/interface.md: z up), so a
//! mounted array's frame must be level for the rule to hold.

use nalgebra::Vector3;

/// A candidate within this many degrees of a talking track's azimuth (measured in the
/// horizontal plane)...
pub(crate) const IMAGE_AZIMUTH_DEG: f64 = 6.0;

/// ...and at least this many degrees from its elevation is its vertical reflection.
pub const IMAGE_ELEVATION_DEG: f64 = 20.0;

/// A track is talking when its last detection is at most this old (seconds).
pub const IMAGE_TALKING_S: f64 = 0.5;

/// Azimuths are compared only for directions at most this far from the horizontal
/// plane (degrees): near the zenith an azimuth means little.
pub(crate) const IMAGE_MAX_ELEVATION_DEG: f64 = 80.0;

/// Whether `candidate` (its cone of half-angle `cone_deg`) looks like a vertical
/// reflection of a source heard from `source`: the same azimuth (within
/// [`IMAGE_AZIMUTH_DEG`]; any, when its cone holds the zenith or the nadir, where an
/// azimuth means nothing), an elevation at least [`IMAGE_ELEVATION_DEG`] away, both
/// within [`IMAGE_MAX_ELEVATION_DEG`] of the horizontal plane. A small planar array
/// reads a ceiling image high above its plane, where its azimuth is loose: a talker's
/// image on a 6-mic circle of 4.63 cm at 68 deg of elevation read 75 deg from his
/// azimuth, its cone 68 deg wide (`benches/voices.py --seed 300`).
pub fn is_vertical_image(candidate: &Vector3<f64>, cone_deg: f64, source: &Vector3<f64>) -> bool {
    let elevation = |u: &Vector3<f64>| u.z.clamp(-1.0, 1.0).asin().to_degrees();
    let within = if cone_deg >= 90.0 - elevation(candidate).abs() {
        180.0
    } else {
        IMAGE_AZIMUTH_DEG
    };
    in_plane_within(candidate, source, within)
        && (elevation(candidate) - elevation(source)).abs() >= IMAGE_ELEVATION_DEG
}

/// Whether `candidate` is at `source`'s azimuth (within [`IMAGE_AZIMUTH_DEG`]), both
/// within [`IMAGE_MAX_ELEVATION_DEG`] of the horizontal plane: where its vertical
/// reflections are heard, at whatever elevation (the evidence counts nothing there
/// while the source talks: `evidence::ACTIVE_S`; a clap's floor image 19 deg below it
/// was a false source on the fresh draws).
pub fn in_vertical_plane(candidate: &Vector3<f64>, source: &Vector3<f64>) -> bool {
    in_plane_within(candidate, source, IMAGE_AZIMUTH_DEG)
}

/// How long (seconds) an accumulated look nearer the horizontal plane makes one in its
/// vertical plane suspect ([`may_be_image_of`]): a faint talker is heard in scattered
/// looks over his words, his floor image in others (scene 8111 of `benches/words.py
/// --seed 8100 --only hard`: his look at 0.63 s, his floor image's at 1.45-2.36 s,
/// which otherwise became a source). 5 s measured the same as 2 s on the hard rooms.
pub const LOOKED_S: f64 = 2.0;

/// Whether `candidate` may be a vertical reflection of a sound heard from `source`: at
/// its azimuth ([`is_vertical_image`], no cone) and farther from the horizontal plane.
/// A floor or ceiling image always is, for a level array and a source inside the
/// room: the floor image of a source `h_s` above the floor, heard by an array `h_a`
/// above it, is `h_s + h_a` below the array against `|h_s - h_a|` for the source, at
/// the same horizontal distance (the ceiling alike, with the heights under it).
pub fn may_be_image_of(candidate: &Vector3<f64>, source: &Vector3<f64>) -> bool {
    is_vertical_image(candidate, 0.0, source) && candidate.z.abs() > source.z.abs()
}

/// [`in_vertical_plane`] within `azimuth_deg` of azimuth.
fn in_plane_within(candidate: &Vector3<f64>, source: &Vector3<f64>, azimuth_deg: f64) -> bool {
    let elevation = |u: &Vector3<f64>| u.z.clamp(-1.0, 1.0).asin().to_degrees();
    let (ec, es) = (elevation(candidate), elevation(source));
    if ec.abs() > IMAGE_MAX_ELEVATION_DEG || es.abs() > IMAGE_MAX_ELEVATION_DEG {
        return false;
    }
    let azimuth = |u: &Vector3<f64>| u.y.atan2(u.x).to_degrees();
    let mut apart = (azimuth(candidate) - azimuth(source)).abs() % 360.0;
    if apart > 180.0 {
        apart = 360.0 - apart;
    }
    apart <= azimuth_deg
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::unit_from_angles;

    #[test]
    fn images_share_the_azimuth_at_another_elevation() {
        let talker = unit_from_angles(-90.0, 15.0);
        let image = |az, el| is_vertical_image(&unit_from_angles(az, el), 0.0, &talker);
        // Its floor image as measured on the tetrahedron (docs/tracking.md).
        assert!(image(-90.2, -46.4));
        assert!(image(-86.0, 70.0));
        // Another talker beside it, or just above it, is not.
        assert!(!image(-80.0, -46.4));
        assert!(!image(-90.0, 30.0));
        // Across the +-180 deg seam.
        let behind = unit_from_angles(179.0, 10.0);
        assert!(is_vertical_image(
            &unit_from_angles(-177.0, -45.0),
            0.0,
            &behind
        ));
        // Near the zenith, azimuths are not compared.
        assert!(!image(-90.0, 85.0));
    }

    #[test]
    fn an_image_is_farther_from_the_horizontal_than_its_source() {
        // The prism's faint talker and his floor image (`benches/words.py --seed 8100`,
        // scene 8111), and a talker 5 deg under the array's plane with his (scene 7105).
        let talker = unit_from_angles(-109.3, 12.1);
        assert!(may_be_image_of(&unit_from_angles(-111.1, -54.0), &talker));
        assert!(!may_be_image_of(&talker, &unit_from_angles(-111.1, -54.0)));
        let low = unit_from_angles(-127.5, -5.5);
        assert!(may_be_image_of(&unit_from_angles(-127.5, -38.1), &low));
        assert!(!may_be_image_of(&low, &unit_from_angles(-127.5, -38.1)));
        // Not at another azimuth, nor within the elevations of one source.
        assert!(!may_be_image_of(&unit_from_angles(-90.0, -54.0), &talker));
        assert!(!may_be_image_of(&unit_from_angles(-109.3, 25.0), &talker));
    }

    #[test]
    fn an_image_whose_cone_holds_the_zenith_is_at_any_azimuth() {
        // The 6-mic circle's ceiling image (benches/voices.py --seed 300): 75 deg from
        // the talker's azimuth at 68 deg of elevation, its cone 68 deg wide.
        let talker = unit_from_angles(4.1, 29.9);
        let image = |az, el, cone| is_vertical_image(&unit_from_angles(az, el), cone, &talker);
        assert!(image(-70.8, 67.9, 68.0));
        assert!(!image(-70.8, 67.9, 10.0));
        // A cone short of the pole leaves the azimuth to compare.
        assert!(!image(-16.0, 67.9, 20.0));
        assert!(image(-16.0, 67.9, 23.0));
        // Another talker 40 deg away in azimuth, whatever his elevation, is not an image
        // under a cone of a tetrahedron's size; nor is the talker himself 10 deg away.
        assert!(!image(44.0, -10.0, 12.0));
        assert!(!image(-6.0, 5.0, 15.0));
    }
}
