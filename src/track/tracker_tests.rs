//! The tracker's tests (on hand-made detections): association, activity, images;
//! how candidates are confirmed is in `confirmation_tests.rs`.

use super::*;
use crate::geometry::unit_from_angles;
use crate::geometry::Geometry;

const HOP: f64 = 0.01;

fn detection(frame: u64, azimuth: f64) -> Detection {
    let direction = unit_from_angles(azimuth, 0.0);
    Detection {
        frame,
        time_s: frame as f64 * HOP,
        azimuth_deg: azimuth,
        elevation_deg: 0.0,
        direction,
        score: 10.0,
        mics: 8,
        margin: 2.0,
        peak_margin: 2.0,
        uncertainty_deg: 2.0,
        rider: false,
        span_s: 0.0,
        accumulated: false,
    }
}

/// Runs `frames` (per frame, the azimuths detected) through a tracker with the
/// default parameters: the rows (frame, source) and the events.
fn track(frames: &[Vec<f64>]) -> (Vec<(u64, u64, f64)>, Vec<Event>) {
    let frames: Vec<Vec<(f64, f64)>> = frames
        .iter()
        .map(|f| f.iter().map(|&a| (a, 2.0)).collect())
        .collect();
    track_margins(&frames)
}

/// As [`track`], with each detection's (azimuth, margin).
fn track_margins(frames: &[Vec<(f64, f64)>]) -> (Vec<(u64, u64, f64)>, Vec<Event>) {
    confirmed_rows(track_with(TrackParams::default(), frames))
}

/// The rows of [`track_with`], every one with its source.
fn confirmed_rows((rows, events): (Vec<Row>, Vec<Event>)) -> (Vec<(u64, u64, f64)>, Vec<Event>) {
    let rows = rows
        .into_iter()
        .map(|(f, source, a)| (f, source.expect("confirmed"), a))
        .collect();
    (rows, events)
}

/// A row given out: frame, source (none when unconfirmed), azimuth.
type Row = (u64, Option<u64>, f64);

/// As [`track_margins`], with `params`: the rows (frame, source or none, azimuth).
fn track_with(params: TrackParams, frames: &[Vec<(f64, f64)>]) -> (Vec<Row>, Vec<Event>) {
    let delay = params.latency();
    let mut tracker = Tracker::new(params);
    let (mut rows, mut events) = (Vec::new(), Vec::new());
    for (i, found) in frames.iter().enumerate() {
        let ds: Vec<Detection> = found
            .iter()
            .map(|&(a, margin)| Detection {
                margin,
                peak_margin: margin,
                ..detection(i as u64, a)
            })
            .collect();
        tracker.push(i as f64 * HOP, &ds);
        for r in tracker.take_rows() {
            // Rows come out at most the tracker's delay and the smoothing after their frame.
            assert!(
                i as f64 * HOP - r.detection.time_s <= delay + 1e-9,
                "frame {i} row {:?} delay {delay}",
                r.detection.time_s
            );
            rows.push((r.detection.frame, r.source, r.detection.azimuth_deg));
        }
        events.extend(tracker.take_events());
    }
    tracker.finish();
    rows.extend(
        tracker
            .take_rows()
            .map(|r| (r.detection.frame, r.source, r.detection.azimuth_deg)),
    );
    events.extend(tracker.take_events());
    (rows, events)
}

#[test]
fn two_talkers_taking_turns_keep_their_ids_and_outliers_are_dropped() {
    // A at 30 deg for 1 s, B at -60 deg for 1 s, A again after 2 s of silence; a
    // detection every other frame, twice the threshold, and single outliers at the
    // threshold far from them while they talk (a reflection, a stray). (A single
    // detection twice the threshold in silence is a sound: `evidence_tests.rs`.)
    let mut frames = vec![Vec::new(); 560];
    for (start, azimuth) in [(10, 30.0), (110, -60.0), (410, 31.0)] {
        for f in (start..start + 100).step_by(2) {
            frames[f] = vec![(azimuth, 2.0)];
        }
    }
    for (f, azimuth) in [(51, 150.0), (151, -150.0), (451, 100.0)] {
        frames[f] = vec![(azimuth, 1.0)];
    }
    for params in [TrackParams::default(), rules()] {
        let (rows, events) = confirmed_rows(track_with(params, &frames));
        // Every row of the talkers, none of the outliers, in frame order.
        assert_eq!(rows.len(), 150);
        assert!(rows.windows(2).all(|w| w[0].0 < w[1].0));
        assert!(rows.iter().all(|r| r.2 < 90.0));
        let ids: Vec<u64> = rows.iter().map(|r| r.1).collect();
        assert!(rows.iter().all(|r| (r.2 > 0.0) == (r.1 == 1)), "{ids:?}");
        assert!(rows.iter().any(|r| r.1 == 2));
        // Three stretches: A, B, A again with A's id.
        assert_eq!(events.len(), 3, "{events:?}");
        let e: Vec<(u64, u64)> = events.iter().map(|e| (e.source, e.detections)).collect();
        assert_eq!(e, vec![(1, 50), (2, 50), (1, 50)]);
        assert!((events[0].start_s - 0.10).abs() < 1e-9);
        assert!((events[0].end_s - 1.08).abs() < 1e-9);
        assert!(events.iter().all(|e| e.spread_deg < 1.0));
    }
}

#[test]
fn neighbours_in_turn_each_keep_their_own_id() {
    // Five talkers 14 deg apart, each saying a 0.4 s word in turn with 0.4 s pauses,
    // twice over in another order: each person one id, each id one person, one event
    // a turn. (A silent neighbour's gate used to widen at 60 deg/s over the pause and
    // take the next talker's word.)
    let order = [0, 1, 2, 3, 4, 2, 0, 4, 1, 3];
    let mut frames = vec![Vec::new(); 80 * order.len() + 150];
    for (turn, &talker) in order.iter().enumerate() {
        let start = 10 + 80 * turn;
        for f in (start..start + 40).step_by(2) {
            frames[f] = vec![talker as f64 * 14.0];
        }
    }
    let (rows, events) = track(&frames);
    assert_eq!(rows.len(), 20 * order.len());
    let mut id_of = std::collections::BTreeMap::new();
    for &(_, id, azimuth) in &rows {
        let talker = (azimuth / 14.0).round() as u64;
        assert_eq!(*id_of.entry(talker).or_insert(id), id, "talker {talker}");
    }
    let ids: std::collections::BTreeSet<u64> = id_of.values().copied().collect();
    assert_eq!(ids.len(), 5, "{id_of:?}");
    assert_eq!(events.len(), order.len(), "{events:?}");
}

