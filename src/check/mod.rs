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

mod channels;
mod fit;
mod orders;
mod scan;
mod symmetry;

pub use symmetry::symmetries;

use crate::geometry::{units, Geometry};
use crate::stream::{AudioStream, InputError, SampleSource};
use fit::Fit;
use orders::{OrderVerdict, EVIDENCE_NEEDED};
use serde::Serialize;

/// Fewer clear frames than this and the delays are not checked.
pub(crate) const MIN_CLEAR_FRAMES: usize = orders::MIN_FRAMES;
/// With `--expect`, a clear frame is of the expected sound when its direction is within
/// this many degrees of it.
pub(crate) const EXPECT_DEG: f64 = 10.0;
/// With `--expect`, the order settled on puts a direct sound this many degrees nearer
/// the expected direction than any other image does: a sound nearer a mirror of the
/// array than half this cannot settle it.
pub(crate) const EXPECT_MARGIN_DEG: f64 = 4.0;
/// The file's order fits the geometry when its residual is under this share of a random
/// order's (the median over every other order).
pub(crate) const RANDOM_SHARE: f64 = 0.7;
/// Below 5 microphones, another channel order is named when its residual is under this
/// share of the file's (see `beats_one_moved`).
pub(crate) const BETTER_SHARE: f64 = 0.5;
/// A channel this many decibels from the median level is a gain mismatch.
pub(crate) const GAIN_DB: f64 = 6.0;
/// A channel this many dB under the median channel carries only its own noise: dead. A
/// directional capsule facing away is 8-20 dB down, never this far over a recording.
pub(crate) const DEAD_DB: f64 = 30.0;
/// The share of a channel's pairs with a negative peak that makes it inverted.
pub(crate) const INVERTED_SHARE: f64 = 0.6;
/// The share of samples at full scale that makes a channel clip.
pub(crate) const CLIPPED_SHARE: f64 = 1e-3;
/// The share of delays beyond a pair's reach that makes the geometry too small.
pub(crate) const BEYOND_SHARE: f64 = 0.2;
/// Solutions shorter than this (1 is right) make the positions too large.
pub(crate) const SHORT_LENGTH: f64 = 0.3;
/// Solutions longer than this make the positions too small.
pub(crate) const LONG_LENGTH: f64 = 1.5;
/// Orders are all tried up to this many microphones; swaps of two beyond.
pub(crate) const FULL_ORDERS: usize = 8;
/// The frame length (seconds), rounded up to a power of two samples.
pub(crate) const FRAME_S: f64 = 0.06;
/// A microphone is named as moved when leaving it out brings the fit under this share
/// of leaving out a typical one.
pub(crate) const MOVED_SHARE: f64 = 0.6;
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
    /// `silent`, `dead`, `clipped`, `duplicated`, `inverted`, `beyond`, `unit`,
    /// `order`, `moved`, `misfit`, `symmetric` or `unclear`; for a remark, `gain`.
    pub kind: String,
    /// What it is, and what to do.
    pub message: String,
    /// For `order`: the channel (0-based, as the geometry's `channel` key) of each
    /// microphone that fits better: of the orders that fit alike, the one that changes
    /// the fewest channels.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub order: Option<Vec<usize>>,
    /// For `order`, `symmetric` and `unclear`: every order (as `order`) that fits as well
    /// or that the recording cannot tell apart, nearest the file's first.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orders: Option<Vec<Vec<usize>>>,
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
    /// Whether the delays can tell the channels apart at all: not on an array whose
    /// every order is a symmetry (a regular tetrahedron).
    pub order_checked: bool,
    /// How many channel orders the geometry alone cannot tell apart (its symmetries: 1
    /// when it has none; 8 for a rectangular box, 12 for a regular hexagon).
    pub symmetries: usize,
    /// What does not fit; empty when the recording fits.
    pub findings: Vec<Finding>,
    /// What is worth knowing but no fault: a channel's level far from the others
    /// (directional capsules facing away from the sound are quieter).
    pub remarks: Vec<Finding>,
    /// No finding.
    pub fits: bool,
}

/// What `ssl check` is told besides the recording and the geometry.
#[derive(Debug, Clone, Default)]
pub struct CheckOptions {
    /// Sounds in the recording from known directions: they settle orders that are
    /// mirror images or rotations of each other. The order settled on puts a direct
    /// sound near each of them.
    pub expect: Vec<Expected>,
}

