//! The consistency-checked delay search of the paper's Section II-C (eq. 8).
//!
//! Mic 0 of the live set is the reference ("mic 1" in the paper). A candidate set picks one
//! of the `M` peaks of each `R_0l` (`l = 1..K-1`); it is *consistent* when, for every
//! dependent pair `l' < l`, the derived delay `dT_l'l = dT_0l - dT_0l'` (eq. 8) lies within
//! `tolerance` samples of some peak of `R_l'l` (the highest such peak is the match). The
//! score of a set is the sum of the correlation values of its `K-1` chosen peaks and of
//! the `(K-1)(K-2)/2` matched peaks: one value per pair. Among consistent sets the one with
//! the greatest score wins; ties go to the set that comes first in lexicographic order
//! of peak ranks (peaks are ranked by value, highest first).
//!
//! [`Searcher::search`] returns exactly what [`brute_force`] over all `M^(K-1)` sets
//! returns: it scores every complete set it reaches as brute force does (the same numbers
//! added in the same order), keeps the lexicographically first of equal scores, and
//! prunes only subtrees that hold no set brute force would prefer. Choosing a level's
//! peak matches every candidate of every open level against it at once (forward
//! checking), so (a) a candidate that breaks a constraint with a level chosen before it
//! is never entered, (b) a choice that leaves some open level without a consistent
//! candidate is a dead end at once, and (c) a subtree is left when its upper bound cannot
//! beat the best score found: the partial score, plus per open level its best candidate
//! still consistent with everything chosen (with what its matches so far add), plus the
//! top peaks of the pairs between open levels. The level chosen next is the open one with
//! the fewest consistent candidates left (the most constrained first), and a level's
//! candidates are tried in the order of what they could add, so that the first one whose
//! bound cannot beat the best set ends the level. The worst case is still `M^(K-1)` nodes,
//! reached only when nearly every combination is consistent (a tolerance comparable to
//! the spacing of the peaks), or when many sets score nearly alike (a reverberant room
//! heard by many microphones); a budget in candidate matches (`max_work`, the search's
//! time whatever the array's size) bounds the time per frame, and a frame that exhausts
//! it is reported as not exhaustively searched (docs/method.md gives the budget's
//! evidence).

use super::pairs::pair_index;
use super::peaks::Peak;

/// The paper's consistency tolerance in samples (`--paper`, and under `-t` the unit).
pub(crate) const PAPER_TOLERANCE: f64 = 2.0;

/// Default consistency tolerance in microseconds: 2.4 samples at 48 kHz, 0.8 at 16 kHz
/// (where the floor of one sample, 62.5 us, applies); docs/field.md and
/// docs/tracking.md measure it.
pub(crate) const DEFAULT_TOLERANCE_US: f64 = 50.0;

/// How far a pair's peak may lie from the delay the reference pairs imply (eq. 8): in
/// samples, as the paper gives it, or in microseconds, the same time at every rate.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Tolerance {
    /// Samples at the recording's rate (`-t`; the paper's 2 with `--paper`).
    Samples(f64),
    /// Microseconds, as many samples as that is at each file's rate, at least one
    /// (`--tolerance-us`, the default).
    Us(f64),
}

impl Default for Tolerance {
    fn default() -> Self {
        Tolerance::Us(DEFAULT_TOLERANCE_US)
    }
}

#[cfg(feature = "flags")]
impl clap::FromArgMatches for Tolerance {
    fn from_arg_matches(m: &clap::ArgMatches) -> Result<Self, clap::Error> {
        Ok(match m.get_one::<f64>("tolerance") {
            Some(&samples) => Tolerance::Samples(samples),
            None => Tolerance::Us(
                m.get_one::<f64>("tolerance_us")
                    .copied()
                    .unwrap_or(DEFAULT_TOLERANCE_US),
            ),
        })
    }

