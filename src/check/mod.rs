//! `ssl check`: does a recording fit its geometry and channel order? (docs/interface.md,
//! "Checking an array"; docs/guide.md, "Checking an array".)
//!
//! One pass over the recording (`scan.rs`) measures each channel and, for the frames where
//! one sound is clearest, every pair's delay; the far-field least squares of eq. (13)
//! (`fit.rs`) then says how well the geometry explains them. What it reports, each a
//! [`Finding`]:
//!
//! - a channel that is dead (constant or silent), clips, duplicates another, has its
//!   polarity inverted (its pairs' correlation peaks are negative), or is 6 dB or more
//!   louder or quieter than the others;
//! - delays longer than the geometry allows (positions too small, or the wrong sample
//!   rate or speed of sound), or much shorter (positions too large: a unit), with the unit
//!   the numbers look like;
//! - a channel order that fits much better than the file's (every order of up to 8
//!   microphones is tried, every swap of two beyond), or one microphone whose delays
//!   alone disagree with its position (moved, or a wrong position).
//!
//! The constants are in units: samples of residual, decibels, shares of frames.

mod fit;
mod scan;

use crate::geometry::{units, Geometry};
use crate::stream::{AudioStream, InputError, SampleSource};
use fit::{orderings, Fit};
use serde::Serialize;

/// Fewer clear frames than this and the delays are not checked.
pub const MIN_CLEAR_FRAMES: usize = 20;
/// The file's order fits the geometry when its residual is under this share of a random
/// order's (the median over every other order).
pub const RANDOM_SHARE: f64 = 0.7;
/// Another channel order is named when its residual is under this share of the file's.
pub const BETTER_SHARE: f64 = 0.5;
/// A channel this many decibels from the median level is a gain mismatch.
pub const GAIN_DB: f64 = 6.0;
/// The share of a channel's pairs with a negative peak that makes it inverted.
pub const INVERTED_SHARE: f64 = 0.6;
/// The share of samples at full scale that makes a channel clip.
pub const CLIPPED_SHARE: f64 = 1e-3;
/// The share of delays beyond a pair's reach that makes the geometry too small.
pub const BEYOND_SHARE: f64 = 0.2;
/// Solutions shorter than this (1 is right) make the positions too large.
pub const SHORT_LENGTH: f64 = 0.3;
/// Solutions longer than this make the positions too small.
pub const LONG_LENGTH: f64 = 1.5;
/// Orders are all tried up to this many microphones; swaps of two beyond.
pub const FULL_ORDERS: usize = 8;
/// The frame length (seconds), rounded up to a power of two samples.
pub const FRAME_S: f64 = 0.06;
/// A microphone is named as moved when leaving it out brings the fit under this share
/// of leaving out a typical one.
pub const MOVED_SHARE: f64 = 0.6;
/// Frames used to compare orders (the clearest).
const ORDER_FRAMES: usize = 60;

/// Why a recording could not be checked.
#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    /// The recording could not be read.
    #[error("{name}: {error}")]
    Input {
        /// The recording's name.
        name: String,
        /// Why.
        error: InputError,
    },
    /// The recording's channels do not match the geometry's.
    #[error("{name}: {message}")]
    Channels {
        /// The recording's name.
        name: String,
        /// What does not match.
        message: String,
    },
}

/// One thing that does not fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Finding {
    /// `silent`, `dead`, `clipped`, `duplicated`, `inverted`, `gain`, `beyond`, `unit`,
    /// `order`, `moved`, `misfit` or `unclear`.
    pub kind: String,
    /// What it is, and what to do.
    pub message: String,
    /// For `order`: the channel (0-based) of each microphone that fits better.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub order: Option<Vec<usize>>,
}

/// What `ssl check` found.
#[derive(Debug, Clone, Serialize)]
pub struct CheckReport {
    /// The recording, as named.
    pub file: String,
    /// Its sample rate (Hz).
    pub sample_rate: u32,
    /// Its channels.
    pub channels: usize,
    /// Seconds read (at most 600).
    pub seconds_read: f64,
    /// Per channel, its RMS level (dBFS; `None` when constant).
    pub levels_dbfs: Vec<Option<f64>>,
    /// Clear frames found (one sound standing out).
    pub clear_frames: usize,
    /// The mean residual of the far-field fit over them with the file's channel order
    /// (microseconds), when there were enough.
    pub residual_us: Option<f64>,
    /// The share of pair delays longer than the geometry allows.
    pub beyond_share: Option<f64>,
    /// The fit's solution length (about 1 when the positions' scale is right).
    pub length: Option<f64>,
    /// Whether the delays can tell the channels apart: not on an array whose every order
    /// is a symmetry (a regular tetrahedron), whose channel order is then not checked.
    pub order_checked: bool,
    /// What does not fit; empty when the recording fits.
    pub findings: Vec<Finding>,
    /// No finding.
    pub fits: bool,
}

