//! Where a command's output goes, written so that nothing is lost:
//!
//! - standard output (`-o -` or no `-o`), which must be open;
//! - a regular file, written to a temporary file beside it and renamed onto it when the
//!   run completes, so a failed or interrupted run leaves the old file, or nothing;
//! - a device or pipe given as `-o` (`/dev/null`, a FIFO), written in place.
//!
//! An output that is one of the command's inputs is refused before anything is written.
//! A new file gets the user's umask; a replaced file keeps its mode, and a read-only
//! file is not replaced. Temporary files are removed when the process is interrupted
//! (SIGINT, SIGTERM, SIGHUP).

use anyhow::{bail, Context, Result};
use ssl::stream::io_reason;
use std::fs::{File, Permissions};
use std::io::{self, Write};
use std::os::fd::AsFd;
use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Temporary files to remove if the process is interrupted.
static TEMPORARIES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Removes the temporary files on SIGINT, SIGTERM and SIGHUP, then exits with 130.
pub fn remove_temporaries_on_interrupt() {
    // Only fails when a handler is already set, which this binary never does twice.
    let _ = ctrlc::set_handler(|| {
        if let Ok(paths) = TEMPORARIES.lock() {
            for p in paths.iter() {
                let _ = std::fs::remove_file(p);
            }
        }
        eprintln!("ssl: interrupted");
        std::process::exit(130);
    });
}

/// A temporary file beside its target, registered for removal on interrupt; removed
/// when dropped unless renamed onto the target.
struct Temporary(Option<tempfile::NamedTempFile>);

impl Temporary {
    fn new(target: &Path, mode: Option<u32>) -> io::Result<Self> {
        let dir = match target.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        let mut registry = TEMPORARIES.lock().expect("not poisoned");
        let tmp = tempfile::Builder::new()
            .prefix(".ssl-")
            .suffix(".tmp")
            // A new file: read and write for all, less the umask (as any program's).
            .permissions(Permissions::from_mode(0o666))
            .tempfile_in(dir)?;
        if let Some(mode) = mode {
            // A replaced file keeps its mode (which the umask must not narrow).
            std::fs::set_permissions(tmp.path(), Permissions::from_mode(mode))?;
        }
        registry.push(tmp.path().to_path_buf());
        Ok(Temporary(Some(tmp)))
    }

    fn file(&mut self) -> &mut tempfile::NamedTempFile {
        self.0.as_mut().expect("present until persisted")
    }

    fn path(&self) -> &Path {
        self.0.as_ref().expect("present until persisted").path()
    }

    /// Renames the file onto `target`.
    fn persist(mut self, target: &Path) -> io::Result<()> {
        let tmp = self.0.take().expect("present until persisted");
        let path = tmp.path().to_path_buf();
        let result = tmp.persist(target).map(|_| ()).map_err(|e| e.error);
        unregister(&path);
        result
    }
}

impl Drop for Temporary {
    fn drop(&mut self) {
        if let Some(tmp) = self.0.take() {
            let path = tmp.path().to_path_buf();
            drop(tmp);
            unregister(&path);
        }
    }
}

fn unregister(path: &Path) {
    if let Ok(mut paths) = TEMPORARIES.lock() {
        paths.retain(|p| p != path);
    }
}

/// An open destination.
pub struct Sink {
    kind: Kind,
    /// The name to report errors under (`standard output`, or the path as given).
    shown: String,
}

enum Kind {
    Stdout(File),
    Atomic(Temporary, PathBuf),
    Direct(File),
}