/// A at 30 deg for 1 s (frames 10-110), B at 50 deg from 0.3 s after him (frames
/// 140-240, at `b_margin`), and `extra` detections per frame, through a tracker with
/// the default parameters: the events at A's place and the number at B's.
fn a_then_b(b_margin: f64, extra: impl Fn(u64) -> Option<Detection>) -> (Vec<Event>, usize) {
    let mut tracker = Tracker::new(TrackParams::default());
    let mut events = Vec::new();
    for f in 0..400u64 {
        let mut ds = Vec::new();
        if (10..110).contains(&f) && f % 2 == 0 {
            ds.push(detection(f, 30.0));
        }
        if (140..240).contains(&f) && f % 2 == 0 {
            ds.push(Detection {
                margin: b_margin,
                peak_margin: b_margin,
                ..detection(f, 50.0)
            });
        }
        ds.extend(extra(f));
        tracker.push(f as f64 * HOP, &ds);
        events.extend(tracker.take_events());
    }
    tracker.finish();
    events.extend(tracker.take_events());
    let near = |e: &Event, azimuth: f64| {
        angle_between_deg(&e.direction, &unit_from_angles(azimuth, 0.0)) < 5.0
    };
    let b = events.iter().filter(|e| near(e, 50.0)).count();
    (events.into_iter().filter(|e| near(e, 30.0)).collect(), b)
}

#[test]
fn a_turn_ends_when_another_talker_takes_the_floor() {
    // While B talks, a stray at A's place (a detection just above the threshold in B's
    // frame) and a rider beside it, 0.5-0.6 s after A fell silent: within the silence
    // that ends A's stretch (as long as the stretch), but B took the floor, so A's turn
    // ended with his last detection (five talkers in turn: A's event ran on into B's).
    let (a, b) = a_then_b(2.0, |f| match f {
        160 => Some(Detection {
            margin: 1.1,
            peak_margin: 1.1,
            ..detection(f, 31.0)
        }),
        165 => Some(Detection {
            margin: 0.35,
            peak_margin: 0.35,
            rider: true,
            ..detection(f, 31.0)
        }),
        _ => None,
    });
    assert!(!a.is_empty() && a.iter().all(|e| e.end_s < 1.1), "{a:?}");
    assert_eq!(b, 1);
}

#[test]
fn a_silent_talker_takes_no_stray_from_the_next_ones_frames() {
    // B under the threshold (confirmed only after a few looks); in his second frame a
    // detection beside A scoring 0.3 of his: before B is confirmed, it would have
    // joined A's stretch (still open) and run it on into B's turn.
    let (a, _) = a_then_b(0.6, |f| {
        (f == 142).then(|| Detection {
            score: 3.0,
            margin: 1.1,
            peak_margin: 1.1,
            ..detection(f, 31.0)
        })
    });
    assert!(!a.is_empty() && a.iter().all(|e| e.end_s < 1.1), "{a:?}");
}

#[test]
fn a_silent_talker_heard_again_at_the_next_ones_onset_was_hearing_that_onset() {
    // A lone detection at A's place, alone in its frame, 30 ms before B's first or 10
    // ms after it (B under the threshold, confirmed after a few looks): it would have
    // resumed A's stretch (silent for a turn's gap) and run it into B's turn.
    for stray in [137, 141] {
        let (a, b) = a_then_b(0.6, |f| {
            (f == stray).then(|| Detection {
                score: 2.0,
                margin: 1.1,
                peak_margin: 1.1,
                ..detection(f, 31.0)
            })
        });
        assert!(
            !a.is_empty() && a.iter().all(|e| e.end_s < 1.1),
            "{stray}: {a:?}"
        );
        assert_eq!(
            a.iter().map(|e| e.detections).sum::<u64>(),
            50,
            "{stray}: {a:?}"
        );
        assert_eq!(b, 1);
    }
    // Heard again 0.2 s before B, or twice just before him: his own.
    let (a, _) = a_then_b(0.6, |f| (f == 120).then(|| detection(f, 31.0)));
    assert!(a.iter().any(|e| e.end_s >= 1.2), "{a:?}");
    let (a, _) = a_then_b(0.6, |f| [136, 138].contains(&f).then(|| detection(f, 31.0)));
    assert!(a.iter().any(|e| e.end_s >= 1.38), "{a:?}");
}

/// The defaults, confirming by the rules of 0.2.0.
fn rules() -> TrackParams {
    TrackParams {
        confirm_by: ConfirmBy::Rules,
        ..TrackParams::default()
    }
}

#[test]
fn a_source_moving_at_60_degrees_a_second_is_one_track() {
    // 3 s at 60 deg/s, detected in 2 frames of 3.
    let frames: Vec<Vec<f64>> = (0..300)
        .map(|f| {
            if f % 3 == 2 {
                Vec::new()
            } else {
                vec![-90.0 + 60.0 * f as f64 * HOP]
            }
        })
        .collect();
    let (rows, events) = track(&frames);
    assert_eq!(rows.len(), 200);
    assert!(rows.iter().all(|r| r.1 == 1));
    assert_eq!(events.len(), 1);
    // The spread of a 180 deg sweep is large, and says so.
    assert!(events[0].spread_deg > 45.0, "{}", events[0].spread_deg);
    // Its start and end are where the source was first and last heard.
    let azimuth = |u: &Vector3<f64>| u.y.atan2(u.x).to_degrees();
    assert!((azimuth(&events[0].start_direction) + 90.0).abs() < 1e-6);
    let last = -90.0 + 60.0 * 298.0 * HOP;
    assert!((azimuth(&events[0].end_direction) - last).abs() < 1e-6);
}