/// A sound from a known direction (`--expect AZ/EL[@T]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Expected {
    /// Azimuth in degrees, in the geometry's output frame.
    pub azimuth_deg: f64,
    /// Elevation in degrees.
    pub elevation_deg: f64,
    /// When it starts (seconds into the recording): only the direct sounds that start
    /// near then are taken for it. Without it any direct sound is, and with many sounds around a regular array one of them
    /// may lie near the expected direction under a rotation too.
    pub at_s: Option<f64>,
}

/// See [`Expected::at_s`]: a sound given at T is looked for from T - 0.2 s ...
pub(crate) const EXPECT_BEFORE_S: f64 = 0.2;
/// ... to T + 0.4 s (claps half a second apart stay apart).
pub(crate) const EXPECT_AFTER_S: f64 = 0.4;

fn finding(kind: &str, message: String) -> Finding {
    Finding {
        kind: kind.into(),
        message,
        order: None,
        orders: None,
    }
}

/// Checks the WAV file at `path` (`-` for standard input) against `geometry`.
pub fn check(
    path: &str,
    geometry: &Geometry,
    options: &CheckOptions,
) -> Result<CheckReport, CheckError> {
    let name = if path == "-" { "<stdin>" } else { path }.to_string();
    let mut stream = AudioStream::open(path).map_err(|error| CheckError::Input {
        name: name.clone(),
        error,
    })?;
    check_source(&mut stream, geometry, options)
}

/// Checks any source of samples against `geometry`.
pub fn check_source<S: SampleSource>(
    source: &mut S,
    geometry: &Geometry,
    options: &CheckOptions,
) -> Result<CheckReport, CheckError> {
    let expect: Vec<(nalgebra::Vector3<f64>, Option<f64>)> = options
        .expect
        .iter()
        .map(|e| {
            (
                crate::geometry::unit_from_angles(e.azimuth_deg, e.elevation_deg),
                e.at_s,
            )
        })
        .collect();
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
    let used: Vec<usize> = geometry.mics.iter().map(|x| x.channel).collect();
    if used.iter().all(|&c| levels[c].is_none()) {
        let findings = vec![finding(
            "silent",
            "the file is silent (every channel constant): there is nothing to check".into(),
        )];
        return Ok(report(
            name,
            source.sample_rate(),
            k,
            &scan,
            levels,
            Fitted::default(),
            findings,
            Vec::new(),
        ));
    }
    let (mut findings, remarks, dead) = channels::levels(geometry, &scan, &levels, &used);
    let frames = &scan.frames;
    if frames.len() < MIN_CLEAR_FRAMES {
        findings.push(finding(
            "unclear",
            format!(
                "only {} frame(s) with one clear sound in the first {:.0} s, {} needed: the delays cannot be checked (record sharp sounds such as hand claps from several directions around the array, or speech near it)",
                frames.len(),
                scan::MAX_SECONDS,
                MIN_CLEAR_FRAMES
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
            remarks,
        ));
    }
    findings.extend(channels::inverted(geometry, frames, &used, &dead, k));
    // Delays. The channel order first: a permutation that explains the delays explains
    // delays beyond the spacing too, before any unit is blamed.
    let delays = Delays {
        fit,
        positions,
        used,
        k,
        rate,
        speed,
        aperture,
        frames,
        expect,
    };
    let (more, fitted) = delays.findings(&dead);
    findings.extend(more);
    Ok(report(
        name,
        source.sample_rate(),
        k,
        &scan,
        levels,
        fitted,
        findings,
        remarks,
    ))
}

/// What the delays of the clear frames are judged with.
struct Delays<'a> {
    /// The far-field fit of the geometry's positions.
    fit: Fit,
    positions: Vec<nalgebra::Vector3<f64>>,
    /// The channel of each microphone, in the geometry's order.
    used: Vec<usize>,
    /// The recording's channels.
    k: usize,
    rate: f64,
    speed: f64,
    aperture: f64,
    frames: &'a [scan::Frame],
    /// `--expect`: known directions, and when their sounds start.
    expect: Vec<(nalgebra::Vector3<f64>, Option<f64>)>,
}

