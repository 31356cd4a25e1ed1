//! Crash-consistent results directories: what a program writes survives a
//! kill, a full disk or a second process, and a directory's settings never
//! change under its records.
//!
//! | item | what it guarantees |
//! |---|---|
//! | [`AppendLog`] | JSON lines appended whole (one write, then `sync_data`); a torn last line is moved aside to `LOG.torn-MS-PID` and reported on the next open |
//! | [`replace_file`] | a file holds its old or its new contents, never a mix: a uniquely named temporary file, synced, renamed, the directory synced; symbolic links and permissions kept |
//! | [`Manifest`] | a directory records the program, task and settings that made it, once; a program reopening it with another task or other settings is refused, naming the keys |
//! | [`fault`] | tests fail the Nth open, write, sync, rename, ... of the crate ([`FaultPlan`]), from any crate |
//!
//! Every error names its file ([`StoreError`]).
//!
//! # Example
//!
//! ```
//! use store::{AppendLog, Manifest, ManifestStatus, replace_file};
//!
//! let dir = std::env::temp_dir().join(format!("store-lib-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//!
//! // the directory's settings, written once
//! let settings = serde_json::json!({"seeds": 2});
//! let manifest = Manifest::new("demo", "pendulum", &settings, "abc1234", &dir.join("manifest.json")).unwrap();
//! assert_eq!(manifest.create_or_check(&dir.join("manifest.json")).unwrap(), ManifestStatus::Created);
//!
//! // records appended whole, read back on reopening
//! let (mut log, contents) = AppendLog::open::<serde_json::Value>(&dir.join("runs.jsonl")).unwrap();
//! assert!(contents.records.is_empty() && contents.torn.is_none());
//! log.append(&serde_json::json!({"seed": 1, "success": true})).unwrap();
//! drop(log);
//! let (_, contents) = AppendLog::open::<serde_json::Value>(&dir.join("runs.jsonl")).unwrap();
//! assert_eq!(contents.records.len(), 1);
//!
//! // a report replaced atomically
//! replace_file(&dir.join("report.md"), b"# 1 run\n").unwrap();
//! std::fs::remove_dir_all(&dir).unwrap();
//! ```
#![deny(missing_docs)]

mod append;
pub mod error;
pub mod fault;
mod manifest;
mod replace;

pub use append::{AppendLog, LogContents, TornTail, read_log};
pub use error::{Result, StoreError};
pub use fault::{FaultGuard, FaultPlan, OpKind};
pub use manifest::{Manifest, ManifestStatus, differing_keys, digest};
pub use replace::{is_temporary, replace_file};

#[cfg(test)]
mod test_support {
    /// A scratch directory, removed when dropped.
    pub(crate) struct Scratch(pub(crate) std::path::PathBuf);

    impl Scratch {
        pub(crate) fn new(tag: &str) -> Self {
            use std::sync::atomic::{AtomicU64, Ordering};
            static N: AtomicU64 = AtomicU64::new(0);
            let p = std::env::temp_dir().join(format!(
                "nprl-store-{tag}-{}-{}",
                std::process::id(),
                N.fetch_add(1, Ordering::Relaxed)
            ));
            let _ = std::fs::remove_dir_all(&p);
            std::fs::create_dir_all(&p).expect("scratch dir");
            Self(p)
        }
    }

    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
