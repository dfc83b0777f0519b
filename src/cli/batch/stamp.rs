//! What a result was made from: its stamp, `DIR/.ssl/<result>.json`.
//!
//! A stamp names the input as it was opened, read from the descriptor the analysis then
//! read (so a recording replaced by a rename during the run is not mistaken for the one
//! analysed): its path relative to the archive and its absolute path, its size,
//! modification time, inode and device, and a fingerprint of its contents (a hash of
//! the first and last 64 KiB and of 14 blocks of 4 KiB spread between them, so that two
//! recordings of one name, size and time, as a recorder without a clock writes them,
//! are told apart). It names the result's whole recipe: the record kind and format, the
//! run's metadata (the geometry as understood, every parameter), every option, and the
//! build (a hash of the executable itself, since the output changed many times under
//! one version string).
//!
//! `--resume` skips an input whose stamp has this recipe, this relative path, and the
//! size, time and fingerprint the input has now. The inode and device are kept but not
//! compared: a copy of the archive (rsync, a restore) or another machine's view of a
//! network share changes them while the recordings are the same. Reading a stamp never
//! follows a link and never blocks.

use super::super::outdir::{Folder, OutDir, NAME_MAX};
use anyhow::Result;
use serde::{Deserialize, Serialize};
use std::ffi::{OsStr, OsString};
use std::fs::File;
use std::os::unix::fs::{FileExt, MetadataExt};
use std::path::{Path, PathBuf};

/// The stamp format this build writes; a stamp of another is not current.
const VERSION: u32 = 2;

/// An input as it was opened.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct InputId {
    /// Its absolute path (links resolved) when it was opened.
    pub path: String,
    /// Its path under the archive (where its result goes).
    pub relative: String,
    pub size: u64,
    pub mtime_ns: i128,
    pub inode: u64,
    pub device: u64,
    /// FNV-1a of its size and sampled contents ([`fingerprint`]), as hex.
    pub fingerprint: String,
}

impl InputId {
    /// The identity of the open regular file `file`, found at `path`.
    pub fn of(file: &File, path: &str, relative: &Path) -> std::io::Result<InputId> {
        let meta = file.metadata()?;
        Ok(InputId {
            path: std::fs::canonicalize(path)
                .map(|p| p.display().to_string())
                .unwrap_or_else(|_| path.to_string()),
            relative: relative.display().to_string(),
            size: meta.len(),
            mtime_ns: meta.mtime() as i128 * 1_000_000_000 + meta.mtime_nsec() as i128,
            inode: meta.ino(),
            device: meta.dev(),
            fingerprint: format!("{:016x}", fingerprint(file, meta.len())?),
        })
    }

    /// Whether `self` and `other` are the same recording's same contents: size, time
    /// and fingerprint (not where it is, nor its inode).
    pub fn same_contents(&self, other: &InputId) -> bool {
        self.size == other.size
            && self.mtime_ns == other.mtime_ns
            && self.fingerprint == other.fingerprint
    }

    /// Whether the size or time of `file` moved since `self` was taken.
    pub fn moved(&self, file: &File) -> bool {
        file.metadata().map_or(true, |m| {
            m.len() != self.size
                || m.mtime() as i128 * 1_000_000_000 + m.mtime_nsec() as i128 != self.mtime_ns
        })
    }
}

/// FNV-1a over the size and the sampled blocks of a file of `size` bytes.
pub fn fingerprint(file: &File, size: u64) -> std::io::Result<u64> {
    const EDGE: u64 = 64 << 10;
    const BLOCK: u64 = 4 << 10;
    const SPREAD: u64 = 14;
    let mut spans = vec![(0, EDGE.min(size)), (size.saturating_sub(EDGE), size)];
    for i in 1..=SPREAD {
        let at = size / (SPREAD + 1) * i;
        spans.push((at, (at + BLOCK).min(size)));
    }
    let mut h = Fnv::new();
    h.bytes(&size.to_le_bytes());
    let mut buf = vec![0u8; EDGE as usize];
    for (from, to) in spans {
        let len = (to.saturating_sub(from)) as usize;
        file.read_exact_at(&mut buf[..len], from)?;
        h.bytes(&buf[..len]);
    }
    Ok(h.0)
}

