//! Tests of the scores (`mod.rs`).

use super::*;
use crate::record::{parse_detections, EventRecord, TruthSource};

fn source(index: usize, direction: Vector3<f64>, active: Vec<[f64; 2]>) -> TruthSource {
    let (azimuth_deg, elevation_deg) = angles_deg(&direction);
    TruthSource {
        index,
        signal: "a".into(),
        level_db: -26.0,
        position_room: [0.0; 3],
        x: direction.x,
        y: direction.y,
        z: direction.z,
        azimuth_deg,
        elevation_deg,
        distance_m: Some(2.0),
        active,
        turn_deg_per_s: None,
        turn_from_s: None,
        waypoints: Vec::new(),
        azimuth_only: false,
    }
}

fn truth() -> Truth {
    Truth {
        tool: Default::default(),
        sample_rate: 48000,
        duration_s: 10.0,
        seed: 0,
        speed_of_sound: 343.0,
        room: None,
        array: Default::default(),
        sources: vec![
            source(0, Vector3::x(), vec![[1.0, 2.0], [5.0, 6.0]]),
            source(1, Vector3::y(), vec![[3.0, 4.0]]),
        ],
        noise: None,
        recording: None,
    }
}

/// A detection in frame `f` (hop 0.01 s) toward `u`.
fn record(f: u64, u: Vector3<f64>) -> DetectionRecord {
    DetectionRecord {
        time_s: (f + 1) as f64 * 0.01,
        x: u.x,
        y: u.y,
        z: u.z,
        frame: Some(f),
        ..Default::default()
    }
}

/// `deg` degrees from +x toward +z.
fn tilt(deg: f64) -> Vector3<f64> {
    let r = deg.to_radians();
    Vector3::new(r.cos(), 0.0, r.sin())
}

#[test]
fn scores_hand_made_detections() {
    // Source 0, interval 1..2 s: frames wholly inside have centres 1.01..1.99, i.e.
    // f = 100..=198 (99 frames); likewise 5..6 s: f = 500..=598. Total 198 frames.
    let mut dets = vec![
        record(100, tilt(1.0)),
        record(101, tilt(3.0)),
        record(150, tilt(20.0)),
        record(500, tilt(2.0)),
    ];
    // A detection between the intervals (7.5 s, far from any tail): false.
    dets.push(record(749, tilt(0.0)));
    // Source 1 (+y), interval 3..4 s, detected exactly in one frame.
    dets.push(record(349, Vector3::y()));
    let r = evaluate(&truth(), &dets, 0.1).unwrap();
    assert!((r.hop_s - 0.01).abs() < 1e-12);
    let s0 = &r.sources[0];
    assert_eq!(s0.detections, 4);
    assert!(
        (s0.mean_error_deg.unwrap() - 6.5).abs() < 1e-9,
        "{:?}",
        s0.mean_error_deg
    );
    assert!((s0.median_error_deg.unwrap() - 2.5).abs() < 1e-9);
    assert_eq!(s0.active_frames, 198);
    assert_eq!(s0.frames_detected, 3, "the 20 deg detection is not a hit");
    assert_eq!((s0.events, s0.events_detected), (2, 2));
    let s1 = &r.sources[1];
    assert_eq!(
        (s1.detections, s1.frames_detected, s1.events_detected),
        (1, 1, 1)
    );
    assert_eq!(r.false_detections, 1);
    // Background: frames overlapping no interval + 0.1 s tail.
    assert!(
        r.background_s > 6.0 && r.background_s < 7.0,
        "{}",
        r.background_s
    );
    assert!((r.false_per_minute.unwrap() - 60.0 / r.background_s).abs() < 1e-9);
    assert_eq!(r.event_detection_rate, Some(1.0));
}

