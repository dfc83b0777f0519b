//! Scoring tracks and events (results whose rows carry a `source`).
//!
//! - A row belongs to a true source when that source is active at the row's time
//!   (its interval extended by the tail) and the row is within `HIT_DEG` of it, the
//!   nearest such source. Per true source: its rows' tracks, the dominant one (most
//!   rows), that track's purity (the share of its rows that belong to the source), and
//!   how many tracks the source is split into.
//! - Events are those the run wrote (`--events`, a JSON result's `events`) when the
//!   result holds them; else they are read off the rows as the tracker makes them: a
//!   track's rows, split where it is silent for longer than the stretch so far (at least
//!   0.3 s, at most [`TrackParams::end_s`](crate::track::TrackParams), 1 s), the
//!   defaults' rule. A true event (an active interval) is recalled by the event that
//!   overlaps it most in time among those whose direction is within `HIT_DEG` of
//!   its source (a still event's mean direction against the source at its middle; an
//!   event whose first and last directions are 10 deg or more apart, a moving source's,
//!   the mean of its first direction's error at its start and its last's at its end);
//!   its direction error and its onset and offset errors (event start minus
//!   interval start, event end minus interval end) are those of that event; its coverage
//!   is the share of its time that all such events cover (each widened by half a frame
//!   either side). An event that overlaps no true event of a source within `HIT_DEG` is
//!   false.
//! - Several sources at once: over the 0.1 s windows in which two or more sources are
//!   active throughout, the share of (window, source) pairs with a row of that source
//!   in the window.

use super::{Det, Metric, Source, HIT_DEG};
use crate::record::event::is_path;
use crate::record::EventRecord;
use crate::track::turn_ended;
use nalgebra::Vector3;
use std::collections::BTreeMap;

/// Window length for several sources at once (seconds).
pub(crate) const OVERLAP_WINDOW_S: f64 = 0.1;

/// How one true source was tracked.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SourceTracks {
    /// The source's index in the scene.
    pub index: usize,
    /// Its rows (within `HIT_DEG`, nearest to it, while it is active).
    pub rows: usize,
    /// The track with most of its rows.
    pub dominant_track: Option<u64>,
    /// The share of the dominant track's rows that belong to this source.
    pub purity: Option<f64>,
    /// Tracks its rows are split into.
    pub tracks: usize,
}

/// The scores of tracks and events.
#[derive(Debug, Clone, serde::Serialize)]
pub struct TrackReport {
    /// Per true source.
    pub sources: Vec<SourceTracks>,
    /// Distinct tracks in the result.
    pub tracks: usize,
    /// Mean tracks per true source, over the sources with rows.
    pub tracks_per_source: Option<f64>,
    /// The lowest purity of a source's dominant track.
    pub min_purity: Option<f64>,
    /// True events (active intervals).
    pub true_events: usize,
    /// True events recalled by an event.
    pub events_recalled: usize,
    /// Where the events come from: `written` (those the run wrote, `--events` or a JSON
    /// result's) or `rows` (read off the rows as `--events` makes them).
    pub events_from: &'static str,
    /// Events scored.
    pub events: usize,
    /// Of those, events matching no true event.
    pub false_events: usize,
    /// False events per minute of recording.
    pub false_events_per_minute: f64,
    /// Mean direction error of the recalling events (degrees).
    pub event_error_deg: Option<f64>,
    /// Mean absolute onset error (seconds).
    pub onset_error_s: Option<f64>,
    /// Mean absolute offset error (seconds).
    pub offset_error_s: Option<f64>,
    /// True events in proportion to how much of each the events cover: the mean share.
    pub event_coverage: Option<f64>,
    /// (window, source) pairs with two or more sources active throughout the window.
    pub overlap_pairs: usize,
    /// Of those, pairs with a row of the source in the window.
    pub overlap_detected: usize,
}