impl Delays<'_> {
    /// The findings of the delays (none when every channel is live and fits) and the
    /// fit's figures.
    fn findings(&self, dead: &[usize]) -> (Vec<Finding>, Fitted) {
        let (fit, frames, used, k) = (&self.fit, self.frames, &self.used, self.k);
        let mut findings = Vec::new();
        let mut buf = Vec::new();
        let own = fit.score(frames, used, k, &mut buf);
        let group = symmetry::symmetries(&self.positions);
        let strongest: Vec<_> = frames.iter().take(ORDER_FRAMES).cloned().collect();
        let judged =
            (dead.is_empty()).then(|| orders::judge(fit, &strongest, used, k, &group, FULL_ORDERS));
        let beyond = fit.beyond_share(frames, used, k);
        let length = fit.length(frames, used, k);
        // The direct sounds the order was judged on, and the fits without each microphone.
        let direct: Vec<scan::Frame> = judged
            .as_ref()
            .map(|j| j.frames.iter().map(|&i| strongest[i].clone()).collect())
            .unwrap_or_default();
        let without = fit_without(&self.positions, self.rate, self.speed);
        let fix = self.fix(judged.as_ref(), &direct, &without);
        let order_found = fix.is_some();
        findings.extend(fix);
        let scale = (!order_found)
            .then(|| self.scale(judged.as_ref(), beyond, length))
            .flatten();
        let explained = order_found || scale.is_some();
        findings.extend(scale);
        if let (false, Some(judged)) = (explained, &judged) {
            findings.extend(self.verdict(judged, &direct, &without));
        }
        let fitted = Fitted {
            residual_us: Some(own / self.rate * 1e6),
            beyond_share: Some(beyond),
            length: Some(length),
            order_checked: group.len() < factorial(used.len().min(FULL_ORDERS + 1)),
            symmetries: group.len(),
        };
        (findings, fitted)
    }

    /// Whether `order` keeps the delays within the positions' reach.
    fn plausible(&self, order: &[usize]) -> bool {
        let (fit, frames, k) = (&self.fit, self.frames, self.k);
        fit.beyond_share(frames, order, k) <= BEYOND_SHARE
            && (SHORT_LENGTH..=LONG_LENGTH).contains(&fit.length(frames, order, k))
    }

    /// A permutation that explains the delays, within the positions' reach, better than
    /// one microphone elsewhere would: the order finding.
    fn fix(
        &self,
        judged: Option<&orders::Judged>,
        direct: &[scan::Frame],
        without: &[Fit],
    ) -> Option<Finding> {
        let (fit, used, k, rate, expect) = (&self.fit, &self.used, self.k, self.rate, &self.expect);
        match judged {
            Some(orders::Judged {
                verdict:
                    OrderVerdict::Better {
                        orders,
                        best,
                        own: base,
                        rivals,
                    },
                ..
            }) if self.plausible(&orders[0])
                && beats_one_moved(
                    fit,
                    without,
                    direct,
                    &orders[0],
                    used,
                    k,
                    *best < BETTER_SHARE * *base,
                ) =>
            {
                // A known direction picks among the fix's images, as it does among the file's.
                let settled =
                    match (orders.len() > 1).then(|| settle(fit, direct, orders, k, expect)) {
                        Some(Settled::Own) => vec![orders[0].clone()],
                        Some(Settled::Other(o)) => vec![o],
                        _ => orders.clone(),
                    };
                Some(order_finding(
                    &settled[0],
                    &settled,
                    rivals,
                    used,
                    *base / best.max(1e-9),
                    best / rate * 1e6,
                    base / rate * 1e6,
                ))
            }
            _ => None,
        }
    }

    /// The positions' scale, when no order explains the delays: `beyond` (too long) or
    /// `unit` (too short). A wrong unit scales every order's delays alike and cannot make
    /// another order explain them better than the file's: when one does, beyond doubt,
    /// the lengths are not blamed on a unit.
    fn scale(&self, judged: Option<&orders::Judged>, beyond: f64, length: f64) -> Option<Finding> {
        let beaten = matches!(judged, Some(orders::Judged { verdict: OrderVerdict::Open { t, .. }, .. }) if *t <= -EVIDENCE_NEEDED)
            || matches!(
                judged,
                Some(orders::Judged {
                    verdict: OrderVerdict::Better { .. },
                    ..
                })
            );
        if beaten {
            None
        } else if beyond > BEYOND_SHARE || length > LONG_LENGTH {
            Some(finding(
                "beyond",
                format!(
                    "the delays are about {:.1} times longer than the positions allow ({:.0}% of them beyond the microphones' spacing), and no channel order explains them: positions too small (they must be in metres), or the wrong sample rate or speed of sound",
                    length,
                    100.0 * beyond
                ),
            ))
        } else if length < SHORT_LENGTH {
            let advice = units::advice(self.aperture)
                .map(|a| format!("; {a}"))
                .unwrap_or_default();
            Some(finding(
                "unit",
                format!(
                    "the delays are about {:.0} times shorter than the positions imply: positions too large (they must be in metres){advice}",
                    1.0 / length.max(1e-9)
                ),
            ))
        } else {
            None
        }
    }

    /// What the order's verdict says when no order was offered and the scale is not
    /// blamed: a moved microphone, a misfit, an open question, or the symmetry.
    fn verdict(
        &self,
        judged: &orders::Judged,
        spoken: &[scan::Frame],
        without: &[Fit],
    ) -> Vec<Finding> {
        let (fit, frames, used, k, rate) = (&self.fit, self.frames, &self.used, self.k, self.rate);
        let (positions, speed) = (&self.positions, self.speed);
        let mut findings = Vec::new();
        let moved = moved_twice(fit, without, spoken, used, k, rate);
        let informative = judged.own < RANDOM_SHARE * judged.random;
        match &judged.verdict {
            _ if judged.frames.len() < orders::MIN_FRAMES => {
                findings.push(finding(
                    "unclear",
                    format!(
                        "{}: too few sounds from afar to check the channel order (a room's reverberation, or sources too near the array, blur the rest); record sharp sounds such as hand claps from several directions, a metre or more away",
                        found_clear(frames.len(), judged.frames.len())
                    ),
                ));
            }
            _ if !informative && matches!(judged.verdict, OrderVerdict::Better { .. }) => {
                findings.push(finding(
                    "unclear",
                    format!(
                        "{}: no channel order explains the delays of the clearest frames better than another ({:.0} us with the file's order, {:.0} us typically): the sound is not clear enough to check the geometry; record sharp sounds (hand claps) from several directions around the array",
                        found_clear(frames.len(), judged.frames.len()),
                        judged.own / rate * 1e6,
                        judged.random / rate * 1e6
                    ),
                ));
            }
            OrderVerdict::Better { .. } if moved.is_some() => {
                findings.extend(moved.clone());
            }
            OrderVerdict::Better { orders, .. } if self.plausible(&orders[0]) => {
                // Better, but not beyond one microphone elsewhere: named, not offered.
                findings.push(Finding {
                    kind: "misfit".into(),
                    message: format!(
                        "the delays do not fit the geometry: with the file's channel order the far-field fit errs by {:.0} us; {} explains them better, but not beyond what one microphone elsewhere than the geometry says would (each channel left out in turn, the sounds of one direction weighed as one); check the positions, or record sounds from more directions",
                        judged.own / rate * 1e6,
                        describe_change(&orders[0], used, positions, speed)
                    ),
                    order: None,
                    orders: Some(orders.clone()),
                });
            }
            OrderVerdict::Better { .. } => {
                // The better order still needs other positions.
                findings.push(finding(
                    "misfit",
                    format!(
                        "the delays do not fit the geometry: with the file's channel order the far-field fit errs by {:.0} us, and no channel order brings the delays within the positions' reach; check the positions and their unit",
                        judged.own / rate * 1e6
                    ),
                ));
            }
            // A moved microphone breaks the array's symmetry and leaves orders open
            // that are images of the true one: named first.
            OrderVerdict::Open { .. } if moved.is_some() => {
                findings.extend(moved.clone());
            }
            OrderVerdict::Open {
                rival,
                t,
                needed_frames,
                rivals,
            } if *t <= -EVIDENCE_NEEDED => {
                // Another order explains the delays better, beyond doubt, yet neither
                // explains them well: the positions are wrong, not (only) the order.
                findings.push(Finding {
                    kind: "misfit".into(),
                    message: format!(
                        "the delays fit the geometry with no channel order: {} explains them better than the file's order ({:.1} nats of evidence), but no order explains them as well as a far source and true positions would; a microphone is elsewhere than the geometry says, or a position is wrong (with {} orders alike)",
                        describe_change(rival, used, positions, speed),
                        -t,
                        rivals.len()
                    ),
                    order: None,
                    orders: Some(rivals.clone()),
                });
            }
            OrderVerdict::Open {
                rival,
                t,
                needed_frames,
                rivals,
            } => {
                let what = describe_change(rival, used, positions, speed);
                let more = match needed_frames {
                    Some(n) if *n > frames.len() => format!(
                        "; about {n} clear frames (sharp sounds such as hand claps, from several directions) would likely tell them apart"
                    ),
                    _ => "; more clear sounds, from other directions, are needed to tell them apart".into(),
                };
                findings.push(Finding {
                    kind: "unclear".into(),
                    message: format!(
                        "{}: the delays cannot yet tell the file's order from {} orders that differ from it, the nearest {} ({} = {}; evidence {:.1} nats, {EVIDENCE_NEEDED:.1} needed){more}",
                        found_clear(frames.len(), judged.frames.len()),
                        rivals.len(),
                        what,
                        "order",
                        numbered(rival),
                        t
                    ),
                    order: None,
                    orders: Some(rivals.clone()),
                });
            }
            OrderVerdict::Fits { images, weakest_t } => {
                findings.extend(self.fits(judged, images, *weakest_t, moved, spoken));
            }
        }
        findings
    }

    /// When the file's order fits as well as its images: a misfit if even it leaves
    /// more than a far source does, a moved microphone, or the image a known sound
    /// settles on (`order`) or cannot settle (`symmetric`).
    fn fits(
        &self,
        judged: &orders::Judged,
        images: &[Vec<usize>],
        weakest_t: f64,
        moved: Option<Finding>,
        spoken: &[scan::Frame],
    ) -> Vec<Finding> {
        let (fit, used, k, rate) = (&self.fit, &self.used, self.k, self.rate);
        let (positions, speed, expect) = (&self.positions, self.speed, &self.expect);
        let mut findings = Vec::new();
        if judged.own > orders::explained_within(rate, fit.longest()) {
            findings.push(finding(
                "misfit",
                format!(
                    "the delays do not fit the geometry: with the file's channel order, the best there is, the far-field fit errs by {:.0} us on the direct sounds, more than a far source leaves ({:.0} us; a random order: {:.0} us); check the positions and their unit",
                    judged.own / rate * 1e6,
                    orders::explained_within(rate, fit.longest()) / rate * 1e6,
                    judged.random / rate * 1e6
                ),
            ));
        } else if let Some(f) = moved {
            findings.push(f);
        } else if images.len() > 1 {
            match settle(fit, spoken, images, k, expect) {
                Settled::Own => {}
                Settled::Other(order) => {
                    findings.push(Finding {
                        kind: "order".into(),
                        message: format!(
                            "the sound from the expected direction is heard elsewhere with the file's order; order {} (a {} of the array) puts it there: {}",
                            numbered(&order),
                            image_kind(&order, used, positions),
                            describe_change(&order, used, positions, speed)
                        ),
                        order: Some(order.clone()),
                        orders: Some(vec![order]),
                    });
                }
                Settled::Not(why) => findings.push(Finding {
                    kind: "symmetric".into(),
                    message: format!(
                        "the delays fit the file's channel order ({}), but also {} other order(s) that are mirror images or rotations of this array, which delays can never tell apart: {}{why}; give --expect AZ/EL for a sound in the recording from a known direction to settle it",
                        if weakest_t.is_finite() {
                            format!("every other order told apart by at least {weakest_t:.1} nats of evidence")
                        } else {
                            "every order of these microphones is one of them".to_string()
                        },
                        images.len() - 1,
                        images[1..]
                            .iter()
                            .take(6)
                            .map(|o| numbered(o))
                            .collect::<Vec<_>>()
                            .join(", ")
                            + if images.len() > 7 { ", ..." } else { "" },
                    ),
                    order: None,
                    orders: Some(images.to_vec()),
                }),
            }
        }
        findings
    }
}

