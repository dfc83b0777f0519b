//! Which channel orders the delays of the clearest frames allow: every order of up to
//! [`super::FULL_ORDERS`] microphones (every swap of two beyond) against the file's, frame
//! by frame. An order is told apart from another when its residuals are larger frame by
//! frame with a paired t of at least [`T_NEEDED`]; orders that are images of each other
//! under the array's symmetries ([`super::symmetry`]) give the same residuals and are
//! never told apart by delays.

use super::fit::{orderings, Fit};
use super::scan::Frame;
use std::collections::HashSet;

/// The paired t (mean difference of two orders' residuals over its standard error)
/// that tells two orders apart: about one chance in 10^4 of a difference by chance
/// among 30 frames or more, a few in 10^3 among 8.
pub const T_NEEDED: f64 = 4.0;
/// Fewer frames than this and no order is told apart from another.
pub const MIN_FRAMES: usize = 6;

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

/// Mean, and paired t of `a` minus `b` (0 when they are equal frame by frame).
fn paired_t(a: &[f64], b: &[f64]) -> (f64, f64) {
    let n = a.len().max(1) as f64;
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    let mean = d.iter().sum::<f64>() / n;
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    let se = (var / n).sqrt();
    let t = if se > 1e-12 {
        mean / se
    } else if mean.abs() > 1e-9 {
        mean.signum() * f64::INFINITY
    } else {
        0.0
    };
    (mean, t)
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

/// What [`judge`] found: its verdict, the file's order's mean residual and the median
/// of the other orders' (what an order that does not fit gives), in samples.
pub struct Judged {
    pub verdict: OrderVerdict,
    pub own: f64,
    pub random: f64,
}

/// The verdict of the delays in `frames` on the order `used` (the channel of each
/// microphone, `k` channels), the array's symmetries being `group`.
pub fn judge(
    fit: &Fit,
    frames: &[Frame],
    used: &[usize],
    k: usize,
    group: &[Vec<usize>],
    max_full: usize,
) -> Judged {
    let (verdict, own, mut means) = verdict(fit, frames, used, k, group, max_full);
    means.sort_by(f64::total_cmp);
    let random = means.get(means.len() / 2).copied().unwrap_or(f64::INFINITY);
    Judged {
        verdict,
        own,
        random,
    }
}

fn verdict(
    fit: &Fit,
    frames: &[Frame],
    used: &[usize],
    k: usize,
    group: &[Vec<usize>],
    max_full: usize,
) -> (OrderVerdict, f64, Vec<f64>) {
    let mut buf = Vec::new();
    let own = fit.residuals(frames, used, k, &mut buf);
    let own_images = images(used, group, used);
    let own_class: HashSet<Vec<usize>> = own_images.iter().cloned().collect();
    // One pass: each other order's mean, its t against the file's, and the best.
    let mut best = (f64::INFINITY, used.to_vec(), own.clone());
    let mut open: Vec<(Vec<usize>, f64)> = Vec::new();
    let mut weakest = f64::INFINITY;
    let mut candidates: Vec<Vec<usize>> = Vec::new();
    orderings(used, max_full, |order| candidates.push(order.to_vec()));
    // Beyond full orders only swaps are tried: the images of the file's order too.
    for o in &own_images {
        if !candidates.contains(o) {
            candidates.push(o.clone());
        }
    }
    let mut all_means = Vec::with_capacity(candidates.len());
    for order in &candidates {
        if own_class.contains(order) {
            continue;
        }
        let r = fit.residuals(frames, order, k, &mut buf);
        let (diff, t) = paired_t(&r, &own);
        let mean = r.iter().sum::<f64>() / r.len().max(1) as f64;
        all_means.push(mean);
        if mean < best.0 {
            best = (mean, order.clone(), r);
        }
        if t < T_NEEDED || frames.len() < MIN_FRAMES {
            open.push((order.clone(), if diff < 0.0 { t.min(0.0) } else { t }));
        } else {
            weakest = weakest.min(t);
        }
    }
    let own_mean = own.iter().sum::<f64>() / own.len().max(1) as f64;
    // Another order much better, and told apart: the fix, among its images nearest.
    if best.0 < super::BETTER_SHARE * own_mean {
        let (_, t) = paired_t(&own, &best.2);
        if t >= T_NEEDED && frames.len() >= MIN_FRAMES {
            let orders = images(&best.1, group, used);
            let best_class: HashSet<Vec<usize>> = orders.iter().cloned().collect();
            let mut rivals: Vec<Vec<usize>> = candidates
                .iter()
                .filter(|o| !best_class.contains(*o) && !own_class.contains(*o))
                .filter(|o| {
                    let r = fit.residuals(frames, o, k, &mut buf);
                    paired_t(&r, &best.2).1 < T_NEEDED
                })
                .cloned()
                .collect();
            rivals.sort_by_key(|o| (changes(o, used), o.clone()));
            rivals.truncate(12);
            let verdict = OrderVerdict::Better {
                orders,
                best: best.0,
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
    // t grows as the root of the frames: the frames that would likely bring the
    // nearest open order to T_NEEDED, when it is on its way there.
    let needed_frames = (t > 0.5).then(|| {
        let n = frames.len().max(MIN_FRAMES) as f64 * (T_NEEDED / t).powi(2);
        n.ceil() as usize
    });
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