/// FNV-1a, 64 bits.
pub struct Fnv(pub u64);

impl Fnv {
    pub fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }

    pub fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 = (self.0 ^ x as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    /// Mixes 8 bytes at a time (for large inputs such as the executable).
    pub fn words(&mut self, b: &[u8]) {
        let mut chunks = b.chunks_exact(8);
        for c in &mut chunks {
            let w = u64::from_le_bytes(c.try_into().expect("8 bytes"));
            self.0 = (self.0 ^ w).wrapping_mul(0x0000_0100_0000_01b3);
            self.0 ^= self.0 >> 29;
        }
        self.bytes(chunks.remainder());
    }
}

/// The stamp of one result.
#[derive(Debug, Serialize, Deserialize, PartialEq)]
pub struct Stamp {
    pub stamp: u32,
    pub input: InputId,
    /// A hash of the result's recipe ([`recipe`]).
    pub recipe: String,
    /// The result's path under DIR, and its size.
    pub result: String,
    pub result_size: u64,
    /// The array the result was made with (the run's metadata's `geometry`, as a JSON
    /// result carries it): how `ssl evaluate` and `ssl plot` score a CSV or NDJSON
    /// result, which cannot say it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub geometry: Option<serde_json::Value>,
}

/// What a batch's stamps say of all its results: the hash of their recipe ([`recipe`])
/// and the array they were made with.
pub struct Recipe {
    pub hash: String,
    pub geometry: Option<serde_json::Value>,
}

/// The array named by the stamp of the result at `result`, when it lies in a batch's
/// results folder (`DIR/.ssl/<its path under DIR>.json` for some folder DIR above it,
/// naming this result): how a CSV or NDJSON result of `--out-dir` says its array.
pub fn stamped_array(result: &Path) -> Option<crate::Geometry> {
    let result = std::fs::canonicalize(result).ok()?;
    for dir in result.ancestors().skip(1) {
        let Ok(relative) = result.strip_prefix(dir) else {
            continue;
        };
        let (folder, name) = place(relative);
        let path = dir.join(folder).join(name);
        let Ok(meta) = std::fs::metadata(&path) else {
            continue;
        };
        if !meta.is_file() || meta.len() > 1 << 16 {
            continue;
        }
        // A stamp that cannot be read, or of another result, says nothing of this one:
        // a folder further up may hold its own.
        let stamp = std::fs::read(&path)
            .ok()
            .and_then(|bytes| serde_json::from_slice::<Stamp>(&bytes).ok());
        if let Some(stamp) = stamp.filter(|s| Path::new(&s.result) == relative) {
            return crate::record::array_of(stamp.geometry.as_ref()?);
        }
    }
    None
}

/// A hash of everything that decides a result's bytes but the input: `what` (the
/// record kind, format, metadata and options as text) and this executable's contents.
pub fn recipe(what: &str) -> String {
    let mut h = Fnv::new();
    h.bytes(what.as_bytes());
    // Read in pieces of 64 KiB (a multiple of 8): the executable is tens of MB.
    let exe = std::env::current_exe().and_then(|p| {
        let mut file = File::open(p)?;
        let mut piece = vec![0u8; 64 << 10];
        let mut exe = Fnv::new();
        loop {
            // Whole pieces whatever the reads return, so the hash does not depend on them.
            let mut n = 0;
            while n < piece.len() {
                match std::io::Read::read(&mut file, &mut piece[n..])? {
                    0 => break,
                    k => n += k,
                }
            }
            exe.words(&piece[..n]);
            if n < piece.len() {
                return Ok(exe.0);
            }
        }
    });
    match exe {
        Ok(exe) => h.bytes(&exe.to_le_bytes()),
        // Not readable: the version alone, as before stamps knew the build.
        Err(_) => h.bytes(env!("CARGO_PKG_VERSION").as_bytes()),
    }
    format!("{:016x}", h.0)
}