/// The error split: each detection's azimuth and elevation against its source's
/// (source 0 at azimuth 0, elevation 0).
#[test]
fn splits_the_error_into_azimuth_and_elevation() {
    let at = |az: f64, el: f64| crate::geometry::unit_from_angles(az, el);
    let dets = vec![
        record(100, at(2.0, 3.0)),
        record(101, at(-4.0, -1.0)),
        record(102, at(0.0, 4.0)),
    ];
    let r = evaluate(&truth(), &dets, 0.1).unwrap();
    let close = |v: Option<f64>, want: f64| (v.unwrap() - want).abs() < 1e-9;
    assert!(close(r.mean_azimuth_error_deg, 2.0), "{r:?}");
    assert!(close(r.mean_elevation_error_deg, 8.0 / 3.0), "{r:?}");
    assert!(close(r.elevation_bias_deg, 2.0), "{r:?}");
    assert!(r
        .table()
        .contains("azimuth 2.00 deg, elevation 2.67 deg (on average +2.00 deg"));
}

#[test]
fn reads_every_output_format_and_refuses_several_files() {
    let csv = "time_s,azimuth_deg,elevation_deg,x,y,z,score,file,frame,mics\n0.5,0,0,1,0,0,3,a.wav,49,8\n";
    let nd = "{\"time_s\":0.5,\"azimuth_deg\":0,\"elevation_deg\":0,\"x\":1,\"y\":0,\"z\":0,\"score\":3,\"file\":\"a.wav\",\"frame\":49,\"mics\":8}\n";
    let doc = "{\"tool\":{},\"detections\":[\n{\"time_s\":0.5,\"azimuth_deg\":0,\"elevation_deg\":0,\"x\":1,\"y\":0,\"z\":0,\"score\":3,\"file\":\"a.wav\",\"frame\":49,\"mics\":8}\n],\"files\":[]}";
    for text in [csv, nd, doc] {
        let d = parse_detections(text).unwrap();
        assert_eq!(d.len(), 1);
        assert_eq!(d[0].frame, Some(49));
        assert_eq!(
            (d[0].x, d[0].file.as_str(), d[0].mics),
            (1.0, "a.wav", Some(8))
        );
    }
    let two = parse_detections(&format!("{csv}0.6,0,0,1,0,0,3,b.wav,50,8\n")).unwrap();
    let err = evaluate(&truth(), &two, 0.0).unwrap_err();
    assert!(err.to_string().contains("2 files"), "{err}");
    assert!(parse_detections("time_s,x\n0.5,oops\n").is_err());
}

#[test]
fn frame_runs_count_what_visiting_every_frame_counts() {
    // Issue 31, item 14: the active and background frames are counted by binary search
    // over runs, not by visiting (and storing) every frame; a brute force agrees.
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    for _ in 0..300 {
        let hop = rng.random_range(0.001..0.05);
        let frames: u64 = rng.random_range(0..400);
        let centre = |f: u64| (f as f64 + 1.0) * hop;
        let intervals: Vec<(f64, f64)> = (0..rng.random_range(0..5))
            .map(|_| {
                let a: f64 = rng.random_range(-0.5..frames as f64 * hop + 0.5);
                (a, a + rng.random_range(0.0..1.0))
            })
            .collect();
        let inside =
            |f: u64, (a, b): (f64, f64)| centre(f) - hop >= a - 1e-9 && centre(f) + hop <= b + 1e-9;
        let runs = FrameRuns::new(intervals.iter().map(|&iv| {
            (
                first_true(frames, |f| centre(f) - hop >= iv.0 - 1e-9),
                first_true(frames, |f| centre(f) + hop > iv.1 + 1e-9),
            )
        }));
        let brute: Vec<u64> = (0..frames)
            .filter(|&f| intervals.iter().any(|&iv| inside(f, iv)))
            .collect();
        assert_eq!(runs.len(), brute.len() as u64);
        for f in 0..frames + 3 {
            assert_eq!(runs.contains(f), brute.contains(&f), "frame {f}");
        }
    }
}

#[test]
fn a_week_long_truth_is_scored_in_bounded_memory_and_time() {
    let mut t = truth();
    t.duration_s = MAX_DURATION_S;
    t.sample_rate = 768_000;
    t.sources = vec![source(0, Vector3::x(), vec![[1.0, MAX_DURATION_S - 1.0]])];
    let start = std::time::Instant::now();
    let report = evaluate(&t, &[], 0.0).unwrap();
    assert!(start.elapsed().as_secs_f64() < 5.0, "{:?}", start.elapsed());
    // The default frames at 768 kHz hop by 1/93.75 s: about 5.7e7 frames in a week,
    // which the old count visited and stored one by one.
    assert!(report.sources[0].active_frames > 56_000_000, "{report:?}");
}

