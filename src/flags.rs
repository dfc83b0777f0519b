//! The command line's value parsers for numbers and named choices (feature `cli`): each
//! checks one kind of value and says what is wrong with it. The configuration's sections
//! name them in their flags; parsers tied to one parameter's range sit beside it.

use crate::Named;
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};

/// A finite number.
pub(crate) fn parse_f64(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("`{s}` is not a number"))?;
    if !v.is_finite() {
        return Err(format!("`{s}` is not a finite number"));
    }
    Ok(v)
}

/// A number from 0 to 1.
pub(crate) fn unit_interval(s: &str) -> Result<f64, String> {
    let v = parse_f64(s)?;
    if !(0.0..=1.0).contains(&v) {
        return Err(format!("{v} is outside 0..=1"));
    }
    Ok(v)
}

/// A number of 0 or more, in single precision.
#[cfg(feature = "cli")]
pub(crate) fn non_negative(s: &str) -> Result<f32, String> {
    non_negative_f64(s).map(|v| v as f32)
}

/// A number of 0 or more.
pub(crate) fn non_negative_f64(s: &str) -> Result<f64, String> {
    let v = parse_f64(s)?;
    if v < 0.0 {
        return Err(format!("{v} is negative"));
    }
    Ok(v)
}

/// A number over 0.
pub(crate) fn positive(s: &str) -> Result<f64, String> {
    let v = parse_f64(s)?;
    if v <= 0.0 {
        return Err(format!("{v} is not positive"));
    }
    Ok(v)
}

/// A number over 0 and at most `max`; `why` follows `max` in the error.
pub(crate) fn positive_at_most(s: &str, max: f64, why: &str) -> Result<f64, String> {
    let v = positive(s)?;
    if v > max {
        return Err(format!("{v} is over {max}{why}"));
    }
    Ok(v)
}

/// A share of the threshold: over 0, at most 1.
pub(crate) fn share(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s} is not a number"))?;
    if !(v > 0.0 && v <= 1.0) {
        return Err(format!("{v} is not over 0 and at most 1"));
    }
    Ok(v)
}

/// A parser for one of the library's named choices, listing each with its help.
pub(crate) fn choice<T: Named + Send + Sync>() -> impl TypedValueParser<Value = T> {
    let values = T::ALL
        .iter()
        .map(|&(_, name, help)| PossibleValue::new(name).help(help));
    PossibleValuesParser::new(values).map(|s| T::from_name(&s).expect("a possible value"))
}

/// A whole number within `range`, as `usize`.
pub(crate) fn count(
    range: std::ops::RangeInclusive<usize>,
) -> impl TypedValueParser<Value = usize> {
    clap::value_parser!(u64)
        .range(*range.start() as u64..=*range.end() as u64)
        .map(|v| v as usize)
}

/// A default value as the help shows it (the command is built once per run, so the few
/// bytes this keeps are kept once).
pub(crate) fn default_shown(v: f64) -> &'static str {
    Box::leak(v.to_string().into_boxed_str())
}
