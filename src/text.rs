//! Text in and out, below every other module: reading a text input (a geometry, a scene,
//! a result) with a size limit, an I/O error's reason in a few words, and a number
//! rounded as it is written.

use std::io;

/// Reads a text file of at most `limit` bytes. A longer file (or an endless one, such
/// as `/dev/zero`) is an error of kind `FileTooLarge` after `limit` bytes, not an
/// attempt to read it whole.
pub(crate) fn read_text(path: &std::path::Path, limit: u64) -> io::Result<String> {
    read_text_from(std::fs::File::open(path)?, limit)
}

/// Reads text of at most `limit` bytes from `reader` (see [`read_text`]).
pub(crate) fn read_text_from(reader: impl io::Read, limit: u64) -> io::Result<String> {
    let mut text = String::new();
    io::Read::read_to_string(&mut io::Read::take(reader, limit + 1), &mut text)?;
    if text.len() as u64 > limit {
        return Err(io::Error::new(
            io::ErrorKind::FileTooLarge,
            format!("longer than {limit} bytes"),
        ));
    }
    Ok(text)
}

/// An I/O error as a short lower-case reason without the "(os error N)" suffix.
pub(crate) fn io_reason(e: &io::Error) -> String {
    match e.kind() {
        io::ErrorKind::NotFound => "no such file".into(),
        io::ErrorKind::PermissionDenied => "permission denied".into(),
        _ => {
            let s = e.to_string();
            match s.find(" (os error") {
                Some(i) => s[..i].to_string(),
                None => s,
            }
        }
    }
}

/// A number as a message shows it: as Rust writes it between 1e-4 and 1e9 (`0.35`,
/// `48000`), in exponent form outside (`1e300`, `1e-300`), never hundreds of digits.
#[derive(Debug, Clone, Copy)]
pub struct BriefNumber(pub f64);

impl std::fmt::Display for BriefNumber {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let v = self.0;
        if !v.is_finite() || v == 0.0 || (1e-4..1e9).contains(&v.abs()) {
            write!(f, "{v}")
        } else {
            write!(f, "{v:e}")
        }
    }
}

/// Three numbers as a message shows them: `[1, 2, 1e300]`.
pub(crate) fn shown3(v: &[f64; 3]) -> String {
    format!(
        "[{}, {}, {}]",
        BriefNumber(v[0]),
        BriefNumber(v[1]),
        BriefNumber(v[2])
    )
}

/// `v` rounded to `decimals` places, with -0 written as 0.
pub(crate) fn fixed(v: f64, decimals: i32) -> f64 {
    let f = 10f64.powi(decimals);
    (v * f).round() / f + 0.0
}

/// Exactly `N` numbers from a TOML array, for `#[serde(deserialize_with)]`: serde's own
/// arrays take the first `N` of a longer one and drop the rest without a word
/// (`position = [0.1, 0, 0, 1000]` was read as `[0.1, 0, 0]`).
pub(crate) fn numbers<'de, D, const N: usize>(d: D) -> Result<[f64; N], D::Error>
where
    D: serde::Deserializer<'de>,
{
    exactly(serde::Deserialize::deserialize(d)?)
}

/// [`numbers`] of an optional key (with `#[serde(default)]`).
pub(crate) fn numbers_opt<'de, D, const N: usize>(d: D) -> Result<Option<[f64; N]>, D::Error>
where
    D: serde::Deserializer<'de>,
{
    let v: Option<Vec<f64>> = serde::Deserialize::deserialize(d)?;
    v.map(exactly).transpose()
}

/// An optional list of [`numbers`] (with `#[serde(default)]`): `[[0.1, 0.5], [1.0, 2.0]]`.
#[cfg(feature = "simulate")]
pub(crate) fn numbers_list_opt<'de, D, const N: usize>(
    d: D,
) -> Result<Option<Vec<[f64; N]>>, D::Error>
where
    D: serde::Deserializer<'de>,
{
    let v: Option<Vec<Vec<f64>>> = serde::Deserialize::deserialize(d)?;
    v.map(|list| list.into_iter().map(exactly).collect())
        .transpose()
}

fn exactly<E: serde::de::Error, const N: usize>(v: Vec<f64>) -> Result<[f64; N], E> {
    let len = v.len();
    v.try_into()
        .map_err(|_| E::invalid_length(len, &format!("an array of {N} numbers").as_str()))
}
