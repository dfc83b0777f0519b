//! The M highest peaks of each pair's correlation (the paper's eq. 7 generalised to M
//! candidates, Section II-C), with optional sub-sample refinement.

use crate::Named;
use multiversion::multiversion;

/// How a peak's lag is refined between samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Interpolation {
    /// Integer lags only.
    None,
    /// A parabola through the peak and its two neighbours (`--paper`'s).
    Parabolic,
    /// A cosine through the peak and its two neighbours (the default): nearer the shape
    /// of a band-limited correlation's main lobe, which a parabola biases toward whole
    /// samples (by up to 0.12 sample over the whole band; the cosine 0.08; see the
    /// tests). The peak's value is the parabola's formula at the cosine's offset, so
    /// [`Interpolation::overshoot`] bounds it as before. Measured on real speech in the
    /// field benchmark (docs/field.md): the same at 48 kHz; at 8 and 16 kHz on arrays a
    /// few centimetres across, 0.1-1.3 deg less mean error in 7 of the 8 rows that
    /// moved (an 8-mic circle at 16 kHz 0.3 more) and a square's lost speech event
    /// (75% -> 100% at 8 kHz) found.
    Cosine,
}

impl Named for Interpolation {
    const ALL: &'static [(Interpolation, &'static str, &'static str)] = &[
        (Interpolation::None, "none", "Integer lags only"),
        (
            Interpolation::Parabolic,
            "parabolic",
            "A parabola through the peak and its two neighbours (--paper's)",
        ),
        (
            Interpolation::Cosine,
            "cosine",
            "A cosine through the peak and its two neighbours (the default; less biased toward whole samples)",
        ),
    ];
}

impl Interpolation {
    /// How far a refined peak can rise above the largest sample of the correlation, as
    /// a factor: a parabola through a local maximum and its neighbours peaks at most a
    /// quarter of the larger neighbour above it.
    pub fn overshoot(self) -> f64 {
        match self {
            Interpolation::None => 1.0,
            Interpolation::Parabolic | Interpolation::Cosine => 1.25,
        }
    }
}

/// One candidate delay of a pair: its lag in samples (sub-sample refined) and the value of
/// the correlation there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Peak {
    /// Lag in samples (refined between samples per [`Interpolation`]).
    pub lag: f32,
    /// The correlation's value there.
    pub value: f32,
}

/// The largest M that [`find_peaks`] accepts.
pub(crate) const MAX_PEAKS: usize = 64;

/// Peaks M kept per pair by default (the paper's M = 8).
pub(crate) const DEFAULT_PEAKS: usize = 8;

/// The peaks kept of each pair's correlation, and how their lags are refined.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "flags", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
#[non_exhaustive]
pub struct Peaks {
    /// Peaks M kept in each pair's cross-correlation
    #[cfg_attr(feature = "flags", arg(short = 'm', long = "peaks", id = "peaks", value_name = "PEAKS", default_value_t = DEFAULT_PEAKS, value_parser = crate::flags::count(1..=MAX_PEAKS), hide_short_help = true))]
    pub count: usize,
    /// Sub-sample refinement of correlation peaks [default: cosine; parabolic with --paper]
    #[cfg_attr(feature = "flags", arg(long, value_parser = crate::flags::choice::<Interpolation>(), hide_short_help = true))]
    pub interpolation: Option<Interpolation>,
}

impl Default for Peaks {
    fn default() -> Self {
        Peaks {
            count: DEFAULT_PEAKS,
            interpolation: None,
        }
    }
}

impl Peaks {
    /// The refinement as the stages read it (a resolved configuration always gives one;
    /// none reads as the default, cosine).
    pub(crate) fn refinement(&self) -> Interpolation {
        self.interpolation.unwrap_or(Interpolation::Cosine)
    }
}

