//! Where a command's output goes, written so that nothing is lost:
//!
//! - standard output (`-o -` or no `-o`), which must be open;
//! - a regular file, written to a temporary file beside it and renamed onto it when the
//!   run completes, so a failed or interrupted run leaves the old file, or nothing;
//! - a descriptor named as a file (`/dev/stdout`, `/dev/stderr`, `/dev/fd/N`,
//!   `/proc/self/fd/N`), written through that descriptor, so `>> log` appends and a pipe
//!   works;
//! - a device or pipe given as `-o` (`/dev/null`, a FIFO), written in place.
//!
//! An output that is one of the files the command reads is refused before anything is
//! written, compared as files (device and inode), with `-` resolved to the file behind
//! standard input. A new file gets the user's umask; a replaced file keeps its mode, and
//! a read-only file is not replaced. Temporary files are removed when a signal ends the
//! process, and no signal lands between the renames of a commit.

use super::outdir::Staged;
use super::temporaries;
use crate::stream::io_reason;
use anyhow::{bail, Context, Result};
use std::fs::{File, Permissions};
use std::io::{self, Write};
use std::os::fd::AsFd;
use std::os::unix::fs::{MetadataExt, OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Held while outputs are renamed into place: a signal waits for the commit to end, so
/// `ssl simulate`'s two files are both replaced or neither at every instant.
static COMMIT: Mutex<()> = Mutex::new(());

/// Set when a signal arrives, before its handler waits for a commit to end: the commit
/// then waits for the handler to end the process (with the signal's status).
static SIGNALLED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Holds the commit lock for `f`; when a signal came meanwhile, the process ends by it.
fn committing<T>(f: impl FnOnce() -> T) -> T {
    let result = {
        let _commit = COMMIT.lock();
        f()
    };
    if SIGNALLED.load(std::sync::atomic::Ordering::SeqCst) {
        loop {
            std::thread::park();
        }
    }
    result
}

/// The signals whose default action ends the process: each removes the temporary files
/// and exits with 128 + its number, after any commit under way. SIGXFSZ (a file size
/// limit, `ulimit -f`) is caught instead, so the write that passes the limit fails with
/// "File too large" and the run ends with that error line.
pub fn remove_temporaries_on_signal() {
    use signal_hook::consts::signal::*;
    let ending = [
        SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGUSR1, SIGUSR2, SIGALRM, SIGVTALRM, SIGPROF, SIGXCPU,
    ];
    let xfsz = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    // Registration fails only for a forbidden signal (SIGKILL, SIGSTOP), none of these.
    let _ = signal_hook::flag::register(SIGXFSZ, xfsz);
    let Ok(mut signals) = signal_hook::iterator::Signals::new(ending) else {
        return;
    };
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            SIGNALLED.store(true, std::sync::atomic::Ordering::SeqCst);
            let _commit = COMMIT.lock();
            temporaries::remove_all();
            let name = signal_hook::low_level::signal_name(signal).unwrap_or("a signal");
            if signal == SIGINT {
                eprintln!("ssl: interrupted");
            } else {
                eprintln!("ssl: ended by {name}");
            }
            std::process::exit(128 + signal);
        }
    });
}

/// A temporary file beside its target, registered for removal on a signal; removed
/// when dropped unless renamed onto the target.
struct Temporary(Option<tempfile::NamedTempFile>);

impl Temporary {
    fn new(target: &Path, mode: Option<u32>) -> io::Result<Self> {
        Self::make(target, |path| {
            let file = std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                // A new file: read and write for all, less the umask (as any program's).
                .mode(0o666)
                .open(path)?;
            if let Some(mode) = mode {
                // A replaced file keeps its mode (which the umask must not narrow).
                file.set_permissions(Permissions::from_mode(mode))?;
            }
            Ok(file)
        })
    }

    /// A second name for `target`'s file (a hard link, or a copy where links are not
    /// supported): its old contents, kept until a commit is complete.
    fn backup(target: &Path) -> io::Result<Self> {
        Self::make(target, |path| {
            if std::fs::hard_link(target, path).is_err() {
                std::fs::copy(target, path)?;
            }
            std::fs::OpenOptions::new().append(true).open(path)
        })
    }

