//! Steered response over the averaged correlations (beyond the paper): candidates that
//! do not need every pair to agree, and further sources in the same frame.
//!
//! The consistency search of eq. (8) keeps a direction only when every pair has one of
//! its M peaks at that direction's delay. With real speech in a reverberant room a pair
//! or two often has not, and the frame gives nothing; with two talkers at once each
//! pair's peaks are shared between them. Here each pair's averaged correlation is read
//! at the delays of every direction of a fixed grid and summed over the pairs (the
//! steered response power of SRP-PHAT, built from the same weighted correlations), so
//! a pair that disagrees only lowers the sum.
//!
//! - **Grid:** [`GRID_POINTS`] directions spread evenly over the sphere (a Fibonacci
//!   lattice, no point further than about [`COVER_RAD`] from the nearest). Each pair's
//!   correlation is first replaced by its running maximum over the lags a direction
//!   can move within that distance, so no peak falls between grid points.
//! - **Refinement:** from the best grid point, each pair's highest local peak near the
//!   point's delay (sub-sample refined) gives its lag, and eq. (13) through the same
//!   solver as the consistency search gives the direction; twice, the second time within
//!   the consistency tolerance. Pairs with no peak there keep the delay of the direction
//!   itself, so they do not pull it.
//! - **Score:** the sum over the pairs of the refined peaks within the tolerance of the
//!   final direction's delays (zero for a pair with none): the same quantity, on the
//!   same scale, as a consistent set's score, so the same threshold applies.
//! - **Further sources:** every pair's correlation is cleared (its positive part) within
//!   [`CLEAR_SAMPLES`] plus the tolerance of each found direction's delay, and the grid
//!   is searched again.

use crate::method::paper::correlation::window_max;
use crate::method::paper::direction::DirectionSolver;
use crate::method::paper::pairs::pair_index;
use multiversion::multiversion;
use nalgebra::Vector3;

/// When the steered response gives a frame's direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Steering {
    /// Never: only consistent sets (the paper's search).
    #[default]
    Off,
    /// Where no set is consistent, its peak when it passes the threshold with at least
    /// half the pairs agreeing and within the residual gate; and further sources (with a
    /// tracker under the calibrated threshold).
    Partial,
    /// Where no set is consistent, its peak in every frame, whatever it scores and
    /// however many pairs agree (`ssl analyze --every-frame`): the row's score and cone
    /// say how far to trust it.
    EveryFrame,
}

impl Steering {
    /// Whether the steered response runs at all.
    pub fn is_on(self) -> bool {
        self != Steering::Off
    }
}

/// Directions in the grid.
pub(crate) const GRID_POINTS: usize = 1000;

/// The largest angle (radians) from any direction to its nearest grid point, with a
/// margin: for a Fibonacci lattice of `n` points about `0.7 sqrt(4 pi / n)`.
pub(crate) const COVER_RAD: f64 = 0.085;

/// Half-width (samples, beyond the tolerance) of what is cleared around a found
/// source's delay before the next is looked for.
pub const CLEAR_SAMPLES: f32 = 1.0;

/// The tolerance (samples) of a steered direction's pairs where the consistency
/// tolerance sits at its floor of one sample (at 20 kHz and under with the default 50
/// us), on arrays whose longest delay is at least [`LOOSE_MIN_LAGS`] samples: in a faint
/// talker's frames in a reverberant room a pair's refined peak stands up to two samples
/// at 16 kHz off the plane wave's delay. On the prism at 16 kHz, words found 94-99% ->
/// 99-100% and hard rooms 56-96% -> 78-100%, no false event (benches/words.py,
/// docs/experiments.md, 2026-12-06).
pub(crate) const LOOSE_SAMPLES: f32 = 2.0;

/// Arrays whose longest delay is under this many samples keep the consistency
/// tolerance for the steered response: on the 8-mic circle of radius 15 cm at 16 kHz
/// (14 samples) two samples split one talker in eight into two tracks
/// (benches/voices.py), and on smaller arrays they are a quarter of the delays or more.
pub(crate) const LOOSE_MIN_LAGS: f64 = 16.0;

