//! How much of a true interval was heard: the share of its time that the stretches of
//! activity found for its source cover, each stretch widened by half a frame either
//! side (a row stands for its frame). Rows are grouped into stretches as `--events`
//! groups a track's rows ([`ends_after`]), so a row-based coverage and an event-based
//! one measure the same thing.

use crate::track::{ends_after, TrackParams};

/// Whether a row at `t` continues a stretch from `first` to `last` (seconds): unless
/// the silence since is longer than the tracker at its defaults ends an event after.
pub(super) fn continues(first: f64, last: f64, t: f64) -> bool {
    t - last <= ends_after(last - first, TrackParams::default().end_s, true)
}

/// Sorted times grouped into stretches `(first, last)` ([`continues`]).
pub(super) fn stretches(times: impl IntoIterator<Item = f64>) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::new();
    for t in times {
        match out.last_mut() {
            Some((a, b)) if continues(*a, *b, t) => *b = t.max(*b),
            _ => out.push((t, t)),
        }
    }
    out
}

/// The share of `[a, b]` covered by the union of `spans`, each widened by `pad` either
/// side.
pub(super) fn share(a: f64, b: f64, spans: &[(f64, f64)], pad: f64) -> f64 {
    if b <= a {
        return 0.0;
    }
    let mut clipped: Vec<(f64, f64)> = spans
        .iter()
        .map(|&(s, e)| ((s - pad).max(a), (e + pad).min(b)))
        .filter(|(s, e)| s < e)
        .collect();
    clipped.sort_by(|x, y| x.0.total_cmp(&y.0));
    let (mut covered, mut reach) = (0.0, a);
    for (s, e) in clipped {
        let s = s.max(reach);
        if e > s {
            covered += e - s;
            reach = e;
        }
    }
    (covered / (b - a)).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_group_as_events_do_and_cover_what_they_span() {
        // Rows every 0.05 s over 0-1 s, then one at 1.8 s (after 0.8 s of silence, less
        // than the 1 s the stretch has lasted), then one at 3.0 s (1.2 s later: past the
        // 1 s most): two stretches.
        let mut t: Vec<f64> = (0..=20).map(|i| i as f64 * 0.05).collect();
        t.extend([1.8, 3.0]);
        assert_eq!(stretches(t), vec![(0.0, 1.8), (3.0, 3.0)]);
        // A clap's rows 0.1 s long, then silence of 0.35 s: past the 0.3 s least.
        assert_eq!(
            stretches([0.0, 0.05, 0.1, 0.45]),
            vec![(0.0, 0.1), (0.45, 0.45)]
        );
        // 4 s heard for 0.5 s: 12.5%; padded by 0.25 s either side: 25%.
        assert!((share(0.0, 4.0, &[(1.0, 1.5)], 0.0) - 0.125).abs() < 1e-12);
        assert!((share(0.0, 4.0, &[(1.0, 1.5)], 0.25) - 0.25).abs() < 1e-12);
        // Overlapping spans count once; what lies outside the interval not at all.
        assert!(
            (share(0.0, 4.0, &[(-1.0, 1.0), (0.5, 2.0), (3.5, 9.0)], 0.0) - 0.625).abs() < 1e-12
        );
        assert_eq!(share(1.0, 1.0, &[(0.0, 2.0)], 0.0), 0.0);
    }
}
