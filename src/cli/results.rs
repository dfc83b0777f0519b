//! Results as `ssl evaluate` and `ssl plot` take them: files, `-` (one result or the
//! concatenation of several), or folders such as `ssl analyze --out-dir` writes,
//! searched recursively for `*.csv`, `*.json` and `*.ndjson` in name order (not the
//! batch summaries `batch.json` and `batch.K-of-N.json`, not the stamps in `.ssl/`).

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
            walk(path, path, &mut found)
                .with_context(|| format!("{}: cannot read the folder", path.display()))?;
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

fn is_result(relative: &Path) -> bool {
    let ext = relative
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let name = relative
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or_default();
    let summary = relative.parent() == Some(Path::new(""))
        && name.starts_with("batch")
        && name.ends_with(".json");
    matches!(ext.as_deref(), Some("csv" | "json" | "ndjson")) && !summary
}

fn walk(root: &Path, dir: &Path, out: &mut Vec<PathBuf>) -> std::io::Result<()> {
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        let path = entry.path();
        let hidden = entry.file_name().to_string_lossy().starts_with('.');
        if entry.file_type()?.is_dir() {
            if !hidden {
                walk(root, &path, out)?;
            }
        } else if !hidden
            && path.is_file()
            && is_result(path.strip_prefix(root).expect("under the root"))
        {
            out.push(path);
        }
    }
    Ok(())
}