/// An event: its first and last row's times, the sum of its rows' directions, and its
/// first and last row's directions (where a moving source started and ended).
#[derive(Clone, Copy)]
pub(super) struct Stretch {
    pub(super) start: f64,
    pub(super) end: f64,
    pub(super) sum: Vector3<f64>,
    pub(super) first: Vector3<f64>,
    pub(super) last: Vector3<f64>,
}

impl Stretch {
    /// An event the run wrote, with its mean direction `direction` (a unit vector); a
    /// result written before events had first and last directions gives its mean for
    /// both.
    pub(super) fn written(e: &EventRecord, direction: Vector3<f64>) -> Stretch {
        let (first, last) = e.ends().unwrap_or((direction, direction));
        Stretch {
            start: e.start_s,
            end: e.end_s.max(e.start_s),
            sum: direction,
            first,
            last,
        }
    }

    /// Its error (degrees) against `s`: a moving event's
    /// ([`is_path`](crate::record::event::is_path)) is the mean of its first
    /// direction's against the source at its start and its last's at its end; a still
    /// one's, its mean direction's against the source at its middle.
    fn error_deg(&self, s: &Source, metric: &Metric) -> f64 {
        if is_path(&self.first, &self.last) {
            (metric.error_deg(&self.first, &s.at(self.start))
                + metric.error_deg(&self.last, &s.at(self.end)))
                / 2.0
        } else {
            metric.error_deg(&self.sum, &s.at((self.start + self.end) / 2.0))
        }
    }
}

/// What scoring tracks needs to know besides rows and sources.
pub(super) struct Scoring<'a> {
    pub(super) duration_s: f64,
    /// The analysis hop (seconds): a row stands for one frame, a hop either side.
    pub(super) hop_s: f64,
    pub(super) tail_s: f64,
    pub(super) metric: &'a Metric,
}

/// Tracks and events of `dets` (each with its track in `tracks`) against `sources`;
/// events from `written` when the run wrote them, else read off the rows.
pub(super) fn score_tracks(
    sources: &[Source],
    dets: &[Det],
    tracks: &[u64],
    written: Option<Vec<Stretch>>,
    how: &Scoring,
) -> TrackReport {
    let Scoring {
        duration_s,
        tail_s,
        metric,
        ..
    } = *how;
    let active = |s: &Source, t: f64| s.spans.any_reaching(t, t - tail_s);
    // The true source of each row, if any.
    let owner: Vec<Option<usize>> = dets
        .iter()
        .map(|d| {
            sources
                .iter()
                .enumerate()
                .filter(|(_, s)| active(s, d.time_s))
                .map(|(i, s)| (i, metric.error_deg(&d.direction, &s.at(d.time_s))))
                .filter(|(_, e)| *e < HIT_DEG)
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(i, _)| i)
        })
        .collect();
    let mut rows_of_track: BTreeMap<u64, usize> = BTreeMap::new();
    for &t in tracks {
        *rows_of_track.entry(t).or_default() += 1;
    }
    let per_source = source_tracks(sources.len(), &owner, tracks, &rows_of_track);
    let with_rows: Vec<&SourceTracks> = per_source.iter().filter(|s| s.rows > 0).collect();
    let events_from = if written.is_some() { "written" } else { "rows" };
    let stretches = written.unwrap_or_else(|| stretches(dets, tracks));
    // An event's direction against its source's ([`Stretch::error_deg`]).
    let matches = |e: &Stretch, s: &Source, (a, b): (f64, f64)| {
        e.start <= b + tail_s && e.end >= a && e.error_deg(s, metric) < HIT_DEG
    };
    let (mut true_events, mut recalled) = (0, 0);
    let (mut errors, mut onsets, mut offsets) = (Vec::new(), Vec::new(), Vec::new());
    let mut covered = 0.0;
    let indexed = super::Spans::new(stretches.iter().map(|e| (e.start, e.end)));
    for s in sources {
        for &(a, b) in &s.intervals {
            true_events += 1;
            let overlap = |e: &Stretch| e.end.min(b + tail_s) - e.start.max(a);
            // The stretches that overlap the interval (start <= b + tail, end >= a),
            // found through the index, in the order a scan of them all takes.
            let mut candidates: Vec<usize> = indexed.reaching(b + tail_s, a).collect();
            candidates.sort_unstable();
            let found: Vec<&Stretch> = candidates
                .into_iter()
                .map(|i| &stretches[i])
                .filter(|e| matches(e, s, (a, b)))
                .collect();
            let spans: Vec<(f64, f64)> = found.iter().map(|e| (e.start, e.end)).collect();
            covered += super::coverage::share(a, b, &spans, how.hop_s);
            if let Some(e) = found
                .into_iter()
                .max_by(|x, y| overlap(x).total_cmp(&overlap(y)))
            {
                recalled += 1;
                errors.push(e.error_deg(s, metric));
                onsets.push((e.start - a).abs());
                offsets.push((e.end - b).abs());
            }
        }
    }
    let false_events = stretches
        .iter()
        .filter(|e| {
            !sources.iter().any(|s| {
                s.spans.any_reaching(e.end, e.start - tail_s) && e.error_deg(s, metric) < HIT_DEG
            })
        })
        .count();
    let (overlap_pairs, overlap_detected) = overlaps(sources, dets, &owner, duration_s);
    let mean = |v: &[f64]| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
    TrackReport {
        tracks: rows_of_track.len(),
        tracks_per_source: (!with_rows.is_empty()).then(|| {
            with_rows.iter().map(|s| s.tracks as f64).sum::<f64>() / with_rows.len() as f64
        }),
        min_purity: with_rows
            .iter()
            .filter_map(|s| s.purity)
            .min_by(f64::total_cmp),
        sources: per_source,
        true_events,
        events_recalled: recalled,
        events_from,
        events: stretches.len(),
        false_events,
        false_events_per_minute: false_events as f64 / (duration_s / 60.0),
        event_error_deg: mean(&errors),
        onset_error_s: mean(&onsets),
        offset_error_s: mean(&offsets),
        event_coverage: (true_events > 0).then(|| covered / true_events as f64),
        overlap_pairs,
        overlap_detected,
    }
}

