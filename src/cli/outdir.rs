//! The results folder of a batch (`--out-dir DIR`), written without ever following a
//! link: DIR itself is opened as the user named it, and every folder under it is opened
//! from its parent's descriptor with `O_NOFOLLOW`, so a link planted inside DIR (to a
//! recording, to a file outside DIR, to another folder, as `DIR/.ssl`) is refused and
//! never written through. A file is written to a temporary beside its target and renamed
//! onto it from the folder's descriptor: a rename replaces the name, never what a link
//! at that name points to. Only regular files are replaced; a link, a FIFO or a device
//! at a result's name is refused, so no write blocks and nothing outside DIR changes.
//!
//! Temporaries are named `.ssl-<host>-<pid>-<n>.tmp`, so that a later batch on the same
//! host can sweep those whose process is gone (a batch ended by SIGKILL cannot remove
//! its own): see [`OutDir::sweep`].

use anyhow::{anyhow, bail, Result};
use rustix::fs::{AtFlags, FileType, Mode, OFlags};
use std::ffi::{OsStr, OsString};
use std::fs::File;
use std::io::{self, Read, Write};
use std::os::fd::{AsFd, OwnedFd};
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// The longest name a folder entry may have on the file systems a batch writes to.
pub(super) const NAME_MAX: usize = 255;

/// A batch's results folder, open.
pub struct OutDir {
    root: OwnedFd,
    path: PathBuf,
}

/// A folder under [`OutDir`], opened without following links.
pub struct Folder {
    fd: OwnedFd,
    /// Its path, for messages and for removal on a signal.
    path: PathBuf,
}

/// What is at a name inside a folder, looked at without following a link.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Entry {
    Missing,
    /// A regular file, with its size.
    File(u64),
    /// A symbolic link: never followed (removing it removes the link alone).
    Link,
    /// A folder, a FIFO, a device or a socket: never written, read or removed.
    Other(&'static str),
}

fn kind_name(t: FileType) -> &'static str {
    match t {
        FileType::Symlink => "a symbolic link",
        FileType::Directory => "a folder",
        FileType::Fifo => "a FIFO",
        FileType::CharacterDevice | FileType::BlockDevice => "a device",
        FileType::Socket => "a socket",
        _ => "not a regular file",
    }
}

fn errno(e: rustix::io::Errno) -> io::Error {
    e.into()
}

impl OutDir {
    /// Opens (and makes, with its parents) the folder `path`; links in `path` itself
    /// are the user's and are followed.
    pub fn open(path: &Path) -> Result<OutDir> {
        std::fs::create_dir_all(path).map_err(|e| {
            anyhow!(
                "{}: cannot create the results folder: {}",
                path.display(),
                crate::stream::io_reason(&e)
            )
        })?;
        let root = rustix::fs::open(
            path,
            OFlags::RDONLY | OFlags::DIRECTORY | OFlags::CLOEXEC,
            Mode::empty(),
        )
        .map_err(|e| {
            anyhow!(
                "{}: cannot open the results folder: {}",
                path.display(),
                crate::stream::io_reason(&errno(e))
            )
        })?;
        Ok(OutDir {
            root,
            path: path.to_path_buf(),
        })
    }

    /// The folder's path as the user gave it.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The folder `relative` names under DIR (made when `create`; `Ok(None)` when it
    /// does not exist and `create` is false). Refused when a component is a link or not
    /// a folder, or is `..`.
    pub fn folder(&self, relative: &Path, create: bool) -> Result<Option<Folder>> {
        let mut fd = rustix::io::dup(&self.root).map_err(errno)?;
        let mut path = self.path.clone();
        for c in relative.components() {
            let Component::Normal(name) = c else {
                if matches!(c, Component::CurDir) {
                    continue;
                }
                bail!(
                    "{}: not a path under the results folder",
                    relative.display()
                );
            };
            path.push(name);
            let open = |fd: &OwnedFd| {
                rustix::fs::openat(
                    fd,
                    name,
                    OFlags::RDONLY | OFlags::DIRECTORY | OFlags::NOFOLLOW | OFlags::CLOEXEC,
                    Mode::empty(),
                )
            };
            let next = match open(&fd) {
                Err(rustix::io::Errno::NOENT) if create => {
                    match rustix::fs::mkdirat(&fd, name, Mode::from_raw_mode(0o777)) {
                        Ok(()) | Err(rustix::io::Errno::EXIST) => open(&fd),
                        Err(e) => Err(e),
                    }
                }
                Err(rustix::io::Errno::NOENT) => return Ok(None),
                other => other,
            };
            fd = next.map_err(|e| match e {
                rustix::io::Errno::LOOP | rustix::io::Errno::NOTDIR => {
                    let what = rustix::fs::statat(&fd, name, AtFlags::SYMLINK_NOFOLLOW)
                        .map(|s| kind_name(FileType::from_raw_mode(s.st_mode)))
                        .unwrap_or("not a folder");
                    anyhow!(
                        "{}: is {what}, not a folder this batch made; a batch never writes through links (remove it, or choose another --out-dir)",
                        path.display()
                    )
                }
                e => anyhow!(
                    "{}: cannot open the folder: {}",
                    path.display(),
                    crate::stream::io_reason(&errno(e))
                ),
            })?;
        }
        Ok(Some(Folder { fd, path }))
    }

