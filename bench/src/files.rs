//! Files written whole: every report, table and record file of the
//! benchmark goes through [`write()`].

use std::path::Path;

use crate::error::{BenchError, Result};

/// Writes `text` to `path` whole or not at all (`store::replace_file`: a
/// unique temporary in the same directory, synced and renamed over it; a
/// symlink's target replaced, an existing file's mode kept), making the
/// directory first.
///
/// # Errors
/// [`BenchError::Io`] for the directory, [`BenchError::Store`] naming the
/// file.
pub fn write(path: &Path, text: &str) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(BenchError::io(dir))?;
    }
    Ok(store::replace_file(path, text.as_bytes())?)
}