    fn update_from_arg_matches(&mut self, m: &clap::ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

#[cfg(feature = "flags")]
impl clap::Args for Tolerance {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        use clap::Arg;
        cmd.arg(
            Arg::new("tolerance")
                .hide_short_help(true)
                .short('t')
                .long("tolerance")
                .value_name("TOLERANCE")
                .value_parser(crate::flags::non_negative_f64)
                .help("Consistency tolerance in samples: how far a pair's peak may be from the delay the reference pairs imply [default: --tolerance-us]"),
        )
        .arg(
            Arg::new("tolerance_us")
                .hide_short_help(true)
                .long("tolerance-us")
                .value_name("US")
                .value_parser(crate::flags::non_negative_f64)
                .default_value(crate::flags::default_shown(DEFAULT_TOLERANCE_US))
                .conflicts_with("tolerance")
                .help("Consistency tolerance in microseconds, the same time at every sample rate"),
        )
    }

    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}

/// The outcome of a search.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// Summed correlation of the chosen and matched peaks (one per pair).
    pub score: f64,
    /// For each live mic `l = 1..K-1`, the rank of the chosen peak of `R_0l`.
    pub choice: Vec<usize>,
    /// For every pair (in [`pair_index`] order), the lag (samples) of its chosen or
    /// matched peak: the pair's own measured delay.
    pub lags: Vec<f64>,
}

/// Reusable state for the search (no allocation per frame once warmed up).
pub struct Searcher {
    /// How far (samples) a pair's peak may lie from the delay the reference pairs imply.
    pub tolerance: f32,
    /// Work at most per search, in candidate matches (see [`Searcher::work`]).
    pub max_work: u64,
    k: usize,
    nodes: u64,
    work: u64,
    exhausted: bool,
    /// Per level `l = 1..K-1`, the rank of its chosen peak (on the current path).
    choice: Vec<usize>,
    /// Per level, whether it is chosen on the current path.
    chosen: Vec<bool>,
    /// Per depth, the level chosen there.
    order: Vec<usize>,
    /// Peaks per level (of `R_0l`) at most, the stride of the per-candidate tables.
    width: usize,
    /// Per (level `l`, candidate `c`), the depth whose choice left it no consistent
    /// peak in its pair with that level, or 0 while it has one with every choice so far.
    killed: Vec<usize>,
    /// Per (level `l`, candidate `c`, chosen level `x`), the value of its matched peak
    /// in the pair of `l` and `x`.
    matched: Vec<f32>,
    /// Per (depth, level `l`, candidate `c`): over the levels `x` chosen up to that depth,
    /// the matched values, less the top peaks of the pairs `(x, l)`, `x < l`, that they
    /// replace in `tops`.
    gained: Vec<f64>,
    /// Per level `l`: the top peaks of its pairs with the levels `x < l`, summed.
    tops: Vec<f64>,
    /// Per pair (in [`pair_index`] order), its top peak's value.
    top: Vec<f64>,
    /// Per (depth, level `l` open at that depth): the most `l` can add with what is
    /// chosen up to that depth (its value, its matches with chosen levels and the top
    /// peaks of its pairs with the open levels before it), for its best candidate still
    /// alive.
    bounds: Vec<f64>,
    /// Per level, the depth it is chosen at (filled at a leaf).
    depth_of: Vec<usize>,
    /// Per depth, the candidates of the level chosen there still alive, each with the
    /// most it could add, that most first.
    ranked: Vec<(f64, usize)>,
    /// Per level `l`, during a forward check: the most the open levels after `l` add,
    /// whatever is chosen after.
    tail: Vec<f64>,
    /// Every pair's peak lags, [`LANES`] to a row (padded with infinity), so that a
    /// pair's first peak within the tolerance of a delay is one vector comparison a row.
    lags: Vec<f32>,
    /// Rows of `lags` per pair.
    rows: usize,
    best_score: f64,
    best_choice: Vec<usize>,
    found: bool,
    solution: Solution,
}