    fn make(target: &Path, create: impl Fn(&Path) -> io::Result<File>) -> io::Result<Self> {
        let dir = match target.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        let tmp = temporaries::make(|| {
            let tmp = tempfile::Builder::new()
                .prefix(".ssl-")
                .suffix(".tmp")
                .make_in(dir, |path| create(path))?;
            let path = tmp.path().to_path_buf();
            Ok((tmp, path))
        })?;
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
    temporaries::unregister(path)
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
    /// A file in a batch's results folder, written without following links.
    Staged(Staged),
}

impl Sink {
    /// Standard output (`None` or `-`), or `path`, which must not be one of the files
    /// the command reads, `inputs` (compared as files, not as spellings; `-` is the file
    /// behind standard input; symlinks are followed, so a link stays a link).
    pub fn open(path: Option<&Path>, inputs: &[&Path]) -> Result<Self> {
        let refuse_input = |output: Option<FileId>, shown: &str| -> Result<()> {
            let Some(output) = output else { return Ok(()) };
            if let Some(input) = inputs.iter().find(|i| FileId::of(i) == Some(output)) {
                if *input == Path::new("-") {
                    bail!("{shown}: the output is the file standard input reads; choose another output file");
                }
                bail!(
                    "{shown}: the output is the input {}; choose another output file",
                    input.display()
                );
            }
            Ok(())
        };
        let Some(path) = path.filter(|p| *p != Path::new("-")) else {
            if stdout_was_closed() {
                bail!("cannot write to standard output: it is closed (>&-); redirect it to a file or use -o");
            }
            let file = File::from(io::stdout().as_fd().try_clone_to_owned().map_err(|e| {
                anyhow::anyhow!("cannot write to standard output: {}", io_reason(&e))
            })?);
            refuse_input(FileId::of_file(&file), "standard output")?;
            return Ok(Sink {
                kind: Kind::Stdout(file),
                shown: "standard output".into(),
            });
        };
        let shown = path.display().to_string();
        if let Some(file) = descriptor(path) {
            let file =
                file.map_err(|e| anyhow::anyhow!("cannot write {shown}: {}", io_reason(&e)))?;
            refuse_input(FileId::of_file(&file), &shown)?;
            return Ok(Sink {
                kind: Kind::Direct(file),
                shown,
            });
        }
        refuse_input(FileId::of(path), &shown)?;
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
                check_directory(&target, &shown)?;
                let mode = existing.ok().map(|m| m.permissions().mode() & 0o7777);
                let tmp = Temporary::new(&target, mode)
                    .map_err(|e| anyhow::anyhow!("cannot write {shown}: {}", io_reason(&e)))?;
                Kind::Atomic(tmp, target)
            }
        };
        Ok(Sink { kind, shown })
    }

    /// A file of a batch's results folder ([`Staged`]).
    pub(super) fn staged(staged: Staged) -> Sink {
        Sink {
            shown: staged.shown().display().to_string(),
            kind: Kind::Staged(staged),
        }
    }

    /// Whether a person or program reads the output as it comes (standard output).
    pub fn is_live(&self) -> bool {
        matches!(self.kind, Kind::Stdout(_))
    }

    /// The bytes written so far (flushed first); 0 for standard output and devices.
    pub fn len(&mut self) -> io::Result<u64> {
        self.flush()?;
        match &mut self.kind {
            Kind::Atomic(tmp, _) => Ok(tmp.file().as_file().metadata()?.len()),
            Kind::Staged(s) => {
                Ok(rustix::fs::fstat(s.fd()).map_err(io::Error::from)?.st_size as u64)
            }
            _ => Ok(0),
        }
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
        let persisted = match self.kind {
            Kind::Atomic(tmp, target) => committing(|| tmp.persist(&target)),
            Kind::Staged(staged) => committing(|| staged.persist(None)),
            _ => Ok(()),
        };
        persisted.map_err(|e| anyhow::anyhow!("cannot write {}: {}", self.shown, io_reason(&e)))
    }

    /// Ends a run that failed: the target is left as it was (or not made), and what was
    /// written goes beside it as `<stem>.partial.<ext>` (replacing an earlier one). The
    /// line that says so is returned; `None` for standard output, devices and pipes,
    /// which were written as the run went.
    pub fn set_aside(mut self) -> Result<Option<String>> {
        self.flush().map_err(|e| self.write_error(&e))?;
        let (tmp, target) = match self.kind {
            Kind::Atomic(tmp, target) => (tmp, target),
            Kind::Staged(staged) => {
                let partial = partial_name(Path::new(staged.name()));
                let partial = partial.as_os_str().to_os_string();
                let shown = staged.shown().with_file_name(&partial);
                let kept = if staged.target_exists() {
                    "left as it was"
                } else {
                    "not written"
                };
                committing(|| staged.persist(Some(&partial))).map_err(|e| {
                    anyhow::anyhow!("cannot write {}: {}", shown.display(), io_reason(&e))
                })?;
                return Ok(Some(format!(
                    "{}: {kept}, since the recording failed; the results of what was read are in {}",
                    self.shown,
                    shown.display()
                )));
            }
            _ => return Ok(None),
        };
        let partial = partial_name(&target);
        let kept = if target.exists() {
            "left as it was"
        } else {
            "not written"
        };
        committing(|| tmp.persist(&partial)).map_err(|e| {
            anyhow::anyhow!("cannot write {}: {}", partial.display(), io_reason(&e))
        })?;
        Ok(Some(format!(
            "{}: {kept}, since a file failed; the results of what was read are in {}",
            self.shown,
            partial.display()
        )))
    }

    /// Completes two outputs together: both are replaced, or neither, at every instant
    /// a signal could see (the first target keeps a second name for its old contents
    /// until the second is in place, and signals wait for the commit).
    pub fn commit_both(mut self, mut second: Sink) -> Result<()> {
        self.flush().map_err(|e| self.write_error(&e))?;
        second.flush().map_err(|e| second.write_error(&e))?;
        let Kind::Atomic(tmp, target) = self.kind else {
            return second.commit();
        };
        committing(|| Self::replace_both(tmp, &target, &self.shown, second))
    }

    /// The renames of [`Sink::commit_both`], under the commit lock.
    fn replace_both(tmp: Temporary, target: &Path, shown: &str, second: Sink) -> Result<()> {
        let backup = match std::fs::metadata(target) {
            Ok(_) => Some(
                Temporary::backup(target)
                    .map_err(|e| anyhow::anyhow!("cannot write {}: {}", shown, io_reason(&e)))?,
            ),
            Err(_) => None,
        };
        let restore = |backup: Option<Temporary>| match backup {
            Some(b) => {
                let _ = b.persist(target);
            }
            None => {
                let _ = std::fs::remove_file(target);
            }
        };
        if let Err(e) = tmp.persist(target) {
            bail!("cannot write {}: {}", shown, io_reason(&e));
        }
        // A seam for the test that signals the process between the two renames.
        if let Some(ms) = std::env::var("SSL_TEST_COMMIT_PAUSE_MS")
            .ok()
            .and_then(|v| v.parse().ok())
        {
            std::thread::sleep(std::time::Duration::from_millis(ms));
        }
        let second_result = match second.kind {
            Kind::Atomic(tmp, ref second_target) => tmp
                .persist(second_target)
                .map_err(|e| anyhow::anyhow!("cannot write {}: {}", second.shown, io_reason(&e))),
            _ => Ok(()),
        };
        if let Err(e) = second_result {
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
            Kind::Staged(w) => w.write(buf),
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        match &mut self.kind {
            Kind::Stdout(w) => w.flush(),
            Kind::Atomic(w, _) => w.file().flush(),
            Kind::Direct(w) => w.flush(),
            Kind::Staged(w) => w.flush(),
        }
    }
}

