//! What the tracker gives out: each row with its track's id, and what it made of a
//! recording (see the [`track`](super) module).

use super::faint::FaintPlace;
use crate::method::Detection;
use crate::text::BriefNumber;

/// A detection as the tracker gives it out: with its track's id.
#[derive(Debug, Clone, PartialEq)]
pub struct Tracked {
    /// The detection.
    pub detection: Detection,
    /// Its track's id (from 1, never reused within one recording), or `None` for a
    /// detection no track confirmed, given out only with
    /// [`TrackParams::keep_unconfirmed`](super::TrackParams::keep_unconfirmed).
    pub source: Option<u64>,
}

/// What a tracker made of a recording's detections (the JSON document's `files`
/// entries carry it as `tracking`).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TrackStats {
    /// Tracks confirmed (ids given).
    pub tracks: u64,
    /// Detections given out with a track's id.
    pub rows: u64,
    /// Detections no track confirmed: dropped, or given out without an id with
    /// [`TrackParams::keep_unconfirmed`](super::TrackParams::keep_unconfirmed).
    pub unconfirmed: u64,
    /// Of those, the detections of candidates taken for a talking track's floor or
    /// ceiling image (see `image.rs`).
    pub reflections: u64,
    /// The place whose candidates, never confirmed, were heard most (five times or
    /// more): where a source too faint to confirm may be. Not written in the JSON
    /// document.
    #[serde(skip)]
    pub faint: Option<FaintPlace>,
}

impl TrackStats {
    /// Why a tracked recording gave no row although the method detected something: the
    /// tracker with parameters `p` dropped every detection (candidates included), or with
    /// `--keep-unconfirmed` wrote it without a source. When five or more came from one
    /// place, says where, when and how close they came to a source (a faint talker in a
    /// reverberant room, docs/guide.md); otherwise they were isolated. `None` when a track
    /// was confirmed or nothing was detected (the method's own warnings say why).
    pub fn nothing_confirmed(&self, p: &super::TrackParams) -> Option<String> {
        (self.rows == 0 && self.unconfirmed > 0).then(|| {
            let all = self.unconfirmed;
            let (fate, tail) = if p.keep_unconfirmed {
                (
                    format!("all {all} detections (candidates included) are written with an empty source"),
                    "",
                )
            } else {
                (
                    format!("the tracker dropped all {all} detections (candidates included)"),
                    "; --keep-unconfirmed writes them with an empty source, --no-track writes every frame's detection",
                )
            };
            let Some(place) = self.faint else {
                let rule = match p.confirm_by {
                    super::ConfirmBy::Rules => format!(
                        "a track starts from {} detections above the threshold within --confirm-s, {} of which 1 is above it, or {} candidates",
                        p.confirm_hits, p.confirm_candidates, p.confirm_weak
                    ),
                    super::ConfirmBy::Evidence => format!(
                        "none gathered the evidence a source needs for at most {} false sources an hour (--false-per-hour)",
                        p.false_per_hour
                    ),
                };
                return format!("no source confirmed: {fate} as isolated ({rule}){tail}");
            };
            let (azimuth, elevation) = crate::geometry::angles_deg(&place.direction);
            let too_faint = "a source too faint to confirm (a talker across a reverberant room, or a steady noise such as a fan; a larger --false-per-hour confirms fainter sources, and more false ones: docs/guide.md)";
            let (short, advice) = match (place.best_nats, place.needed_nats) {
                (Some(best), Some(needed)) => (format!(
                    "gathered at best {} of the {} nats of evidence a source needs for at most {} false sources an hour (--false-per-hour)",
                    BriefNumber((best * 10.0).round() / 10.0),
                    BriefNumber((needed * 10.0).round() / 10.0),
                    p.false_per_hour
                ), too_faint),
                _ => match p.confirm_by {
                    super::ConfirmBy::Rules => (format!(
                        "never made a track (a track starts from {} detections above the threshold within --confirm-s, {} of which 1 is above it, or {} candidates)",
                        p.confirm_hits, p.confirm_candidates, p.confirm_weak
                    ), too_faint),
                    // Only riders: a place that candidates added to has their evidence.
                    super::ConfirmBy::Evidence => (
                        "were each heard only in its own frame's correlations, under the candidates' floor (--candidates), which starts nothing and gathers no evidence".to_string(),
                        "a source too faint even for a candidate (a talker across a reverberant room at about the noise's level), which no --false-per-hour confirms",
                    ),
                },
            };
            format!(
                "no source confirmed: {fate}; {} of them came from one place, azimuth {} deg, elevation {} deg, from {} to {} s, and {short}: {advice}{tail}",
                place.detections,
                BriefNumber((azimuth * 10.0).round() / 10.0),
                BriefNumber((elevation * 10.0).round() / 10.0),
                BriefNumber((place.first_s * 100.0).round() / 100.0),
                BriefNumber((place.last_s * 100.0).round() / 100.0),
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::unit_from_angles;
    use crate::track::{ConfirmBy, TrackParams};

    #[test]
    fn a_faint_place_of_riders_only_is_told_by_the_rule_in_force() {
        let stats = TrackStats {
            unconfirmed: 39,
            faint: Some(FaintPlace {
                direction: unit_from_angles(-54.5, 7.1),
                detections: 7,
                first_s: 0.54,
                last_s: 4.9,
                best_nats: None,
                needed_nats: None,
            }),
            ..TrackStats::default()
        };
        let evidence = stats.nothing_confirmed(&TrackParams::default()).unwrap();
        assert!(evidence.contains("azimuth -54.5 deg"), "{evidence}");
        assert!(
            evidence.contains("under the candidates' floor"),
            "{evidence}"
        );
        assert!(!evidence.contains("--confirm-s"), "{evidence}");
        assert!(!evidence.contains("larger --false-per-hour"), "{evidence}");
        let rules = TrackParams {
            confirm_by: ConfirmBy::Rules,
            ..TrackParams::default()
        };
        let said = stats.nothing_confirmed(&rules).unwrap();
        assert!(said.contains("--confirm-s"), "{said}");
    }
}