/// The `m` highest local maxima of a correlation (eq. 7), ranked by their sample value,
/// each refined per `interp`, then ordered by refined value, highest first (ties: smaller
/// lag first). `window` holds `r(tau)` for `tau = -h..=h` (odd length `2h + 1`, from
/// [`Correlator::lags`](super::correlation::Correlator::lags)); peaks are looked for at `|tau| < h`, the outer two samples
/// being their neighbours. A plateau counts once, at its first sample. `out` is cleared
/// and refilled; it does not allocate once its capacity reaches `m` (`1..=``MAX_PEAKS`).
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
pub fn find_peaks(window: &[f32], m: usize, interp: Interpolation, out: &mut Vec<Peak>) {
    assert!(m <= MAX_PEAKS, "at most {MAX_PEAKS} peaks per pair");
    out.clear();
    if m == 0 || window.len() < 3 {
        return;
    }
    // The best m are the first m of the best 8, 16, 32 or 64 (same order, same ties).
    let h = window.len() / 2;
    match m {
        1..=8 => Top::<8>::select(window).write(m, h, out),
        9..=16 => Top::<16>::select(window).write(m, h, out),
        17..=32 => Top::<32>::select(window).write(m, h, out),
        _ => Top::<64>::select(window).write(m, h, out),
    }
    if interp != Interpolation::None {
        let h = h as isize;
        // Eight peaks at a time: each one's two neighbours, then their cosine offsets in
        // one vector pass.
        for chunk in out.chunks_mut(LANES) {
            let (mut prev, mut here, mut next) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
            for (j, p) in chunk.iter().enumerate() {
                let i = (p.lag as isize + h) as usize;
                (prev[j], here[j], next[j]) = (window[i - 1], p.value, window[i + 1]);
            }
            let cosine = match interp {
                Interpolation::Cosine => cosine_offsets(prev, here, next),
                _ => [f32::NAN; LANES],
            };
            for (j, p) in chunk.iter_mut().enumerate() {
                let (prev, here, next) = (prev[j], here[j], next[j]);
                let denom = prev - 2.0 * here + next;
                let parabolic = if denom < 0.0 {
                    (0.5 * (prev - next) / denom).clamp(-0.5, 0.5)
                } else {
                    0.0
                };
                let delta = if cosine[j].is_finite() {
                    cosine[j].clamp(-0.5, 0.5)
                } else {
                    parabolic
                };
                *p = Peak {
                    lag: p.lag + delta,
                    value: here - 0.25 * (prev - next) * delta,
                };
            }
        }
        // Refinement can reorder close peaks; the search expects highest first. (A stable
        // insertion sort of at most M entries: no allocation.)
        for i in 1..out.len() {
            let mut j = i;
            while j > 0 && out[j - 1].value < out[j].value {
                out.swap(j - 1, j);
                j -= 1;
            }
        }
    }
}

/// Peaks refined together ([`cosine_offsets`]).
const LANES: usize = 8;

/// Where `A cos(w (x - d))` through `(-1, prev)`, `(0, here)`, `(1, next)` peaks, for
/// eight peaks at once: `d` unclamped, or NaN where no such cosine exists (a peak not
/// above zero, or neighbours not under it). wide's vector `acos` and `atan` (Agner
/// Fog's polynomials, within a few units in the last place of libm's) cost an eighth
/// of libm's one at a time, which took 3.5% of a meeting's time.
#[inline(always)]
fn cosine_offsets(prev: [f32; LANES], here: [f32; LANES], next: [f32; LANES]) -> [f32; LANES] {
    use wide::{f32x8, CmpGt, CmpLt};
    let (prev, here, next) = (f32x8::from(prev), f32x8::from(here), f32x8::from(next));
    let two = f32x8::splat(2.0);
    let c = (prev + next) / (two * here);
    let exists = here.cmp_gt(f32x8::ZERO) & c.cmp_gt(-f32x8::ONE) & c.cmp_lt(f32x8::ONE);
    // Lanes with no cosine compute on c = 0 (no NaN inside) and are replaced after.
    let c = exists.blend(c, f32x8::ZERO);
    let (w, sin) = (c.acos(), (f32x8::ONE - c * c).sqrt());
    let d = ((next - prev) / (two * here * sin)).atan() / w;
    exists.blend(d, f32x8::splat(f32::NAN)).to_array()
}

