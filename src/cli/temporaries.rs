//! The temporary files this process is writing (an output's, a batch result's), so that
//! a signal that ends the process removes them ([`super::sink`]'s handler).

use std::io;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

static TEMPORARIES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Makes a temporary file with `make` (which returns it and its path) while the list is
/// held, so that no signal lands between its creation and its registration.
pub(super) fn make<T>(make: impl FnOnce() -> io::Result<(T, PathBuf)>) -> io::Result<T> {
    let mut registry = TEMPORARIES.lock().unwrap_or_else(|e| e.into_inner());
    let (made, path) = make()?;
    registry.push(path);
    Ok(made)
}

/// The temporary at `path` was renamed or removed.
pub(super) fn unregister(path: &Path) {
    if let Ok(mut paths) = TEMPORARIES.lock() {
        paths.retain(|p| p != path);
    }
}

/// Removes every temporary file still registered.
pub(super) fn remove_all() {
    if let Ok(paths) = TEMPORARIES.lock() {
        for p in paths.iter() {
            let _ = std::fs::remove_file(p);
        }
    }
}