/// An order as the list of each microphone's channel: "[0, 2, 1]".
fn numbered(order: &[usize]) -> String {
    let list: Vec<String> = order.iter().map(|c| c.to_string()).collect();
    format!("[{}]", list.join(", "))
}

fn factorial(n: usize) -> usize {
    (1..=n).product()
}

/// "found N clear frames", with what a check needs.
fn found_clear(n: usize, explained: usize) -> String {
    format!(
        "{n} clear frame(s) found, {explained} of them direct sounds that a far source explains (at least {} needed, from several directions)",
        orders::MIN_FRAMES
    )
}

/// What distinguishes `order` from `used`: the microphones that change channel, and
/// for a swap of two, how far apart they are and the most a delay changes.
fn describe_change(
    order: &[usize],
    used: &[usize],
    positions: &[nalgebra::Vector3<f64>],
    speed: f64,
) -> String {
    let changed: Vec<usize> = (0..used.len()).filter(|&i| order[i] != used[i]).collect();
    if changed.len() == 2 {
        let (a, b) = (changed[0], changed[1]);
        let d = (positions[a] - positions[b]).norm();
        format!(
            "channels {} and {} swapped (mics {} and {}, {:.1} cm apart: delays change by up to {:.0} us)",
            used[a],
            used[b],
            a + 1,
            b + 1,
            100.0 * d,
            2.0 * d / speed * 1e6
        )
    } else {
        let moves: Vec<String> = changed
            .iter()
            .map(|&i| format!("mic {} on channel {}", i + 1, order[i]))
            .collect();
        format!(
            "{} mics on other channels ({})",
            changed.len(),
            moves.join(", ")
        )
    }
}