/// Whether the process started with standard output closed (`>&-`). The Rust runtime
/// then opens `/dev/null` read-write in its place before `main`, so that writes vanish
/// without an error; a shell's `> /dev/null` opens it write-only. Linux only (it reads
/// /proc); elsewhere `false`.
pub fn stdout_was_closed() -> bool {
    let is_null = std::fs::read_link("/proc/self/fd/1").is_ok_and(|p| p == Path::new("/dev/null"));
    let read_write = std::fs::read_to_string("/proc/self/fdinfo/1").is_ok_and(|info| {
        info.lines()
            .find_map(|l| l.strip_prefix("flags:"))
            .and_then(|f| u32::from_str_radix(f.trim(), 8).ok())
            .is_some_and(|flags| flags & 0o3 == 0o2)
    });
    is_null && read_write
}

/// A regular file's identity: its device and inode.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct FileId(u64, u64);

impl FileId {
    /// The regular file `path` names (links followed), or the one behind standard input
    /// for `-`; `None` for anything else (a pipe, a terminal, a missing file), which no
    /// output can overwrite.
    pub fn of(path: &Path) -> Option<FileId> {
        if path == Path::new("-") {
            let file = File::from(io::stdin().as_fd().try_clone_to_owned().ok()?);
            return Self::of_file(&file);
        }
        Self::of_metadata(&std::fs::metadata(path).ok()?)
    }

