//! Further sources from a frame's own correlations (beyond the paper).
//!
//! Averaging each pair's correlation over [`Room::average_frames`](crate::method::Room::average_frames)
//! frames steadies a talker's delays in a reverberant room, but when two talk at once
//! the average belongs to whichever dominated the span: the other, louder in the last
//! frame alone, is not found there (the steered response's further sources read the
//! same average). When the average gives a source, the frame's own correlations are
//! therefore searched too, through the same stages, and a direction they give is a
//! further source of the frame when it is
//!
//! - more than [`SEPARATION_DEG`] from every direction found (else it is the same
//!   source, whose averaged direction is the steadier);
//! - at least [`SHARE`] of the first source's score (below, the frame's own side lobes
//!   and reflections);
//! - not a vertical reflection of a direction found: within [`IMAGE_PLANE_DEG`] of the
//!   vertical plane through it and [`IMAGE_ELEVATION_DEG`] or more from its elevation.
//!   A floor or ceiling image keeps its talker's azimuth; near the zenith a small
//!   planar array's azimuth means little (measured on the 6-mic circle: a talker's
//!   ceiling image at 75 deg of elevation read 57 deg from the talker's azimuth, 13 deg
//!   from its vertical plane), so the test is on the plane, not on the azimuth.
//!
//! Measured on the tracking benchmark (docs/tracking.md): two talkers at once are found
//! in 4-18 more windows in a hundred on the three arrays; the meetings, the background
//! and the moving talker keep their figures.

use crate::method::outcome::{Detection, Detections};
use nalgebra::Vector3;

/// A direction of the frame's own further than this from every direction found is
/// another source (degrees; 5, 10 and 20 gave the same figures).
pub const SEPARATION_DEG: f64 = 10.0;

/// A further source scores at least this share of the first (without it, the
/// tetrahedron's talker turning in the room erred by 2.5 deg instead of 1.8-1.9).
pub const SHARE: f64 = 0.5;

/// A direction within this many degrees of the vertical plane through a direction
/// found...
pub const IMAGE_PLANE_DEG: f64 = 15.0;

/// ...and this far or further from its elevation is its floor or ceiling image.
pub const IMAGE_ELEVATION_DEG: f64 = 20.0;

/// Whether `candidate` may be a further source beside `found` (see the module).
pub fn distinct(candidate: &Detection, found: &Detection) -> bool {
    apart(&candidate.direction, &found.direction, IMAGE_ELEVATION_DEG)
}

/// [`distinct`] for directions `u` and `f`, with a vertical reflection taken from
/// `image_elevation_deg` of elevation on (instead of [`IMAGE_ELEVATION_DEG`]).
pub fn apart(u: &Vector3<f64>, f: &Vector3<f64>, image_elevation_deg: f64) -> bool {
    if u.angle(f).to_degrees() <= SEPARATION_DEG {
        return false;
    }
    let horizontal = Vector3::new(f.x, f.y, 0.0);
    let plane = match Vector3::new(-horizontal.y, horizontal.x, 0.0).try_normalize(1e-9) {
        Some(normal) => normal.dot(u).abs().min(1.0).asin().to_degrees(),
        // A direction found at the zenith: every vertical plane holds it.
        None => 0.0,
    };
    let elevation = |v: &Vector3<f64>| v.z.clamp(-1.0, 1.0).asin().to_degrees();
    !(plane <= IMAGE_PLANE_DEG && (elevation(u) - elevation(f)).abs() >= image_elevation_deg)
}

/// Adds to `found` (the average's sources, the strongest first) the directions of the
/// frame's own, `own`, that are further sources, up to `max_sources` in all; a direction
/// of the frame's own within [`SEPARATION_DEG`] of one found raises that one's
/// [`Detection::peak_margin`] to its margin when higher (the same source, heard more
/// clearly in the frame alone).
pub fn add_further(found: &mut Detections, own: &Detections, max_sources: usize) {
    let Some(first) = found.as_slice().first().map(|d| d.score) else {
        return;
    };
    for d in own.as_slice() {
        found.raise_peaks(d, SEPARATION_DEG);
    }
    for d in own.as_slice() {
        if found.len() >= max_sources {
            break;
        }
        if d.score >= SHARE * first && found.as_slice().iter().all(|f| distinct(d, f)) {
            found.push(*d);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::unit_from_angles;

    fn at(azimuth: f64, elevation: f64, score: f64) -> Detection {
        Detection {
            frame: 7,
            time_s: 0.08,
            azimuth_deg: azimuth,
            elevation_deg: elevation,
            direction: unit_from_angles(azimuth, elevation),
            score,
            mics: 6,
            margin: 1.0,
            peak_margin: 1.0,
            uncertainty_deg: 2.0,
            rider: false,
            span_s: 0.0,
            accumulated: false,
        }
    }

    #[test]
    fn another_talker_is_added_and_the_same_one_is_not() {
        let mut found = Detections::one(at(20.0, -7.0, 6.0));
        let own = [
            at(24.0, -5.0, 7.0),
            at(-10.0, -7.0, 4.0),
            at(-60.0, -7.0, 5.0),
        ];
        let mut all = Detections::default();
        own.iter().for_each(|d| all.push(*d));
        add_further(&mut found, &all, 2);
        // The first within 10 deg is the same talker; the next is added; then full.
        let azimuths: Vec<f64> = found.as_slice().iter().map(|d| d.azimuth_deg).collect();
        assert_eq!(azimuths, [20.0, -10.0]);
    }

    #[test]
    fn weak_directions_are_not_added() {
        let mut found = Detections::one(at(20.0, -7.0, 6.0));
        add_further(&mut found, &Detections::one(at(-40.0, -7.0, 2.9)), 3);
        assert_eq!(found.len(), 1);
        add_further(&mut found, &Detections::one(at(-40.0, -7.0, 3.0)), 3);
        assert_eq!(found.len(), 2);
    }

    #[test]
    fn floor_and_ceiling_images_are_not_further_sources() {
        // As measured on the 6-mic circle (module docs): the talker, its ceiling image.
        let talker = at(-135.06, 14.33, 5.8);
        assert!(!distinct(&at(168.42, 74.58, 8.6), &talker));
        // A floor image at the talker's azimuth.
        assert!(!distinct(&at(-134.0, -50.0, 5.0), &talker));
        // A talker at the same elevation 30 deg away, or above at another azimuth, is not
        // an image.
        assert!(distinct(&at(-105.0, 14.0, 5.0), &talker));
        assert!(distinct(&at(-75.0, 50.0, 5.0), &talker));
        // Above the first one, close in elevation: not an image but not the same source.
        assert!(distinct(&at(-135.0, 30.0, 5.0), &talker));
        // Anything against a direction found at the zenith, far enough in elevation, is
        // taken as its image.
        assert!(!distinct(&at(40.0, 20.0, 5.0), &at(0.0, 90.0, 5.0)));
    }
}