/// Per true source: its rows (those whose direction is its), the track most of them
/// are in and that track's share of them, and how many tracks they are spread over.
fn source_tracks(
    sources: usize,
    owner: &[Option<usize>],
    tracks: &[u64],
    rows_of_track: &BTreeMap<u64, usize>,
) -> Vec<SourceTracks> {
    let mut per_source = Vec::new();
    for i in 0..sources {
        let mut by_track: BTreeMap<u64, usize> = BTreeMap::new();
        for (o, &t) in owner.iter().zip(tracks) {
            if *o == Some(i) {
                *by_track.entry(t).or_default() += 1;
            }
        }
        let dominant = by_track
            .iter()
            .max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0)))
            .map(|(&t, &n)| (t, n));
        per_source.push(SourceTracks {
            index: i,
            rows: by_track.values().sum(),
            dominant_track: dominant.map(|d| d.0),
            purity: dominant.map(|(t, n)| n as f64 / rows_of_track[&t] as f64),
            tracks: by_track.len(),
        });
    }
    per_source
}

/// The events read off the rows: each track's runs of rows split where it is silent
/// longer than the tracker ends an event after (the defaults' rule,
/// [`continues`](super::coverage::continues)), or where another track's run starts
/// after it has been silent for a turn's gap (the tracker's rule, [`turn_ended`]),
/// with the sum of their directions.
fn stretches(dets: &[Det], tracks: &[u64]) -> Vec<Stretch> {
    let mut open: BTreeMap<u64, Stretch> = BTreeMap::new();
    let mut stretches = Vec::new();
    for (d, &t) in dets.iter().zip(tracks) {
        match open.get_mut(&t) {
            Some(s) if super::coverage::continues(s.start, s.end, d.time_s) => {
                s.end = d.time_s;
                s.sum += d.direction;
                s.last = d.direction;
            }
            _ => {
                let new = Stretch {
                    start: d.time_s,
                    end: d.time_s,
                    sum: d.direction,
                    first: d.direction,
                    last: d.direction,
                };
                if let Some(done) = open.insert(t, new) {
                    stretches.push(done);
                }
                open.retain(|&other, s| {
                    let ended = other != t && turn_ended(s.end, d.time_s);
                    if ended {
                        stretches.push(*s);
                    }
                    !ended
                });
            }
        }
    }
    stretches.extend(open.into_values());
    stretches
}

