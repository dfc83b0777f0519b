//! The inputs of `ssl analyze` (docs/interface.md, "Many files"): files as given, every
//! recording under a directory (searched recursively, in name order, matching `--glob`),
//! and the paths of `--files-from`; each with the path its result takes under
//! `--out-dir`.

use super::args::{AnalyzeArgs, WarningKind};
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
    /// Why it cannot be analysed, found before it is opened (a list line that is not a
    /// path): it fails with this message, and the others go on.
    pub refused: Option<String>,
}

/// Every input `args` names, in order.
pub fn expand(args: &AnalyzeArgs) -> Result<Vec<Input>> {
    let globs = globs(&args.glob)?;
    let mut inputs = Vec::new();
    let mut empty = Vec::new();
    for path in &args.files {
        if add(
            path,
            None,
            &globs,
            &mut inputs,
            !args.warns(WarningKind::Inputs),
        )? == 0
        {
            empty.push(path.clone());
        }
    }
    if let Some(list) = &args.files_from {
        let text = if list == Path::new("-") {
            crate::stream::read_text_from(std::io::stdin().lock(), 1 << 30).map_err(|e| {
                anyhow::anyhow!(
                    "<stdin>: cannot read the list: {}",
                    crate::stream::io_reason(&e)
                )
            })?
        } else {
            crate::stream::read_text(list, 1 << 30).map_err(|e| {
                anyhow::anyhow!(
                    "{}: cannot read the list: {}",
                    list.display(),
                    crate::stream::io_reason(&e)
                )
            })?
        };
        let shown = if list == Path::new("-") {
            "<stdin>".to_string()
        } else {
            list.display().to_string()
        };
        for (n, line) in text.lines().enumerate() {
            let line = line.trim_end();
            if line.is_empty() {
                continue;
            }
            if let Some(why) = not_a_path(line) {
                let path = escape(line);
                inputs.push(Input {
                    refused: Some(format!("{shown}:{}: {path}: {why}", n + 1)),
                    relative: PathBuf::from(&path),
                    path,
                });
                continue;
            }
            if add(
                line,
                Some(line),
                &globs,
                &mut inputs,
                !args.warns(WarningKind::Inputs),
            )? == 0
            {
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
        super::warn(!args.warns(WarningKind::Inputs), &why(dir));
    }
    Ok(inputs)
}

/// Why a list line is not a path to analyse: a control character (a NUL cannot be in
/// a path; the others are a corrupt list), or a name that ends in `..` or `/`.
fn not_a_path(line: &str) -> Option<&'static str> {
    if line.contains('\0') {
        return Some("a NUL byte in the line: not a path");
    }
    if line.chars().any(|c| c.is_control() && c != '\t') {
        return Some("a control character in the line: not a path");
    }
    let p = Path::new(line);
    if line.ends_with('/')
        || matches!(
            p.components().next_back(),
            Some(Component::ParentDir | Component::RootDir) | None
        )
    {
        return Some("names a folder (it ends in `..` or `/`), not a recording");
    }
    None
}

/// `text` with control characters written as escapes (`\0`, `\u{1b}`), for messages.
fn escape(text: &str) -> String {
    text.chars()
        .map(|c| {
            if c == '\0' {
                "\\0".to_string()
            } else if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
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
    quiet: bool,
) -> Result<usize> {
    let p = Path::new(path);
    if path != "-" && p.is_dir() {
        let mut found = Vec::new();
        let mut unreadable = Vec::new();
        std::fs::read_dir(p).with_context(|| format!("{path}: cannot read the directory"))?;
        walk(p, &mut found, &mut unreadable);
        for (folder, e) in unreadable {
            super::warn(
                quiet,
                &format!(
                    "{}: cannot read the folder ({}); its recordings are not analysed",
                    folder.display(),
                    crate::stream::io_reason(&e)
                ),
            );
        }
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
                    refused: None,
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
        _ => match p.file_name() {
            Some(name) => PathBuf::from(name),
            None => {
                // `..`, `/`: no name to give a result; never a path out of --out-dir.
                inputs.push(Input {
                    path: path.to_string(),
                    relative: PathBuf::from("."),
                    refused: Some(format!(
                        "{path}: names a folder (it ends in `..` or `/`), not a recording"
                    )),
                });
                return Ok(1);
            }
        },
    };
    inputs.push(Input {
        path: path.to_string(),
        relative,
        refused: None,
    });
    Ok(1)
}

/// Every regular file under `dir`, recursively: links to files are followed, links to
/// directories are not (a link to a parent would never end). A folder that cannot be
/// read (`lost+found`) goes to `unreadable`, and the rest is still searched.
fn walk(dir: &Path, out: &mut Vec<PathBuf>, unreadable: &mut Vec<(PathBuf, std::io::Error)>) {
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) => return unreadable.push((dir.to_path_buf(), e)),
    };
    for entry in entries {
        let entry = match entry {
            Ok(e) => e,
            Err(e) => return unreadable.push((dir.to_path_buf(), e)),
        };
        let path = entry.path();
        if entry.file_type().is_ok_and(|t| t.is_dir()) {
            walk(&path, out, unreadable);
        } else if path.is_file() {
            out.push(path);
        }
    }
}
