//! Keyword arguments to a [`Config`], through the flags' own clap definitions: the
//! keyword `false_per_hour=1000` is parsed as `--false-per-hour=1000` is by `ssl
//! analyze`, with the same checks and messages, so the set of options, their values and
//! their defaults are never a second list.

use clap::{ArgAction, Args, Command, FromArgMatches};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyList, PyTuple};
use ssl::Config;

/// The configuration's flags as a command (no binary name, no help flag).
fn command() -> Command {
    Config::augment_args(
        Command::new("ssloc")
            .no_binary_name(true)
            .disable_help_flag(true)
            .disable_version_flag(true),
    )
}

/// A keyword's flag: `false_per_hour` is `--false-per-hour`.
fn flag_of(keyword: &str) -> String {
    keyword.replace('_', "-")
}

/// A flag's keyword.
fn keyword_of(flag: &str) -> String {
    flag.replace('-', "_")
}

/// The presets by name, as the flags that make them.
pub const PRESETS: [(&str, &[&str]); 4] = [
    ("default", &[]),
    ("paper", &["--paper"]),
    ("untracked", &["--no-track"]),
    ("every_frame", &["--every-frame"]),
];

/// The configuration `preset` and `options` (keyword -> value) ask for.
pub fn config(preset: Option<&str>, options: Option<&Bound<'_, PyDict>>) -> PyResult<Config> {
    let mut argv: Vec<String> = Vec::new();
    if let Some(name) = preset {
        let Some((_, flags)) = PRESETS.iter().find(|(n, _)| *n == name) else {
            let names: Vec<&str> = PRESETS.iter().map(|(n, _)| *n).collect();
            return Err(PyValueError::new_err(format!(
                "preset `{name}` is not one of {}",
                names.join(", ")
            )));
        };
        argv.extend(flags.iter().map(|f| f.to_string()));
    }
    let command = command();
    if let Some(options) = options {
        for (key, value) in options.iter() {
            let key: String = key.extract()?;
            argv.extend(arguments(&command, &key, &value)?);
        }
    }
    let matches = command
        .try_get_matches_from(&argv)
        .map_err(|e| PyValueError::new_err(clap_message(&e)))?;
    Config::from_arg_matches(&matches).map_err(|e| PyValueError::new_err(clap_message(&e)))
}

/// The command line arguments of `key=value`.
fn arguments(command: &Command, key: &str, value: &Bound<'_, PyAny>) -> PyResult<Vec<String>> {
    let long = flag_of(key);
    let Some(arg) = command
        .get_arguments()
        .find(|a| a.get_long() == Some(long.as_str()))
    else {
        // Not a flag: clap says so, with the nearest flag as its tip.
        return Ok(vec![format!("--{long}")]);
    };
    if value.is_none() {
        return Ok(Vec::new());
    }
    let switch = matches!(arg.get_action(), ArgAction::SetTrue | ArgAction::SetFalse);
    if switch {
        let Ok(on) = value.cast::<PyBool>() else {
            return Err(PyValueError::new_err(format!(
                "{key}: True or False, not `{}`",
                value.repr()?
            )));
        };
        return Ok(match on.is_true() {
            true => vec![format!("--{long}")],
            false => Vec::new(),
        });
    }
    let values: Vec<Bound<'_, PyAny>> =
        if value.is_instance_of::<PyList>() || value.is_instance_of::<PyTuple>() {
            value.try_iter()?.collect::<PyResult<_>>()?
        } else {
            vec![value.clone()]
        };
    values
        .iter()
        .map(|v| Ok(format!("--{long}={}", text(v)?)))
        .collect()
}

/// A value as the command line writes it: `True`/`False` as `on`/`off`, numbers and
/// strings as Python prints them.
fn text(value: &Bound<'_, PyAny>) -> PyResult<String> {
    if let Ok(b) = value.cast::<PyBool>() {
        return Ok(if b.is_true() { "on" } else { "off" }.into());
    }
    Ok(value.str()?.to_string())
}