fn finding(kind: &str, message: String) -> Finding {
    Finding {
        kind: kind.into(),
        message,
        order: None,
    }
}

/// Checks the WAV file at `path` (`-` for standard input) against `geometry`.
pub fn check(path: &str, geometry: &Geometry) -> Result<CheckReport, CheckError> {
    let name = if path == "-" { "<stdin>" } else { path }.to_string();
    let mut stream = AudioStream::open(path).map_err(|error| CheckError::Input {
        name: name.clone(),
        error,
    })?;
    check_source(&mut stream, geometry)
}

/// Checks any source of samples against `geometry`.
pub fn check_source<S: SampleSource>(
    source: &mut S,
    geometry: &Geometry,
) -> Result<CheckReport, CheckError> {
    let name = source.name().to_string();
    let k = source.channels();
    let m = geometry.mics.len();
    let needed = geometry.mics.iter().map(|x| x.channel).max().unwrap_or(0) + 1;
    if (!geometry.explicit_channels && k != m) || k < needed {
        return Err(CheckError::Channels {
            name,
            message: format!(
                "the recording has {k} channel(s) but the geometry has {m} microphone(s){}",
                if geometry.explicit_channels {
                    format!(" on channels up to {needed}")
                } else {
                    String::new()
                }
            ),
        });
    }
    let rate = source.sample_rate() as f64;
    let positions = geometry.positions();
    let speed = geometry.speed_of_sound;
    let fit = Fit::new(&positions, rate, speed);
    // A frame long enough for the longest delay the geometry allows, and longer ones.
    let (aperture, _, _) = geometry.aperture();
    let longest = aperture * rate / speed;
    // About 64 ms (a sustained sound's PHAT peak stands out of a room's reverberation
    // better in long frames), and at least four times the longest delay.
    let mut n = 1024;
    while (n as f64) < FRAME_S * rate && n < 1 << 16 {
        n *= 2;
    }
    while (n as f64) < 4.0 * longest && n < 1 << 16 {
        n *= 2;
    }
    let scan =
        scan::scan(source, n, longest.ceil() as usize + 2).map_err(|error| CheckError::Input {
            name: name.clone(),
            error,
        })?;
    let samples = scan.samples.max(1) as f64;
    let levels: Vec<Option<f64>> = scan
        .channels
        .iter()
        .map(|c| (c.max > c.min).then(|| 10.0 * (c.energy / samples).max(1e-30).log10()))
        .collect();
    let mut findings = Vec::new();
    let mics_on = |c: usize| -> String {
        match geometry.mics.iter().position(|x| x.channel == c) {
            Some(i) => format!("channel {} (mic {})", c + 1, i + 1),
            None => format!("channel {}", c + 1),
        }
    };
    let used: Vec<usize> = geometry.mics.iter().map(|x| x.channel).collect();
    if used.iter().all(|&c| levels[c].is_none()) {
        findings.push(finding(
            "silent",
            "the file is silent (every channel constant): there is nothing to check".into(),
        ));
        return Ok(report(
            name,
            source.sample_rate(),
            k,
            &scan,
            levels,
            Fitted::default(),
            findings,
        ));
    }
    // Channels.
    let dead: Vec<usize> = used
        .iter()
        .copied()
        .filter(|&c| levels[c].is_none_or(|l| l < -100.0))
        .collect();
    for &c in &dead {
        findings.push(finding(
            "dead",
            format!("{} is dead (constant or silent)", mics_on(c)),
        ));
    }
    for &c in &used {
        let share = scan.channels[c].clipped as f64 / samples;
        if share > CLIPPED_SHARE {
            findings.push(finding(
                "clipped",
                format!(
                    "{} clips: {:.2}% of its samples are at full scale (lower the gain)",
                    mics_on(c),
                    100.0 * share
                ),
            ));
        }
    }
    for (a, &i) in used.iter().enumerate() {
        for &j in &used[a + 1..] {
            let (lo, hi) = (i.min(j), i.max(j));
            let (ei, ej) = (scan.channels[lo].energy, scan.channels[hi].energy);
            let rho = scan.cross[crate::method::pairs::pair_index(lo, hi, k)] / (ei * ej).sqrt();
            if ei > 0.0 && ej > 0.0 && rho > 0.9995 {
                findings.push(finding(
                    "duplicated",
                    format!(
                        "{} and {} carry the same signal (duplicated channel)",
                        mics_on(lo),
                        mics_on(hi)
                    ),
                ));
            }
        }
    }
    let live: Vec<f64> = used
        .iter()
        .filter(|c| !dead.contains(c))
        .filter_map(|&c| levels[c])
        .collect();
    if live.len() >= 3 {
        let mut sorted = live.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted[sorted.len() / 2];
        for &c in used.iter().filter(|c| !dead.contains(c)) {
            let l = levels[c].unwrap_or(median);
            if (l - median).abs() >= GAIN_DB {
                findings.push(finding(
                    "gain",
                    format!(
                        "{} is {:.1} dB {} than the median channel (gain mismatch)",
                        mics_on(c),
                        (l - median).abs(),
                        if l > median { "louder" } else { "quieter" }
                    ),
                ));
            }
        }
    }
    let frames = &scan.frames;
    if frames.len() < MIN_CLEAR_FRAMES {
        findings.push(finding(
            "unclear",
            format!(
                "only {} frame(s) with one clear sound in the first {:.0} s: the delays cannot be checked (record a few hand claps or speech near the array)",
                frames.len(),
                scan::MAX_SECONDS
            ),
        ));
        return Ok(report(
            name,
            source.sample_rate(),
            k,
            &scan,
            levels,
            Fitted::default(),
            findings,
        ));
    }
    // Polarity: a channel whose pairs' peaks are mostly negative.
    for &c in used.iter().filter(|c| !dead.contains(c)) {
        let (mut negative, mut all) = (0usize, 0usize);
        for f in frames {
            for &o in used.iter().filter(|&&o| o != c && !dead.contains(&o)) {
                let v = f.near_peaks[crate::method::pairs::pair_index(c.min(o), c.max(o), k)];
                if v.abs() > 0.1 {
                    negative += usize::from(v < 0.0);
                    all += 1;
                }
            }
        }
        if all > 0 && negative as f64 / all as f64 > INVERTED_SHARE {
            findings.push(finding(
                "inverted",
                format!("{} is polarity-inverted: its correlation with the others peaks negative (swap its wires or negate it)", mics_on(c)),
            ));
        }
    }
    // Delays.
    let mut buf = Vec::new();
    let own = fit.score(frames, &used, k, &mut buf);
    let beyond = fit.beyond_share(frames, &used, k);
    let length = fit.length(frames, &used, k);
    let mut explained = false;
    if beyond > BEYOND_SHARE || length > LONG_LENGTH {
        explained = true;
        findings.push(finding(
            "beyond",
            format!(
                "the delays are about {:.1} times longer than the positions allow ({:.0}% of them beyond the microphones' spacing): positions too small (they must be in metres), or the wrong sample rate or speed of sound",
                length,
                100.0 * beyond
            ),
        ));
    } else if length < SHORT_LENGTH {
        explained = true;
        let advice = units::advice(aperture)
            .map(|a| format!("; {a}"))
            .unwrap_or_default();
        findings.push(finding(
            "unit",
            format!(
                "the delays are about {:.0} times shorter than the positions imply: positions too large (they must be in metres){advice}",
                1.0 / length.max(1e-9)
            ),
        ));
    }
    let mut identifiable = true;
    if !explained && dead.is_empty() {
        // Every other order (or swap) of the microphones, on the clearest frames: the
        // best, and the median, which is what an order that does not fit gives.
        let strongest: Vec<_> = frames.iter().take(ORDER_FRAMES).cloned().collect();
        let base = fit.score(&strongest, &used, k, &mut buf);
        let mut best = (f64::INFINITY, used.clone());
        let mut others = Vec::new();
        orderings(&used, FULL_ORDERS, |order| {
            if order != used.as_slice() {
                let s = fit.score(&strongest, order, k, &mut buf);
                others.push(s);
                if s < best.0 {
                    best = (s, order.to_vec());
                }
            }
        });
        others.sort_by(f64::total_cmp);
        let random = others
            .get(others.len() / 2)
            .copied()
            .unwrap_or(f64::INFINITY);
        // A regular tetrahedron's every order is one of its symmetries: its delays cannot
        // tell its channels apart (nor a wrong order from a right one).
        identifiable = random > base * (1.0 + 1e-6);
        let informative = best.0.min(base) < RANDOM_SHARE * random;
        if !identifiable {
            // Nothing to compare: the order and the positions are not checked.
        } else if !informative {
            findings.push(finding(
                "unclear",
                format!(
                    "no channel order explains the delays of the clearest frames better than another ({:.0} us at best, {:.0} us typically): the sound is not clear enough to check the geometry (record a few hand claps or speech near the array, in a quiet room)",
                    best.0.min(base) / rate * 1e6,
                    random / rate * 1e6
                ),
            ));
        } else if best.0 < BETTER_SHARE * base {
            let changed: Vec<usize> = (0..m).filter(|&i| best.1[i] != used[i]).collect();
            let moved: Vec<String> = changed
                .iter()
                .map(|&i| format!("mic {} on channel {}", i + 1, best.1[i] + 1))
                .collect();
            let what = if changed.len() == 2 {
                let (a, b) = (used[changed[0]], used[changed[1]]);
                format!(
                    "channels {} and {} look swapped",
                    a.min(b) + 1,
                    a.max(b) + 1
                )
            } else {
                "the channel order looks wrong".to_string()
            };
            findings.push(Finding {
                kind: "order".into(),
                message: format!(
                    "{what}: {} fits {:.1} times better (residual {:.0} us against {:.0} us); give each [[mic]] its `channel`",
                    moved.join(", "),
                    base / best.0.max(1e-9),
                    best.0 / rate * 1e6,
                    base / rate * 1e6
                ),
                order: Some(best.1.clone()),
            });
        } else if let Some(f) = moved_mic(
            &fit_without(&positions, rate, speed),
            &strongest,
            &used,
            k,
            base,
            rate,
        ) {
            findings.push(f);
        } else if base >= RANDOM_SHARE * random {
            findings.push(finding(
                "misfit",
                format!(
                    "the delays do not fit the geometry: with the file's channel order the far-field fit errs by {:.0} us, hardly better than a random order's {:.0} us; check the positions, their unit and the channel order",
                    base / rate * 1e6,
                    random / rate * 1e6
                ),
            ));
        }
    }
    let fitted = Fitted {
        residual_us: Some(own / rate * 1e6),
        beyond_share: Some(beyond),
        length: Some(length),
        order_checked: identifiable,
    };
    Ok(report(
        name,
        source.sample_rate(),
        k,
        &scan,
        levels,
        fitted,
        findings,
    ))
}