/// A talker turning at 60 deg/s who pauses for 0.7 s comes back 42 deg on, further
/// than the widest gate (30 deg) from where it was heard last: the track's velocity
/// carries it there. A still talker whose directions scatter by 3 deg keeps one track
/// through the same pause (its scatter is not read as a turn).
#[test]
fn a_turning_talker_is_followed_through_a_pause() {
    let mut frames: Vec<Vec<f64>> = vec![Vec::new(); 220];
    for (f, frame) in frames.iter_mut().enumerate() {
        if !(100..170).contains(&f) {
            *frame = vec![-90.0 + 60.0 * f as f64 * HOP];
        }
    }
    let (rows, events) = track(&frames);
    assert_eq!(rows.len(), 150);
    let ids: Vec<u64> = rows.iter().map(|r| r.1).collect();
    assert!(ids.iter().all(|&id| id == 1), "{ids:?}");
    assert_eq!(events.len(), 1);
    let still: Vec<Vec<f64>> = (0..220)
        .map(|f| {
            if !(100..170).contains(&f) {
                vec![20.0 + 3.0 * ((f * 7919) % 13) as f64 / 6.0 - 3.0]
            } else {
                Vec::new()
            }
        })
        .collect();
    let (rows, _) = track(&still);
    assert_eq!(rows.len(), 150);
    assert!(rows.iter().all(|r| r.1 == 1));
}

/// A walker turning at 9 deg/s, under the half-second turn's threshold, who talks for
/// 1.2 s and pauses for 2 s (18 deg on, further than a still track's gate widens): his
/// turn is measured over a longer span, and his track carries him through the pauses
/// (before, each stretch was a new track). A still talker whose directions scatter by
/// 6 deg over the same times is not taken as turning: one track each.
#[test]
fn a_slow_walker_is_followed_through_a_pause() {
    let talking = |f: usize| (f % 320) < 120;
    let walker: Vec<Vec<f64>> = (0..760)
        .map(|f| {
            if talking(f) {
                vec![-40.0 + 9.0 * f as f64 * HOP]
            } else {
                Vec::new()
            }
        })
        .collect();
    let (rows, _) = track(&walker);
    assert!(rows.len() > 300, "{}", rows.len());
    assert!(
        rows.iter().all(|r| r.1 == 1),
        "{:?}",
        rows.iter().map(|r| r.1).collect::<Vec<_>>()
    );
    let still: Vec<Vec<f64>> = (0..760)
        .map(|f| {
            if talking(f) {
                vec![20.0 + 6.0 * ((f * 7919) % 13) as f64 / 12.0 - 3.0]
            } else {
                Vec::new()
            }
        })
        .collect();
    let (rows, _) = track(&still);
    assert!(rows.len() > 300);
    assert!(rows.iter().all(|r| r.1 == 1));
}

/// A walker turning at 10 deg/s who pauses for 0.6 s and comes back 11 deg ahead of
/// where his track predicts him, heard under the threshold: beyond a candidate's gate
/// of his track, within its own. His weak detections start a candidate that takes his
/// track up again, with every row of his words (before, they were the silent track's
/// outliers: his first 0.4 s were dropped; on `benches/moving.py`, further ahead, a
/// second track took him).
#[test]
fn a_walker_heard_weakly_after_a_pause_keeps_his_track() {
    let frames: Vec<Vec<(f64, f64)>> = (0..300)
        .map(|f| {
            let t = f as f64 * HOP;
            match f {
                0..120 => vec![(-40.0 + 10.0 * t, 2.0)],
                120..180 => Vec::new(),
                _ => vec![(-40.0 + 11.0 + 10.0 * t, 0.7)],
            }
        })
        .collect();
    let (rows, _) = track_with(TrackParams::default(), &frames);
    let late: Vec<Option<u64>> = rows.iter().filter(|r| r.0 >= 180).map(|r| r.1).collect();
    assert_eq!(late.len(), 120, "rows after the pause");
    assert!(late.iter().all(|&s| s == Some(1)), "{late:?}");
}

#[test]
fn two_sources_in_the_same_frames_get_one_row_each() {
    let frames: Vec<Vec<f64>> = (0..100).map(|_| vec![10.0, 70.0]).collect();
    let (rows, events) = track(&frames);
    assert_eq!(rows.len(), 200);
    for f in 0..100 {
        let here: Vec<_> = rows.iter().filter(|r| r.0 == f).collect();
        assert_eq!(here.len(), 2);
        assert_ne!(here[0].1, here[1].1);
    }
    assert_eq!(events.len(), 2);
}

/// By the rules. (By the evidence, a detection twice the threshold in silence is a
/// sound, and scattered candidates never make a track: `evidence_tests.rs`.)
#[test]
fn scattered_detections_never_make_a_track() {
    // One detection every 0.2 s, each 47 deg round from the one before: no two
    // within a confirmation window are within the gate of each other.
    let frames: Vec<Vec<f64>> = (0..2000)
        .map(|f| {
            if f % 20 == 0 {
                vec![(f as f64 / 20.0 * 47.0) % 360.0 - 180.0]
            } else {
                Vec::new()
            }
        })
        .collect();
    let frames: Vec<Vec<(f64, f64)>> = (frames.iter())
        .map(|f| f.iter().map(|&a| (a, 2.0)).collect())
        .collect();
    let (rows, events) = track_with(rules(), &frames);
    assert!(rows.is_empty() && events.is_empty());
}

