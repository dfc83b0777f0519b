//! Directions of single frequency bins (beyond the paper; [`Talkers::bin_votes`](crate::method::Talkers::bin_votes)): riders
//! for a talker that another one drowns in the correlations, on arrays a few
//! centimetres across.
//!
//! With two talkers at once each pair's correlation (eq. 6) sums every bin, and on a
//! small array the two talkers' peaks are a few samples wide and merge: the consistency
//! search and the steered response find the louder one. Speech is sparse in time and
//! frequency, though: most bins of a frame hold one talker far more than the other. On
//! an array whose pairs are shorter than half a wavelength at a bin's frequency, the
//! phase of each pair's cross-spectrum in that bin is its delay without ambiguity, and
//! the least-squares solution of eq. (13) over those pairs is that bin's direction.
//!
//! - **Votes:** every bin from [`LOW_HZ`] up to where fewer than 2 (planar) or 3
//!   (volumetric) independent pairs stay shorter than half a wavelength, whose power
//!   stands [`SNR_FLOOR`] times above the noise estimate (so a steady background hardly
//!   votes), and whose pairs agree with one plane wave (their path differences within
//!   [`MAX_RESIDUAL`] of the mean pair length of the fit), gives its direction, weighted
//!   by `log10` of that ratio.
//! - **Peaks:** over the frames the correlations are averaged over, the azimuth (in
//!   the array's plane for a planar array, about its z axis otherwise) with the most
//!   weight within [`PEAK_DEG`], as the weighted mean of those votes; the votes within
//!   [`APART_DEG`] of it are then set aside and the next is looked for. A peak counts
//!   with at least [`MIN_MASS`] and [`PEAK_SHARE`] of the first. Azimuths only: a
//!   bin's elevation is coarse (on a planar array it comes from how much shorter the
//!   delays are than the array is wide, which a single bin's noise and reverberation
//!   shorten further: the votes of a talker at +15 deg came out at +25 to +40).
//! - **Riders:** each peak apart from the frame's detections (and not their floor or
//!   ceiling image) becomes a rider, its elevation the one, in steps of 2 deg, at which
//!   the frame's own correlations sum highest at that azimuth, which is also its score.
//!   A tracker only lets a rider add a row to a talking track within its candidates'
//!   gate ([`crate::track`]): it starts and confirms nothing. A frame the `threshold`
//!   module calls steady gives none.
//!
//! Only frames with every microphone live vote.

use super::frame_sources::{apart, IMAGE_ELEVATION_DEG};
use super::MAX_SOURCES;
use crate::geometry::{Geometry, Shape};
use crate::method::detect::detection;
use crate::method::layout::Layout;
use crate::method::outcome::Detections;
use crate::method::paper::direction::{plane_basis, DirectionSolver};
use crate::method::paper::pairs::pair_index;
use crate::method::paper::weighting::MAX_SNR_RATIO;
use crate::method::state::{Correlated, FrameState, Vote};
use crate::method::uncertainty::uncertainty_deg;
use nalgebra::{DMatrix, Vector3};

/// Lowest bin frequency that votes (Hz): below it a delay is a small share of a cycle
/// and its phase mostly noise.
pub(crate) const LOW_HZ: f64 = 300.0;

/// A bin votes when its power is at least this times the noise estimate's (which holds
/// the late reverberation too): 4 added half as many windows of two talkers on a 6-mic
/// circle.
pub(crate) const SNR_FLOOR: f32 = 2.0;

/// A bin votes when its pairs' path differences fit one plane wave within this share of
/// their mean length (RMS).
pub(crate) const MAX_RESIDUAL: f64 = 0.15;

/// Votes within this (degrees) of a peak count toward it.
pub(crate) const PEAK_DEG: f64 = 8.0;

/// After a peak, the votes within this (degrees) are set aside.
pub(crate) const APART_DEG: f64 = 20.0;

/// A peak's least weight (the sum of its votes' `log10` power ratios).
pub(crate) const MIN_MASS: f64 = 5.0;

/// A peak's least weight as a share of the first's.
pub(crate) const PEAK_SHARE: f64 = 0.3;

/// An array votes when at least this many bins can (the prism's pairs, 36-71 cm, are
/// shorter than half a wavelength only up to about 340 Hz).
pub(crate) const MIN_BINS: usize = 8;

/// The most pairs a bin uses (larger arrays use the shortest).
const MAX_PAIRS: usize = 66;

