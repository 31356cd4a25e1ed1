//! Files written whole: every report, table and record file of the
//! benchmark goes through [`write()`].
// issue 51: no panic on user input in the programs' paths
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use std::path::Path;

use crate::error::Result;

/// Writes `text` to `path` whole or not at all (`store::replace_file`: a
/// unique temporary in the same directory, synced and renamed over it; an
/// existing file's mode kept; a symbolic link, device, FIFO or directory
/// at `path` refused and left alone), making the directory first
/// (`store::create_output_dir`).
///
/// # Errors
/// [`BenchError::Store`](crate::BenchError::Store) naming the file or directory.
pub fn write(path: &Path, text: &str) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        store::create_output_dir(dir)?;
    }
    Ok(store::replace_file(path, text.as_bytes())?)
}