/// The `K` highest local maxima of a window seen so far: values, highest first (ties in
/// scan order, i.e. smaller lag first), and their indices; empty places hold -inf.
struct Top<const K: usize> {
    values: [f32; K],
    index: [u32; K],
}

impl<const K: usize> Top<K> {
    #[inline(always)]
    fn select(window: &[f32]) -> Self {
        let mut top = Top {
            values: [f32::NEG_INFINITY; K],
            index: [0; K],
        };
        // A floor before the scan: the local maxima at indices of each residue mod K
        // (one SIMD lane each) have their highest; those K are distinct local maxima, so
        // no sample below the lowest of them is among the best K. It spares most of the
        // insertions a scan from -inf makes while the list fills.
        let mut lanes = [f32::NEG_INFINITY; K];
        for chunk in window.windows(K + 2).step_by(K) {
            for (lane, w) in lanes.iter_mut().zip(chunk.windows(3)) {
                let hit = (w[1] > w[0]) & (w[1] >= w[2]);
                *lane = lane.max(if hit { w[1] } else { f32::NEG_INFINITY });
            }
        }
        let prefloor = lanes.iter().fold(f32::INFINITY, |a, &b| a.min(b));
        // Candidates are marked 32 samples at a time without branches (the compiler
        // vectorises the comparisons); only samples that may enter the list are marked,
        // and `insert` has the final word, so blocking does not change the result.
        let interior = window.len() - 2;
        let mut start = 0;
        while start < interior {
            let len = (interior - start).min(32);
            let floor = top.values[K - 1];
            let mut mask = 0u32;
            for (b, w) in window[start..start + len + 2].windows(3).enumerate() {
                let hit = (w[1] > floor) & (w[1] >= prefloor) & (w[1] > w[0]) & (w[1] >= w[2]);
                mask |= (hit as u32) << b;
            }
            while mask != 0 {
                let i = start + mask.trailing_zeros() as usize + 1;
                mask &= mask - 1;
                // A candidate the list has risen past since the block was marked would
                // change nothing.
                if window[i] > top.values[K - 1] {
                    top.insert(window[i], i as u32);
                }
            }
            start += len;
        }
        top
    }

    /// Inserts a candidate that comes after every one inserted so far (in lag order), if
    /// it beats the last. No data-dependent branches: the place is a count and the shift
    /// a fixed sequence of selects, which the compiler unrolls for the constant `K`.
    #[inline(always)]
    fn insert(&mut self, value: f32, index: u32) {
        // The list is sorted, so `ahead` is true for a prefix: the entries that stay.
        // The candidate goes to the first place not ahead, the rest move down one.
        // Selects are bit masks, so that the compiler keeps the list in vector registers.
        let (values, indices) = (self.values, self.index);
        let ahead: [u32; K] =
            std::array::from_fn(|j| 0u32.wrapping_sub((values[j] >= value) as u32));
        let place: [u32; K] =
            std::array::from_fn(|j| !ahead[j] & if j == 0 { u32::MAX } else { ahead[j - 1] });
        let blend = |stay: u32, put: u32, moved: u32, j: usize| {
            (stay & ahead[j]) | (put & place[j]) | (moved & !(ahead[j] | place[j]))
        };
        self.values = std::array::from_fn(|j| {
            f32::from_bits(blend(
                values[j].to_bits(),
                value.to_bits(),
                values[j.saturating_sub(1)].to_bits(),
                j,
            ))
        });
        self.index =
            std::array::from_fn(|j| blend(indices[j], index, indices[j.saturating_sub(1)], j));
    }