/// Whether `order` is a rotation or a mirror image of `used` on this array.
fn image_kind(
    order: &[usize],
    used: &[usize],
    positions: &[nalgebra::Vector3<f64>],
) -> &'static str {
    // The map taking each mic to the one whose channel it now has.
    let m = used.len();
    let s: Vec<usize> = (0..m)
        .map(|i| used.iter().position(|&c| c == order[i]).unwrap_or(i))
        .collect();
    let centre = positions.iter().sum::<nalgebra::Vector3<f64>>() / m as f64;
    let v: Vec<_> = positions.iter().map(|p| p - centre).collect();
    // Least squares of the map over the positions, then the sign of its determinant.
    let mut a = nalgebra::Matrix3::zeros();
    for i in 0..m {
        a += v[s[i]] * v[i].transpose();
    }
    let svd = a.svd(true, true);
    match (svd.u, svd.v_t) {
        (Some(u), Some(vt)) if (u * vt).determinant() < 0.0 => "mirror image",
        _ => "rotation",
    }
}

/// What a sound from a known direction says of orders that are images of each other.
enum Settled {
    /// The file's order hears it there.
    Own,
    /// Another image does.
    Other(Vec<usize>),
    /// Nothing settles it (the reason, for the message; empty without `--expect`).
    Not(String),
}