    /// Removes the temporaries that batches on this host left when they were killed
    /// (their process is gone), in DIR and every folder under it, links not followed.
    /// Returns how many were removed.
    pub fn sweep(&self) -> usize {
        let Ok(fd) = rustix::io::dup(&self.root) else {
            return 0;
        };
        sweep_folder(fd, 0)
    }
}

fn sweep_folder(fd: OwnedFd, depth: usize) -> usize {
    // Deeper than any archive: a guard against a pathological tree, not a limit met.
    if depth > 64 {
        return 0;
    }
    let Ok(dir) = rustix::fs::Dir::read_from(&fd) else {
        return 0;
    };
    let host = host();
    let mut removed = 0;
    let mut folders = Vec::new();
    for entry in dir.flatten() {
        let name = entry.file_name().to_bytes();
        if name == b"." || name == b".." {
            continue;
        }
        let name = std::os::unix::ffi::OsStrExt::from_bytes(name);
        let name: &OsStr = name;
        if entry.file_type() == FileType::Directory {
            folders.push(name.to_os_string());
        } else if let Some(pid) = stale_owner(&name.to_string_lossy(), &host) {
            if !process_alive(pid) && rustix::fs::unlinkat(&fd, name, AtFlags::empty()).is_ok() {
                removed += 1;
            }
        }
    }
    for name in folders {
        if let Ok(sub) = rustix::fs::openat(
            &fd,
            &name,
            OFlags::RDONLY | OFlags::DIRECTORY | OFlags::NOFOLLOW | OFlags::CLOEXEC,
            Mode::empty(),
        ) {
            removed += sweep_folder(sub, depth + 1);
        }
    }
    removed
}

/// This host's name, as temporaries carry it (`-` and `/` replaced).
fn host() -> String {
    rustix::system::uname()
        .nodename()
        .to_string_lossy()
        .replace(['-', '/', '.'], "_")
}

/// The pid of a temporary of this host named `.ssl-<host>-<pid>-<n>.tmp`.
fn stale_owner(name: &str, host: &str) -> Option<i32> {
    let rest = name.strip_prefix(".ssl-")?.strip_suffix(".tmp")?;
    let rest = rest.strip_prefix(host)?.strip_prefix('-')?;
    let (pid, n) = rest.split_once('-')?;
    n.parse::<u64>().ok()?;
    pid.parse().ok()
}

fn process_alive(pid: i32) -> bool {
    match rustix::process::Pid::from_raw(pid) {
        // EPERM: it exists, owned by another user.
        Some(p) => !matches!(
            rustix::process::test_kill_process(p),
            Err(rustix::io::Errno::SRCH)
        ),
        None => true,
    }
}

static NEXT_TEMPORARY: AtomicU64 = AtomicU64::new(0);

impl Folder {
    /// The folder's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// What is at `name`, not following a link.
    pub fn entry(&self, name: &OsStr) -> io::Result<Entry> {
        match rustix::fs::statat(&self.fd, name, AtFlags::SYMLINK_NOFOLLOW) {
            Ok(s) => Ok(match FileType::from_raw_mode(s.st_mode) {
                FileType::RegularFile => Entry::File(s.st_size as u64),
                FileType::Symlink => Entry::Link,
                t => Entry::Other(kind_name(t)),
            }),
            Err(rustix::io::Errno::NOENT) => Ok(Entry::Missing),
            Err(e) => Err(errno(e)),
        }
    }

    /// The contents of the regular file `name` when it has at most `limit` bytes
    /// (`None`: missing, not a regular file, or larger). Never blocks on a FIFO.
    pub fn read_small(&self, name: &OsStr, limit: u64) -> Option<Vec<u8>> {
        let fd = rustix::fs::openat(
            &self.fd,
            name,
            OFlags::RDONLY | OFlags::NOFOLLOW | OFlags::NONBLOCK | OFlags::CLOEXEC,
            Mode::empty(),
        )
        .ok()?;
        let s = rustix::fs::fstat(&fd).ok()?;
        if FileType::from_raw_mode(s.st_mode) != FileType::RegularFile || s.st_size as u64 > limit {
            return None;
        }
        let mut bytes = Vec::new();
        File::from(fd)
            .take(limit + 1)
            .read_to_end(&mut bytes)
            .ok()?;
        (bytes.len() as u64 <= limit).then_some(bytes)
    }