/// How far (samples) a pair's peak may lie from a steered direction's delay, for an
/// array whose longest delay is `longest` samples: [`LOOSE_SAMPLES`] where the
/// consistency `tolerance` is one sample or less on arrays of [`LOOSE_MIN_LAGS`] or
/// more (at higher rates, 50 us is 1.6 samples and more and is kept), else `tolerance`.
/// [`Steering::EveryFrame`] keeps `tolerance`: its cones, fitted to it, held the truth
/// in 90% of a pyroomacoustics room's frames with two samples (93% asked,
/// python/tests/test_pyroomacoustics.py).
pub(crate) fn steer_tolerance(tolerance: f32, longest: f64, steering: Steering) -> f32 {
    if steering != Steering::EveryFrame && longest >= LOOSE_MIN_LAGS && tolerance <= 1.0 {
        LOOSE_SAMPLES
    } else {
        tolerance
    }
}

/// Further sources are looked for this far (degrees) from those found.
pub(crate) const EXCLUDE_DEG: f64 = 15.0;

/// The grid points ordered by their response before the best apart are picked.
pub(crate) const TOP_POINTS: usize = 64;

/// A further source in a frame scores at least this share of the first: a strong
/// source's side lobes, left after its delays are cleared, add up to 10-12% of its score
/// in other directions (measured on the shipped example).
pub const FURTHER_SHARE: f64 = 0.2;

/// The most pairs the grid reads, the longest baselines (every pair of arrays up to 12
/// microphones; 32 microphones have 496). The refinement reads them all.
pub(crate) const GRID_PAIRS: usize = 66;

/// Grid points refined per search: the best, apart by [`SEPARATION_DEG`].
pub(crate) const REFINED: usize = 6;

/// Grid points refined in one search are at least this far apart (degrees).
pub const SEPARATION_DEG: f64 = 10.0;

/// Entries of [`Steered`]'s table: one per `u16` index.
const TABLE: usize = 1 << 16;

/// The grid, its delays per pair, and the buffers of one search.
pub(crate) struct Steered {
    points: Vec<Vector3<f64>>,
    /// Per pair of the array (in the order of [`pair_index`] over all microphones), the
    /// index into the pair's window (lag `-h-1` at 0) of each grid point's delay.
    index: Vec<Vec<u16>>,
    /// Per pair, `x_ab * fs / c` (samples per unit of direction).
    diffs: Vec<Vector3<f64>>,
    /// Per pair, the running maximum's half-width (samples).
    radius: Vec<usize>,
    /// Per pair, whether the grid reads it (at most [`GRID_PAIRS`], the longest).
    coarse: Vec<bool>,
    /// Per pair, where its window starts in a frame's windows, and its half-length.
    starts: Vec<(usize, usize)>,
    pooled: Vec<f32>,
    scratch: Vec<f32>,
    /// A pair's running maximum, at the start of a table every `u16` indexes (so the
    /// grid's reads need no bounds checks and vectorise; only the start is ever touched).
    table: Box<[f32; TABLE]>,
    /// Per value of the windows searched (laid out as a frame's), the value when it is
    /// a positive local maximum ([`local_peak`]'s candidates), else 0: marked once a
    /// search, read by every refinement.
    marks: Vec<f32>,
    power: Vec<f32>,
    order: Vec<usize>,
    tried: Vec<Vector3<f64>>,
    lags: Vec<f64>,
    /// The lags (per live pair, in the order of [`pair_index`]) behind the direction
    /// the last search gave.
    best_lags: Vec<f64>,
}

/// What one search looks at: the live microphones `live` (of `mics`), the directions
/// `found` so far (cleared first), the tolerance in samples, and the score under which
/// nothing counts.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Query<'a> {
    pub live: &'a [usize],
    pub mics: usize,
    pub found: &'a [Vector3<f64>],
    pub tolerance: f32,
    pub floor: f64,
}

/// A direction the steered response found, with its score (summed over the pairs).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Steer {
    pub direction: Vector3<f64>,
    pub score: f64,
    /// Pairs with a peak within the tolerance of the direction's delay.
    pub agreeing: usize,
}

