//! Where candidates were heard that never became a source: what a run that confirms
//! nothing can still tell its user ([`TrackStats::faint`](super::TrackStats::faint)).
//!
//! A talker too faint for the room gives candidates at his place word after word, each
//! dropped before it gathers the evidence a source needs; clutter gives them scattered,
//! or at a fan's place; in a frame with nothing above the threshold, the frame's own
//! correlations often still hear him (a rider, which adds rows only to a talking
//! track). Every candidate dropped unconfirmed, and every rider that rode along no
//! track, adds its detections to the place it was heard at (within a still track's
//! gate), so that a run with no source can say where the most came from, over how long,
//! and how close they came to a source (on the fresh scenes of `benches/words.py --seed
//! 900`, the scenes of one talker at 2.5 m that gave no row had all but a few of their
//! detections within 10 deg of him, most of them riders).

use crate::method::Detection;
use nalgebra::Vector3;

/// Places remembered at most (the one with the fewest detections makes room).
const MAX_PLACES: usize = 64;

/// A place spans this many still tracks' gates: the detections of a source too faint to
/// confirm scatter more than those of one heard well (one talker at 2.5 m at 0-5 dB on
/// the prism: within 10 deg of him, 15 deg apart, against a gate of 7.5 deg).
pub(crate) const PLACE_GATES: f64 = 2.0;

/// A place says something only from this many detections.
pub(crate) const MIN_DETECTIONS: u64 = 5;

/// Candidates heard at one place and never confirmed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaintPlace {
    /// Their mean direction (unit vector).
    pub direction: Vector3<f64>,
    /// Their detections.
    pub detections: u64,
    /// The first detection's time (seconds).
    pub first_s: f64,
    /// The last detection's time (seconds).
    pub last_s: f64,
    /// The most evidence one of them gathered (nats), with the evidence test
    /// ([`ConfirmBy::Evidence`](super::ConfirmBy::Evidence)).
    pub best_nats: Option<f64>,
    /// The evidence a source needs (nats), with the evidence test.
    pub needed_nats: Option<f64>,
}

impl FaintPlace {
    /// A detection that started nothing (a rider that rode along no track).
    pub(super) fn heard_once(d: &Detection) -> Self {
        FaintPlace {
            direction: d.direction,
            detections: 1,
            first_s: d.time_s,
            last_s: d.time_s,
            best_nats: None,
            needed_nats: None,
        }
    }
}

/// The places of a recording's unconfirmed candidates.
#[derive(Debug, Default)]
pub(super) struct FaintPlaces {
    places: Vec<FaintPlace>,
    /// The sums of their detections' directions.
    sums: Vec<Vector3<f64>>,
}

impl FaintPlaces {
    /// A candidate dropped unconfirmed, as a place of its own: joins the nearest place
    /// within `gate_deg` (its direction the mean of their detections'), or starts one.
    pub fn add(&mut self, candidate: FaintPlace, gate_deg: f64) {
        if candidate.detections == 0 {
            return;
        }
        let nearest = self
            .places
            .iter()
            .enumerate()
            .map(|(i, p)| (i, p.direction.angle(&candidate.direction).to_degrees()))
            .filter(|&(_, angle)| angle <= gate_deg)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i);
        let weight = candidate.detections as f64;
        match nearest {
            Some(i) => {
                let p = &mut self.places[i];
                self.sums[i] += candidate.direction * weight;
                p.direction = self.sums[i].try_normalize(1e-12).unwrap_or(p.direction);
                p.detections += candidate.detections;
                p.first_s = p.first_s.min(candidate.first_s);
                p.last_s = p.last_s.max(candidate.last_s);
                p.best_nats = max_of(p.best_nats, candidate.best_nats);
                p.needed_nats = p.needed_nats.or(candidate.needed_nats);
            }
            None => {
                if self.places.len() >= MAX_PLACES {
                    let (fewest, _) = self
                        .places
                        .iter()
                        .enumerate()
                        .min_by_key(|(_, p)| p.detections)
                        .expect("full");
                    if self.places[fewest].detections >= candidate.detections {
                        return;
                    }
                    self.places.swap_remove(fewest);
                    self.sums.swap_remove(fewest);
                }
                self.places.push(candidate);
                self.sums.push(candidate.direction * weight);
            }
        }
    }

    /// The place with the most detections, if it has at least [`MIN_DETECTIONS`].
    pub fn most(&self) -> Option<FaintPlace> {
        self.places
            .iter()
            .filter(|p| p.detections >= MIN_DETECTIONS)
            .max_by(|a, b| {
                a.detections
                    .cmp(&b.detections)
                    .then(b.first_s.total_cmp(&a.first_s))
            })
            .copied()
    }
}

fn max_of(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a.max(b)),
        (a, None) => a,
        (None, b) => b,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::unit_from_angles;

    fn heard(az: f64, n: u64, at: f64, nats: f64) -> FaintPlace {
        FaintPlace {
            direction: unit_from_angles(az, 0.0),
            detections: n,
            first_s: at,
            last_s: at + 0.3,
            best_nats: Some(nats),
            needed_nats: Some(9.2),
        }
    }

    #[test]
    fn words_from_one_place_add_up_and_strays_do_not() {
        let mut places = FaintPlaces::default();
        // A faint talker at 40 deg, word after word, his directions 1-2 deg apart.
        for (k, az) in [40.0, 41.5, 39.0, 40.5].into_iter().enumerate() {
            places.add(heard(az, 3, k as f64, 5.0 + k as f64), 6.0);
        }
        // Strays everywhere else, two detections each.
        for k in 0..20 {
            places.add(heard(-120.0 + 7.0 * k as f64, 2, 0.1 * k as f64, 1.0), 6.0);
        }
        let p = places.most().expect("a place");
        assert_eq!(p.detections, 12);
        assert!((p.direction.y.atan2(p.direction.x).to_degrees() - 40.25).abs() < 0.1);
        assert_eq!((p.first_s, p.last_s), (0.0, 3.3));
        assert_eq!(p.best_nats, Some(8.0));
        // Strays alone say nothing.
        let mut strays = FaintPlaces::default();
        for k in 0..20 {
            strays.add(heard(18.0 * k as f64 - 170.0, 2, k as f64, 1.0), 6.0);
        }
        assert_eq!(strays.most(), None);
    }
}