/// Slack for floating-point rounding in the bound: a subtree is pruned only when its
/// bound is below the best score by more than this (relative) amount, so pruning never
/// removes a set that brute force would prefer.
const BOUND_SLACK: f64 = 1e-9;

impl Searcher {
    /// A searcher with this tolerance and budget (in candidate matches).
    pub fn new(tolerance: f32, max_work: u64) -> Self {
        Searcher {
            tolerance,
            max_work,
            k: 0,
            nodes: 0,
            work: 0,
            exhausted: false,
            choice: Vec::new(),
            chosen: Vec::new(),
            order: Vec::new(),
            width: 0,
            killed: Vec::new(),
            matched: Vec::new(),
            gained: Vec::new(),
            tops: Vec::new(),
            bounds: Vec::new(),
            tail: Vec::new(),
            ranked: Vec::new(),
            depth_of: Vec::new(),
            top: Vec::new(),
            lags: Vec::new(),
            rows: 0,
            best_score: f64::NEG_INFINITY,
            best_choice: Vec::new(),
            found: false,
            solution: Solution {
                score: 0.0,
                choice: Vec::new(),
                lags: Vec::new(),
            },
        }
    }

    /// The last search's solution (meaningful only when that search found one).
    pub fn solution(&self) -> Option<&Solution> {
        self.found.then_some(&self.solution)
    }

    /// Nodes (candidate peaks tried) in the last search.
    pub fn nodes(&self) -> u64 {
        self.nodes
    }

    /// The work of the last search, in candidate matches: one per node, plus each
    /// candidate of an open level matched against its choice (what takes the search's
    /// time, about 15 ns each; a node on 32 microphones matches up to 31 times 8, on 8
    /// up to 7 times 8).
    pub fn work(&self) -> u64 {
        self.work
    }

    /// Whether the last search stopped at its budget before finishing.
    pub fn exhausted(&self) -> bool {
        self.exhausted
    }

    /// The best consistent set for `k` live mics whose pair peaks are `peaks[pair_index(a,
    /// b, k)]` (each sorted by value, highest first), or `None` when no set is consistent.
    pub fn search(&mut self, k: usize, peaks: &[Vec<Peak>]) -> Option<&Solution> {
        assert!(k >= 2, "a search needs at least two microphones");
        let pairs = k * (k - 1) / 2;
        self.k = k;
        self.nodes = 0;
        self.work = 0;
        self.exhausted = false;
        self.found = false;
        self.best_score = f64::NEG_INFINITY;
        for v in [&mut self.choice, &mut self.best_choice, &mut self.order] {
            v.clear();
            v.resize(k, 0);
        }
        self.chosen.clear();
        self.chosen.resize(k, false);
        if peaks[..pairs].iter().any(|p| p.is_empty()) {
            return None;
        }
        let width = (1..k)
            .map(|l| peaks[pair_index(0, l, k)].len())
            .max()
            .unwrap_or(0);
        self.width = width;
        self.killed.clear();
        self.killed.resize(k * width, 0);
        self.matched.clear();
        self.matched.resize(k * width * k, 0.0);
        self.gained.clear();
        self.gained.resize(k * k * width, 0.0);
        let most = peaks[..pairs].iter().map(Vec::len).max().unwrap_or(0);
        self.rows = most.div_ceil(LANES);
        self.lags.clear();
        self.lags.resize(pairs * self.rows * LANES, f32::INFINITY);
        for (pair, list) in peaks[..pairs].iter().enumerate() {
            let row = &mut self.lags[pair * self.rows * LANES..];
            for (slot, peak) in row.iter_mut().zip(list) {
                *slot = peak.lag;
            }
        }
        let root = self.start(peaks);
        self.descend(1, root, 0.0, peaks);
        if !self.found {
            return None;
        }
        let sol = &mut self.solution;
        sol.score = self.best_score;
        sol.choice.clear();
        sol.choice.extend_from_slice(&self.best_choice[1..k]);
        sol.lags.clear();
        sol.lags.resize(pairs, 0.0);
        let chosen = |l: usize| peaks[pair_index(0, l, k)][self.best_choice[l]].lag;
        for l in 1..k {
            let p = pair_index(0, l, k);
            sol.lags[p] = chosen(l) as f64;
            for lp in 1..l {
                let p = pair_index(lp, l, k);
                let q = matching_peak(&peaks[p], chosen(l) - chosen(lp), self.tolerance)
                    .expect("the best set is consistent");
                sol.lags[p] = peaks[p][q].lag as f64;
            }
        }
        Some(&self.solution)
    }

