//! Which channel orders the delays of the clearest frames allow: every order of up to
//! [`super::FULL_ORDERS`] microphones (every swap of two beyond) against the file's, frame
//! by frame. An order is told apart from another when its residuals are larger frame by
//! frame, weighing the evidence ([`evidence`]): at least [`EVIDENCE_NEEDED`] nats;
//! orders that are images of each other
//! under the array's symmetries ([`super::symmetry`]) give the same residuals and are
//! never told apart by delays.

use super::fit::{orderings, Fit};
use super::scan::Frame;
use std::collections::HashSet;

/// The evidence (natural log of the likelihood ratio) that tells two orders apart:
/// 9.2 nats, odds of 10^4 to 1.
pub(crate) const EVIDENCE_NEEDED: f64 = 9.2;
/// The most one frame adds to the evidence (nats): no single frame, which a
/// reflection may have shaped, decides alone.
pub(crate) const FRAME_EVIDENCE: f64 = 5.0;
/// The least residual noise assumed (samples RMS): delays are read to about a tenth of
/// a sample, and the frames' peaks to no better than this.
pub(crate) const SIGMA_FLOOR: f64 = 0.25;
/// Fewer frames than this and no order is told apart from another.
pub(crate) const MIN_FRAMES: usize = 4;

/// What the delays say of the channel order.
#[derive(Debug, Clone)]
pub enum OrderVerdict {
    /// The file's order, and only it and its symmetry images, explain the delays; every
    /// other order is told apart. `images` are the file's order's images (itself first).
    Fits {
        images: Vec<Vec<usize>>,
        /// The smallest t of an excluded order.
        weakest_t: f64,
    },
    /// Another order explains the delays much better: `best` (the one of its images
    /// nearest the file's order) and all its images, nearest first.
    Better {
        orders: Vec<Vec<usize>>,
        /// Mean residuals (samples): the best order's and the file's.
        best: f64,
        own: f64,
        /// Other orders (not images of the best) not told apart from it, nearest first.
        rivals: Vec<Vec<usize>>,
    },
    /// Some order not an image of the file's is not told apart from it: the nearest
    /// such (fewest changes), its t, and how many frames would likely tell it apart.
    Open {
        rival: Vec<usize>,
        t: f64,
        needed_frames: Option<usize>,
        /// Every order not told apart from the file's (not its images), nearest first.
        rivals: Vec<Vec<usize>>,
    },
}

/// The residual noise of the delays (samples RMS): the median of the file's order's
/// frames' residuals, at least [`SIGMA_FLOOR`].
pub(super) fn sigma(own: &[f64]) -> f64 {
    let mut r = own.to_vec();
    r.sort_by(f64::total_cmp);
    r.get(r.len() / 2).copied().unwrap_or(0.0).max(SIGMA_FLOOR)
}

/// The mean residual difference of `a` over `b` and the evidence for `b` against `a`:
/// with the pairs' delays off by Gaussian noise of `sigma` samples, each frame's log
/// likelihood ratio, `pairs (r_a^2 - r_b^2) / (2 sigma^2)`, within
/// +-[`FRAME_EVIDENCE`], summed over the frames. A swap that changes the delays of a
/// clap by a few samples is told apart by two claps; a frame whose sound comes from a
/// direction the swap does not change adds nothing either way.
pub(super) fn evidence(a: &[f64], b: &[f64], sigma: f64, pairs: usize) -> (f64, f64) {
    let n = a.len().max(1) as f64;
    let mean = a.iter().zip(b).map(|(x, y)| x - y).sum::<f64>() / n;
    let e = a
        .iter()
        .zip(b)
        .map(|(&x, &y)| frame_evidence(x, y, sigma, pairs))
        .sum();
    (mean, e)
}

/// One frame's evidence for residual `y` against `x` (see [`evidence`]).
pub(super) fn frame_evidence(x: f64, y: f64, sigma: f64, pairs: usize) -> f64 {
    (pairs as f64 * (x * x - y * y) / (2.0 * sigma * sigma)).clamp(-FRAME_EVIDENCE, FRAME_EVIDENCE)
}

