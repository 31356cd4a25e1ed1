//! A scratch directory for tests and examples that write results.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Result, StoreError};

/// A fresh, empty directory `nprl-<tag>-<pid>-<n>` under the system's
/// temporary directory (unique to the process, its tag and a counter),
/// removed with everything in it when dropped. For tests and examples
/// that write a results directory; never for a user's results.
///
/// ```
/// let dir = store::ScratchDir::new("doc")?;
/// store::replace_file(&dir.path().join("report.md"), b"# 1 run\n")?;
/// let kept = dir.path().to_path_buf();
/// assert!(kept.join("report.md").is_file());
/// drop(dir);
/// assert!(!kept.exists());
/// # Ok::<(), store::StoreError>(())
/// ```
#[derive(Debug)]
pub struct ScratchDir(PathBuf);

impl ScratchDir {
    /// Creates the directory (a leftover of the same name, from a killed
    /// process whose id was reused, is removed first).
    ///
    /// # Errors
    /// [`StoreError::Io`] naming the directory when it cannot be created.
    pub fn new(tag: &str) -> Result<Self> {
        static N: AtomicU64 = AtomicU64::new(0);
        let path = std::env::temp_dir().join(format!(
            "nprl-{tag}-{}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&path);
        std::fs::create_dir_all(&path).map_err(|e| StoreError::io("creating", &path, e))?;
        Ok(Self(path))
    }

    /// The directory.
    pub fn path(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for ScratchDir {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