/// The image among `images` (the file's first) whose direct sounds (`frames`) come
/// nearest each of `expect`: within [`EXPECT_DEG`], and [`EXPECT_MARGIN_DEG`] nearer than under any other.
fn settle(
    fit: &Fit,
    frames: &[scan::Frame],
    images: &[Vec<usize>],
    k: usize,
    expect: &[(nalgebra::Vector3<f64>, Option<f64>)],
) -> Settled {
    if expect.is_empty() {
        return Settled::Not(String::new());
    }
    // Per image, how near its nearest direct sound (in each expected sound's time, when
    // given) comes to each expected direction; the farthest of them counts.
    let near: Vec<f64> = images
        .iter()
        .map(|o| {
            expect
                .iter()
                .map(|(u, at)| {
                    frames
                        .iter()
                        .filter(|f| {
                            at.is_none_or(|t| {
                                (t - EXPECT_BEFORE_S..=t + EXPECT_AFTER_S).contains(&f.start_s)
                            })
                        })
                        .map(|f| fit.distance_to(f, o, k, u))
                        .fold(f64::INFINITY, f64::min)
                })
                .fold(0.0, f64::max)
        })
        .collect();
    let mut ranked: Vec<usize> = (0..images.len()).collect();
    ranked.sort_by(|&a, &b| near[a].total_cmp(&near[b]).then(a.cmp(&b)));
    let (best, next) = (ranked[0], ranked.get(1).copied().unwrap_or(ranked[0]));
    let chord = |deg: f64| 2.0 * (deg.to_radians() / 2.0).sin();
    let deg = |c: f64| 2.0 * (c / 2.0).min(1.0).asin().to_degrees();
    if near[best].is_nan() || near[best] >= chord(EXPECT_DEG) {
        return Settled::Not(format!(
            " (--expect: under none of them is there a direct sound within {EXPECT_DEG:.0} deg of each expected direction (in its time, when given); the nearest comes {:.0} deg away)",
            deg(near[best])
        ));
    }
    // The next image must put its nearest sound EXPECT_MARGIN_DEG farther: else the
    // direction lies on (or near) a mirror of the array.
    if deg(near[next]) < deg(near[best]) + EXPECT_MARGIN_DEG {
        return Settled::Not(format!(
            " (--expect: two of them put a sound near the expected direction, {:.1} and {:.1} deg away: it lies on or near a mirror of the array, which cannot settle it; give a sound from a direction off the array's mirrors)",
            deg(near[best]),
            deg(near[next])
        ));
    }
    if best == 0 {
        Settled::Own
    } else {
        Settled::Other(images[best].clone())
    }
}