#[test]
fn pooling_two_recordings_scores_them_as_one_recording_end_to_end() {
    // Recording A: the hand-made truth; B: source 0 alone, other intervals.
    let a = truth();
    let mut b = truth();
    b.sources.truncate(1);
    b.sources[0].active = vec![[2.0, 3.5]];
    let rows_a: Vec<DetectionRecord> = (95..210)
        .map(|f| record(f, tilt(if f % 3 == 0 { 2.0 } else { 6.0 })))
        .chain((300..350).map(|f| record(f, Vector3::y())))
        .chain((700..720).map(|f| record(f, Vector3::z())))
        .collect();
    let rows_b: Vec<DetectionRecord> = (190..260)
        .map(|f| record(f, tilt(if f % 2 == 0 { 1.0 } else { 12.0 })))
        .chain((800..810).map(|f| record(f, Vector3::y())))
        .collect();
    let (ra, rb) = (
        evaluate(&a, &rows_a, 0.0).unwrap(),
        evaluate(&b, &rows_b, 0.0).unwrap(),
    );
    let pooled = pool([&ra, &rb]);
    // The same as one recording of B played after A (B's times shifted by A's 10 s =
    // 1000 hops): each detection, frame and event counts once.
    let mut joined = a.clone();
    joined.duration_s = 20.0;
    let mut shifted = b.sources[0].clone();
    shifted.index = 2;
    shifted.active = vec![[12.0, 13.5]];
    joined.sources.push(shifted);
    let rows: Vec<DetectionRecord> = rows_a
        .iter()
        .cloned()
        .chain(rows_b.iter().map(|r| {
            let f = r.frame.unwrap() + 1000;
            record(f, Vector3::new(r.x, r.y, r.z))
        }))
        .collect();
    let one = evaluate(&joined, &rows, 0.0).unwrap();
    assert_eq!(pooled.recordings, 2);
    assert_eq!(pooled.detections, one.detections);
    assert_eq!(pooled.detections, ra.detections + rb.detections);
    let close = |x: Option<f64>, y: Option<f64>| (x.unwrap() - y.unwrap()).abs() < 1e-9;
    assert!(close(pooled.mean_error_deg, one.mean_error_deg));
    assert!(close(pooled.median_error_deg, one.median_error_deg));
    assert!(close(pooled.frame_detection_rate, one.frame_detection_rate));
    assert!(close(pooled.event_detection_rate, one.event_detection_rate));
    assert_eq!(pooled.false_detections, one.false_detections);
    // Two recordings lose one frame each at their ends (a frame spans two hops).
    assert!((pooled.background_s - one.background_s).abs() <= 0.02 + 1e-9);
}

/// A row in a frame that straddles one source's end, wholly inside another's interval,
/// toward the first: it is not charged to the second (a talker's error stays his own),
/// nor to the first (its frame is not wholly inside its interval).
#[test]
fn a_row_straddling_its_own_sources_end_is_not_charged_to_another() {
    let mut t = truth();
    // A long source 2 at -y over 0.5-9 s, beside source 0 (+x, 1-2 s and 5-6 s).
    t.sources.push(source(2, -Vector3::y(), vec![[0.5, 9.0]]));
    // The frame centred at 2.00 s (f = 199) straddles source 0's end and is wholly
    // inside source 2's interval; a row there toward source 0, and one toward source 2
    // at 3.5 s.
    let dets = vec![record(199, Vector3::x()), record(349, -Vector3::y())];
    let r = evaluate(&t, &dets, 0.0).unwrap();
    let s2 = &r.sources[2];
    assert_eq!(s2.detections, 1, "{s2:?}");
    assert_eq!(s2.mean_error_deg, Some(0.0));
    // The next frame, from 2.00 to 2.02 s, is source 0's only within a tail.
    let r = evaluate(&t, &[record(200, Vector3::x())], 0.0).unwrap();
    assert_eq!(r.sources[2].detections, 1);
    let r = evaluate(&t, &[record(200, Vector3::x())], 0.05).unwrap();
    assert_eq!(r.sources[2].detections, 0);
}