impl Steered {
    pub fn new(positions: &[Vector3<f64>], rate: f64, speed: f64, max_lag: &[usize]) -> Self {
        let mics = positions.len();
        let n = GRID_POINTS;
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let points: Vec<Vector3<f64>> = (0..n)
            .map(|i| {
                let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
                let r = (1.0 - z * z).sqrt();
                let phi = golden * i as f64;
                Vector3::new(r * phi.cos(), r * phi.sin(), z)
            })
            .collect();
        let mut diffs = vec![Vector3::zeros(); max_lag.len()];
        let mut radius = vec![0; max_lag.len()];
        let mut index = vec![Vec::new(); max_lag.len()];
        let mut starts = vec![(0, 0); max_lag.len()];
        let mut start = 0;
        for a in 0..mics {
            for b in a + 1..mics {
                let pair = pair_index(a, b, mics);
                let half = max_lag[pair] + 1;
                let x = (positions[b] - positions[a]) * rate / speed;
                diffs[pair] = x;
                radius[pair] = (x.norm() * COVER_RAD).ceil() as usize;
                index[pair] = points
                    .iter()
                    .map(|u| {
                        let lag = u.dot(&x).round() as isize;
                        (lag.clamp(-(half as isize) + 1, half as isize - 1) + half as isize) as u16
                    })
                    .collect();
                starts[pair] = (start, half);
                start += 2 * half + 1;
            }
        }
        let widest_radius = radius.iter().copied().max().unwrap_or(0);
        // The grid reads the longest baselines only (they resolve directions best);
        // the refinement reads every pair.
        let mut by_length: Vec<usize> = (0..diffs.len()).collect();
        by_length.sort_by(|&x, &y| diffs[y].norm().total_cmp(&diffs[x].norm()).then(x.cmp(&y)));
        let mut coarse = vec![false; diffs.len()];
        for &pair in by_length.iter().take(GRID_PAIRS) {
            coarse[pair] = true;
        }
        Steered {
            coarse,
            power: vec![0.0; points.len()],
            points,
            index,
            diffs,
            radius,
            starts,
            pooled: Vec::with_capacity(
                max_lag.iter().map(|&h| 2 * h + 3).max().unwrap_or(0) + 2 * widest_radius,
            ),
            scratch: Vec::with_capacity(
                max_lag.iter().map(|&h| 2 * h + 3).max().unwrap_or(0) + 2 * widest_radius,
            ),
            table: vec![0.0; TABLE]
                .into_boxed_slice()
                .try_into()
                .expect("TABLE entries"),
            marks: vec![0.0; start],
            order: Vec::with_capacity(GRID_POINTS),
            tried: Vec::with_capacity(REFINED),
            lags: Vec::with_capacity(max_lag.len()),
            best_lags: Vec::with_capacity(max_lag.len()),
        }
    }

    /// Per pair of the array (in the order of [`pair_index`]), `x_ab * fs / c`: a
    /// direction's delay over the pair, in samples, is its dot product with this.
    pub fn pair_samples(&self, pair: usize) -> &Vector3<f64> {
        &self.diffs[pair]
    }

    /// Whether `steer`, the last search's result, is a direction: it scores `floor` or
    /// more with at least half the `pairs` agreeing, and (with the residual gate) a
    /// single source explains its delays (a source's mixed with a reflection's are no
    /// more a direction here than in the consistency search): a residual of at most
    /// `gate_us` microseconds at the speed of sound `speed`. When it is, its fit's
    /// residual ([`Steered::residual_m`], metres), computed once for the gate and the
    /// detection's uncertainty.
    pub fn accepts(
        &self,
        steer: &Steer,
        floor: f64,
        pairs: usize,
        (gate_us, speed): (Option<f64>, f64),
        solver: &DirectionSolver,
    ) -> Option<f64> {
        if steer.score < floor || steer.agreeing < pairs.div_ceil(2) {
            return None;
        }
        let residual = self.residual_m(steer, solver);
        gate_us
            .is_none_or(|gate| residual / speed * 1e6 <= gate)
            .then_some(residual)
    }