    /// Fills `tops` and the root's `bounds`; returns the level to choose first (the one
    /// with the fewest candidates, the first of those).
    fn start(&mut self, peaks: &[Vec<Peak>]) -> usize {
        let k = self.k;
        self.tops.clear();
        self.tops.resize(k, 0.0);
        self.bounds.clear();
        self.bounds.resize(k * k, 0.0);
        self.tail.clear();
        self.tail.resize(k + 1, 0.0);
        self.ranked.clear();
        self.ranked.resize(k * self.width, (0.0, 0));
        self.depth_of.clear();
        self.depth_of.resize(k, 0);
        self.top.clear();
        self.top
            .extend(peaks[..k * (k - 1) / 2].iter().map(|p| p[0].value as f64));
        let mut first = 1;
        for l in 1..k {
            for x in 1..l {
                self.tops[l] += self.top[pair_index(x, l, k)];
            }
            let own = &peaks[pair_index(0, l, k)];
            self.bounds[l] = own[0].value as f64 + self.tops[l];
            if own.len() < peaks[pair_index(0, first, k)].len() {
                first = l;
            }
        }
        first
    }

    /// Tries each candidate of `level`, the level chosen at `depth`, the one that could
    /// add most first, until one cannot beat the best set (nor can those after it). A
    /// candidate's consistency with the levels chosen before it is known already
    /// (forward checking: choosing a level matches every candidate of every open level
    /// against it), so a choice that leaves some open level no consistent candidate is a
    /// dead end at once. The level chosen next is the open one with the fewest
    /// candidates left (the most constrained first). The bound of a subtree adds, per
    /// open level, its best candidate still consistent with what its matches so far add,
    /// plus the top peaks of its pairs with the open levels before it.
    fn descend(&mut self, depth: usize, level: usize, partial: f64, peaks: &[Vec<Peak>]) {
        let (k, width) = (self.k, self.width);
        let reference = &peaks[pair_index(0, level, k)];
        // The candidates still alive, the one that could add most first: each with the
        // most it adds (its value, its matches with the chosen levels, the top peaks of
        // its pairs with the open levels before it).
        let base = depth * width;
        let mut alive = 0;
        for (c, cand) in reference.iter().enumerate() {
            let at = level * width + c;
            if self.killed[at] != 0 {
                continue;
            }
            let gained = if depth > 1 {
                self.gained[((depth - 1) * k + level) * width + c]
            } else {
                0.0
            };
            self.ranked[base + alive] = (cand.value as f64 + self.tops[level] + gained, c);
            alive += 1;
        }
        // The others are tried and turned down at once.
        self.nodes += (reference.len() - alive) as u64;
        self.ranked[base..base + alive].sort_by(|a, b| b.0.total_cmp(&a.0));
        // What the other open levels add at most, whatever this one's choice.
        let others: f64 = (1..k)
            .filter(|&l| l != level && !self.chosen[l])
            .map(|l| self.bounds[(depth - 1) * k + l])
            .sum();
        self.chosen[level] = true;
        self.order[depth] = level;
        for r in base..base + alive {
            let (most, c) = self.ranked[r];
            if self.work >= self.max_work {
                self.exhausted = true;
                break;
            }
            self.nodes += 1;
            self.work += 1;
            let slack = BOUND_SLACK * (1.0 + self.best_score.abs());
            if self.found && partial + most + others < self.best_score - slack {
                // Neither this candidate nor any after it can beat the best set.
                break;
            }
            let cand = reference[c];
            let at = level * width + c;
            let matched = &self.matched[at * k..][..k];
            let score = partial
                + cand.value as f64
                + self.order[1..depth]
                    .iter()
                    .map(|&x| matched[x] as f64)
                    .sum::<f64>();
            self.choice[level] = c;
            if depth + 1 == k {
                self.leaf(peaks);
                continue;
            }
            // What the open levels must add for the set to count.
            let need = if self.found {
                self.best_score - slack - score
            } else {
                f64::NEG_INFINITY
            };
            let Some((later, next)) = self.check_forward(depth, level, c, need, peaks) else {
                continue;
            };
            if later >= need {
                self.descend(depth + 1, next, score, peaks);
                if self.exhausted {
                    break;
                }
            }
        }
        self.chosen[level] = false;
    }