/// The order finding for `order` (and the images of it in `orders`), with the changes
/// from `used`, the residuals (us) and ready-to-paste `[[mic]]` tables.
#[allow(clippy::too_many_arguments)]
fn order_finding(
    order: &[usize],
    orders: &[Vec<usize>],
    rivals: &[Vec<usize>],
    used: &[usize],
    ratio: f64,
    best_us: f64,
    own_us: f64,
) -> Finding {
    let changed: Vec<usize> = (0..used.len()).filter(|&i| order[i] != used[i]).collect();
    let what = if changed.len() == 2 {
        let (a, b) = (used[changed[0]], used[changed[1]]);
        format!("channels {} and {} look swapped", a.min(b), a.max(b))
    } else {
        format!("{} microphones look to be on other channels", changed.len())
    };
    let moves: Vec<String> = changed
        .iter()
        .map(|&i| format!("mic {} on channel {}", i + 1, order[i]))
        .collect();
    let alike = if orders.len() > 1 {
        format!(
            "; {} other order(s), images of it under the array's symmetry, fit as well (see `orders`): this one changes the fewest channels",
            orders.len() - 1
        )
    } else {
        String::new()
    };
    let near = if rivals.is_empty() {
        String::new()
    } else {
        format!(
            "; {} other order(s) are not told apart from it by this recording (see `orders`)",
            rivals.len()
        )
    };
    let mut all = orders.to_vec();
    all.extend(rivals.iter().cloned());
    Finding {
        kind: "order".into(),
        message: format!(
            "{what}: {} fits {:.1} times better (residual {:.0} us against {:.0} us){alike}{near}; give each [[mic]] its `channel`",
            moves.join(", "),
            ratio,
            best_us,
            own_us
        ),
        order: Some(order.to_vec()),
        orders: Some(all),
    }
}

/// What the fit measured (nothing when the delays were not checked).
#[derive(Default)]
struct Fitted {
    residual_us: Option<f64>,
    beyond_share: Option<f64>,
    length: Option<f64>,
    order_checked: bool,
    symmetries: usize,
}

#[allow(clippy::too_many_arguments)]
fn report(
    file: String,
    sample_rate: u32,
    channels: usize,
    scan: &scan::Scan,
    levels: Vec<Option<f64>>,
    fitted: Fitted,
    findings: Vec<Finding>,
    remarks: Vec<Finding>,
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
        symmetries: fitted.symmetries.max(1),
        fits: findings.is_empty(),
        findings,
        remarks,
    }
}

/// Whether `order` explains the direct sounds better than the file's order `used` with
/// any one channel left out of both: a swap survives this (no one channel left out
/// mends the file's order), a microphone elsewhere than the geometry says does not
/// (leaving its channel out mends the file's order, while a permutation only bends the
/// others to it). Both sides of each comparison hear the same channels, so that what
/// one channel's noise or echoes add is not taken for evidence; and the frames of one
/// direction (within [`SAME_DIRECTION`]) weigh as one frame, since an error of the
/// positions or of the capsules errs alike for every sound from there. Weighed as
/// [`orders::judge`] weighs orders, [`EVIDENCE_NEEDED`] nats and the odds of
/// [`near_orders`] more. Below 5 microphones one left out leaves too few pairs to
/// weigh: a permutation must then halve the file's residual (`halved`).
fn beats_one_moved(
    fit: &Fit,
    without: &[Fit],
    frames: &[scan::Frame],
    order: &[usize],
    used: &[usize],
    k: usize,
    halved: bool,
) -> bool {
    let m = used.len();
    if m < 5 {
        return halved;
    }
    let mut buf = Vec::new();
    let groups = directions(fit, frames, &[used, order], k);
    let mut left_out = |o: &[usize], channel: usize| -> Vec<f64> {
        let skip = o.iter().position(|&c| c == channel).unwrap_or(0);
        let rest: Vec<usize> = (0..m).filter(|&i| i != skip).map(|i| o[i]).collect();
        without[skip].residuals(frames, &rest, k, &mut buf)
    };
    let pairs = (m - 1) * (m - 2) / 2;
    let needed = EVIDENCE_NEEDED + near_orders(m, orders::changes(order, used)).ln();
    used.iter().all(|&channel| {
        let (mine, theirs) = (left_out(used, channel), left_out(order, channel));
        let sigma = orders::sigma(&theirs);
        let mut by_group = vec![0.0; groups.iter().max().map_or(0, |g| g + 1)];
        for ((x, y), &g) in mine.iter().zip(&theirs).zip(&groups) {
            // A residual beyond OUTLIER_SIGMAS is an echo's or a stray peak's: as
            // unlikely under either order, it weighs nothing.
            let cap = OUTLIER_SIGMAS * sigma;
            by_group[g] += orders::frame_evidence(x.min(cap), y.min(cap), sigma, pairs);
        }
        let t: f64 = by_group
            .iter()
            .map(|e| e.clamp(-orders::FRAME_EVIDENCE, orders::FRAME_EVIDENCE))
            .sum();
        t >= needed
    })
}