/// clap's message in one line (with its possible values or its tip), the flags
/// written as keywords.
fn clap_message(e: &clap::Error) -> String {
    let text = e.render().to_string();
    let mut lines = text.lines().map(str::trim).filter(|l| !l.is_empty());
    let first = lines
        .next()
        .unwrap_or("invalid options")
        .trim_start_matches("error: ");
    let more: Vec<&str> = lines
        .filter(|l| l.starts_with("[possible values") || l.starts_with("tip:"))
        .collect();
    let line = std::iter::once(first)
        .chain(more)
        .collect::<Vec<_>>()
        .join(" ");
    as_keywords(&line)
}

/// `'--false-per-hour <F>'` -> `'false_per_hour'`.
fn as_keywords(line: &str) -> String {
    let mut out = String::new();
    let mut rest = line;
    while let Some(i) = rest.find("'--") {
        out += &rest[..i + 1];
        let after = &rest[i + 3..];
        let end = after
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
            .unwrap_or(after.len());
        out += &keyword_of(&after[..end]);
        let close = after[end..].find('\'').map_or(after.len(), |j| end + j);
        rest = &after[close..];
    }
    out + rest
}

/// One option, as `options()` describes it to Python.
pub struct OptionInfo {
    pub keyword: String,
    pub flag: String,
    pub help: String,
    pub section: String,
    /// A switch (`True`/`False`), else a value.
    pub switch: bool,
    pub value_name: Option<String>,
    pub choices: Vec<String>,
    pub default: Option<String>,
    pub repeatable: bool,
}

/// Every option, in the order `ssl analyze --help` gives them.
pub fn infos() -> Vec<OptionInfo> {
    command()
        .get_arguments()
        .filter_map(|a| {
            let long = a.get_long()?;
            let switch = matches!(a.get_action(), ArgAction::SetTrue | ArgAction::SetFalse);
            Some(OptionInfo {
                keyword: keyword_of(long),
                flag: format!("--{long}"),
                help: a
                    .get_long_help()
                    .or(a.get_help())
                    .map(|h| h.to_string())
                    .unwrap_or_default(),
                section: a.get_help_heading().unwrap_or("Method").to_string(),
                switch,
                value_name: (!switch)
                    .then(|| a.get_value_names())
                    .flatten()
                    .and_then(|v| v.first())
                    .map(|v| v.to_string()),
                choices: (if switch {
                    Vec::new()
                } else {
                    a.get_possible_values()
                })
                .iter()
                .filter(|v| !v.is_hide_set())
                .map(|v| v.get_name().to_string())
                .collect(),
                default: (!switch)
                    .then(|| {
                        a.get_default_values()
                            .iter()
                            .map(|v| v.to_string_lossy().into_owned())
                            .collect::<Vec<_>>()
                            .join(",")
                    })
                    .filter(|d| !d.is_empty()),
                repeatable: matches!(a.get_action(), ArgAction::Append),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_in_messages_are_written_as_keywords() {
        assert_eq!(
            as_keywords("invalid value 'x' for '--false-per-hour <F>': no"),
            "invalid value 'x' for 'false_per_hour': no"
        );
        assert_eq!(
            as_keywords("the argument '--paper' cannot be used with '--min-score <SCORE>'"),
            "the argument 'paper' cannot be used with 'min_score'"
        );
    }

    #[test]
    fn every_flag_of_the_configuration_is_an_option() {
        let infos = infos();
        assert!(infos
            .iter()
            .any(|o| o.keyword == "false_per_hour" && !o.switch));
        assert!(infos.iter().any(|o| o.keyword == "paper" && o.switch));
        assert!(infos.iter().any(|o| o.keyword == "no_track" && o.switch));
        let keywords: std::collections::BTreeSet<_> = infos.iter().map(|o| &o.keyword).collect();
        assert_eq!(keywords.len(), infos.len(), "one keyword per flag");
    }
}
