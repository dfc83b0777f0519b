//! Results as `ssl evaluate` and `ssl plot` take them: files, `-` (one result or the
//! concatenation of several), or folders such as `ssl analyze --out-dir` writes,
//! searched recursively for `*.csv`, `*.json` and `*.ndjson` in name order. Not taken:
//! the batch summaries (`batch.json` and `batch.K-of-N.json` at the top, told by their
//! contents, so that the result of a recording `batch2.wav` is read), the truths
//! `ssl simulate` writes beside recordings (`*.truth.json`, `*.truth.csv`: a results
//! folder may be the archive itself), the rows of failed runs (`*.partial.*`), and
//! hidden files and folders (the stamps in `.ssl/`). A subfolder that cannot be read
//! is named in a warning, and the rest is read.

use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

/// One result file, and the path under the folder it was found in (`None`: given by
/// itself).
#[derive(Debug, Clone)]
pub struct ResultFile {
    pub path: PathBuf,
    pub relative: Option<PathBuf>,
}

/// Every result `paths` names, in order; a folder with none is an error.
pub fn expand(paths: &[PathBuf]) -> Result<Vec<ResultFile>> {
    let mut out = Vec::new();
    for path in paths {
        if path != Path::new("-") && path.is_dir() {
            let mut found = Vec::new();
            std::fs::read_dir(path)
                .with_context(|| format!("{}: cannot read the folder", path.display()))?;
            walk(path, path, &mut found);
            found.sort();
            if found.is_empty() {
                anyhow::bail!(
                    "{}: a folder with no result (*.csv, *.json, *.ndjson)",
                    path.display()
                );
            }
            out.extend(found.into_iter().map(|f| ResultFile {
                relative: Some(f.strip_prefix(path).expect("under it").to_path_buf()),
                path: f,
            }));
        } else {
            out.push(ResultFile {
                path: path.clone(),
                relative: None,
            });
        }
    }
    Ok(out)
}

fn is_result(root: &Path, relative: &Path) -> bool {
    let ext = relative
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let name = relative
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or_default()
        .to_ascii_lowercase();
    if !matches!(ext.as_deref(), Some("csv" | "json" | "ndjson")) {
        return false;
    }
    let stem = Path::new(&name).file_stem().map(Path::new);
    let second = stem.and_then(|s| s.extension()).and_then(|e| e.to_str());
    if matches!(second, Some("truth" | "partial")) {
        return false;
    }
    !(super::batch::is_summary_name(relative) && is_summary(&root.join(relative)))
}

/// Whether the JSON file at `path` is a batch summary (an object with `done`,
/// `skipped`, `failed` and `files`), not a result.
fn is_summary(path: &Path) -> bool {
    let Ok(text) = crate::stream::read_text(path, 64 << 20) else {
        return false;
    };
    serde_json::from_str::<serde_json::Value>(&text).is_ok_and(|v| {
        ["done", "skipped", "failed", "files"]
            .iter()
            .all(|k| v.get(k).is_some())
            && v.get("detections").is_none()
    })
}

fn walk(root: &Path, dir: &Path, out: &mut Vec<PathBuf>) {
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) => return unreadable(dir, &e),
    };
    for entry in entries {
        let entry = match entry {
            Ok(e) => e,
            Err(e) => return unreadable(dir, &e),
        };
        let path = entry.path();
        let hidden = entry.file_name().to_string_lossy().starts_with('.');
        if entry.file_type().is_ok_and(|t| t.is_dir()) {
            if !hidden {
                walk(root, &path, out);
            }
        } else if !hidden
            && path.is_file()
            && is_result(root, path.strip_prefix(root).expect("under the root"))
        {
            out.push(path);
        }
    }
}

fn unreadable(dir: &Path, e: &std::io::Error) {
    super::warn(
        false,
        &format!(
            "{}: cannot read the folder ({}); its results are not read",
            dir.display(),
            crate::stream::io_reason(e)
        ),
    );
}
