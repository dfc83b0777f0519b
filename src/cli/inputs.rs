//! The inputs of `ssl analyze` (docs/interface.md, "Many files"): files as given, every
//! recording under a directory (searched recursively, in name order, matching `--glob`),
//! and the paths of `--files-from`; each with the path its result takes under
//! `--out-dir`.

use super::args::AnalyzeArgs;
use anyhow::{bail, Context, Result};
use globset::{GlobSet, GlobSetBuilder};
use std::path::{Component, Path, PathBuf};

/// The patterns a directory's files must match when `--glob` gives none.
pub const DEFAULT_GLOBS: [&str; 2] = ["*.wav", "*.flac"];

/// One recording to analyse.
#[derive(Debug, Clone, PartialEq)]
pub struct Input {
    /// The path to open (`-` for standard input).
    pub path: String,
    /// Where its result goes under `--out-dir`, before the extension is replaced: its
    /// path relative to the directory it was found in, or as a list gives it.
    pub relative: PathBuf,
}

/// Every input `args` names, in order.
pub fn expand(args: &AnalyzeArgs) -> Result<Vec<Input>> {
    let globs = globs(&args.glob)?;
    let mut inputs = Vec::new();
    let mut empty = Vec::new();
    for path in &args.files {
        if add(path, None, &globs, &mut inputs)? == 0 {
            empty.push(path.clone());
        }
    }
    if let Some(list) = &args.files_from {
        let text = if list == Path::new("-") {
            ssl::stream::read_text_from(std::io::stdin().lock(), 1 << 30).map_err(|e| {
                anyhow::anyhow!(
                    "<stdin>: cannot read the list: {}",
                    ssl::stream::io_reason(&e)
                )
            })?
        } else {
            ssl::stream::read_text(list, 1 << 30).map_err(|e| {
                anyhow::anyhow!(
                    "{}: cannot read the list: {}",
                    list.display(),
                    ssl::stream::io_reason(&e)
                )
            })?
        };
        for line in text.lines().map(str::trim_end).filter(|l| !l.is_empty()) {
            if add(line, Some(line), &globs, &mut inputs)? == 0 {
                empty.push(line.to_string());
            }
        }
    }
    let why = |dir: &str| {
        format!(
            "{dir}: a directory with no file matching {}",
            patterns(&args.glob)
        )
    };
    if inputs.is_empty() {
        bail!("{}: nothing to analyse", why(&empty.join(", ")));
    }
    for dir in &empty {
        super::warn(args.quiet, &why(dir));
    }
    Ok(inputs)
}

fn patterns(globs: &[String]) -> String {
    if globs.is_empty() {
        DEFAULT_GLOBS.join(", ")
    } else {
        globs.join(", ")
    }
}

fn globs(given: &[String]) -> Result<GlobSet> {
    let mut set = GlobSetBuilder::new();
    let defaults: Vec<String> = DEFAULT_GLOBS.iter().map(|g| g.to_string()).collect();
    for g in if given.is_empty() { &defaults } else { given } {
        // `*.wav` matches at any depth; the match ignores case (`.WAV` from recorders).
        let glob = globset::GlobBuilder::new(g)
            .case_insensitive(true)
            .literal_separator(false)
            .build()
            .with_context(|| format!("--glob {g}: not a pattern"))?;
        set.add(glob);
    }
    Ok(set.build()?)
}

/// Adds `path` (a file, or every matching file under a directory); `listed` is how a
/// list gave it. Returns how many inputs it added.
fn add(
    path: &str,
    listed: Option<&str>,
    globs: &GlobSet,
    inputs: &mut Vec<Input>,
) -> Result<usize> {
    let p = Path::new(path);
    if path != "-" && p.is_dir() {
        let mut found = Vec::new();
        walk(p, &mut found).with_context(|| format!("{path}: cannot read the directory"))?;
        found.sort();
        let before = inputs.len();
        for f in found {
            let relative = f
                .strip_prefix(p)
                .expect("under the directory")
                .to_path_buf();
            if globs.is_match(&relative) {
                inputs.push(Input {
                    path: f.to_string_lossy().into_owned(),
                    relative,
                });
            }
        }
        return Ok(inputs.len() - before);
    }
    let relative = match listed.map(Path::new) {
        Some(l)
            if l.is_relative()
                && l.components()
                    .all(|c| matches!(c, Component::Normal(_) | Component::CurDir)) =>
        {
            l.components()
                .filter(|c| matches!(c, Component::Normal(_)))
                .collect()
        }
        _ if path == "-" => PathBuf::from("stdin"),
        _ => PathBuf::from(p.file_name().unwrap_or(p.as_os_str())),
    };
    inputs.push(Input {
        path: path.to_string(),
        relative,
    });
    Ok(1)
}

/// Every regular file under `dir`, recursively: links to files are followed, links to
/// directories are not (a link to a parent would never end).
fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> std::io::Result<()> {
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        let path = entry.path();
        if entry.file_type()?.is_dir() {
            walk(&path, out)?;
        } else if path.is_file() {
            out.push(path);
        }
    }
    Ok(())
}
