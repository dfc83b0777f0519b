//! Each channel on its own and against the others: dead, clipping, duplicated, a gain
//! mismatch (a remark) and an inverted polarity.

use super::scan::{Frame, Scan};
use super::{finding, Finding, CLIPPED_SHARE, DEAD_DB, GAIN_DB, INVERTED_SHARE};
use crate::geometry::Geometry;
use crate::method::pairs::pair_index;

/// "channel C (mic M)": channels 0-based, as the geometry's `channel` key; microphones
/// as `ssl geometry` lists them.
pub(super) fn mics_on(geometry: &Geometry, c: usize) -> String {
    match geometry.mics.iter().position(|x| x.channel == c) {
        Some(i) => format!("channel {c} (mic {})", i + 1),
        None => format!("channel {c}"),
    }
}

/// What the levels and the whole recording's correlations say of the channels `used`
/// (`levels` in dBFS, `None` when constant): the findings, the remarks, and the dead
/// channels (constant, silent, or [`DEAD_DB`] under the median channel).
pub(super) fn levels(
    geometry: &Geometry,
    scan: &Scan,
    levels: &[Option<f64>],
    used: &[usize],
) -> (Vec<Finding>, Vec<Finding>, Vec<usize>) {
    let k = scan.channels.len();
    let samples = scan.samples.max(1) as f64;
    let (mut findings, mut remarks) = (Vec::new(), Vec::new());
    let median_level = {
        let mut l: Vec<f64> = used.iter().filter_map(|&c| levels[c]).collect();
        l.sort_by(f64::total_cmp);
        l.get(l.len() / 2).copied().unwrap_or(-100.0)
    };
    let dead: Vec<usize> = used
        .iter()
        .copied()
        .filter(|&c| levels[c].is_none_or(|l| l < -100.0 || l < median_level - DEAD_DB))
        .collect();
    for &c in &dead {
        let why = match levels[c] {
            Some(l) if l >= -100.0 => format!(
                "{:.0} dB under the median channel: only noise, no microphone",
                median_level - l
            ),
            _ => "constant or silent".into(),
        };
        findings.push(finding(
            "dead",
            format!("{} is dead ({why})", mics_on(geometry, c)),
        ));
    }
    for &c in used {
        let share = scan.channels[c].clipped as f64 / samples;
        if share > CLIPPED_SHARE {
            findings.push(finding(
                "clipped",
                format!(
                    "{} clips: {:.2}% of its samples are at full scale (lower the gain)",
                    mics_on(geometry, c),
                    100.0 * share
                ),
            ));
        }
    }
    for (a, &i) in used.iter().enumerate() {
        for &j in &used[a + 1..] {
            let (lo, hi) = (i.min(j), i.max(j));
            let (ei, ej) = (scan.channels[lo].energy, scan.channels[hi].energy);
            let rho = scan.cross[pair_index(lo, hi, k)] / (ei * ej).sqrt();
            if ei > 0.0 && ej > 0.0 && rho > 0.9995 {
                findings.push(finding(
                    "duplicated",
                    format!(
                        "{} and {} carry the same signal (duplicated channel)",
                        mics_on(geometry, lo),
                        mics_on(geometry, hi)
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
                remarks.push(finding(
                    "gain",
                    format!(
                        "{} is {:.1} dB {} than the median channel: a gain mismatch, or a directional capsule facing away from the sound (not a fault in itself)",
                        mics_on(geometry, c),
                        (l - median).abs(),
                        if l > median { "louder" } else { "quieter" }
                    ),
                ));
            }
        }
    }
    (findings, remarks, dead)
}

/// The live channels whose pairs' peaks on the clear `frames` are mostly negative: their
/// polarity is inverted.
pub(super) fn inverted(
    geometry: &Geometry,
    frames: &[Frame],
    used: &[usize],
    dead: &[usize],
    k: usize,
) -> Vec<Finding> {
    let mut findings = Vec::new();
    for &c in used.iter().filter(|c| !dead.contains(c)) {
        let (mut negative, mut all) = (0usize, 0usize);
        for f in frames {
            for &o in used.iter().filter(|&&o| o != c && !dead.contains(&o)) {
                let v = f.near_peaks[pair_index(c.min(o), c.max(o), k)];
                if v.abs() > 0.1 {
                    negative += usize::from(v < 0.0);
                    all += 1;
                }
            }
        }
        if all > 0 && negative as f64 / all as f64 > INVERTED_SHARE {
            findings.push(finding(
                "inverted",
                format!("{} is polarity-inverted: its correlation with the others peaks negative (swap its wires or negate it)", mics_on(geometry, c)),
            ));
        }
    }
    findings
}