/// Where the stamp of the result `relative` (under DIR) lives: its folder under
/// `DIR/.ssl` and its name, `<result name>.json`, or, when that passes the longest name
/// a folder allows, the name's first 200 bytes and a hash of the whole.
pub fn place(relative: &Path) -> (PathBuf, OsString) {
    let folder = Path::new(".ssl").join(relative.parent().unwrap_or(Path::new("")));
    let name = relative.file_name().unwrap_or_default();
    let mut full = name.to_os_string();
    full.push(".json");
    if full.len() <= NAME_MAX {
        return (folder, full);
    }
    let bytes = name.as_encoded_bytes();
    let mut h = Fnv::new();
    h.bytes(bytes);
    let mut cut = 200;
    while cut > 0 && !name.to_string_lossy().is_char_boundary(cut) {
        cut -= 1;
    }
    let head = String::from_utf8_lossy(&bytes[..cut.min(bytes.len())]).into_owned();
    (folder, OsString::from(format!("{head}-{:016x}.json", h.0)))
}

/// The folder of the stamp of the result `relative` (made when `create`), and the
/// stamp's name in it; refused when a folder on the way is a link.
pub fn open(dir: &OutDir, relative: &Path, create: bool) -> Result<Option<(Folder, OsString)>> {
    let (folder, name) = place(relative);
    Ok(dir.folder(&folder, create)?.map(|f| (f, name)))
}

/// The stamp in `folder` named `name`, if one is there and reads (a link, a FIFO or a
/// stamp of another format is none).
pub fn read(folder: &Folder, name: &OsStr) -> Option<Stamp> {
    let bytes = folder.read_small(name, 1 << 16)?;
    serde_json::from_slice::<Stamp>(&bytes)
        .ok()
        .filter(|s| s.stamp == VERSION)
}

/// Writes the stamp `name` of the result `relative` (atomically, not following links).
pub fn write(
    folder: &Folder,
    name: &OsStr,
    relative: &Path,
    input: &InputId,
    recipe: &Recipe,
    size: u64,
) -> Result<()> {
    let stamp = Stamp {
        stamp: VERSION,
        input: input.clone(),
        recipe: recipe.hash.clone(),
        result: relative.display().to_string(),
        result_size: size,
        geometry: recipe.geometry.clone(),
    };
    let mut staged = folder.stage(name)?;
    serde_json::to_writer(&mut staged, &stamp)?;
    staged.persist(None)?;
    Ok(())
}

/// The folder of a result and its name.
pub fn result_folder(
    dir: &OutDir,
    relative: &Path,
    create: bool,
) -> Result<Option<(Folder, OsString)>> {
    let parent = relative.parent().unwrap_or(Path::new(""));
    let name = relative.file_name().unwrap_or_default().to_os_string();
    Ok(dir.folder(parent, create)?.map(|f| (f, name)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_result_name_gets_a_stamp_name_that_fits() {
        let long = "x".repeat(252) + ".csv";
        let (folder, name) = place(Path::new(&format!("d/{long}")));
        assert_eq!(folder, Path::new(".ssl/d"));
        assert!(name.len() <= NAME_MAX, "{}", name.len());
        let (_, other) = place(Path::new(&("x".repeat(252) + ".ndj")));
        assert_ne!(name, other);
        assert_eq!(place(Path::new("a.csv")).1, "a.csv.json");
    }

    #[test]
    fn the_fingerprint_tells_apart_files_that_differ_in_a_sampled_block() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a");
        let mut bytes = vec![0u8; 1 << 20];
        std::fs::write(&a, &bytes).unwrap();
        let fa = fingerprint(&File::open(&a).unwrap(), bytes.len() as u64).unwrap();
        bytes[(1 << 20) / 15 * 7 + 5] = 1;
        std::fs::write(&a, &bytes).unwrap();
        let fb = fingerprint(&File::open(&a).unwrap(), bytes.len() as u64).unwrap();
        assert_ne!(fa, fb);
    }
}