/// What the fit measured (nothing when the delays were not checked).
#[derive(Default)]
struct Fitted {
    residual_us: Option<f64>,
    beyond_share: Option<f64>,
    length: Option<f64>,
    order_checked: bool,
}

fn report(
    file: String,
    sample_rate: u32,
    channels: usize,
    scan: &scan::Scan,
    levels: Vec<Option<f64>>,
    fitted: Fitted,
    findings: Vec<Finding>,
) -> CheckReport {
    CheckReport {
        file,
        sample_rate,
        channels,
        seconds_read: scan.samples as f64 / sample_rate as f64,
        levels_dbfs: levels,
        clear_frames: scan.frames.len(),
        residual_us: fitted.residual_us,
        beyond_share: fitted.beyond_share,
        length: fitted.length,
        order_checked: fitted.order_checked,
        fits: findings.is_empty(),
        findings,
    }
}

/// Per microphone, the fit of the others without it.
fn fit_without(positions: &[nalgebra::Vector3<f64>], rate: f64, speed: f64) -> Vec<Fit> {
    (0..positions.len())
        .map(|skip| {
            let keep: Vec<_> = (0..positions.len())
                .filter(|&i| i != skip)
                .map(|i| positions[i])
                .collect();
            Fit::new(&keep, rate, speed)
        })
        .collect()
}

