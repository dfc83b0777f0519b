//! Where a command's output goes: standard output, or a file written atomically (a
//! temporary file beside it, renamed onto it when complete, so a failed run leaves the
//! old file or nothing), or a device or pipe given as `-o`, written in place.

use anyhow::{bail, Context, Result};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// An open destination.
pub enum Sink {
    /// Standard output.
    Stdout(io::Stdout),
    /// A temporary file and the path it is renamed onto by [`Sink::commit`].
    Atomic(tempfile::NamedTempFile, PathBuf),
    /// Something that is not a regular file (`/dev/null`, a named pipe, a terminal):
    /// renaming over it would replace it, so it is written in place.
    Direct(std::fs::File),
}

impl Sink {
    /// Standard output, or `path` (symlinks are followed, so a link stays a link).
    pub fn open(path: Option<&Path>) -> Result<Self> {
        let Some(path) = path else {
            return Ok(Sink::Stdout(io::stdout()));
        };
        let is_link = std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink());
        let target = if is_link {
            std::fs::canonicalize(path)
                .with_context(|| format!("{}: cannot follow the link", path.display()))?
        } else {
            path.to_path_buf()
        };
        match std::fs::metadata(&target) {
            Ok(m) if m.is_dir() => bail!("{}: is a directory", path.display()),
            Ok(m) if !m.is_file() => {
                let file = std::fs::OpenOptions::new()
                    .write(true)
                    .open(&target)
                    .with_context(|| format!("{}: cannot open for writing", path.display()))?;
                Ok(Sink::Direct(file))
            }
            _ => {
                let dir = match target.parent() {
                    Some(d) if !d.as_os_str().is_empty() => d,
                    _ => Path::new("."),
                };
                let tmp = tempfile::Builder::new()
                    .prefix(".ssl-")
                    .suffix(".tmp")
                    .tempfile_in(dir)
                    .with_context(|| {
                        format!("{}: cannot create the output file", path.display())
                    })?;
                Ok(Sink::Atomic(tmp, target))
            }
        }
    }

    /// Whether a person or program reads the output as it comes (standard output).
    pub fn is_live(&self) -> bool {
        matches!(self, Sink::Stdout(_))
    }

    /// Completes the output: renames a temporary file onto its target. `shown` is the
    /// name to report errors under.
    pub fn commit(self, shown: &Path) -> Result<()> {
        match self {
            Sink::Atomic(tmp, target) => {
                tmp.persist(&target).map_err(|e| e.error).with_context(|| {
                    format!("{}: cannot write the output file", shown.display())
                })?;
            }
            Sink::Stdout(mut out) => out.flush()?,
            Sink::Direct(mut file) => file.flush()?,
        }
        Ok(())
    }
}

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match self {
            Sink::Stdout(w) => w.write(buf),
            Sink::Atomic(w, _) => w.write(buf),
            Sink::Direct(w) => w.write(buf),
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        match self {
            Sink::Stdout(w) => w.flush(),
            Sink::Atomic(w, _) => w.flush(),
            Sink::Direct(w) => w.flush(),
        }
    }
}