/// A talking track's floor image (its azimuth, 60 deg lower) starts no track; once the
/// talker has been silent for a while, a source there is a source. The image is never
/// heard alone, so by default it is not even confirmed (`alone_s`); without that rule
/// the image rule refuses it.
#[test]
fn a_talkers_floor_image_starts_no_track() {
    let at = |frame: u64, azimuth: f64, elevation: f64| Detection {
        elevation_deg: elevation,
        direction: unit_from_angles(azimuth, elevation),
        ..detection(frame, azimuth)
    };
    let run = |image_from: u64, params: TrackParams| {
        let mut tracker = Tracker::new(params);
        for f in 0..300u64 {
            let mut ds = Vec::new();
            if f < 60 {
                ds.push(at(f, 30.0, 15.0));
            }
            if (image_from..image_from + 40).contains(&f) {
                ds.push(at(f, 31.0, -45.0));
            }
            tracker.push(f as f64 * HOP, &ds);
        }
        tracker.finish();
        let rows: Vec<Tracked> = tracker.take_rows().collect();
        let events: Vec<Event> = tracker.take_events().collect();
        (rows, events, tracker.stats())
    };
    let image_rule_only = TrackParams {
        alone_s: 0.0,
        ..rules()
    };
    // The image while the talker talks: only the talker's rows, one event, every image
    // detection dropped.
    for params in [TrackParams::default(), image_rule_only.clone()] {
        let (rows, events, stats) = run(20, params);
        assert_eq!(rows.len(), 60);
        assert!(rows
            .iter()
            .all(|r| (r.detection.elevation_deg - 15.0).abs() < 1e-9));
        assert_eq!(events.len(), 1);
        assert_eq!((stats.tracks, stats.rows, stats.unconfirmed), (1, 60, 40));
    }
    // Without the rule of detections heard alone, the image rule refuses the image's
    // candidates two by two: each detection is counted as a reflection. (With it, only
    // a dense run of them gets that far.)
    assert_eq!(run(20, image_rule_only.clone()).2.reflections, 40);
    // The same direction 1.4 s after the talker's last word: a source of its own.
    for params in [TrackParams::default(), image_rule_only] {
        let (rows, events, stats) = run(200, params);
        assert_eq!((stats.tracks, stats.reflections), (2, 0));
        assert_eq!(rows.len(), 100);
        assert_eq!(events.len(), 2);
        assert_eq!(rows[60].source, Some(2));
    }
}

/// With `keep_unconfirmed`, the detections dropped by default come out too, without an
/// id, in frame order among the others; the confirmed rows and the events are the same.
#[test]
fn unconfirmed_detections_are_kept_without_an_id_on_request() {
    // A talker at 30 deg; an isolated detection at -100 deg (never confirmed), a
    // candidate 8 deg off the live track (its outlier), and a weak candidate alone at
    // 150 deg (never confirmed, still open at the end).
    let mut frames: Vec<Vec<(f64, f64)>> = (0..60)
        .map(|f| {
            if f % 2 == 0 {
                vec![(30.0, 2.0)]
            } else {
                Vec::new()
            }
        })
        .collect();
    frames[11] = vec![(-100.0, 2.0)];
    frames[21] = vec![(38.0, 0.6)];
    frames[59] = vec![(150.0, 0.7)];
    let (plain, plain_events) = track_with(TrackParams::default(), &frames);
    let keep = TrackParams {
        keep_unconfirmed: true,
        ..TrackParams::default()
    };
    let (kept, kept_events) = track_with(keep, &frames);
    assert_eq!(plain.len(), 30);
    assert!(plain.iter().all(|r| r.1 == Some(1)));
    let confirmed: Vec<_> = kept.iter().filter(|r| r.1.is_some()).copied().collect();
    assert_eq!(confirmed, plain);
    let unconfirmed: Vec<(u64, f64)> = kept
        .iter()
        .filter(|r| r.1.is_none())
        .map(|r| (r.0, r.2))
        .collect();
    assert_eq!(unconfirmed, vec![(11, -100.0), (21, 38.0), (59, 150.0)]);
    assert!(kept.windows(2).all(|w| w[0].0 < w[1].0));
    assert_eq!(kept_events.len(), 1);
    assert_eq!(kept_events[0].detections, plain_events[0].detections);
}

/// A planar array knows elevation roughly: its detections 30 deg apart in elevation
/// at one azimuth are one source, and 30 deg apart in azimuth two.
#[test]
fn a_planar_array_is_tracked_by_its_azimuth() {
    let shape = Shape::Planar {
        normal: Vector3::z(),
    };
    let mut tracker = Tracker::for_shape(TrackParams::default(), &shape);
    for i in 0..40u64 {
        let elevation = if i % 2 == 0 { 0.0 } else { 30.0 };
        let up = Detection {
            direction: unit_from_angles(50.0, elevation),
            ..detection(i, 50.0)
        };
        let other = Detection {
            direction: unit_from_angles(80.0, 0.0),
            ..detection(i, 80.0)
        };
        tracker.push(i as f64 * HOP, &[up, other]);
    }
    tracker.finish();
    let mut ids: Vec<(u64, f64)> = tracker
        .take_rows()
        .map(|r| (r.source.expect("confirmed"), r.detection.azimuth_deg))
        .collect();
    assert_eq!(ids.len(), 80);
    ids.sort_by_key(|a| a.0);
    // (Smoothed over the track: the same azimuth to rounding.)
    ids.dedup_by(|a, b| a.0 == b.0 && (a.1 - b.1).abs() < 1e-9);
    // Two tracks, each with one azimuth (in either order).
    assert_eq!(ids.len(), 2, "{ids:?}");
    assert_ne!(ids[0].0, ids[1].0);
    // Compared in 3-D, the 30 deg jumps lose half the first's rows: the same azimuth 30
    // deg higher is taken for its floor or ceiling image (see `image`; by the rules it
    // is confirmed and then refused, counted as reflections; by the evidence it tells
    // nothing while the first is heard, and is dropped unconfirmed); without that rule
    // they made a second track.
    for (params, reflections) in [(rules(), 20), (TrackParams::default(), 0)] {
        let mut plain = Tracker::new(params);
        for i in 0..40u64 {
            let elevation = if i % 2 == 0 { 0.0 } else { 30.0 };
            let up = Detection {
                direction: unit_from_angles(50.0, elevation),
                ..detection(i, 50.0)
            };
            plain.push(i as f64 * HOP, &[up]);
        }
        plain.finish();
        let mut split: Vec<u64> = plain.take_rows().filter_map(|r| r.source).collect();
        let rows = split.len();
        split.sort();
        split.dedup();
        assert_eq!((split.len(), rows), (1, 20), "{split:?}");
        assert_eq!(plain.stats().reflections, reflections);
        assert_eq!(plain.stats().unconfirmed, 20);
    }
}