/// A frame's residual beyond this many noise sigmas is an outlier's (an echo, a stray
/// peak): it weighs no more than one this far off.
pub(crate) const OUTLIER_SIGMAS: f64 = 3.0;

/// Frames whose directions are within this chord of each other (on the unit sphere,
/// or of the array's span for a plane or a line; 0.35 is 20 degrees) are of one
/// direction.
pub(crate) const SAME_DIRECTION: f64 = 0.35;

/// Each frame's direction group: frames within [`SAME_DIRECTION`] of a group's first
/// frame under each of `orders` join it, in frame order (a wrong order bends
/// directions together; the right one among `orders` keeps them apart).
fn directions(fit: &Fit, frames: &[scan::Frame], orders: &[&[usize]], k: usize) -> Vec<usize> {
    let mut buf = Vec::new();
    let mut seeds: Vec<Vec<nalgebra::Vector3<f64>>> = Vec::new();
    frames
        .iter()
        .map(|f| {
            let ws: Vec<nalgebra::Vector3<f64>> = orders
                .iter()
                .map(|o| {
                    fit.lags(f, o, k, &mut buf);
                    let w = fit.solve(&buf).0;
                    // A plane's or a line's array sees the projection on its span.
                    if w.norm() > 1.0 {
                        w.normalize()
                    } else {
                        w
                    }
                })
                .collect();
            seeds
                .iter()
                .position(|s| {
                    s.iter()
                        .zip(&ws)
                        .all(|(a, b)| (a - b).norm() < SAME_DIRECTION)
                })
                .unwrap_or_else(|| {
                    seeds.push(ws);
                    seeds.len() - 1
                })
        })
        .collect()
}

/// How many orders of `m` channels differ from one in at most `c` places: the orders a
/// fix changing `c` channels was chosen among. Naming one needs that many times the
/// odds (a prior that spreads a mistake's chance over them alike), so that the best of
/// many orders that fit a wrong geometry by chance is not taken for a wiring mistake.
fn near_orders(m: usize, c: usize) -> f64 {
    // Derangements: d(0) = 1, d(1) = 0, d(j) = (j - 1) (d(j - 1) + d(j - 2)).
    let mut d = vec![1.0f64, 0.0];
    for j in 2..=c.max(1) {
        d.push((j - 1) as f64 * (d[j - 1] + d[j - 2]));
    }
    let choose = |j: usize| (0..j).fold(1.0, |a, i| a * (m - i) as f64 / (i + 1) as f64);
    (0..=c.min(m)).map(|j| choose(j) * d[j]).sum()
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

/// A microphone that does not fit its position in two looks: [`moved_mic`] on the
/// clearest frames taken alternately into two halves must name the same one (a
/// directional capsule's weak channel, or a few odd frames, do not show twice); the
/// finding is then the one of all the frames.
fn moved_twice(
    fit: &Fit,
    without: &[Fit],
    frames: &[scan::Frame],
    used: &[usize],
    k: usize,
    rate: f64,
) -> Option<Finding> {
    let mut buf = Vec::new();
    let mut look = |frames: &[scan::Frame]| {
        let base = fit.score(frames, used, k, &mut buf);
        moved_mic(without, frames, used, k, base, rate)
    };
    let halves: [Vec<scan::Frame>; 2] =
        [0, 1].map(|h| frames.iter().skip(h).step_by(2).cloned().collect());
    match (look(&halves[0]), look(&halves[1])) {
        (Some((a, _)), Some((b, _))) if a == b => look(frames).map(|(_, f)| f),
        _ => None,
    }
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
) -> Option<(usize, Finding)> {
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
        let f = finding(
            "moved",
            format!(
                "mic {} (channel {}) does not fit its position, in both halves of the clear frames: without it the others fit {:.1} times better (residual {:.0} us against {:.0} us); it moved, or its position in the geometry is wrong",
                worst + 1,
                used[worst],
                base / lowest.max(1e-9),
                lowest / rate * 1e6,
                base / rate * 1e6
            ),
        );
        (worst, f)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The count of orders within `c` changes, against every order of up to 7 counted.
    #[test]
    fn near_orders_counts_what_a_brute_force_counts() {
        for m in 1..=7 {
            let base: Vec<usize> = (0..m).collect();
            let mut by_changes = vec![0usize; m + 1];
            fit::orderings(&base, m, |o| by_changes[orders::changes(o, &base)] += 1);
            for c in 0..=m {
                let want: usize = by_changes[..=c].iter().sum();
                assert_eq!(near_orders(m, c), want as f64, "m {m} c {c}");
            }
        }
    }
}
