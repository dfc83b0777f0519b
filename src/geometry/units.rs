//! Positions in the wrong unit: a geometry file's positions are metres, and a file
//! written in centimetres or millimetres describes an array 100 or 1000 times too wide.
//! Nothing in the numbers is wrong in itself, so the only sign is an implausible size;
//! this says which unit the numbers likely are in and by what to divide them.

use crate::text::{fixed, BriefNumber};

/// The apertures (metres) of the arrays people build: from a 1 cm cluster of MEMS
/// microphones to a 2 m frame.
pub const TYPICAL_APERTURE_M: (f64, f64) = (0.01, 2.0);
/// Wider than this (metres), an array is unusual enough to say so: the positions may be
/// centimetres (a 3 cm array in centimetres is 3 "m" wide).
pub const WIDE_APERTURE_M: f64 = 1.5;

/// A length in metres as a message shows it, in plain numbers: `4.243 m`, `4.2 cm`,
/// `3.5 mm`.
pub fn shown_length(m: f64) -> String {
    if m >= 1.0 {
        format!("{} m", BriefNumber(fixed(m, 3)))
    } else if m >= 0.01 {
        format!("{} cm", BriefNumber(fixed(m * 100.0, 1)))
    } else {
        format!("{} mm", BriefNumber(fixed(m * 1000.0, 2)))
    }
}

/// The units in which positions spanning `aperture` (as metres) would describe an array
/// of a typical size, the likelier first (nearer 10 cm, the commonest size): each with
/// its divisor. Empty when none would.
pub fn likely_units(aperture: f64) -> Vec<(&'static str, f64)> {
    let mut units: Vec<(&'static str, f64)> = [("centimetres", 100.0), ("millimetres", 1000.0)]
        .into_iter()
        .filter(|(_, f)| {
            let a = aperture / f;
            a >= TYPICAL_APERTURE_M.0 && a <= TYPICAL_APERTURE_M.1
        })
        .collect();
    let off = |f: f64| (aperture / f / 0.1).ln().abs();
    units.sort_by(|a, b| off(a.1).total_cmp(&off(b.1)));
    units
}

/// What to tell a user whose positions span `aperture` (as metres): `"they look like
/// centimetres (divide them by 100: the array is then 4.2 cm across)"`, with a second
/// unit when both fit; `None` when no unit gives a typical array.
pub fn advice(aperture: f64) -> Option<String> {
    let units = likely_units(aperture);
    if units.is_empty() {
        return None;
    }
    let each: Vec<String> = units
        .iter()
        .map(|(name, f)| {
            format!(
                "{name} (divide them by {f}: the array is then {} across)",
                shown_length(aperture / f)
            )
        })
        .collect();
    Some(format!("they look like {}", each.join(" or ")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_centimetre_array_is_advised_as_centimetres_and_a_millimetre_one_as_millimetres() {
        // A 3 cm square written in centimetres: 4.24 "m" across.
        let a = 3.0 * 2f64.sqrt();
        assert_eq!(likely_units(a)[0].0, "centimetres");
        let text = advice(a).unwrap();
        assert!(
            text.contains("divide them by 100: the array is then 4.2 cm across"),
            "{text}"
        );
        // A 64 cm array in millimetres: 640 "m"; in centimetres it would be 6.4 m.
        assert_eq!(likely_units(640.0), vec![("millimetres", 1000.0)]);
        // A 40 cm array in centimetres (40 "m") or a 4 cm one in millimetres: both named,
        // the one nearer 10 cm first.
        let both = likely_units(40.0);
        assert_eq!(both.len(), 2);
        // Nothing plausible: no advice.
        assert!(advice(1e9).is_none());
    }

    #[test]
    fn lengths_are_plain_numbers() {
        assert_eq!(shown_length(6.463), "6.463 m");
        assert_eq!(shown_length(0.0424), "4.2 cm");
        assert_eq!(shown_length(0.0035), "3.5 mm");
        assert_eq!(shown_length(1.2e6), "1200000 m");
    }
}