#[path = "confirmation_tests.rs"]
mod confirmation;

#[test]
fn a_candidate_after_a_pause_does_not_move_its_track_alone() {
    // A talker at 0 deg for 0.5 s; after a pause of 0.15 s one candidate 4.5 deg off (a
    // direction a second look found slightly astray), then its candidates at -1 deg.
    // The candidate after the pause moves the track by one frame's share, not to
    // itself: the candidates after it are within the candidates' gate (5 deg) and join
    // the track. (Taken whole, it left the track 5.5 deg from them: they were dropped as
    // its outliers.)
    let mut frames: Vec<Vec<(f64, f64)>> = (0..50).map(|_| vec![(0.0, 2.0)]).collect();
    frames.extend((0..15).map(|_| Vec::new()));
    frames.push(vec![(4.5, 0.5)]);
    frames.extend((0..30).map(|_| vec![(-1.0, 0.5)]));
    let (rows, _) = track_with(TrackParams::default(), &frames);
    let late: Vec<&Row> = rows.iter().filter(|r| r.0 > 65).collect();
    assert_eq!(late.len(), 30, "{rows:?}");
    assert!(late.iter().all(|r| r.1 == Some(1)), "{late:?}");
}

/// Riders add rows to a talking track within a candidate's gate without moving it, and
/// start nothing: a dense run of them elsewhere is dropped, and riders drifting away
/// from the track stop joining it once past the gate (a track they moved would follow).
#[test]
fn riders_only_ride_along_a_talking_track() {
    let rider = |frame: u64, azimuth: f64| Detection {
        margin: 0.35,
        peak_margin: 0.35,
        rider: true,
        ..detection(frame, azimuth)
    };
    // Frames 11-25 (42.2-45 deg) by the rules, which confirm the track at frame 10;
    // frames 1-25 but the talker's by the evidence, which confirms it at its first
    // detection (twice the threshold, in silence).
    for (params, expected) in [(rules(), 14), (TrackParams::default(), 23)] {
        let mut tracker = Tracker::new(params);
        let mut rows = Vec::new();
        for f in 0..200u64 {
            let mut ds = Vec::new();
            // A talker at 40 deg, heard above the threshold every 10 frames for 0.5 s.
            if f < 50 && f % 10 == 0 {
                ds.push(detection(f, 40.0));
            }
            // Riders drifting from 40 to 50 deg by 0.2 deg a frame, between those.
            if f < 50 && f % 10 != 0 {
                ds.push(rider(f, 40.0 + 0.2 * f as f64));
            }
            // A dense run of riders at -60 deg, far from any track.
            if f % 2 == 1 {
                ds.push(rider(f, -60.0));
            }
            tracker.push(f as f64 * HOP, &ds);
            rows.extend(tracker.take_rows());
        }
        tracker.finish();
        rows.extend(tracker.take_rows());
        assert!(rows.iter().all(|r| r.source == Some(1)), "one track only");
        assert!(rows.iter().all(|r| r.detection.azimuth_deg > 0.0));
        let riding: Vec<f64> = rows
            .iter()
            .filter(|r| r.detection.rider)
            .map(|r| r.detection.azimuth_deg)
            .collect();
        // Within the candidates' gate (5 deg) of the track, which stays at 40 deg.
        assert!(
            !riding.is_empty() && riding.iter().all(|&a| a <= 45.0),
            "{riding:?}"
        );
        assert_eq!(riding.len(), expected, "{riding:?}");
    }
}

#[path = "evidence_tests.rs"]
mod evidence;

/// A tracker with the default parameters for a 5.7 cm tetrahedron at 16 kHz.
fn tetrahedron_tracker() -> Tracker {
    let a = 0.057 / (2.0 * 2f64.sqrt());
    let tetra =
        Geometry::from_positions(&[[a, a, a], [a, -a, -a], [-a, a, -a], [-a, -a, a]]).unwrap();
    Tracker::for_array(TrackParams::default(), &tetra, 16000.0, 343.0)
}

/// Runs frames of (azimuth, elevation) detections, each with cone `cone_deg`, through
/// [`tetrahedron_tracker`]: the sources of the rows given out.
fn sources_of(frames: &[Vec<(f64, f64)>], cone_deg: f64) -> Vec<u64> {
    let mut tracker = tetrahedron_tracker();
    let mut sources = Vec::new();
    for (i, found) in frames.iter().enumerate() {
        let ds: Vec<Detection> = found
            .iter()
            .map(|&(a, e)| Detection {
                elevation_deg: e,
                direction: unit_from_angles(a, e),
                uncertainty_deg: cone_deg,
                ..detection(i as u64, a)
            })
            .collect();
        tracker.push(i as f64 * HOP, &ds);
        sources.extend(tracker.take_rows().filter_map(|r| r.source));
    }
    tracker.finish();
    sources.extend(tracker.take_rows().filter_map(|r| r.source));
    sources
}