/// The pairs one bin uses and the least-squares solution over them.
#[derive(Debug, Clone)]
struct Band {
    /// `(a, b)` microphone indices.
    pairs: Vec<(usize, usize)>,
    /// `u = sum_p cols[p] * path_p` (the in-plane part for a planar array).
    cols: Vec<Vector3<f64>>,
    /// Per pair, `p_b - p_a`.
    diffs: Vec<Vector3<f64>>,
    mean_length: f64,
}

/// A peak of the votes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct VotePeak {
    pub direction: Vector3<f64>,
}

/// The bins' solvers, made once per run.
#[derive(Debug, Clone)]
pub(crate) struct BinVotes {
    /// Per bin from `first`, the index of its band in `bands` (none past the last).
    band_of: Vec<usize>,
    first: usize,
    bands: Vec<Band>,
    /// The plane's basis and normal (toward `side`) of a planar array.
    plane: Option<(Vector3<f64>, Vector3<f64>, Vector3<f64>)>,
    mics: usize,
}

impl BinVotes {
    /// For `geometry` at `rate` with frames of `n`: `None` when no bin from [`LOW_HZ`]
    /// has enough pairs shorter than half its wavelength (a large array), or for a
    /// linear array.
    pub fn new(geometry: &Geometry, n: usize, rate: f64, speed: f64) -> Option<Self> {
        let mics = geometry.mics.len();
        if mics > 64 {
            return None;
        }
        let full = if mics == 64 {
            u64::MAX
        } else {
            (1u64 << mics) - 1
        };
        let plane = match geometry.subset_shape(full).ok()? {
            Shape::Volumetric => None,
            Shape::Planar { normal } => {
                let (e1, e2) = plane_basis(&normal);
                Some((e1, e2, normal))
            }
            Shape::Linear { .. } => return None,
        };
        let rank = if plane.is_some() { 2 } else { 3 };
        let first = ((LOW_HZ * n as f64 / rate).ceil() as usize).max(1);
        let mut bands: Vec<Band> = Vec::new();
        let mut band_of = Vec::new();
        for k in first..n / 2 {
            let f = k as f64 * rate / n as f64;
            let length = |&(a, b): &(usize, usize)| {
                (geometry.mics[b].position - geometry.mics[a].position).norm()
            };
            let mut pairs: Vec<(usize, usize)> = (0..mics)
                .flat_map(|a| (a + 1..mics).map(move |b| (a, b)))
                .filter(|pair| length(pair) * f / speed < 0.5)
                .collect();
            // The shortest, when there are more.
            pairs.sort_by(|x, y| length(x).total_cmp(&length(y)).then(x.cmp(y)));
            pairs.truncate(MAX_PAIRS);
            if bands.last().is_none_or(|b| b.pairs != pairs) {
                match Band::new(geometry, pairs, plane, rank) {
                    Some(band) => bands.push(band),
                    None => break,
                }
            }
            band_of.push(bands.len() - 1);
        }
        (band_of.len() >= MIN_BINS).then_some(BinVotes {
            band_of,
            first,
            bands,
            plane,
            mics,
        })
    }

    /// The votes of one frame (its spectra per microphone, `X(k)` and `X_n(k)`), into
    /// `votes`.
    pub fn collect(
        &self,
        state: &FrameState,
        rate: f64,
        n: usize,
        speed: f64,
        votes: &mut Vec<Vote>,
    ) {
        votes.clear();
        if state.live.len() < self.mics {
            return;
        }
        let mut paths = [0.0f64; MAX_PAIRS];
        for (i, &band) in self.band_of.iter().enumerate() {
            let k = self.first + i;
            if state.weights[k] == 0.0 {
                // Outside `--band`: not analysed.
                continue;
            }
            // Capped as eq. (5)'s ratio is (a noise estimate of 0 after digital silence).
            let ratio = (state.power[k] / state.noise[k]).min(MAX_SNR_RATIO);
            if ratio.is_nan() || ratio < SNR_FLOOR {
                continue;
            }
            let band = &self.bands[band];
            let omega = std::f64::consts::TAU * k as f64 * rate / n as f64;
            // X_a X_b* = e^{-i w dT_ab} (eq. 11-12's dT_ab = t_a - t_b): the path
            // difference c dT_ab, and eq. (13)'s least squares over the bin's pairs.
            let mut u = Vector3::zeros();
            for ((&(a, b), col), path) in band.pairs.iter().zip(&band.cols).zip(&mut paths) {
                let cross = state.spectra[a][k] * state.spectra[b][k].conj();
                *path = -(cross.im as f64).atan2(cross.re as f64) / omega * speed;
                u += col * *path;
            }
            let residual = (band
                .diffs
                .iter()
                .zip(&paths)
                .map(|(x, path)| (x.dot(&u) - path).powi(2))
                .sum::<f64>()
                / band.diffs.len() as f64)
                .sqrt();
            if residual.is_nan() || residual > MAX_RESIDUAL * band.mean_length {
                continue;
            }
            let r = u.norm();
            let (direction, azimuth) = match self.plane {
                // The in-plane part: its length is the cosine of the angle to the plane.
                Some((e1, e2, normal)) => {
                    if !(r > 0.0 && r < 1.0 + MAX_RESIDUAL) {
                        continue;
                    }
                    let inplane = u / r.max(1.0);
                    let up = (1.0 - inplane.norm_squared()).max(0.0).sqrt();
                    (inplane + normal * up, u.dot(&e2).atan2(u.dot(&e1)))
                }
                None => {
                    if !((1.0 - 2.0 * MAX_RESIDUAL..1.0 + MAX_RESIDUAL).contains(&r)) {
                        continue;
                    }
                    (u / r, u.y.atan2(u.x))
                }
            };
            votes.push(Vote {
                direction,
                azimuth,
                weight: (ratio as f64).log10(),
            });
        }
    }

