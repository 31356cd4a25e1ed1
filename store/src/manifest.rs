//! A results directory's write-once manifest: which program made it, for
//! which task, with which settings.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Result, StoreError};
use crate::fault::{OpKind, op};
use crate::replace::replace_file;

/// What made a results directory: written once when the directory is
/// created ([`Manifest::create_or_check`]), checked by every later program
/// that opens it, and never rewritten by one that is refused or fails.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// The program (and subcommand) that made the directory, e.g. `swingup experiments`.
    pub program: String,
    /// The task its records are of, e.g. `pendulum`.
    pub task: String,
    /// The settings every record of the directory was made with.
    pub settings: serde_json::Value,
    /// The code that created the directory (a commit), for provenance
    /// only: it is not compared.
    pub created_by_commit: String,
    /// What part of the task the records cover (a shard of a grid, the
    /// runs it plans), when the directory holds one part of several; not
    /// compared by [`Manifest::check_against`]. Absent from manifests
    /// written without one, which read back as `None`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scope: Option<serde_json::Value>,
}

/// What [`Manifest::create_or_check`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ManifestStatus {
    /// There was no manifest: it was written.
    Created,
    /// The manifest there records the same program, task and settings.
    Matches,
}

impl Manifest {
    /// A manifest of `settings` (serialised to JSON).
    ///
    /// # Errors
    /// The settings cannot be serialised ([`StoreError::Serialize`], naming `path`
    /// as the file they were meant for).
    pub fn new(
        program: &str,
        task: &str,
        settings: &impl Serialize,
        created_by_commit: &str,
        path: &Path,
    ) -> Result<Self> {
        Ok(Self {
            program: program.into(),
            task: task.into(),
            settings: serde_json::to_value(settings).map_err(|e| StoreError::Serialize {
                path: path.to_path_buf(),
                message: e.to_string(),
            })?,
            created_by_commit: created_by_commit.into(),
            scope: None,
        })
    }

    /// Reads the manifest `path`; `None` if there is none.
    ///
    /// # Errors
    /// The file cannot be read, or is not a manifest ([`StoreError::BadManifest`]).
    pub fn read(path: &Path) -> Result<Option<Self>> {
        crate::check_output(path)?;
        let bytes = match op(OpKind::Read, path, || std::fs::read(path)) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(StoreError::io("reading", path, e)),
        };
        serde_json::from_slice(&bytes)
            .map(Some)
            .map_err(|e| StoreError::BadManifest {
                path: path.to_path_buf(),
                message: e.to_string(),
            })
    }

    /// Writes the manifest to `path`, replacing any ([`replace_file`]): for
    /// a directory started over on the user's explicit request only.
    ///
    /// # Errors
    /// The file cannot be written.
    pub fn write(&self, path: &Path) -> Result<()> {
        let mut text = serde_json::to_vec_pretty(self).map_err(|e| StoreError::Serialize {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        text.push(b'\n');
        replace_file(path, &text)
    }

    /// Checks that `saved` (read from `path`) records this manifest's
    /// program, task and settings.
    ///
    /// # Errors
    /// [`StoreError::TaskMismatch`] or [`StoreError::SettingsMismatch`]
    /// (naming the keys that differ).
    pub fn check_against(&self, saved: &Manifest, path: &Path) -> Result<()> {
        if saved.program != self.program || saved.task != self.task {
            return Err(StoreError::TaskMismatch {
                path: path.to_path_buf(),
                saved_program: saved.program.clone(),
                saved_task: saved.task.clone(),
                program: self.program.clone(),
                task: self.task.clone(),
            });
        }
        let keys = differing_keys(&saved.settings, &self.settings);
        match keys.first() {
            None => Ok(()),
            Some(first) => {
                let at = |v: &serde_json::Value| lookup(v, first).map_or("(absent)".to_string(), ToString::to_string);
                Err(StoreError::SettingsMismatch {
                    path: path.to_path_buf(),
                    first: format!("{first} saved {}, now {}", at(&saved.settings), at(&self.settings)),
                    keys,
                })
            }
        }
    }

    /// Writes this manifest to `path` if there is none, or checks the one
    /// there ([`Manifest::check_against`]); a manifest that differs is left
    /// as it is.
    ///
    /// ```
    /// use store::{Manifest, ManifestStatus, StoreError};
    ///
    /// let dir = std::env::temp_dir().join(format!("store-manifest-doc-{}", std::process::id()));
    /// std::fs::create_dir_all(&dir).unwrap();
    /// let path = dir.join("manifest.json");
    /// let settings = serde_json::json!({"seeds": 2, "max_trials": 4});
    /// let m = Manifest::new("swingup experiments", "pendulum", &settings, "abc1234", &path).unwrap();
    /// assert_eq!(m.create_or_check(&path).unwrap(), ManifestStatus::Created);
    /// assert_eq!(m.create_or_check(&path).unwrap(), ManifestStatus::Matches);
    /// let other = serde_json::json!({"seeds": 2, "max_trials": 3});
    /// let m2 = Manifest::new("swingup experiments", "pendulum", &other, "abc1234", &path).unwrap();
    /// match m2.create_or_check(&path) {
    ///     Err(StoreError::SettingsMismatch { keys, .. }) => assert_eq!(keys, vec!["max_trials"]),
    ///     other => panic!("{other:?}"),
    /// }
    /// std::fs::remove_dir_all(&dir).unwrap();
    /// ```
    ///
    /// # Errors
    /// The file cannot be read or written, is not a manifest, or records
    /// another program, task or settings.
    pub fn create_or_check(&self, path: &Path) -> Result<ManifestStatus> {
        match Self::read(path)? {
            Some(saved) => self.check_against(&saved, path).map(|()| ManifestStatus::Matches),
            None => self.write(path).map(|()| ManifestStatus::Created),
        }
    }

    /// A short fingerprint of the settings (16 hex digits, FNV-1a over their
    /// JSON), for records to carry so that a record is never read under
    /// other settings than it was made with.
    pub fn settings_digest(&self) -> String {
        digest(self.settings.to_string().as_bytes())
    }
}

/// FNV-1a (64 bits) of `bytes`, as 16 hex digits: a stable fingerprint
/// (not a cryptographic one).
pub fn digest(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// The value at the dotted `key` of `v`.
fn lookup<'a>(v: &'a serde_json::Value, key: &str) -> Option<&'a serde_json::Value> {
    if key == "(all)" {
        return Some(v);
    }
    key.split('.').try_fold(v, |v, k| v.get(k))
}