/// One microphone that does not fit its position: leaving it out brings the others' fit
/// under [`MOVED_SHARE`] of what leaving out a typical one does, and of the whole array's
/// `base`. Needs 5 microphones or more (leaving one of 4 out leaves too few pairs to
/// tell).
fn moved_mic(
    without: &[Fit],
    frames: &[scan::Frame],
    used: &[usize],
    k: usize,
    base: f64,
    rate: f64,
) -> Option<Finding> {
    let m = used.len();
    if m < 5 {
        return None;
    }
    let mut buf = Vec::new();
    let scores: Vec<f64> = (0..m)
        .map(|skip| {
            let order: Vec<usize> = (0..m).filter(|&i| i != skip).map(|i| used[i]).collect();
            without[skip].score(frames, &order, k, &mut buf)
        })
        .collect();
    let mut sorted = scores.clone();
    sorted.sort_by(f64::total_cmp);
    let typical = sorted[m / 2];
    let (worst, lowest) = scores
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .map(|(i, v)| (i, *v))?;
    (lowest < MOVED_SHARE * typical && lowest < MOVED_SHARE * base).then(|| {
        finding(
            "moved",
            format!(
                "mic {} (channel {}) does not fit its position: without it the others fit {:.1} times better (residual {:.0} us against {:.0} us); it moved, or its position in the geometry is wrong",
                worst + 1,
                used[worst] + 1,
                base / lowest.max(1e-9),
                lowest / rate * 1e6,
                base / rate * 1e6
            ),
        )
    })
}
