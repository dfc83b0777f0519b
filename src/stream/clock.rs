//! Wall-clock times from a Broadcast WAV `bext` chunk (EBU Tech 3285): its origination
//! date and its time reference, the first sample's count of samples since midnight, so
//! that rows line up with other sensors recorded on the same clock (`--clock`).

use chrono::{NaiveDate, NaiveDateTime, TimeDelta};

/// Bytes of a `bext` chunk up to and including its time reference (description 256,
/// originator 32, its reference 32, date 10, time 8, time reference 8).
pub(super) const BEXT_TIME_END: usize = 346;

/// What a `bext` chunk says of when its first sample was recorded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TimeReference {
    /// `OriginationDate`, when it holds a date.
    pub date: Option<NaiveDate>,
    /// `TimeReference`: samples from midnight to the first sample.
    pub samples: u64,
}

impl TimeReference {
    /// The time reference of a `bext` chunk's body, if it is long enough to hold one.
    pub(super) fn from_bext(body: &[u8]) -> Option<Self> {
        if body.len() < BEXT_TIME_END {
            return None;
        }
        // "yyyy-mm-dd", with any separator (EBU 3285 allows '-', '_', ':', ' ', '.').
        let date = &body[320..330];
        let number = |r: std::ops::Range<usize>| -> Option<u32> {
            std::str::from_utf8(&date[r]).ok()?.parse().ok()
        };
        let date = match (number(0..4), number(5..7), number(8..10)) {
            (Some(y), Some(m), Some(d)) => NaiveDate::from_ymd_opt(y as i32, m, d),
            _ => None,
        };
        let low = u32::from_le_bytes(body[338..342].try_into().expect("4 bytes"));
        let high = u32::from_le_bytes(body[342..346].try_into().expect("4 bytes"));
        Some(TimeReference {
            date,
            samples: (high as u64) << 32 | low as u64,
        })
    }
}

impl TimeReference {
    /// Whether the first sample is within a year of its date's midnight at `rate` Hz:
    /// a recorder that runs past midnight counts on from the day it started, but a
    /// reference of 2^64 - 1 samples (millions of years) is no time at all.
    pub fn within_a_year(&self, rate: u32) -> bool {
        (self.samples as u128) < 366 * 86_400 * rate.max(1) as u128
    }
}

/// When a recording's first sample was taken, on the recorder's clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClockOrigin {
    /// The first sample's date and time (to the microsecond).
    start: NaiveDateTime,
}

impl ClockOrigin {
    /// The origin a time reference gives at `rate` Hz, when it has a date and its
    /// samples from midnight are within a year.
    pub fn new(reference: &TimeReference, rate: u32) -> Option<Self> {
        if !reference.within_a_year(rate) {
            return None;
        }
        let midnight = reference.date?.and_hms_opt(0, 0, 0)?;
        let micros = (reference.samples as u128 * 1_000_000 / rate.max(1) as u128) as i64;
        Some(ClockOrigin {
            start: midnight.checked_add_signed(TimeDelta::microseconds(micros))?,
        })
    }

    /// The wall-clock time `time_s` seconds after the first sample, in ISO 8601 to the
    /// microsecond (`2026-05-04T14:03:05.250000`), without a time zone: the recorder's.
    pub fn at(&self, time_s: f64) -> String {
        let micros = (time_s * 1e6).round() as i64;
        let t = self
            .start
            .checked_add_signed(TimeDelta::microseconds(micros))
            .unwrap_or(self.start);
        t.format("%Y-%m-%dT%H:%M:%S%.6f").to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bext(date: &str, samples: u64) -> Vec<u8> {
        let mut body = vec![0u8; 602];
        body[320..330].copy_from_slice(date.as_bytes());
        body[330..338].copy_from_slice(b"10:00:00");
        body[338..342].copy_from_slice(&(samples as u32).to_le_bytes());
        body[342..346].copy_from_slice(&((samples >> 32) as u32).to_le_bytes());
        body
    }

    #[test]
    fn the_time_reference_counts_samples_from_midnight() {
        // 14:03:05.25 at 48 kHz: 50585.25 s after midnight.
        let r = TimeReference::from_bext(&bext("2026-05-04", 2_428_092_000)).unwrap();
        let origin = ClockOrigin::new(&r, 48000).unwrap();
        assert_eq!(origin.at(0.0), "2026-05-04T14:03:05.250000");
        assert_eq!(origin.at(1.5), "2026-05-04T14:03:06.750000");
        // Past midnight, the date turns (a 64-bit reference: 30 h at 192 kHz).
        let r = TimeReference::from_bext(&bext("2026:12:31", 30 * 3600 * 192_000)).unwrap();
        let origin = ClockOrigin::new(&r, 192_000).unwrap();
        assert_eq!(origin.at(0.000_001), "2027-01-01T06:00:00.000001");
        // No date: no origin.
        let r = TimeReference::from_bext(&bext("          ", 48000)).unwrap();
        assert_eq!(r.date, None);
        assert!(ClockOrigin::new(&r, 48000).is_none());
        assert!(TimeReference::from_bext(&[0u8; 300]).is_none());
    }
}