    /// Directions at the azimuth of `u` (in the array's plane for a planar array, about
    /// z otherwise) from elevation 0 (the plane) toward its side, or from -80 to 80 deg,
    /// in steps of 2 deg: what a peak's elevation is chosen among.
    pub fn elevations(&self, u: &Vector3<f64>) -> impl Iterator<Item = Vector3<f64>> + '_ {
        let (e1, e2, normal) = self
            .plane
            .unwrap_or((Vector3::x(), Vector3::y(), Vector3::z()));
        let azimuth = u.dot(&e2).atan2(u.dot(&e1));
        let flat = e1 * azimuth.cos() + e2 * azimuth.sin();
        let low = if self.plane.is_some() { 0 } else { -40 };
        (low..=40).map(move |k| {
            let e = (2.0 * k as f64).to_radians();
            flat * e.cos() + normal * e.sin()
        })
    }

    /// The peaks of `votes` (those of the frames averaged), strongest first, at most
    /// `max`: the weight is summed per degree of azimuth, and each peak's window of
    /// `2 PEAK_DEG + 1` degrees found by a running sum around the circle.
    pub fn peaks(&self, votes: &mut [Vote], max: usize, out: &mut Vec<VotePeak>) {
        out.clear();
        let degree = |azimuth: f64| (azimuth.to_degrees().rem_euclid(360.0) as usize).min(359);
        let mut weights = [0.0f64; 360];
        for v in votes.iter() {
            weights[degree(v.azimuth)] += v.weight;
        }
        let half = PEAK_DEG as usize;
        let gap = |a: f64, b: f64| {
            let d = (a - b).rem_euclid(std::f64::consts::TAU);
            d.min(std::f64::consts::TAU - d)
        };
        let mut first_mass = None;
        while out.len() < max {
            let mut sum: f64 = (0..=2 * half)
                .map(|i| weights[(360 - half + i) % 360])
                .sum();
            let mut best = (sum, 0);
            for centre in 1..360 {
                sum += weights[(centre + half) % 360] - weights[(centre + 359 - half) % 360];
                if sum > best.0 {
                    best = (sum, centre);
                }
            }
            let (mass, centre) = best;
            if mass < MIN_MASS || first_mass.is_some_and(|f| mass < PEAK_SHARE * f) {
                break;
            }
            first_mass.get_or_insert(mass);
            let at = (centre as f64 + 0.5).to_radians();
            let sum: Vector3<f64> = votes
                .iter()
                .filter(|v| {
                    v.weight > 0.0 && gap(v.azimuth, at) <= (half as f64 + 0.5).to_radians()
                })
                .map(|v| v.direction * v.weight)
                .sum();
            if let Some(direction) = sum.try_normalize(1e-12) {
                out.push(VotePeak { direction });
            }
            for v in votes.iter_mut() {
                if v.weight > 0.0 && gap(v.azimuth, at) <= APART_DEG.to_radians() {
                    weights[degree(v.azimuth)] -= v.weight;
                    v.weight = 0.0;
                }
            }
        }
    }
}

