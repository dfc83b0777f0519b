//! A source's active intervals, indexed for the questions scoring asks of every row and
//! event (is some interval around this time?), so that a truth of a million intervals
//! (a week of words) is scored in n log n, not in rows x intervals.

/// Intervals `(start, end)` sorted by start, with the largest end of every prefix and
/// each one's place in the order they were given.
pub(super) struct Spans {
    starts: Vec<f64>,
    ends: Vec<f64>,
    ids: Vec<usize>,
    max_end: Vec<f64>,
}

impl Spans {
    pub(super) fn new(intervals: impl IntoIterator<Item = (f64, f64)>) -> Spans {
        let mut v: Vec<(f64, f64, usize)> = intervals
            .into_iter()
            .enumerate()
            .map(|(i, (a, b))| (a, b, i))
            .collect();
        v.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
        let mut max_end = Vec::with_capacity(v.len());
        let mut m = f64::NEG_INFINITY;
        for &(_, b, _) in &v {
            m = m.max(b);
            max_end.push(m);
        }
        Spans {
            starts: v.iter().map(|iv| iv.0).collect(),
            ends: v.iter().map(|iv| iv.1).collect(),
            ids: v.iter().map(|iv| iv.2).collect(),
            max_end,
        }
    }

    /// Whether some interval has `start <= x` and `end >= y`.
    pub(super) fn any_reaching(&self, x: f64, y: f64) -> bool {
        let n = self.starts.partition_point(|&a| a <= x);
        n > 0 && self.max_end[n - 1] >= y
    }

    /// Whether some interval has `start < x` and `end > y`.
    pub(super) fn any_strictly(&self, x: f64, y: f64) -> bool {
        let n = self.starts.partition_point(|&a| a < x);
        n > 0 && self.max_end[n - 1] > y
    }

    /// The places (in the order given) of the intervals with `start <= x` and
    /// `end >= y`, latest start first: those whose start is at most `x`, walked back
    /// while some earlier one can still reach `y`.
    pub(super) fn reaching(&self, x: f64, y: f64) -> impl Iterator<Item = usize> + '_ {
        let n = self.starts.partition_point(|&a| a <= x);
        (0..n)
            .rev()
            .take_while(move |&i| self.max_end[i] >= y)
            .filter(move |&i| self.ends[i] >= y)
            .map(move |i| self.ids[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_index_answers_as_a_scan_of_every_interval_does() {
        let mut seed = 7u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let ivs: Vec<(f64, f64)> = (0..300)
            .map(|_| {
                let a = next() * 100.0;
                (a, a + next() * 8.0 + 0.01)
            })
            .collect();
        let spans = Spans::new(ivs.iter().copied());
        for _ in 0..2000 {
            let (x, y) = (next() * 110.0 - 5.0, next() * 110.0 - 5.0);
            let brute = ivs.iter().any(|&(a, b)| a <= x && b >= y);
            assert_eq!(spans.any_reaching(x, y), brute);
            let strict = ivs.iter().any(|&(a, b)| a < x && b > y);
            assert_eq!(spans.any_strictly(x, y), strict);
            let all: Vec<usize> = (0..ivs.len())
                .filter(|&i| ivs[i].0 <= x && ivs[i].1 >= y)
                .collect();
            let mut got: Vec<usize> = spans.reaching(x, y).collect();
            got.sort();
            assert_eq!(got, all);
        }
    }
}