    /// A complete consistent set: scored as [`brute_force`] scores it, kept when it
    /// beats the best so far or ties with it and comes first in lexicographic order.
    fn leaf(&mut self, peaks: &[Vec<Peak>]) {
        let (k, width) = (self.k, self.width);
        for (depth, &level) in self.order[1..k].iter().enumerate() {
            self.depth_of[level] = depth;
        }
        // A pair's match was stored when the later of its two levels was checked
        // against the earlier (the same peak brute force matches: `b - a` and `-(a - b)`
        // are the same number).
        let matched = |l: usize, x: usize| {
            let (later, earlier) = if self.depth_of[l] > self.depth_of[x] {
                (l, x)
            } else {
                (x, l)
            };
            self.matched[(later * width + self.choice[later]) * k + earlier] as f64
        };
        let mut score = 0.0f64;
        for l in 1..k {
            score += peaks[pair_index(0, l, k)][self.choice[l]].value as f64;
            for lp in 1..l {
                score += matched(l, lp);
            }
        }
        if !self.found
            || score > self.best_score
            || (score == self.best_score && self.choice[1..k] < self.best_choice[1..k])
        {
            self.best_score = score;
            self.best_choice.copy_from_slice(&self.choice);
            self.found = true;
        }
    }

    /// Matches every candidate of the open levels against the choice `choice` of `level`
    /// at `depth`; returns the most those levels can add and the one to choose next, or
    /// `None` when one of them has no consistent candidate left or they cannot add
    /// `need`. A choice it turns down is not descended into, so what it leaves unchecked
    /// is never read.
    fn check_forward(
        &mut self,
        depth: usize,
        level: usize,
        choice: usize,
        need: f64,
        peaks: &[Vec<Peak>],
    ) -> Option<(f64, usize)> {
        let (k, width, rows) = (self.k, self.width, self.rows);
        let lag = peaks[pair_index(0, level, k)][choice].lag;
        // Before matching, the most each open level can add: its bound at the depth
        // before, plus (for a level before this one) its pair with this one, which
        // this level's bound counted while it was open.
        self.tail[k] = 0.0;
        for l in (1..k).rev() {
            let mut most = 0.0;
            if !self.chosen[l] {
                most = self.bounds[(depth - 1) * k + l];
                if l < level {
                    most += self.top[pair_index(l, level, k)];
                }
            }
            self.tail[l] = self.tail[l + 1] + most;
        }
        if self.tail[1] < need {
            return None;
        }
        let mut later = 0.0;
        let mut next = 0;
        let mut fewest = usize::MAX;
        for l in 1..k {
            if self.chosen[l] {
                continue;
            }
            let (a, b, sign) = if level < l {
                (level, l, 1.0)
            } else {
                (l, level, -1.0)
            };
            let p = pair_index(a, b, k);
            let pair = &peaks[p];
            let lags = &self.lags[p * rows * LANES..][..rows * LANES];
            self.work += peaks[pair_index(0, l, k)].len() as u64;
            let mut best = f64::NEG_INFINITY;
            let mut alive = 0;
            for (c, cand) in peaks[pair_index(0, l, k)].iter().enumerate() {
                let at = l * width + c;
                if self.killed[at] != 0 && self.killed[at] < depth {
                    continue;
                }
                let before = if depth > 1 {
                    self.gained[((depth - 1) * k + l) * width + c]
                } else {
                    0.0
                };
                match first_within(lags, sign * (cand.lag - lag), self.tolerance) {
                    Some(q) => {
                        self.killed[at] = 0;
                        let value = pair[q].value;
                        self.matched[at * k + level] = value;
                        let replaced = if level < l { self.top[p] } else { 0.0 };
                        let gained = before + value as f64 - replaced;
                        self.gained[(depth * k + l) * width + c] = gained;
                        best = best.max(cand.value as f64 + self.tops[l] + gained);
                        alive += 1;
                    }
                    None => self.killed[at] = depth,
                }
            }
            if alive == 0 {
                return None;
            }
            self.bounds[depth * k + l] = best;
            later += best;
            if later + self.tail[l + 1] < need {
                return None;
            }
            if alive < fewest {
                (next, fewest) = (l, alive);
            }
        }
        Some((later, next))
    }
}