impl Band {
    fn new(
        geometry: &Geometry,
        pairs: Vec<(usize, usize)>,
        plane: Option<(Vector3<f64>, Vector3<f64>, Vector3<f64>)>,
        rank: usize,
    ) -> Option<Band> {
        if pairs.len() < rank || pairs.len() > MAX_PAIRS {
            return None;
        }
        let diffs: Vec<Vector3<f64>> = pairs
            .iter()
            .map(|&(a, b)| geometry.mics[b].position - geometry.mics[a].position)
            .collect();
        let cols = match plane {
            Some((e1, e2, _)) => {
                let d = DMatrix::from_fn(diffs.len(), 2, |r, c| {
                    diffs[r].dot(if c == 0 { &e1 } else { &e2 })
                });
                if d.rank(1e-9) < 2 {
                    return None;
                }
                let pinv = d.pseudo_inverse(1e-12).ok()?;
                (0..diffs.len())
                    .map(|r| e1 * pinv[(0, r)] + e2 * pinv[(1, r)])
                    .collect()
            }
            None => {
                let d = DMatrix::from_fn(diffs.len(), 3, |r, c| diffs[r][c]);
                if d.rank(1e-9) < 3 {
                    return None;
                }
                let pinv = d.pseudo_inverse(1e-12).ok()?;
                (0..diffs.len())
                    .map(|r| Vector3::new(pinv[(0, r)], pinv[(1, r)], pinv[(2, r)]))
                    .collect()
            }
        };
        let mean_length = diffs.iter().map(|x| x.norm()).sum::<f64>() / diffs.len() as f64;
        Some(Band {
            pairs,
            cols,
            diffs,
            mean_length,
        })
    }
}

/// Adds to `found` (a frame's detections, the strongest first) riders from the peaks
/// of the bins' votes over `span` (the frame and those it averages): each peak apart
/// from every detection (and from their floor and ceiling images), at the elevation
/// where the frame's own correlations sum highest at its azimuth, scored by that sum,
/// up to [`Talkers::max_sources`](crate::method::Talkers::max_sources) in all. Only beside a
/// detection that is not a rider: in a frame that gave nothing, a peak is mostly the
/// same talker, whose rows the correlations place better (the field benchmark's planar
/// arrays gave 10-35% more confidently wrong rows with riders there). A frame the
/// `threshold` module calls steady gives none. `scratch`: buffers for the votes and
/// their peaks.
pub(crate) fn add_riders(
    setup: &Layout,
    solver: &DirectionSolver,
    bins: &BinVotes,
    span: &[FrameState],
    index: u64,
    found: &mut Detections,
    scratch: (&mut Vec<Vote>, &mut Vec<VotePeak>),
) {
    let state = span.last().expect("a frame");
    let wanted = setup.params.talkers.max_sources;
    if found.as_slice().iter().all(|d| d.rider)
        || found.len() >= wanted
        || state.steady
        || state.votes.is_empty()
    {
        return;
    }
    let (votes, peaks) = scratch;
    votes.clear();
    for f in span {
        votes.extend_from_slice(&f.votes);
    }
    bins.peaks(votes, MAX_SOURCES, peaks);
    for peak in peaks.iter() {
        if found.len() >= wanted {
            break;
        }
        if !found
            .as_slice()
            .iter()
            .all(|f| apart(&peak.direction, &f.direction, IMAGE_ELEVATION_DEG))
        {
            continue;
        }
        let Some((score, u)) = bins
            .elevations(&peak.direction)
            .map(|u| (own_response(setup, state, &u), u))
            .max_by(|a, b| a.0.total_cmp(&b.0))
        else {
            continue;
        };
        let mut d = detection(
            setup,
            state,
            index,
            u,
            score,
            uncertainty_deg(solver, &u, None, setup.speed),
        );
        d.rider = true;
        found.push(d);
    }
}

/// The frame's own summed correlation at the delays of direction `u` (each live pair's
/// window read at the delay, linearly between lags): the steered response of eq. (6)'s
/// correlations, on the scale of a set's score. 0 when the frame's correlations were
/// not computed.
fn own_response(setup: &Layout, state: &FrameState, u: &Vector3<f64>) -> f64 {
    if state.correlated != Correlated::Yes {
        return 0.0;
    }
    let mics = setup.mics();
    let mut sum = 0.0;
    for (a, &i) in state.live.iter().enumerate() {
        for &j in &state.live[a + 1..] {
            let pair = pair_index(i, j, mics);
            let half = setup.max_lag[pair] + 1;
            let window = &state.windows[setup.window_starts[pair]..][..2 * half + 1];
            let x = setup.geometry.mics[j].position - setup.geometry.mics[i].position;
            let reach = half as f64 - 1.0;
            let lag = (u.dot(&x) * setup.rate / setup.speed).clamp(-reach, reach);
            let at = lag + half as f64;
            let low = at.floor() as usize;
            let t = (at - low as f64) as f32;
            let high = (low + 1).min(window.len() - 1);
            sum += (window[low] * (1.0 - t) + window[high] * t) as f64;
        }
    }
    sum
}

#[cfg(test)]
#[path = "votes_tests.rs"]
mod tests;