impl Sink {
    /// Standard output (`None` or `-`), or `path`, which must not be one of `inputs`
    /// (compared as files, not as spellings; symlinks are followed, so a link stays a
    /// link).
    pub fn open(path: Option<&Path>, inputs: &[&Path]) -> Result<Self> {
        let Some(path) = path.filter(|p| *p != Path::new("-")) else {
            if stdout_was_closed() {
                bail!("cannot write to standard output: it is closed (>&-); redirect it to a file or use -o");
            }
            let file = io::stdout().as_fd().try_clone_to_owned().map_err(|e| {
                anyhow::anyhow!("cannot write to standard output: {}", io_reason(&e))
            })?;
            return Ok(Sink {
                kind: Kind::Stdout(File::from(file)),
                shown: "standard output".into(),
            });
        };
        let shown = path.display().to_string();
        if let Some(input) = inputs.iter().find(|i| same_file(path, i)) {
            bail!(
                "{shown}: the output is the input {}; choose another output file",
                input.display()
            );
        }
        let target = if std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) {
            std::fs::canonicalize(path)
                .with_context(|| format!("{shown}: cannot follow the link"))?
        } else {
            path.to_path_buf()
        };
        let kind = match std::fs::metadata(&target) {
            Ok(m) if m.is_dir() => bail!("{shown}: is a directory"),
            Ok(m) if !m.is_file() => Kind::Direct(
                std::fs::OpenOptions::new()
                    .write(true)
                    .open(&target)
                    .map_err(|e| anyhow::anyhow!("cannot write {shown}: {}", io_reason(&e)))?,
            ),
            Ok(m) if m.permissions().readonly() => {
                bail!("{shown}: is read-only; it is not replaced (make it writable, or choose another output file)")
            }
            existing => {
                let mode = existing.ok().map(|m| m.permissions().mode() & 0o7777);
                let tmp = Temporary::new(&target, mode)
                    .map_err(|e| anyhow::anyhow!("cannot write {shown}: {}", io_reason(&e)))?;
                Kind::Atomic(tmp, target)
            }
        };
        Ok(Sink { kind, shown })
    }

    /// Whether a person or program reads the output as it comes (standard output).
    pub fn is_live(&self) -> bool {
        matches!(self.kind, Kind::Stdout(_))
    }

    /// The name errors are reported under.
    pub fn shown(&self) -> &str {
        &self.shown
    }

    /// The temporary file a writer that needs a path (and seeks) writes to; `None` for
    /// standard output, devices and pipes.
    pub fn temporary_path(&self) -> Option<&Path> {
        match &self.kind {
            Kind::Atomic(tmp, _) => Some(tmp.path()),
            _ => None,
        }
    }

    /// An error writing to this output, as one line naming it.
    pub fn write_error(&self, e: &io::Error) -> anyhow::Error {
        anyhow::anyhow!("cannot write {}: {}", self.shown, io_reason(e))
    }

    /// Completes the output: flushes it, and renames a temporary file onto its target.
    pub fn commit(mut self) -> Result<()> {
        self.flush().map_err(|e| self.write_error(&e))?;
        if let Kind::Atomic(tmp, target) = self.kind {
            tmp.persist(&target)
                .map_err(|e| anyhow::anyhow!("cannot write {}: {}", self.shown, io_reason(&e)))?;
        }
        Ok(())
    }

    /// Completes two outputs together: both are replaced, or neither (when the second
    /// cannot be renamed into place, the first target gets its old contents back).
    pub fn commit_both(mut self, mut second: Sink) -> Result<()> {
        self.flush().map_err(|e| self.write_error(&e))?;
        second.flush().map_err(|e| second.write_error(&e))?;
        let Kind::Atomic(tmp, target) = self.kind else {
            return second.commit();
        };
        // Keep the first target's old contents until the second is in place.
        let backup = match std::fs::metadata(&target) {
            Ok(_) => {
                let backup = Temporary::new(&target, None)?;
                std::fs::rename(&target, backup.path()).map_err(|e| {
                    anyhow::anyhow!("cannot write {}: {}", self.shown, io_reason(&e))
                })?;
                Some(backup)
            }
            Err(_) => None,
        };
        let restore = |backup: Option<Temporary>| match backup {
            Some(b) => {
                let _ = b.persist(&target);
            }
            None => {
                let _ = std::fs::remove_file(&target);
            }
        };
        if let Err(e) = tmp.persist(&target) {
            restore(backup);
            bail!("cannot write {}: {}", self.shown, io_reason(&e));
        }
        if let Err(e) = second.commit() {
            restore(backup);
            return Err(e);
        }
        Ok(())
    }
}

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match &mut self.kind {
            Kind::Stdout(w) => w.write(buf),
            Kind::Atomic(w, _) => w.file().write(buf),
            Kind::Direct(w) => w.write(buf),
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        match &mut self.kind {
            Kind::Stdout(w) => w.flush(),
            Kind::Atomic(w, _) => w.file().flush(),
            Kind::Direct(w) => w.flush(),
        }
    }
}

/// Whether the process started with standard output closed (`>&-`). The Rust runtime
/// then opens `/dev/null` read-write in its place before `main`, so that writes vanish
/// without an error; a shell's `> /dev/null` opens it write-only. Linux only (it reads
/// /proc); elsewhere `false`.
fn stdout_was_closed() -> bool {
    let is_null = std::fs::read_link("/proc/self/fd/1").is_ok_and(|p| p == Path::new("/dev/null"));
    let read_write = std::fs::read_to_string("/proc/self/fdinfo/1").is_ok_and(|info| {
        info.lines()
            .find_map(|l| l.strip_prefix("flags:"))
            .and_then(|f| u32::from_str_radix(f.trim(), 8).ok())
            .is_some_and(|flags| flags & 0o3 == 0o2)
    });
    is_null && read_write
}

/// Whether `a` and `b` name the same existing file (device and inode, links followed).
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
        _ => false,
    }
}
