//! The value parsers of the arguments only the command line has ([`super::args`]): a
//! batch's share and an expected direction. The configuration's are `crate::flags` and
//! beside each section.

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