/// Without a room, the default tail is one analysis frame: a row just after a burst
/// (the frame's end, or a smoothed row) is not a false detection; with no tail it was.
#[test]
fn the_default_tail_is_one_frame_and_half_the_rooms_rt60() {
    let t = truth();
    // Hop 0.01 s: frames of 0.02 s. Source 0 ends at 2.0 s; rows 10 and 20 ms later.
    let rows = vec![record(200, Vector3::x()), record(201, Vector3::x())];
    let (tail, rule) = default_tail(&t, &rows);
    assert!((tail - 0.02).abs() < 1e-12, "{tail}");
    assert!(rule.starts_with("one frame"), "{rule}");
    assert_eq!(evaluate(&t, &rows, tail).unwrap().false_detections, 0);
    assert_eq!(evaluate(&t, &rows, 0.0).unwrap().false_detections, 2);
    // With a room, half its RT60 more.
    let mut roomy = t.clone();
    roomy.room = Some(crate::record::TruthRoom {
        dimensions: [5.0, 4.0, 3.0],
        rt60_requested: Some(0.4),
        rt60_measured: 0.4,
        rt60_eyring: 0.4,
        reflection_coefficient: 0.8,
    });
    assert!((default_tail(&roomy, &rows).0 - 0.22).abs() < 1e-12);
}

/// An interval counts in proportion to how much of it was heard: a 4 s interval whose
/// rows span 0.5 s of it is 0.5 s (and a frame's half either side) heard, though it is
/// detected; the share is the same whether events are read off the rows or given.
#[test]
fn an_interval_counts_by_the_share_of_it_heard() {
    let mut t = truth();
    t.sources = vec![source(0, Vector3::x(), vec![[1.0, 5.0]])];
    // Rows every 10 ms over 2.00-2.50 s (frames 199-249), source 1.
    let rows: Vec<DetectionRecord> = (199..=249)
        .map(|f| DetectionRecord {
            source: Some(1),
            ..record(f, Vector3::x())
        })
        .collect();
    let r = evaluate(&t, &rows, 0.0).unwrap();
    assert_eq!(r.sources[0].events_detected, 1);
    // 2.00-2.50 s widened by a hop (0.01 s) either side: 0.52 s of 4 s.
    let heard = 0.52 / 4.0;
    assert!((r.sources[0].events_heard - heard).abs() < 1e-9, "{r:?}");
    assert!((r.event_coverage.unwrap() - heard).abs() < 1e-9);
    assert_eq!(r.event_detection_rate, Some(1.0));
    let tracking = r.tracking.as_ref().unwrap();
    assert_eq!(tracking.events_from, "rows");
    assert!((tracking.event_coverage.unwrap() - heard).abs() < 1e-9);
    // The run's own event over the same span scores the same, said as written.
    let event = EventRecord {
        source: 1,
        start_s: 2.0,
        end_s: 2.5,
        x: 1.0,
        detections: 51,
        ..Default::default()
    };
    let r = evaluate_by(&t, &rows, Some(&[event]), 0.0, &Metric::ThreeD).unwrap();
    let tracking = r.tracking.as_ref().unwrap();
    assert_eq!((tracking.events_from, tracking.events), ("written", 1));
    assert!((tracking.event_coverage.unwrap() - heard).abs() < 1e-9);
}