/// On a small array a talker's detections scatter: a run of them beyond his track's
/// gate (14-15 deg on a 5.7 cm tetrahedron at 16 kHz) but within his and their cones
/// combined is his, not a second source beside him, whether it comes after a pause or
/// between his own detections; the same run heard in the same frames as his track is
/// another source.
#[test]
fn a_run_within_a_talkers_cones_is_his_unless_heard_with_him() {
    #[derive(Clone, Copy)]
    enum Run {
        AfterAPause,
        Between,
        Together,
    }
    let ids = |run: Run, off: f64, cone: f64| {
        let (him, it) = ((20.0, 10.0), (20.0 + off, 10.0));
        let frames: Vec<Vec<(f64, f64)>> = (0..300)
            .map(|f| match (run, f) {
                (_, 0..100) | (_, 170..) => vec![him],
                (Run::AfterAPause, 100..135) => Vec::new(),
                (Run::AfterAPause, _) => vec![it],
                (Run::Between, _) if f % 2 == 0 => vec![him],
                (Run::Between, _) => vec![it],
                (Run::Together, _) => vec![him, it],
            })
            .collect();
        let mut ids = sources_of(&frames, cone);
        ids.sort();
        ids.dedup();
        ids
    };
    // 16 deg off after a pause, cones of 13 deg (18.4 combined).
    assert_eq!(ids(Run::AfterAPause, 16.0, 13.0), vec![1]);
    // 28 deg off (beyond where a talking track mutes a candidate's evidence), cones of
    // 25 deg (35 combined).
    assert_eq!(ids(Run::Between, 28.0, 25.0), vec![1]);
    assert_eq!(ids(Run::Together, 28.0, 25.0), vec![1, 2]);
}

/// A candidate of `hits` (row, detection), as `tracker` would hold it with no evidence
/// yet, where its last detection is.
fn candidate_of(tracker: &Tracker, hits: VecDeque<(u64, Detection)>) -> Candidate {
    let (first, last) = (hits.front().unwrap().1, hits.back().unwrap().1);
    let look = tracker.evidence.look(last.time_s);
    Candidate {
        key: 999,
        direction: last.direction,
        last_s: last.time_s,
        heard: hits.len() as u64,
        beside_talk: VecDeque::new(),
        accumulated: false,
        first_s: first.time_s,
        hits,
        alone_s: f64::NEG_INFINITY,
        test: Test::new(look),
        bursts: Bursts::new(look),
        place: None,
        best_nats: f64::NEG_INFINITY,
        together: Vec::new(),
    }
}

/// A candidate confirmed beside a talking track on a 5.7 cm tetrahedron, its latest
/// detections drifted 30 deg from him (beyond his reach and his and its cones combined)
/// but heard on average 15 deg from him, is his scatter: its rows are his.
#[test]
fn a_candidate_that_drifted_from_a_talking_track_is_his_by_where_it_was_heard() {
    let mut tracker = tetrahedron_tracker();
    let at = |f: u64, azimuth: f64, elevation: f64| Detection {
        elevation_deg: elevation,
        direction: unit_from_angles(azimuth, elevation),
        uncertainty_deg: 15.0,
        ..detection(f, azimuth)
    };
    // He is heard in every other frame; the candidate in the others.
    for f in (0..100).step_by(2) {
        tracker.push(f as f64 * HOP, &[at(f, 20.0, 10.0)]);
    }
    // From 1 deg beside him to 15 deg aside and 28 deg above.
    let hits: VecDeque<(u64, Detection)> = (0..20)
        .map(|i| {
            let x = i as f64 / 19.0;
            (10_000 + i, at(61 + 2 * i, 19.0 - 14.0 * x, 10.0 + 28.0 * x))
        })
        .collect();
    let c = candidate_of(&tracker, hits);
    tracker.confirm(c);
    for row in 10_000..10_020 {
        assert_eq!(tracker.resolved.get(&row), Some(&Some(1)), "row {row}");
    }
}

/// A detection at (`azimuth`, 10 deg) in frame `f` with `margin` and cone `cone_deg`.
fn weak_at(f: u64, azimuth: f64, margin: f64, cone_deg: f64) -> Detection {
    Detection {
        elevation_deg: 10.0,
        direction: unit_from_angles(azimuth, 10.0),
        uncertainty_deg: cone_deg,
        margin,
        peak_margin: margin,
        ..detection(f, azimuth)
    }
}

/// Runs 300 frames, `frame(f)` the detections of frame `f`, through
/// [`tetrahedron_tracker`]: the sources of the rows given out of detections under the
/// threshold.
fn weak_rows_sources(frame: impl Fn(u64) -> Vec<Detection>) -> Vec<Option<u64>> {
    let mut tracker = tetrahedron_tracker();
    let mut rows = Vec::new();
    for f in 0..300u64 {
        tracker.push(f as f64 * HOP, &frame(f));
        rows.extend(tracker.take_rows().map(|r| (r.detection, r.source)));
    }
    tracker.finish();
    rows.extend(tracker.take_rows().map(|r| (r.detection, r.source)));
    rows.into_iter()
        .filter(|(d, _)| d.margin < 1.0)
        .map(|(_, s)| s)
        .collect()
}

/// Detections under the threshold 15 deg from a talking track on a 5.7 cm tetrahedron
/// (beyond his gate, 12 deg, within his stretch's cone, 20 deg), in frames he is not
/// heard in, are his scatter: their candidate, muted beside him, gives him its rows
/// before the delay drops them (two talkers at once there: a track 6 deg off its
/// talker left 14 frames of him within 2 deg of him without a row); not when it was
/// heard with him, nor when it lies within another talking stretch's cone too.
#[test]
fn a_muted_candidate_beside_a_talking_track_gives_him_its_rows() {
    let at = |f: u64, azimuth: f64, margin: f64| weak_at(f, azimuth, margin, 20.0);
    #[derive(Clone, Copy, PartialEq)]
    enum Run {
        Alone,
        /// He is heard in the run's frames too.
        Together,
        /// A second talker at 50 deg talks with him: the run is within both stretches'
        /// cones.
        Between,
    }
    // The run's rows and their sources.
    let run = |run: Run| {
        weak_rows_sources(|f| {
            let mut found = match f {
                0..100 | 130..200 => vec![at(f, 20.0, 2.0)],
                100..130 if run == Run::Together => vec![at(f, 20.0, 2.0), at(f, 35.0, 0.6)],
                100..130 => vec![at(f, 35.0, 0.6)],
                _ => Vec::new(),
            };
            if run == Run::Between && !(100..130).contains(&f) && f < 200 {
                found.push(at(f, 50.0, 2.0));
            }
            found
        })
    };
    assert_eq!(run(Run::Alone), vec![Some(1); 30]);
    // Heard with him, it is someone else (here never confirmed: no row of his); between
    // two talkers, it is either's.
    assert!(
        !run(Run::Together).contains(&Some(1)),
        "{:?}",
        run(Run::Together)
    );
    assert_eq!(run(Run::Between), Vec::new());
}