/// How many places `order` differs from `base` in.
pub fn changes(order: &[usize], base: &[usize]) -> usize {
    order.iter().zip(base).filter(|(a, b)| a != b).count()
}

/// The images of `order` under `group` (`order[s[i]]` for each symmetry `s`), `base`'s
/// nearest first.
pub fn images(order: &[usize], group: &[Vec<usize>], base: &[usize]) -> Vec<Vec<usize>> {
    let mut out: Vec<Vec<usize>> = Vec::new();
    for s in group {
        let o: Vec<usize> = (0..order.len()).map(|i| order[s[i]]).collect();
        if !out.contains(&o) {
            out.push(o);
        }
    }
    out.sort_by_key(|o| (changes(o, base), o.clone()));
    out
}

/// A frame speaks of the order when some order explains its delays within this many
/// samples (RMS), or [`EXPLAINED_US`] if that is more: the direct sound of a clap does,
/// its room's tail does not. Chosen by every order alike (the least residual over all
/// of them), so the choice favours none.
pub(crate) const EXPLAINED_SAMPLES: f64 = 1.0;
/// The same in time: a large array hears a clap a few metres away with a curved front
/// that a far-field fit misses by tens of microseconds.
pub(crate) const EXPLAINED_US: f64 = 120.0;

/// The residual (samples) within which a frame is explained at `rate` Hz, on an array
/// whose longest delay is `longest` samples: [`EXPLAINED_SAMPLES`] or [`EXPLAINED_US`],
/// but never more than [`EXPLAINED_SHARE`] of the longest delay (a small array's
/// delays are a few samples, which any order explains within one).
pub fn explained_within(rate: f64, longest: f64) -> f64 {
    EXPLAINED_SAMPLES
        .max(EXPLAINED_US * 1e-6 * rate)
        .min(EXPLAINED_SHARE * longest)
}

/// See [`explained_within`].
pub(crate) const EXPLAINED_SHARE: f64 = 0.2;

/// What [`judge`] found: its verdict, the file's order's mean residual and the median
/// of the other orders' (what an order that does not fit gives), in samples, over the
/// frames that some order explains (their indices in `frames`).
pub struct Judged {
    pub verdict: OrderVerdict,
    pub own: f64,
    pub random: f64,
    pub frames: Vec<usize>,
}

/// The verdict of the delays in `frames` on the order `used` (the channel of each
/// microphone, `k` channels), the array's symmetries being `group`. Each order's
/// residuals are computed once, on every frame; the frames that speak are those some
/// order explains within [`explained_within`].
pub fn judge(
    fit: &Fit,
    frames: &[Frame],
    used: &[usize],
    k: usize,
    group: &[Vec<usize>],
    max_full: usize,
) -> Judged {
    let own_images = images(used, group, used);
    let mut candidates: Vec<Vec<usize>> = Vec::new();
    orderings(used, max_full, |order| candidates.push(order.to_vec()));
    // Beyond full orders only swaps are tried: the images of the file's order too.
    for o in &own_images {
        if !candidates.contains(o) {
            candidates.push(o.clone());
        }
    }
    let mut buf = Vec::new();
    let all: Vec<Vec<f64>> = candidates
        .iter()
        .map(|o| fit.residuals(frames, o, k, &mut buf))
        .collect();
    let within = explained_within(fit.rate(), fit.longest());
    let chosen: Vec<usize> = (0..frames.len())
        .filter(|&f| all.iter().map(|r| r[f]).fold(f64::INFINITY, f64::min) <= within)
        .collect();
    let rows: Vec<Vec<f64>> = all
        .iter()
        .map(|r| chosen.iter().map(|&f| r[f]).collect())
        .collect();
    drop(all);
    let own = fit.residuals(frames, used, k, &mut buf);
    let own: Vec<f64> = chosen.iter().map(|&f| own[f]).collect();
    let (verdict, own, mut means) = verdict(&candidates, &rows, &own, used, group, own_images);
    means.sort_by(f64::total_cmp);
    let random = means.get(means.len() / 2).copied().unwrap_or(f64::INFINITY);
    Judged {
        verdict,
        own,
        random,
        frames: chosen,
    }
}