/// Events the run wrote are scored as written, not read again off the rows: two
/// events of one track 0.2 s apart stay two, though rows 0.2 s apart would be one.
#[test]
fn the_runs_own_events_are_scored_as_written() {
    let mut t = truth();
    t.sources = vec![source(0, Vector3::x(), vec![[1.0, 1.5], [1.7, 2.2]])];
    let rows: Vec<DetectionRecord> = (100..=148)
        .chain(170..=218)
        .map(|f| DetectionRecord {
            source: Some(1),
            ..record(f, Vector3::x())
        })
        .collect();
    let event = |a: f64, b: f64| EventRecord {
        source: 1,
        start_s: a,
        end_s: b,
        x: 1.0,
        ..Default::default()
    };
    // Read off the rows, the 0.2 s pause is shorter than the 0.3 s least: one event.
    let read = evaluate(&t, &rows, 0.0).unwrap();
    let read = read.tracking.unwrap();
    assert_eq!((read.events, read.events_recalled), (1, 2));
    let events = [event(1.01, 1.49), event(1.71, 2.19)];
    let written = evaluate_by(&t, &rows, Some(&events), 0.0, &Metric::ThreeD).unwrap();
    let written = written.tracking.unwrap();
    assert_eq!((written.events, written.events_recalled), (2, 2));
    assert!(written.onset_error_s.unwrap() < 0.02);
    // Events alone (an --events result): events scored, rows absent, not zero.
    let alone = evaluate_by(&t, &[], Some(&events), 0.0, &Metric::ThreeD).unwrap();
    assert_eq!(alone.frame_detection_rate, None);
    assert_eq!(alone.tracking.unwrap().events_recalled, 2);
    // An event that is not finite is refused with its place.
    let bad = [event(f64::NAN, 1.0)];
    let e = evaluate_by(&t, &rows, Some(&bad), 0.0, &Metric::ThreeD).unwrap_err();
    assert!(e.to_string().contains("event 1"), "{e}");
}

/// A moving source's event is scored along its path: a walker who turns 90 deg over 3 s
/// and then stands for 2 s has a mean direction (64 deg) 11 deg from where he is at
/// the event's middle (75 deg); scored from its first and last directions against where
/// he is then, the event is on him.
#[test]
fn a_moving_event_is_scored_along_its_path() {
    let mut t = truth();
    // From 0 deg at 1 s to 90 deg at 4 s, waypoints every half second (a turn written
    // as a path); then still at 90 deg to 6 s.
    let mut s = source(0, Vector3::x(), vec![[1.0, 6.0]]);
    s.waypoints = vec![[1.0, 0.0, 0.0], [4.0, 90.0, 0.0], [6.0, 90.0, 0.0]];
    t.sources = vec![s];
    let at = |az: f64| crate::geometry::unit_from_angles(az, 0.0);
    // Rows every 10 ms of 1-6 s, on the walker.
    let rows: Vec<DetectionRecord> = (99..=599)
        .map(|f| {
            let time = (f + 1) as f64 * 0.01;
            let az = ((time - 1.0) * 30.0).min(90.0);
            DetectionRecord {
                source: Some(1),
                ..record(f, at(az))
            }
        })
        .collect();
    let event = |first: f64, last: f64| EventRecord {
        source: 1,
        start_s: 1.0,
        end_s: 6.0,
        // The mean of the rows' unit vectors.
        x: rows.iter().map(|r| r.x).sum::<f64>() / rows.len() as f64,
        y: rows.iter().map(|r| r.y).sum::<f64>() / rows.len() as f64,
        start_azimuth_deg: first,
        end_azimuth_deg: last,
        ..Default::default()
    };
    let scored = |e: EventRecord| {
        let r = evaluate_by(&t, &rows, Some(&[e]), 0.0, &Metric::ThreeD).unwrap();
        r.tracking.unwrap()
    };
    // Along its path: recalled, its error that of its ends (0).
    let path = scored(event(0.0, 90.0));
    assert_eq!(path.events_recalled, 1);
    assert!(path.event_error_deg.unwrap() < 1e-6, "{path:?}");
    // Its mean alone (first and last as one): 64 deg against 75 deg at 3.5 s, more
    // than 10 deg off: not recalled, and false.
    let mean = rows
        .iter()
        .fold(Vector3::zeros(), |a, r| a + Vector3::new(r.x, r.y, r.z));
    let (mean_az, _) = angles_deg(&mean);
    let flat = scored(event(mean_az, mean_az));
    assert_eq!(
        (flat.events_recalled, flat.false_events),
        (0, 1),
        "{flat:?}"
    );
    // Read off the rows, the same event is scored along its path.
    let read = evaluate(&t, &rows, 0.0).unwrap().tracking.unwrap();
    assert_eq!((read.events, read.events_recalled), (1, 1), "{read:?}");
}