/// The dotted keys (`cartpole.max_trials`) whose values differ between
/// `a` and `b`, sorted; two values that are not both objects differ as
/// their key (`(all)` at the top).
pub fn differing_keys(a: &serde_json::Value, b: &serde_json::Value) -> Vec<String> {
    fn walk(prefix: &str, a: &serde_json::Value, b: &serde_json::Value, out: &mut Vec<String>) {
        match (a.as_object(), b.as_object()) {
            (Some(a), Some(b)) => {
                let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
                keys.sort();
                keys.dedup();
                for k in keys {
                    let name = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    match (a.get(k), b.get(k)) {
                        (Some(x), Some(y)) => walk(&name, x, y, out),
                        _ => out.push(name),
                    }
                }
            }
            _ if a != b => out.push(if prefix.is_empty() {
                "(all)".into()
            } else {
                prefix.into()
            }),
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk("", a, b, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ScratchDir;
    use crate::fault::{FaultPlan, install};
    use serde_json::json;

    fn manifest(task: &str, settings: serde_json::Value) -> Manifest {
        Manifest::new("swingup learn", task, &settings, "c0ffee0", Path::new("m.json")).expect("manifest")
    }

    #[test]
    fn another_task_or_settings_is_refused_and_the_manifest_kept() {
        let dir = ScratchDir::new("manifest").expect("scratch dir");
        let path = dir.path().join("manifest.json");
        let m = manifest("pendulum", json!({"seed": 1, "planner": {"lambda": 1000.0}}));
        assert_eq!(m.create_or_check(&path).expect("create"), ManifestStatus::Created);
        let before = std::fs::read(&path).expect("read");
        let e = manifest("cartpole", m.settings.clone())
            .create_or_check(&path)
            .expect_err("task");
        assert!(matches!(e, StoreError::TaskMismatch { .. }), "{e}");
        assert!(e.to_string().contains("cartpole"), "{e}");
        let e = manifest("pendulum", json!({"seed": 1, "planner": {"lambda": 0.0}}))
            .create_or_check(&path)
            .expect_err("settings")
            .to_string();
        assert!(
            e.contains("planner.lambda differs") && e.contains("manifest.json"),
            "{e}"
        );
        assert!(e.contains("saved 1000.0, now 0.0"), "{e}");
        assert_eq!(std::fs::read(&path).expect("read"), before);
    }

    #[test]
    fn a_manifest_that_cannot_be_written_is_absent() {
        let dir = ScratchDir::new("manifest-fault").expect("scratch dir");
        let path = dir.path().join("manifest.json");
        let guard = install(FaultPlan::fail_nth(1, &[OpKind::Rename]).under(dir.path()));
        assert!(manifest("pendulum", json!({})).create_or_check(&path).is_err());
        drop(guard);
        assert!(Manifest::read(&path).expect("read").is_none());
    }

    #[test]
    fn digests_differ_with_the_settings() {
        let a = manifest("pendulum", json!({"max_trials": 1}));
        let b = manifest("pendulum", json!({"max_trials": 3}));
        assert_ne!(a.settings_digest(), b.settings_digest());
        assert_eq!(a.settings_digest().len(), 16);
        assert_eq!(digest(b""), "cbf29ce484222325");
    }
}