/// The verdict from each candidate order's residuals on the frames that speak (`rows`,
/// one per candidate) and the file's order's (`own`).
fn verdict(
    candidates: &[Vec<usize>],
    rows: &[Vec<f64>],
    own: &[f64],
    used: &[usize],
    group: &[Vec<usize>],
    own_images: Vec<Vec<usize>>,
) -> (OrderVerdict, f64, Vec<f64>) {
    let n = own.len();
    let noise = sigma(own);
    let pairs = used.len() * (used.len() - 1) / 2;
    let own_class: HashSet<Vec<usize>> = own_images.iter().cloned().collect();
    // One pass: each other order's mean, its evidence against the file's, and the best.
    let mut best: Option<(usize, f64)> = None;
    let mut open: Vec<(Vec<usize>, f64)> = Vec::new();
    let mut weakest = f64::INFINITY;
    let mut all_means = Vec::with_capacity(candidates.len());
    let mean_of = |r: &[f64]| r.iter().sum::<f64>() / r.len().max(1) as f64;
    for (c, (order, r)) in candidates.iter().zip(rows).enumerate() {
        if own_class.contains(order) {
            continue;
        }
        let (diff, t) = evidence(r, own, noise, pairs);
        let mean = mean_of(r);
        all_means.push(mean);
        if best.is_none_or(|(_, m)| mean < m) {
            best = Some((c, mean));
        }
        if t < EVIDENCE_NEEDED || n < MIN_FRAMES {
            open.push((order.clone(), if diff < 0.0 { t.min(0.0) } else { t }));
        } else {
            weakest = weakest.min(t);
        }
    }
    let own_mean = mean_of(own);
    // Another order much better, and told apart: the fix, among its images nearest.
    if let Some((b, best_mean)) = best.filter(|&(_, m)| m < own_mean) {
        let best_rows = &rows[b];
        let best_noise = sigma(best_rows);
        let (_, t) = evidence(own, best_rows, best_noise, pairs);
        if t >= EVIDENCE_NEEDED && n >= MIN_FRAMES {
            let orders = images(&candidates[b], group, used);
            let best_class: HashSet<Vec<usize>> = orders.iter().cloned().collect();
            let mut rivals: Vec<Vec<usize>> = candidates
                .iter()
                .zip(rows)
                .filter(|(o, _)| !best_class.contains(*o) && !own_class.contains(*o))
                .filter(|(_, r)| evidence(r, best_rows, best_noise, pairs).1 < EVIDENCE_NEEDED)
                .map(|(o, _)| o.clone())
                .collect();
            rivals.sort_by_key(|o| (changes(o, used), o.clone()));
            rivals.truncate(12);
            let verdict = OrderVerdict::Better {
                orders,
                best: best_mean,
                own: own_mean,
                rivals,
            };
            return (verdict, own_mean, all_means);
        }
    }
    if open.is_empty() {
        let verdict = OrderVerdict::Fits {
            images: own_images,
            weakest_t: weakest,
        };
        return (verdict, own_mean, all_means);
    }
    open.sort_by(|a, b| {
        changes(&a.0, used)
            .cmp(&changes(&b.0, used))
            .then(a.1.total_cmp(&b.1))
    });
    let (rival, t) = open[0].clone();
    // Evidence grows with the frames: the frames that would likely bring the nearest
    // open order to EVIDENCE_NEEDED, when it is on its way there.
    let needed_frames =
        (t > 0.5).then(|| (n.max(MIN_FRAMES) as f64 * (EVIDENCE_NEEDED / t)).ceil() as usize);
    let mut rivals: Vec<Vec<usize>> = open.into_iter().map(|(o, _)| o).collect();
    rivals.truncate(12);
    let verdict = OrderVerdict::Open {
        rival,
        t,
        needed_frames,
        rivals,
    };
    (verdict, own_mean, all_means)
}