    /// The far-field fit's residual (metres, [`DirectionSolver::residual_m`]) of `steer`,
    /// the last search's result, at the delays it read.
    pub fn residual_m(&self, steer: &Steer, solver: &DirectionSolver) -> f64 {
        solver.residual_m(&self.best_lags, &steer.direction)
    }

    /// The best direction of the summed correlations `windows` (laid out as a frame's,
    /// averaged) for `query`, after clearing the delays of the directions found. `None`
    /// when none can reach its floor.
    pub fn search(
        &mut self,
        windows: &mut [f32],
        query: &Query,
        solver: &DirectionSolver,
    ) -> Option<Steer> {
        let Query {
            live,
            mics,
            found,
            tolerance,
            floor,
        } = *query;
        let k = live.len();
        // Clear what the sources found so far explain.
        for u in found {
            for a in 0..k {
                for b in a + 1..k {
                    let pair = pair_index(live[a], live[b], mics);
                    let (start, half) = self.starts[pair];
                    let w = &mut windows[start..start + 2 * half + 1];
                    let centre = u.dot(&self.diffs[pair]) as f32 + half as f32;
                    let reach = tolerance + CLEAR_SAMPLES;
                    let (lo, hi) = whole_within((centre - reach) as f64, (centre + reach) as f64);
                    let (lo, hi) = (lo.max(0) as usize, (hi.max(0) as usize).min(w.len() - 1));
                    for v in w.iter_mut().take(hi + 1).skip(lo) {
                        *v = v.min(0.0);
                    }
                }
            }
        }
        // Each pair's positive local maxima, for the refinements. A refinement scores
        // per pair one of them, refined: when the pairs' largest refined maxima cannot
        // reach `floor` (summed as a score is), nothing is refined.
        let mut most = 0.0f64;
        for a in 0..k {
            for b in a + 1..k {
                let pair = pair_index(live[a], live[b], mics);
                let (start, half) = self.starts[pair];
                let range = start..start + 2 * half + 1;
                most += mark_peaks(&windows[range.clone()], &mut self.marks[range]) as f64;
            }
        }
        if most <= 0.0 || most < floor {
            return None;
        }
        // The steered response of the grid, from each pair's running maximum.
        self.power.iter_mut().for_each(|p| *p = 0.0);
        for a in 0..k {
            for b in a + 1..k {
                let pair = pair_index(live[a], live[b], mics);
                if !self.coarse[pair] {
                    continue;
                }
                let (start, half) = self.starts[pair];
                let w = &windows[start..start + 2 * half + 1];
                running_max(w, self.radius[pair], &mut self.pooled, &mut self.scratch);
                self.table[..w.len()].copy_from_slice(&self.pooled);
                gather_add(&mut self.power, &self.table, &self.index[pair]);
            }
        }
        let near = EXCLUDE_DEG.to_radians().cos();
        for (p, u) in self.power.iter_mut().zip(&self.points) {
            if found.iter().any(|f| f.dot(u) > near) {
                *p = f32::NEG_INFINITY;
            }
        }
        // The best few grid points, apart from each other, each refined.
        let mut order = std::mem::take(&mut self.order);
        best_points(&self.power, TOP_POINTS, &mut order);
        let apart = SEPARATION_DEG.to_radians().cos();
        let mut tried = std::mem::take(&mut self.tried);
        tried.clear();
        let mut best: Option<Steer> = None;
        for &g in &order {
            if tried.len() == REFINED || !self.power[g].is_finite() {
                break;
            }
            let start = self.points[g];
            if tried.iter().any(|t| t.dot(&start) > apart) {
                continue;
            }
            tried.push(start);
            let Some(steer) = self.refine(windows, live, mics, start, tolerance, solver) else {
                continue;
            };
            if found.iter().any(|f| f.dot(&steer.direction) > near) {
                continue;
            }
            if best.is_none_or(|b| steer.score > b.score) {
                best = Some(steer);
                self.best_lags.clear();
                self.best_lags.extend_from_slice(&self.lags);
            }
        }
        self.order = order;
        self.tried = tried;
        best
    }