    /// Removes the regular file (or link: the link itself) `name`; a missing one is not
    /// an error. Folders, FIFOs and devices are left alone.
    pub fn remove(&self, name: &OsStr) -> io::Result<()> {
        match self.entry(name)? {
            Entry::Missing | Entry::Other(_) => Ok(()),
            Entry::File(_) | Entry::Link => {
                match rustix::fs::unlinkat(&self.fd, name, AtFlags::empty()) {
                    Ok(()) | Err(rustix::io::Errno::NOENT) => Ok(()),
                    Err(e) => Err(errno(e)),
                }
            }
        }
    }

    /// A new file that will replace `name` when committed. Refused when `name` is too
    /// long, or is anything but a regular file or missing.
    pub fn stage(&self, name: &OsStr) -> Result<Staged> {
        let shown = self.path.join(name);
        if name.len() > NAME_MAX {
            bail!(
                "{}: the name is {} bytes, more than the {NAME_MAX} a file system allows",
                shown.display(),
                name.len()
            );
        }
        match self.entry(name) {
            Ok(e @ (Entry::Link | Entry::Other(_))) => bail!(
                "{}: is {}; a batch replaces only regular files, never through a link (remove it, or choose another --out-dir)",
                shown.display(),
                match e {
                    Entry::Other(kind) => kind,
                    _ => kind_name(FileType::Symlink),
                }
            ),
            Err(e) => bail!(
                "{}: cannot look at it: {}",
                shown.display(),
                crate::stream::io_reason(&e)
            ),
            Ok(_) => {}
        }
        let pid = std::process::id();
        let host = host();
        loop {
            let n = NEXT_TEMPORARY.fetch_add(1, Ordering::Relaxed);
            let tmp = OsString::from(format!(".ssl-{host}-{pid}-{n}.tmp"));
            let full = self.path.join(&tmp);
            let made = super::temporaries::make(|| {
                let fd = rustix::fs::openat(
                    &self.fd,
                    &tmp,
                    OFlags::WRONLY
                        | OFlags::CREATE
                        | OFlags::EXCL
                        | OFlags::NOFOLLOW
                        | OFlags::CLOEXEC,
                    Mode::from_raw_mode(0o666),
                )?;
                Ok((fd, full.clone()))
            });
            match made {
                Ok(fd) => {
                    return Ok(Staged {
                        file: File::from(fd),
                        dir: rustix::io::dup(&self.fd).map_err(errno)?,
                        tmp: Some(tmp),
                        full,
                        name: name.to_os_string(),
                        shown,
                    });
                }
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
                Err(e) => bail!(
                    "cannot write {}: {}",
                    shown.display(),
                    crate::stream::io_reason(&e)
                ),
            }
        }
    }
}

/// A file being written in a [`Folder`], renamed onto its name by [`Staged::persist`];
/// removed when dropped uncommitted.
pub struct Staged {
    file: File,
    dir: OwnedFd,
    tmp: Option<OsString>,
    full: PathBuf,
    name: OsString,
    shown: PathBuf,
}

impl Staged {
    /// The target's path, for messages.
    pub fn shown(&self) -> &Path {
        &self.shown
    }

    /// Renames the file onto its target (`as_name`: onto another name in the folder).
    pub fn persist(mut self, as_name: Option<&OsStr>) -> io::Result<()> {
        let tmp = self.tmp.take().expect("present until persisted");
        let target = as_name.unwrap_or(&self.name);
        let result = rustix::fs::renameat(&self.dir, &tmp, &self.dir, target).map_err(errno);
        if result.is_err() {
            let _ = rustix::fs::unlinkat(&self.dir, &tmp, AtFlags::empty());
        }
        super::temporaries::unregister(&self.full);
        result
    }

    /// Whether the target exists now (a regular file or anything else).
    pub fn target_exists(&self) -> bool {
        rustix::fs::statat(&self.dir, &self.name, AtFlags::SYMLINK_NOFOLLOW).is_ok()
    }

    /// The target's folder and name.
    pub fn name(&self) -> &OsStr {
        &self.name
    }

    /// The open file, as a descriptor (for its size).
    pub fn fd(&self) -> impl AsFd + '_ {
        &self.file
    }
}

impl Write for Staged {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.file.write(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.flush()
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if let Some(tmp) = self.tmp.take() {
            let _ = rustix::fs::unlinkat(&self.dir, &tmp, AtFlags::empty());
            super::temporaries::unregister(&self.full);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_temporary_names_its_host_and_process() {
        assert_eq!(stale_owner(".ssl-box-123-7.tmp", "box"), Some(123));
        assert_eq!(stale_owner(".ssl-other-123-7.tmp", "box"), None);
        assert_eq!(stale_owner(".ssl-abc123.tmp", "box"), None);
        assert_eq!(stale_owner("rec.csv", "box"), None);
    }
}
