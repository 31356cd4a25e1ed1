//! Crash-consistent results directories: what a program writes survives a
//! kill, a full disk or a second process, and a directory's settings never
//! change under its records.
//!
//! | item | what it guarantees |
//! |---|---|
//! | [`AppendLog`] | JSON lines appended whole (one write, then `sync_data`); a torn last line is moved aside to `LOG.torn-MS-PID` and reported on the next open |
//! | [`replace_file`] | a file holds its old or its new contents, never a mix: a uniquely named temporary file, synced, renamed, the directory synced; permissions kept; a symbolic link, device, FIFO, socket or directory at the path is refused, never written through or replaced |
//! | [`check_output`], [`remove_output`], [`create_output_dir`], [`remove_stale_temporaries`], [`DirLock`] | the rules of every output ([`output`]): no link followed, nothing but a regular file replaced, `--force` deletes links instead of writing through them, a killed writer's temporaries cleaned, one writer per directory |
//! | [`Manifest`] | a directory records the program, task and settings that made it, once; a program reopening it with another task or other settings is refused, naming the keys |
//! | [`Shard`] | one part of a grid for N machines or a Slurm job array (`--shard K/N`, or the array's variables), the contract `swingup experiments` and `nprl-bench` share |
//! | [`ScratchDir`] | a unique temporary directory removed on drop, for tests and examples |
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
// issue 51: no panic on user input in the programs' paths
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

mod append;
pub mod block;
pub mod error;
pub mod fault;
mod manifest;
pub mod output;
mod replace;
mod scratch;
pub mod shard;

pub use append::{AppendLog, LogContents, TornTail, read_log};
pub use block::with_block;
pub use error::{Result, StoreError};
pub use fault::{FaultGuard, FaultPlan, OpKind};
pub use manifest::{Manifest, ManifestStatus, differing_keys, digest};
pub use output::{
    DirLock, check_output, create_output_dir, create_output_subdir, remove_output, remove_stale_temporaries, shorten,
};
pub use replace::{is_temporary, replace_file};
pub use scratch::{ScratchDir, Sentinel, SmallDisk, output_within};
pub use shard::{Shard, ShardError};

/// The commit the workspace's code was built from, as results name it:
/// `commit <hash>` (7 hex digits), with `-dirty` when a tracked code file
/// (`*.rs`, `Cargo.toml`, `Cargo.lock`, the compiled-in data) differed from
/// that commit, or `an unknown commit` (built outside the workspace's git
/// checkout). Set at build time (`store/build.rs`): neither the directory a
/// program runs in nor a later commit changes it.
pub fn code_version() -> &'static str {
    env!("NPRL_CODE_VERSION")
}

/// A program's `--version` line: its package's version `package` (its
/// `CARGO_PKG_VERSION`) and the commit it was built from, `0.1.0 (commit
/// abc1234)`. Made once per process (a program has one version).
pub fn program_version(package: &str) -> &'static str {
    static VERSION: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    VERSION.get_or_init(|| format!("{package} ({})", code_version()))
}

/// [`code_version`] split into the commit's hash (`None` when unknown) and
/// whether the code was dirty.
pub fn parse_code_version(version: &str) -> (Option<&str>, bool) {
    match version.strip_prefix("commit ") {
        Some(rest) => match rest.strip_suffix("-dirty") {
            Some(hash) => (Some(hash), true),
            None => (Some(rest), false),
        },
        None => (None, false),
    }
}

#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;

#[cfg(test)]
mod tests {
    use super::*;

    /// The stamp names the checkout's commit (this test is built from it;
    /// `-dirty` when edited since), or says it is unknown without git.
    #[test]
    fn code_version_names_the_commit_built_from() {
        let v = code_version();
        assert_eq!(parse_code_version(v).0.is_some(), v != "an unknown commit");
        let head = std::process::Command::new("git")
            .args(["rev-parse", "--short=7", "HEAD"])
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .ok()
            .filter(|o| o.status.success())
            .and_then(|o| String::from_utf8(o.stdout).ok());
        match head {
            Some(head) => {
                let want = format!("commit {}", head.trim());
                assert!(v == want || v == format!("{want}-dirty"), "{v} against HEAD {head}");
            }
            None => assert_eq!(v, "an unknown commit"),
        }
    }

    #[test]
    fn code_versions_parse() {
        assert_eq!(parse_code_version("commit abc1234"), (Some("abc1234"), false));
        assert_eq!(parse_code_version("commit abc1234-dirty"), (Some("abc1234"), true));
        assert_eq!(parse_code_version("an unknown commit"), (None, false));
    }
}