    /// From grid direction `u`: each pair's peak near the direction's delay, then eq.
    /// (13); three times, the last two within the tolerance.
    fn refine(
        &mut self,
        windows: &[f32],
        live: &[usize],
        mics: usize,
        mut u: Vector3<f64>,
        tolerance: f32,
        solver: &DirectionSolver,
    ) -> Option<Steer> {
        let k = live.len();
        let mut score = (0.0, 0);
        for pass in 0..3 {
            self.lags.clear();
            score = (0.0, 0);
            for a in 0..k {
                for b in a + 1..k {
                    let pair = pair_index(live[a], live[b], mics);
                    let (start, half) = self.starts[pair];
                    let range = start..start + 2 * half + 1;
                    let (w, marks) = (&windows[range.clone()], &self.marks[range]);
                    let expected = u.dot(&self.diffs[pair]);
                    let reach = if pass == 0 {
                        self.radius[pair] as f64 + tolerance as f64
                    } else {
                        tolerance as f64
                    };
                    match local_peak(w, marks, expected + half as f64, reach) {
                        Some((at, value)) => {
                            self.lags.push(at - half as f64);
                            score.0 += value as f64;
                            score.1 += 1;
                        }
                        None => self.lags.push(expected),
                    }
                }
            }
            if pass < 2 {
                u = solver.solve(&self.lags)?;
            }
        }
        Some(Steer {
            direction: u,
            score: score.0,
            agreeing: score.1,
        })
    }
}

/// The `top` grid points of highest `power` (ties: the lower index first), best first,
/// in `order` (cleared first). The points split into `top` blocks or more, whose maxima
/// are that many points: none below the least of them is among the best `top`, so only
/// the rest are selected and sorted.
fn best_points(power: &[f32], top: usize, order: &mut Vec<usize>) {
    let by_power = |x: &usize, y: &usize| power[*y].total_cmp(&power[*x]).then(x.cmp(y));
    let (n, top) = (power.len(), top.min(power.len()));
    order.clear();
    if top == 0 {
        return;
    }
    if top < n {
        let least = power
            .chunks(n / top)
            .map(|block| window_max(block, f32::NEG_INFINITY))
            .fold(f32::INFINITY, f32::min);
        order.extend((0..n).filter(|&g| power[g] >= least));
        if top < order.len() {
            order.select_nth_unstable_by(top - 1, by_power);
        }
    } else {
        order.extend(0..n);
    }
    order.truncate(top);
    order.sort_unstable_by(by_power);
}

/// `out[i]` = the largest of 0 and `w[i - r..=i + r]`, by doubling: after step `s` each
/// value is the largest over `2^s` neighbours, and the window of `2r + 1` is the larger of
/// two overlapping such spans (`log2(2r + 1)` passes, each a plain loop the compiler
/// vectorises: the prefix-suffix scheme it replaces cost a division per value).
fn running_max(w: &[f32], r: usize, out: &mut Vec<f32>, scratch: &mut Vec<f32>) {
    let n = w.len();
    let width = 2 * r + 1;
    // The window's positive part padded with r zeros each side.
    out.clear();
    out.resize(n + 2 * r, 0.0);
    out[r..r + n]
        .iter_mut()
        .zip(w)
        .for_each(|(o, &v)| *o = v.max(0.0));
    // `out[i]` is the largest of `span` values from `i`.
    let mut span = 1;
    while 2 * span <= width {
        scratch.clear();
        scratch.extend(out.iter().zip(&out[span..]).map(|(&a, &b)| a.max(b)));
        std::mem::swap(out, scratch);
        span *= 2;
    }
    scratch.clear();
    scratch.extend(
        out[..n]
            .iter()
            .zip(&out[width - span..])
            .map(|(&a, &b)| a.max(b)),
    );
    std::mem::swap(out, scratch);
}

/// `power[g] += table[index[g]]` for every grid point `g` (the compiler gathers eight at
/// a time: an index of `u16` cannot pass the table's end).
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn gather_add(power: &mut [f32], table: &[f32; TABLE], index: &[u16]) {
    for (p, &i) in power.iter_mut().zip(index) {
        *p += table[i as usize];
    }
}