/// Several sources at once: the (source, window of [`OVERLAP_WINDOW_S`]) pairs where
/// two or more sources sound, and those of them with a row of the source.
fn overlaps(
    sources: &[Source],
    dets: &[Det],
    owner: &[Option<usize>],
    duration_s: f64,
) -> (usize, usize) {
    // The (source, window) pairs with a row, in one pass.
    // The window [w * W, (w + 1) * W) holding t, with the bounds computed as below.
    let window_of = |t: f64| {
        let w = (t / OVERLAP_WINDOW_S).floor() as i64;
        if t >= (w + 1) as f64 * OVERLAP_WINDOW_S {
            w + 1
        } else if t < w as f64 * OVERLAP_WINDOW_S {
            w - 1
        } else {
            w
        }
    };
    let seen: std::collections::BTreeSet<(usize, i64)> = dets
        .iter()
        .zip(owner)
        .filter_map(|(d, o)| o.map(|i| (i, window_of(d.time_s))))
        .collect();
    let (mut overlap_pairs, mut overlap_detected) = (0, 0);
    let windows = (duration_s / OVERLAP_WINDOW_S).floor() as i64;
    for w in 0..windows {
        let (w0, w1) = (
            w as f64 * OVERLAP_WINDOW_S,
            (w + 1) as f64 * OVERLAP_WINDOW_S,
        );
        let on: Vec<usize> = (0..sources.len())
            .filter(|&i| sources[i].spans.any_reaching(w0, w1))
            .collect();
        if on.len() < 2 {
            continue;
        }
        overlap_pairs += on.len();
        overlap_detected += on.iter().filter(|&&i| seen.contains(&(i, w))).count();
    }
    (overlap_pairs, overlap_detected)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::unit_from_angles;

    fn det(t: f64, azimuth: f64) -> Det {
        Det {
            time_s: t,
            direction: unit_from_angles(azimuth, 0.0),
            frame: None,
            source: None,
        }
    }

    #[test]
    fn events_read_off_rows_end_a_turn_when_another_takes_the_floor() {
        // Track 1 talks 0-1 s, track 2 from 1.3 s; a row of track 1 at 1.5 s, within
        // the silence that would end its stretch (as long as the stretch), is a new
        // stretch: track 2 took the floor after track 1 had been silent 0.3 s. The
        // tracker writes its events by the same rule.
        let mut rows: Vec<(Det, u64)> = (0..=20).map(|i| (det(0.05 * i as f64, 0.0), 1)).collect();
        rows.extend((0..=20).map(|i| (det(1.3 + 0.05 * i as f64, 20.0), 2)));
        rows.push((det(1.5, 1.0), 1));
        rows.sort_by(|a, b| a.0.time_s.total_cmp(&b.0.time_s));
        let (dets, ids): (Vec<Det>, Vec<u64>) = rows.into_iter().unzip();
        let mut spans: Vec<(f64, f64)> = stretches(&dets, &ids)
            .iter()
            .map(|s| (s.start, s.end))
            .collect();
        spans.sort_by(|a, b| a.0.total_cmp(&b.0));
        assert_eq!(spans.len(), 3, "{spans:?}");
        assert!((spans[0].1 - 1.0).abs() < 1e-9, "{spans:?}");
        assert!((spans[2].0 - 1.5).abs() < 1e-9, "{spans:?}");
    }

    #[test]
    fn scores_hand_made_tracks_and_events() {
        // Source 0 at 0 deg, on 1-3 s and 6-8 s; source 1 at 90 deg, on 2-5 s.
        let sources = vec![
            Source::new(
                unit_from_angles(0.0, 0.0),
                None,
                Vec::new(),
                vec![(1.0, 3.0), (6.0, 8.0)],
            ),
            Source::new(
                unit_from_angles(90.0, 0.0),
                None,
                Vec::new(),
                vec![(2.0, 5.0)],
            ),
        ];
        let mut rows = Vec::new();
        // Track 1 follows source 0 through 1.2-2.8 s and again 6.5-7.5 s (a new event
        // after 3.7 s of silence); one row of track 1 strays to source 1 at 2.5 s.
        for i in 0..9 {
            rows.push((det(1.2 + 0.2 * i as f64, 1.0), 1));
        }
        rows.push((det(2.5, 89.0), 1));
        for i in 0..6 {
            rows.push((det(6.5 + 0.2 * i as f64, -1.0), 1));
        }
        // Source 1 split into tracks 2 (2.1-3.1 s) and 3 (4.0-4.8 s).
        for i in 0..6 {
            rows.push((det(2.1 + 0.2 * i as f64, 91.0), 2));
        }
        for i in 0..5 {
            rows.push((det(4.0 + 0.2 * i as f64, 90.0), 3));
        }
        // Track 4: something at 200 deg during source 1 only: a false event.
        rows.push((det(4.5, -160.0), 4));
        rows.push((det(4.6, -160.0), 4));
        rows.sort_by(|a, b| a.0.time_s.total_cmp(&b.0.time_s));
        let (dets, ids): (Vec<Det>, Vec<u64>) = rows.into_iter().unzip();
        let how = Scoring {
            duration_s: 10.0,
            hop_s: 0.0,
            tail_s: 0.0,
            metric: &Metric::ThreeD,
        };
        let r = score_tracks(&sources, &dets, &ids, None, &how);
        assert_eq!(r.tracks, 4);
        let s0 = &r.sources[0];
        assert_eq!((s0.rows, s0.dominant_track, s0.tracks), (15, Some(1), 1));
        // Track 1 holds 16 rows, 15 of them source 0's.
        assert!((s0.purity.unwrap() - 15.0 / 16.0).abs() < 1e-12);
        let s1 = &r.sources[1];
        // Source 1: the stray row of track 1, 6 of track 2, 5 of track 3.
        assert_eq!((s1.rows, s1.dominant_track, s1.tracks), (12, Some(2), 3));
        assert_eq!(s1.purity, Some(1.0));
        assert_eq!(r.tracks_per_source, Some(2.0));
        // Events: track 1 twice (with the stray row inside its first), tracks 2, 3, 4.
        assert_eq!((r.events, r.true_events, r.events_recalled), (5, 3, 3));
        assert_eq!(r.false_events, 1);
        assert!((r.false_events_per_minute - 6.0).abs() < 1e-12);
        // Onsets: 0.2 (1.2 vs 1), 0.5 (6.5 vs 6), 0.1 (2.1 vs 2); offsets: 0.2 (2.8 vs 3),
        // 0.5 (7.5 vs 8), 1.9 (3.1 vs 5: track 2 overlaps source 1 longer than track 3).
        assert!((r.onset_error_s.unwrap() - 0.8 / 3.0).abs() < 1e-9);
        assert!((r.offset_error_s.unwrap() - 2.6 / 3.0).abs() < 1e-9);
        // 2-3 s: both sources on, 10 windows x 2 sources; source 0 has a row in the
        // windows at 2.0, 2.2, 2.4, 2.6, 2.8 (5), source 1 at 2.1, 2.3, 2.5, 2.7, 2.9 (5).
        assert_eq!((r.overlap_pairs, r.overlap_detected), (20, 10));
    }
}