    /// Writes the first `m` kept peaks to `out`, with lags counted from index `centre`.
    fn write(&self, m: usize, centre: usize, out: &mut Vec<Peak>) {
        out.extend(
            self.values
                .iter()
                .zip(&self.index)
                .take(m)
                .take_while(|(v, _)| **v > f32::NEG_INFINITY)
                .map(|(&value, &i)| Peak {
                    lag: i as f32 - centre as f32,
                    value,
                }),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The PHAT correlation of a signal delayed by `delay` samples, at lags `-h..=h`:
    /// `(2/N) sum_k cos(2 pi k (tau - delay) / N)` over the bins `1..top` of a frame of
    /// `n` samples, directly (eq. 6 with unit weights up to bin `top`).
    fn delayed(delay: f64, n: usize, top: usize, h: isize) -> Vec<f32> {
        (-h..=h)
            .map(|tau| {
                let x = std::f64::consts::TAU * (tau as f64 - delay) / n as f64;
                let sum: f64 = (1..top).map(|k| (k as f64 * x).cos()).sum();
                (2.0 * sum / n as f64) as f32
            })
            .collect()
    }

    /// The worst error (samples) of `interp` over delays 2.0, 2.05, ..., 3.0.
    fn worst(interp: Interpolation, top: usize) -> f64 {
        (0..=20)
            .map(|step| {
                let delay = 2.0 + step as f64 * 0.05;
                let mut found = Vec::new();
                find_peaks(&delayed(delay, 512, top, 8), 1, interp, &mut found);
                (found[0].lag as f64 - delay).abs()
            })
            .fold(0.0, f64::max)
    }

    /// The vector offsets agree with the cosine's formula in libm's `acos` and `atan`
    /// (f64) to within 1e-4 sample, and are NaN exactly where no cosine exists.
    #[test]
    fn vector_cosine_offsets_match_the_formula() {
        let formula = |prev: f64, here: f64, next: f64| {
            let c = (prev + next) / (2.0 * here);
            (here > 0.0 && c > -1.0 && c < 1.0)
                .then(|| ((next - prev) / (2.0 * here * (1.0 - c * c).sqrt())).atan() / c.acos())
        };
        let mut state = 12345u64;
        let mut draw = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 0.5
        };
        let (mut checked, mut none) = (0, 0);
        for _ in 0..20_000 {
            let (mut prev, mut here, mut next) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
            for j in 0..LANES {
                (prev[j], here[j], next[j]) = (draw(), draw(), draw());
            }
            let got = cosine_offsets(prev, here, next);
            for j in 0..LANES {
                match formula(prev[j] as f64, here[j] as f64, next[j] as f64) {
                    Some(d) if d.abs() <= 0.5 => {
                        assert!((got[j] as f64 - d).abs() < 1e-4, "{} vs {d}", got[j]);
                        checked += 1;
                    }
                    Some(_) => {}
                    None => {
                        assert!(got[j].is_nan(), "{} where no cosine", got[j]);
                        none += 1;
                    }
                }
            }
        }
        assert!(checked > 10_000 && none > 10_000, "{checked} {none}");
    }

    /// A cosine through the three samples is less biased toward whole samples than a
    /// parabola: over the whole band 0.082 sample at worst against 0.118, over its lower
    /// half (a lobe twice as wide) 0.012 against 0.025.
    #[test]
    fn the_cosine_finds_fractional_delays_a_parabola_biases() {
        let (cosine, parabola) = (
            worst(Interpolation::Cosine, 256),
            worst(Interpolation::Parabolic, 256),
        );
        assert!(cosine < 0.09 && parabola > 0.11, "{cosine} {parabola}");
        let (cosine, parabola) = (
            worst(Interpolation::Cosine, 128),
            worst(Interpolation::Parabolic, 128),
        );
        assert!(cosine < 0.015 && parabola > 0.02, "{cosine} {parabola}");
    }

    fn window(h: isize, samples: &[(isize, f32)]) -> Vec<f32> {
        let mut w = vec![0.0; (2 * h + 1) as usize];
        for &(lag, v) in samples {
            w[(lag + h) as usize] = v;
        }
        w
    }

    #[test]
    fn peaks_are_the_highest_local_maxima_in_range_with_parabolic_refinement() {
        // A parabola peaking at lag 5.19 (samples 4, 5, 6), a peak at -3, and at lag 11
        // the window's edge, which is a neighbour, not a candidate.
        let r = window(
            11,
            &[
                (4, 0.91),
                (5, 1.0),
                (6, 0.96),
                (-3, 0.5),
                (11, 2.0),
                (-11, 2.0),
            ],
        );
        let mut peaks = Vec::with_capacity(4);
        find_peaks(&r, 4, Interpolation::Parabolic, &mut peaks);
        assert_eq!(peaks.len(), 2, "{peaks:?}");
        // delta = 0.5 (0.91 - 0.96) / (0.91 - 2 + 0.96) = 0.1923
        assert!((peaks[0].lag - 5.1923).abs() < 1e-3, "{peaks:?}");
        assert!(peaks[0].value >= 1.0);
        assert_eq!(peaks[1].lag, -3.0);
        find_peaks(&r, 1, Interpolation::None, &mut peaks);
        assert_eq!(
            peaks,
            vec![Peak {
                lag: 5.0,
                value: 1.0
            }]
        );
    }

    #[test]
    fn peaks_next_to_lag_zero_and_the_range_ends_are_found() {
        for lag in [-5isize, -2, -1, 0, 1, 2, 5] {
            let r = window(6, &[(lag, 1.0)]);
            let mut peaks = Vec::with_capacity(1);
            find_peaks(&r, 1, Interpolation::None, &mut peaks);
            assert_eq!(
                peaks,
                vec![Peak {
                    lag: lag as f32,
                    value: 1.0
                }],
                "lag {lag}"
            );
        }
    }

    /// The blocked, branch-free selection equals the definition: every local maximum
    /// (first sample of a plateau), stably sorted by value, the first m kept, refined,
    /// stably sorted again. Random windows of up to 300 lags (several 32-lag blocks) with
    /// coarse values, so that ties and plateaus are common.
    #[test]
    fn peak_selection_equals_brute_force() {
        let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(7);
        let mut next = || rand::Rng::random::<u32>(&mut rng) as u64;
        let mut got = Vec::new();
        for case in 0..3000 {
            let h = 1 + (next() % 150) as usize;
            let levels = 2 + next() % 12;
            let r: Vec<f32> = (0..2 * h + 1)
                .map(|_| (next() % levels) as f32 / levels as f32 - 0.3)
                .collect();
            let m = [1, 2, 3, 5, 8, 9, 12, 16, 17, 30, 33, 64][(next() % 12) as usize];
            for interp in [Interpolation::None, Interpolation::Parabolic] {
                let mut want: Vec<(usize, Peak)> = (1..2 * h)
                    .filter(|&i| r[i] > r[i - 1] && r[i] >= r[i + 1])
                    .map(|i| {
                        let p = Peak {
                            lag: i as f32 - h as f32,
                            value: r[i],
                        };
                        (i, p)
                    })
                    .collect();
                want.sort_by(|a, b| b.1.value.total_cmp(&a.1.value));
                want.truncate(m);
                let mut want: Vec<Peak> = want
                    .into_iter()
                    .map(|(i, p)| {
                        let (prev, here, next) = (r[i - 1], r[i], r[i + 1]);
                        let denom = prev - 2.0 * here + next;
                        match interp {
                            Interpolation::Parabolic if denom < 0.0 => {
                                let d = (0.5 * (prev - next) / denom).clamp(-0.5, 0.5);
                                Peak {
                                    lag: p.lag + d,
                                    value: here - 0.25 * (prev - next) * d,
                                }
                            }
                            _ => p,
                        }
                    })
                    .collect();
                want.sort_by(|a, b| b.value.total_cmp(&a.value));
                find_peaks(&r, m, interp, &mut got);
                assert_eq!(got, want, "case {case}, h {h}, m {m}, {interp:?}: {r:?}");
            }
        }
    }
}