/// Lags compared at once by [`first_within`].
const LANES: usize = 8;

/// The first of `lags` (rows of [`LANES`], padded with infinity) within `tolerance` of
/// `lag`: [`matching_peak`] over the same lags, a row at a time without branches.
#[inline]
fn first_within(lags: &[f32], lag: f32, tolerance: f32) -> Option<usize> {
    for (r, row) in lags.chunks_exact(LANES).enumerate() {
        let mut hits = 0u32;
        for (j, &l) in row.iter().enumerate() {
            hits |= (((l - lag).abs() <= tolerance) as u32) << j;
        }
        if hits != 0 {
            return Some(r * LANES + hits.trailing_zeros() as usize);
        }
    }
    None
}

/// The highest-ranked peak within `tolerance` of `lag`, if any.
#[inline]
fn matching_peak(peaks: &[Peak], lag: f32, tolerance: f32) -> Option<usize> {
    peaks.iter().position(|q| (q.lag - lag).abs() <= tolerance)
}

/// The reference answer: every one of the `M^(K-1)` sets, in lexicographic order, scored
/// exactly as [`Searcher::search`] scores them; the first set with the greatest score.
/// Returns `(score, choice)`.
pub fn brute_force(k: usize, peaks: &[Vec<Peak>], tolerance: f32) -> Option<(f64, Vec<usize>)> {
    let pairs = k * (k - 1) / 2;
    if peaks[..pairs].iter().any(|p| p.is_empty()) {
        return None;
    }
    let sizes: Vec<usize> = (1..k).map(|l| peaks[pair_index(0, l, k)].len()).collect();
    let mut idx = vec![0usize; k - 1];
    let mut best: Option<(f64, Vec<usize>)> = None;
    loop {
        let mut score = 0.0f64;
        let mut consistent = true;
        'levels: for l in 1..k {
            let cand = peaks[pair_index(0, l, k)][idx[l - 1]];
            score += cand.value as f64;
            for lp in 1..l {
                let derived = cand.lag - peaks[pair_index(0, lp, k)][idx[lp - 1]].lag;
                let p = pair_index(lp, l, k);
                match matching_peak(&peaks[p], derived, tolerance) {
                    Some(q) => score += peaks[p][q].value as f64,
                    None => {
                        consistent = false;
                        break 'levels;
                    }
                }
            }
        }
        if consistent && best.as_ref().is_none_or(|(b, _)| score > *b) {
            best = Some((score, idx.clone()));
        }
        // Odometer: the last level turns fastest.
        let mut l = k - 1;
        loop {
            if l == 0 {
                return best;
            }
            idx[l - 1] += 1;
            if idx[l - 1] < sizes[l - 1] {
                break;
            }
            idx[l - 1] = 0;
            l -= 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::method::paper::pairs::pair_count;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Test cases from a seeded generator.
    struct Cases(ChaCha8Rng);
    impl Cases {
        fn new(seed: u64) -> Self {
            Cases(ChaCha8Rng::seed_from_u64(seed))
        }
        fn next(&mut self) -> f64 {
            self.0.random()
        }
    }

    /// Random peak lists: some consistent with a hidden true delay set, the rest random,
    /// lags on a coarse grid so that ties and multiple matches happen.
    fn random_case(rng: &mut Cases, k: usize, m: usize, max_lag: f64) -> Vec<Vec<Peak>> {
        let truth: Vec<f64> = (0..k).map(|_| (rng.next() - 0.5) * max_lag).collect();
        let mut peaks = vec![Vec::new(); pair_count(k)];
        for a in 0..k {
            for b in a + 1..k {
                let count = 1 + (rng.next() * m as f64) as usize % m;
                let mut list: Vec<Peak> = (0..count)
                    .map(|_| Peak {
                        lag: ((rng.next() - 0.5) * 2.0 * max_lag).round() as f32 * 0.5,
                        // Values on a grid of 1/8 so that equal scores occur.
                        value: (rng.next() * 8.0).floor() as f32 / 8.0,
                    })
                    .collect();
                if rng.next() < 0.8 {
                    let i = (rng.next() * count as f64) as usize % count;
                    list[i].lag = ((truth[a] - truth[b]) + (rng.next() - 0.5) * 1.5) as f32;
                }
                list.sort_by(|x, y| y.value.total_cmp(&x.value));
                peaks[pair_index(a, b, k)] = list;
            }
        }
        peaks
    }

    #[test]
    fn search_equals_brute_force_on_random_cases() {
        let mut rng = Cases::new(7);
        let mut consistent = 0;
        for case in 0..3000 {
            let k = 2 + case % 5; // 2..6 microphones
            let m = 1 + case % 4; // 1..4 peaks
            let tol = [0.5f32, 1.0, 2.0, 6.0][case % 4];
            let peaks = random_case(&mut rng, k, m, 10.0);
            let expect = brute_force(k, &peaks, tol);
            let mut s = Searcher::new(tol, u64::MAX);
            let got = s.search(k, &peaks).map(|s| (s.score, s.choice.clone()));
            assert_eq!(
                got, expect,
                "case {case}: k={k} m={m} tol={tol} peaks={peaks:?}"
            );
            consistent += expect.is_some() as usize;
        }
        // The cases exercise both outcomes.
        assert!(consistent > 500 && consistent < 2900, "{consistent}");
    }

    #[test]
    fn search_equals_brute_force_with_8_mics_and_8_peaks() {
        let mut rng = Cases::new(99);
        for case in 0..20 {
            let peaks = random_case(&mut rng, 8, 8, 100.0);
            let tol = if case % 2 == 0 { 2.0 } else { 20.0 };
            let expect = brute_force(8, &peaks, tol);
            let mut s = Searcher::new(tol, u64::MAX);
            let got = s.search(8, &peaks).map(|s| (s.score, s.choice.clone()));
            assert_eq!(got, expect, "case {case}");
            // Pruning does real work: far fewer nodes than the 8^7 = 2,097,152 sets.
            if tol == 2.0 {
                assert!(s.nodes() < 20_000, "{} nodes", s.nodes());
            }
        }
    }

    #[test]
    fn solution_reports_each_pairs_own_lag() {
        // Three mics, exact delays t = (0, 2, 5): lag of R_ab = t_a - t_b.
        let k = 3;
        let mut peaks = vec![Vec::new(); 3];
        peaks[pair_index(0, 1, k)] = vec![
            Peak {
                lag: 9.0,
                value: 0.9,
            },
            Peak {
                lag: -2.0,
                value: 0.8,
            },
        ];
        peaks[pair_index(0, 2, k)] = vec![Peak {
            lag: -5.0,
            value: 0.7,
        }];
        peaks[pair_index(1, 2, k)] = vec![Peak {
            lag: -3.2,
            value: 0.6,
        }];
        let mut s = Searcher::new(1.0, u64::MAX);
        let sol = s.search(k, &peaks).unwrap();
        // 9 is inconsistent (-5 - 9 = -14 is not near -3.2), so -2 is chosen.
        assert_eq!(sol.choice, vec![1, 0]);
        assert!((sol.score - (0.8 + 0.7 + 0.6)).abs() < 1e-6);
        assert_eq!(sol.lags, vec![-2.0, -5.0, -3.200000047683716]);
    }

    #[test]
    fn first_within_is_matching_peak() {
        let mut rng = Cases::new(3);
        for case in 0..2000 {
            let count: usize = case % 20;
            let list: Vec<Peak> = (0..count)
                .map(|_| Peak {
                    lag: ((rng.next() - 0.5) * 40.0) as f32,
                    value: 0.5,
                })
                .collect();
            let mut lags = vec![f32::INFINITY; count.div_ceil(LANES).max(1) * LANES];
            for (slot, p) in lags.iter_mut().zip(&list) {
                *slot = p.lag;
            }
            let lag = ((rng.next() - 0.5) * 40.0) as f32;
            let tolerance = [0.0f32, 0.5, 2.4, 10.0][case % 4];
            assert_eq!(
                first_within(&lags, lag, tolerance),
                matching_peak(&list, lag, tolerance),
                "case {case}"
            );
        }
    }

    /// A pair between two later levels that matches nothing ends the search before its
    /// first node: no candidate of either level has a consistent partner in it.
    #[test]
    fn a_dead_end_is_found_before_any_node() {
        let k = 10;
        let truth: Vec<f32> = (0..k).map(|i| (i as f32 * 3.7) % 11.0).collect();
        let mut peaks: Vec<Vec<Peak>> = vec![Vec::new(); pair_count(k)];
        for a in 0..k {
            for b in a + 1..k {
                peaks[pair_index(a, b, k)] = (0..4)
                    .map(|i| Peak {
                        lag: truth[a] - truth[b] + 40.0 * i as f32,
                        value: 1.0 - 0.1 * i as f32,
                    })
                    .collect();
            }
        }
        let mut s = Searcher::new(1.0, u64::MAX);
        assert!(s.search(k, &peaks).is_some());
        // Pair (1, 9) now matches no delay any choice of level 1 implies.
        for p in peaks[pair_index(1, 9, k)].iter_mut() {
            p.lag += 1000.0;
        }
        assert_eq!(brute_force(k, &peaks, 1.0), None);
        assert!(s.search(k, &peaks).is_none());
        assert_eq!(s.nodes(), 4, "only the first level's candidates are tried");
    }

    #[test]
    fn node_budget_stops_a_pathological_search() {
        // Everything consistent (huge tolerance): M^(K-1) sets without the bound.
        let k = 10;
        let peaks: Vec<Vec<Peak>> = (0..pair_count(k))
            .map(|_| {
                (0..8)
                    .map(|i| Peak {
                        lag: i as f32,
                        value: 1.0,
                    })
                    .collect()
            })
            .collect();
        let mut s = Searcher::new(100.0, 10_000);
        assert!(s.search(k, &peaks).is_some());
        assert!(s.exhausted());
        // Checked before each node, which matches at most every open level's peaks.
        assert!(s.work() <= 10_000 + (k * 8) as u64, "{}", s.work());
        assert!(s.nodes() < s.work());
    }
}