/// A detection under the threshold 10 deg from a talking track on a 5.7 cm tetrahedron
/// (beyond a candidate's gate, within the track's gate and its stretch's cone) rides
/// the track: a row of his that would have started nothing. Not after a turn's gap of
/// silence (another's turn may have begun), nor beyond the stretch's cone.
#[test]
fn a_talking_tracks_outlier_within_its_scatter_rides_it() {
    // The weak detections' sources: he talks in even frames to 200 with cone `cone`;
    // they come in odd frames 101-149, or from frame 230 on with `after_a_gap`.
    let weak = |cone: f64, after_a_gap: bool| {
        weak_rows_sources(|f| match f {
            230..240 if after_a_gap => vec![weak_at(f, 30.0, 0.6, cone)],
            101..150 if f % 2 == 1 && !after_a_gap => vec![weak_at(f, 30.0, 0.6, cone)],
            0..200 if f % 2 == 0 => vec![weak_at(f, 20.0, 2.0, cone)],
            _ => Vec::new(),
        })
    };
    assert_eq!(weak(20.0, false), vec![Some(1); 25]);
    assert_eq!(weak(20.0, true), Vec::new());
    assert_eq!(weak(6.0, false), Vec::new());
}

/// A talker heard again after his stretch of activity ended, beyond his track's gate
/// (15 deg on a 5.7 cm tetrahedron at 16 kHz) but within his and the new run's cones
/// combined, is the same source; one beyond their cones is another.
#[test]
fn a_talker_heard_again_within_the_cones_of_where_he_was_keeps_his_id() {
    let ids = |off: f64, cone: f64| {
        let frames: Vec<Vec<(f64, f64)>> = (0..400)
            .map(|f| match f {
                0..100 => vec![(20.0, 10.0)],
                250..350 => vec![(20.0 + off, 10.0)],
                _ => Vec::new(),
            })
            .collect();
        let mut ids = sources_of(&frames, cone);
        ids.sort();
        ids.dedup();
        ids
    };
    assert_eq!(ids(17.0, 13.0), vec![1]);
    assert_eq!(ids(25.0, 13.0), vec![1, 2]);
}

/// A run between a talking track's detections, beyond its reach but within the cones
/// (its scatter), that is nearer a silent track, also within the cones: the talking
/// track's, not the silent one's (which would make an event of its own).
#[test]
fn a_talking_track_takes_its_scatter_before_a_silent_one_heard_again() {
    let frames: Vec<Vec<(f64, f64)>> = (0..500)
        .map(|f| match f {
            0..100 => vec![(20.0, 0.0)],
            200..450 if f % 2 == 0 || !(300..380).contains(&f) => vec![(74.0, 0.0)],
            300..380 => vec![(46.0, 0.0)],
            _ => Vec::new(),
        })
        .collect();
    let ids = sources_of(&frames, 22.0);
    let (first, second): (Vec<u64>, Vec<u64>) = ids.iter().partition(|&&id| id == 1);
    assert_eq!(first.len(), 100, "{ids:?}");
    assert!(second.iter().all(|&id| id == 2), "{ids:?}");
}

/// A run 18 deg from a talking track on a 5.7 cm tetrahedron (within the reach of its
/// strays) tells nothing while the track is heard as often as it; once it outnumbers
/// the track's own detections three to one over the last `ACTIVE_S`, it is a source
/// heard where it is and its detections count as evidence (two talkers 33 deg apart
/// whose merged peaks confirmed a track between them: that track muted both,
/// `benches/together.py`).
#[test]
fn a_run_that_outhears_a_talking_track_beside_it_counts_as_evidence() {
    // He is heard in every frame to 100, then in one of `every`; the run at 38 deg
    // in the others to frame 130.
    let run = |every: u64| {
        let mut tracker = tetrahedron_tracker();
        let mut hits = VecDeque::new();
        for f in 0..130u64 {
            if f < 100 || f % every == 0 {
                tracker.push(f as f64 * HOP, &[weak_at(f, 20.0, 2.0, 10.0)]);
            } else {
                tracker.push(f as f64 * HOP, &[]);
                hits.push_back((f, weak_at(f, 38.0, 0.9, 10.0)));
            }
        }
        let c = candidate_of(&tracker, hits);
        let next = weak_at(130, 38.0, 0.9, 10.0);
        let muted = tracker.muted(&c, &next.direction, 1.3, 1);
        let frame = Frame {
            alone: true,
            strongest: next.score,
        };
        (muted, tracker.hit_nats(&next, frame, muted, &c))
    };
    let (muted, nats) = run(5);
    assert!(!muted && nats.is_some_and(|n| n > 0.0), "{nats:?}");
    let (muted, nats) = run(2);
    assert!(muted && nats.is_none(), "{nats:?}");
}

/// The sources of the rows a tracker on a 6-mic circle of radius 4.63 cm at 16 kHz (a
/// ReSpeaker-like array) gives for `frames` (frame `f`'s detections at `f` hops).
fn small_circle_sources(frames: impl Iterator<Item = Vec<Detection>>) -> Vec<u64> {
    small_circle_rows(frames)
        .into_iter()
        .map(|(_, s)| s)
        .collect()
}

/// [`small_circle_sources`] with each row's time.
fn small_circle_rows(frames: impl Iterator<Item = Vec<Detection>>) -> Vec<(f64, u64)> {
    small_circle_run(frames).0
}

