//! The value parsers of the command line's arguments ([`super::args`]): each checks
//! one kind of number or choice and says what is wrong with it.

use crate::track::evidence::CANDIDATES_PER_HOUR;
use crate::track::{MAX_DELAY_S, MAX_SMOOTH_S};
use crate::Named;
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};

pub(super) fn parse_f64(s: &str) -> std::result::Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("`{s}` is not a number"))?;
    if !v.is_finite() {
        return Err(format!("`{s}` is not a finite number"));
    }
    Ok(v)
}

pub(super) fn unit_interval(s: &str) -> std::result::Result<f32, String> {
    let v = parse_f64(s)?;
    if !(0.0..=1.0).contains(&v) {
        return Err(format!("{v} is outside 0..=1"));
    }
    Ok(v as f32)
}

pub(super) fn non_negative(s: &str) -> std::result::Result<f32, String> {
    let v = parse_f64(s)?;
    if v < 0.0 {
        return Err(format!("{v} is negative"));
    }
    Ok(v as f32)
}

pub(super) fn non_negative_f64(s: &str) -> std::result::Result<f64, String> {
    let v = parse_f64(s)?;
    if v < 0.0 {
        return Err(format!("{v} is negative"));
    }
    Ok(v)
}

pub(super) fn positive(s: &str) -> std::result::Result<f64, String> {
    let v = parse_f64(s)?;
    if v <= 0.0 {
        return Err(format!("{v} is not positive"));
    }
    Ok(v)
}

/// A band of frequencies `LOW-HIGH` in Hz (`--band 300-3400`; a `k` suffix is kHz:
/// `2k-8k`).
pub(super) fn band(s: &str) -> std::result::Result<(f64, f64), String> {
    let Some((low, high)) = s.split_once('-') else {
        return Err(format!("`{s}` is not LOW-HIGH in Hz (like 300-3400)"));
    };
    let hz = |t: &str| match t.trim().strip_suffix(['k', 'K']) {
        Some(k) => parse_f64(k).map(|v| v * 1000.0),
        None => parse_f64(t.trim()),
    };
    let (low, high) = (hz(low)?, hz(high)?);
    if low < 0.0 || high <= low {
        return Err(format!(
            "{low}-{high} Hz is not a band: LOW must be 0 or more and under HIGH"
        ));
    }
    Ok((low, high))
}

/// A speed of sound in m/s, within the range every input accepts.
pub(super) fn speed_of_sound(s: &str) -> std::result::Result<f64, String> {
    let v = parse_f64(s)?;
    if !crate::geometry::speed_of_sound_ok(v) {
        let (low, high) = crate::geometry::SPEED_OF_SOUND_RANGE;
        return Err(format!(
            "{v:e} m/s is not a speed of sound from {low} to {high} m/s"
        ));
    }
    Ok(v)
}

/// A tracker's window or delay: positive, at most [`MAX_DELAY_S`] (rows wait that long
/// in memory).
pub(super) fn tracker_seconds(s: &str) -> std::result::Result<f64, String> {
    positive_at_most(s, MAX_DELAY_S, " s (rows wait that long in memory)")
}

/// A positive number at most `max`; `why` follows `max` in the error.
fn positive_at_most(s: &str, max: f64, why: &str) -> std::result::Result<f64, String> {
    let v = positive(s)?;
    if v > max {
        return Err(format!("{v} is over {max}{why}"));
    }
    Ok(v)
}

/// The false sources an hour (`--false-per-hour`): over 0, at most the candidates an
/// hour ([`CANDIDATES_PER_HOUR`]).
pub(super) fn false_per_hour(s: &str) -> std::result::Result<f64, String> {
    positive_at_most(
        s,
        CANDIDATES_PER_HOUR,
        ", the candidates an hour it is a share of",
    )
}

/// The smoothing window (`--smooth-s`): 0 to [`MAX_SMOOTH_S`].
pub(super) fn smoothing_seconds(s: &str) -> std::result::Result<f64, String> {
    let v = non_negative_f64(s)?;
    if v > MAX_SMOOTH_S {
        return Err(format!("{v} is over {MAX_SMOOTH_S} s"));
    }
    Ok(v)
}

/// A share of the threshold: over 0, at most 1.
pub(super) fn candidate_share(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s} is not a number"))?;
    if !(v > 0.0 && v <= 1.0) {
        return Err(format!("{v} is not over 0 and at most 1"));
    }
    Ok(v)
}

/// A parser for one of the library's named choices, listing each with its help.
pub(super) fn choice<T: Named + Send + Sync>() -> impl TypedValueParser<Value = T> {
    let values = T::ALL
        .iter()
        .map(|&(_, name, help)| PossibleValue::new(name).help(help));
    PossibleValuesParser::new(values).map(|s| T::from_name(&s).expect("a possible value"))
}

/// One share of a batch split over several runs (`--shard K/N`): the K-th of N, K
/// counted from 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shard {
    /// Which share, 1 to `count`.
    pub index: usize,
    /// How many shares.
    pub count: usize,
}

pub(super) fn shard(s: &str) -> std::result::Result<Shard, String> {
    let bad = || format!("`{s}` is not K/N with 1 <= K <= N (the K-th of N shares)");
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let (index, count): (usize, usize) = (
        k.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if index == 0 || index > count {
        return Err(bad());
    }
    Ok(Shard { index, count })
}

/// A sound from a known direction, `AZ/EL` in degrees with an optional `@T` start in
/// seconds (`--expect 30/10`, `--expect -120/-20@3.5`): azimuth within -360..360,
/// elevation within -90..90.
pub(super) fn expected(s: &str) -> std::result::Result<crate::check::Expected, String> {
    let bad = || {
        format!("`{s}` is not AZ/EL in degrees with an optional @T in seconds (e.g. 30/10, or -120/-20@3.5 for a sound that starts 3.5 s in)")
    };
    let (dir, at) = match s.split_once('@') {
        Some((d, t)) => (d, Some(t)),
        None => (s, None),
    };
    let (a, e) = dir.split_once('/').ok_or_else(bad)?;
    let (az, el): (f64, f64) = (
        a.trim().parse().map_err(|_| bad())?,
        e.trim().parse().map_err(|_| bad())?,
    );
    if !(-360.0..=360.0).contains(&az) || !(-90.0..=90.0).contains(&el) {
        return Err(bad());
    }
    let at_s = match at {
        Some(t) => {
            let t: f64 = t.trim().parse().map_err(|_| bad())?;
            if !t.is_finite() || t < 0.0 {
                return Err(bad());
            }
            Some(t)
        }
        None => None,
    };
    Ok(crate::check::Expected {
        azimuth_deg: az,
        elevation_deg: el,
        at_s,
    })
}