    fn of_file(file: &File) -> Option<FileId> {
        Self::of_metadata(&file.metadata().ok()?)
    }

    fn of_metadata(m: &std::fs::Metadata) -> Option<FileId> {
        m.is_file().then(|| FileId(m.dev(), m.ino()))
    }
}

/// Whether `a` and `b` name the same regular file (`-` is the one behind standard input).
pub fn same_file(a: &Path, b: &Path) -> bool {
    FileId::of(a).is_some_and(|x| FileId::of(b) == Some(x))
}

/// The descriptor a path names (`/dev/stdout`, `/dev/stderr`, `/dev/fd/N`,
/// `/proc/self/fd/N`), opened for writing through it: standard output and error are
/// duplicated, so they keep their offset and append mode; another descriptor is reopened
/// to append. `None` for any other path.
fn descriptor(path: &Path) -> Option<io::Result<File>> {
    let text = path.to_str()?;
    let n: u32 = match text {
        "/dev/stdout" => 1,
        "/dev/stderr" => 2,
        "/dev/stdin" => 0,
        _ => text
            .strip_prefix("/dev/fd/")
            .or_else(|| text.strip_prefix("/proc/self/fd/"))?
            .parse()
            .ok()?,
    };
    Some(match n {
        1 => io::stdout().as_fd().try_clone_to_owned().map(File::from),
        2 => io::stderr().as_fd().try_clone_to_owned().map(File::from),
        _ => std::fs::OpenOptions::new()
            .append(true)
            .open(format!("/proc/self/fd/{n}")),
    })
}

/// Refuses an output whose directory does not exist or is not a directory, naming the
/// directory (the file itself would be blamed otherwise).
fn check_directory(target: &Path, shown: &str) -> Result<()> {
    let Some(dir) = target.parent().filter(|d| !d.as_os_str().is_empty()) else {
        return Ok(());
    };
    match std::fs::metadata(dir) {
        Ok(m) if m.is_dir() => Ok(()),
        Ok(_) => bail!("cannot write {shown}: {} is not a directory", dir.display()),
        Err(e) => bail!(
            "cannot write {shown}: directory {}: {}",
            dir.display(),
            io_reason(&e)
        ),
    }
}

/// `out.csv` -> `out.partial.csv`; `out` -> `out.partial`.
pub(super) fn partial_name(target: &Path) -> PathBuf {
    let stem = target.file_stem().unwrap_or_default().to_string_lossy();
    let name = match target.extension() {
        Some(ext) => format!("{stem}.partial.{}", ext.to_string_lossy()),
        None => format!("{stem}.partial"),
    };
    target.with_file_name(name)
}