/// `marks[i]` = `w[i]` where it is a positive local maximum (`w[i] >= w[i - 1]` and
/// `w[i] > w[i + 1]`), else 0; the window's two ends are never one. Returns the largest
/// of those maxima refined ([`refine3`]), or 0 when there is none: every lane
/// refines and keeps its refinement only where it marks, eight lanes at a time, so the
/// loop has no branch and the compiler vectorises it (the largest of the same values as
/// refining the marked ones one by one).
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn mark_peaks(w: &[f32], marks: &mut [f32]) -> f32 {
    const LANES: usize = 8;
    let n = w.len();
    marks[0] = 0.0;
    marks[n - 1] = 0.0;
    let mut lanes = [0.0f32; LANES];
    let (prev, here, next) = (&w[..n - 2], &w[1..n - 1], &w[2..]);
    let inner = &mut marks[1..n - 1];
    let mark = |lane: &mut f32, m: &mut f32, p: f32, v: f32, x: f32| {
        let hit = (v > 0.0) & (v >= p) & (v > x);
        *m = if hit { v } else { 0.0 };
        let refined = refine3(p, v, x).1;
        *lane = lane.max(if hit { refined } else { 0.0 });
    };
    let whole = inner.len() / LANES * LANES;
    for (((m, p), v), x) in inner[..whole]
        .chunks_exact_mut(LANES)
        .zip(prev.chunks_exact(LANES))
        .zip(here.chunks_exact(LANES))
        .zip(next.chunks_exact(LANES))
    {
        for j in 0..LANES {
            mark(&mut lanes[j], &mut m[j], p[j], v[j], x[j]);
        }
    }
    for i in whole..inner.len() {
        mark(&mut lanes[0], &mut inner[i], prev[i], here[i], next[i]);
    }
    lanes.iter().fold(0.0f32, |a, &b| a.max(b))
}

/// The highest local maximum of `w` with a positive value within `reach` of position
/// `centre` (both in window indices; the first of equal ones), refined with a
/// parabola: its position and value. `marks` are `w`'s from [`mark_peaks`].
fn local_peak(w: &[f32], marks: &[f32], centre: f64, reach: f64) -> Option<(f64, f32)> {
    let (lo, hi) = whole_within(centre - reach, centre + reach);
    let (lo, hi) = (lo.max(1) as usize, hi.min(w.len() as i64 - 2) as isize);
    if hi < lo as isize {
        return None;
    }
    // Selects, not branches: which mark is highest is a coin toss for the predictor.
    let (mut top, mut at) = (0.0f32, 0usize);
    for (i, &v) in marks[..=hi as usize].iter().enumerate().skip(lo) {
        let higher = v > top;
        top = if higher { v } else { top };
        at = if higher { i } else { at };
    }
    if top <= 0.0 {
        return None;
    }
    let i = at;
    let (delta, value) = refine_peak(w, i);
    Some((i as f64 + delta as f64, value))
}

/// The whole numbers from `lo` up and from `hi` down: `(lo.ceil(), hi.floor())` as
/// integers (both finite, under 2^62 in size), without the library call that the
/// default x86-64 target (no rounding instruction) makes for `ceil` and `floor`.
#[inline]
pub(crate) fn whole_within(lo: f64, hi: f64) -> (i64, i64) {
    let (a, b) = (lo as i64, hi as i64);
    (a + ((a as f64) < lo) as i64, b - ((b as f64) > hi) as i64)
}

/// The local maximum of `w` at `i` refined with a parabola through it and its two
/// neighbours: its offset (samples) and value.
#[inline]
fn refine_peak(w: &[f32], i: usize) -> (f32, f32) {
    refine3(w[i - 1], w[i], w[i + 1])
}

/// [`refine_peak`] from the three samples. The offset is computed whether or not it is
/// kept, so that the choice is a select and a loop over it vectorises ([`mark_peaks`]).
#[inline(always)]
fn refine3(prev: f32, v: f32, next: f32) -> (f32, f32) {
    let denom = prev - 2.0 * v + next;
    let d = (0.5 * (prev - next) / denom).clamp(-0.5, 0.5);
    if denom < 0.0 {
        (d, v - 0.25 * (prev - next) * d)
    } else {
        (0.0, v)
    }
}

#[cfg(test)]
#[path = "steered_tests.rs"]
mod tests;