/// [`small_circle_rows`] and the events.
fn small_circle_run(frames: impl Iterator<Item = Vec<Detection>>) -> (Vec<(f64, u64)>, Vec<Event>) {
    let positions: Vec<[f64; 3]> = (0..6)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / 6.0;
            [0.0463 * a.cos(), 0.0463 * a.sin(), 0.0]
        })
        .collect();
    let circle = Geometry::from_positions(&positions).unwrap();
    let mut tracker = Tracker::for_array(TrackParams::default(), &circle, 16000.0, 343.0);
    let tracked = |r: Tracked| r.source.map(|s| (r.detection.time_s, s));
    let (mut rows, mut events) = (Vec::new(), Vec::new());
    for (f, ds) in frames.enumerate() {
        tracker.push(f as f64 * HOP, &ds);
        rows.extend(tracker.take_rows().filter_map(tracked));
        events.extend(tracker.take_events());
    }
    tracker.finish();
    rows.extend(tracker.take_rows().filter_map(tracked));
    events.extend(tracker.take_events());
    (rows, events)
}

/// A detection at `azimuth` and 33 deg up with a planar array's wide cone.
fn high_on_a_circle(frame: u64, azimuth: f64, margin: f64) -> Detection {
    Detection {
        elevation_deg: 33.0,
        direction: unit_from_angles(azimuth, 33.0),
        uncertainty_deg: 30.0,
        margin,
        peak_margin: margin,
        ..detection(frame, azimuth)
    }
}

/// A still talker on a 6-mic circle of radius 4.63 cm whose directions wander: 9 deg
/// over 0.6 s, smoothly (the room's reflections change with what he says), which
/// measures as a turn of 15 deg/s and predicts his track on; after a 30 ms gap he is
/// heard back where he began, 9 deg from where his track was last heard and further
/// from where it is predicted. Near where it was last heard, that is his track, not a
/// second source.
#[test]
fn a_wandering_talker_back_where_he_was_is_one_track() {
    let sources = small_circle_sources((0..150u64).map(|f| match f {
        0..=59 => vec![high_on_a_circle(f, -117.0 - 0.15 * f as f64, 2.0)],
        63..=92 => vec![high_on_a_circle(f, -117.3, 2.0)],
        _ => Vec::new(),
    }));
    assert_eq!(sources.len(), 90, "{sources:?}");
    assert!(sources.iter().all(|&s| s == sources[0]), "{sources:?}");
}

/// A low voice on a 6-mic circle of radius 4.63 cm at 16 kHz (a sample of delay is 6.3
/// deg there, a track's reach 10 deg): in his sentence's last 0.2 s each frame also
/// gives a candidate 9 deg from his track, then only those, for 0.6 s. Two detections
/// of a frame closer than the array can tell apart are not two talkers heard
/// together: the candidate is his track's, not a second source.
#[test]
fn a_talkers_scatter_within_reach_is_his_even_heard_in_his_frames() {
    let sources = small_circle_sources(scatter_beside_a_low_voice());
    assert!(sources.len() >= 90, "{}", sources.len());
    assert!(sources.iter().all(|&s| s == sources[0]), "{sources:?}");
}

/// The frames of [`a_talkers_scatter_within_reach_is_his_even_heard_in_his_frames`].
fn scatter_beside_a_low_voice() -> impl Iterator<Item = Vec<Detection>> {
    let at = high_on_a_circle;
    (0..200u64).map(move |f| match f {
        0..=39 => vec![at(f, 60.0, 2.0)],
        40..=59 => vec![at(f, 60.0, 2.0), at(f, 51.0, 0.7)],
        60..=119 => vec![at(f, 51.0, 0.7)],
        _ => Vec::new(),
    })
}

/// A talker on a 6-mic circle of radius 4.63 cm read 30 deg up, and in a pause of his
/// a few strong detections at 68 deg of elevation, 75 deg from his azimuth, with a cone
/// of 68 deg (`benches/voices.py --seed 300`): his ceiling image, whose azimuth the
/// array cannot tell so high above its plane. It starts no source of its own.
#[test]
fn a_ceiling_image_whose_cone_holds_the_zenith_starts_nothing() {
    let image = |frame: u64| Detection {
        elevation_deg: 67.9,
        direction: unit_from_angles(-70.8, 67.9),
        uncertainty_deg: 68.0,
        margin: 3.0,
        peak_margin: 3.0,
        ..detection(frame, -70.8)
    };
    let talker = |frame: u64| Detection {
        elevation_deg: 30.0,
        direction: unit_from_angles(4.1, 30.0),
        uncertainty_deg: 33.0,
        margin: 1.2,
        peak_margin: 1.2,
        ..detection(frame, 4.1)
    };
    let sources = small_circle_sources((0..160u64).map(|f| match f {
        0..=79 => vec![talker(f)],
        80..=85 => vec![image(f)],
        86..=139 => vec![talker(f)],
        _ => Vec::new(),
    }));
    assert!(sources.len() >= 120, "{}", sources.len());
    assert!(sources.iter().all(|&s| s == sources[0]), "{sources:?}");
}

/// docs/interface.md: at most one row per source per frame. The low voice of
/// [`a_talkers_scatter_within_reach_is_his_even_heard_in_his_frames`] gives two
/// detections a frame for 20 frames, both his: one row each frame.
#[test]
fn a_source_has_at_most_one_row_a_frame() {
    let (rows, events) = small_circle_run(scatter_beside_a_low_voice());
    assert!(rows.len() >= 90, "{}", rows.len());
    let mut seen = std::collections::HashSet::new();
    for &(t, s) in &rows {
        assert!(
            seen.insert((t.to_bits(), s)),
            "two rows of source {s} at {t} s"
        );
    }
    // Its events count exactly its rows, none dropped after being counted.
    let mut counted = std::collections::HashMap::new();
    for e in &events {
        *counted.entry(e.source).or_insert(0) += e.detections as usize;
    }
    for (&s, &n) in &counted {
        let given = rows.iter().filter(|r| r.1 == s).count();
        assert_eq!(
            n, given,
            "source {s}: its events count {n} detections, {given} rows"
        );
    }
}
