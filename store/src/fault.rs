//! Fault injection for tests: fail the Nth file system operation of some
//! kinds, as a full disk, a failing sync or a kill mid-write would.
//!
//! Every file system operation of this crate asks one internal check first (one
//! relaxed atomic load when no plan is installed), so a test in any crate
//! can install a [`FaultPlan`] and drive the crate's callers through every
//! failure in turn. Plans are process-wide; a plan limited to a directory
//! ([`FaultPlan::under`]) leaves the tests running beside it alone.
//!
//! ```
//! use store::{FaultPlan, OpKind, replace_file};
//!
//! let dir = std::env::temp_dir().join(format!("store-fault-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//! let file = dir.join("report.json");
//! replace_file(&file, b"old").unwrap();
//! {
//!     let _plan = store::fault::install(FaultPlan::fail_nth(1, &[OpKind::Rename]).under(&dir));
//!     assert!(replace_file(&file, b"new").is_err());
//! }
//! assert_eq!(std::fs::read(&file).unwrap(), b"old");
//! std::fs::remove_dir_all(&dir).unwrap();
//! ```

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

/// The kinds of file system operation the crate performs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum OpKind {
    /// Opening or creating a file or directory.
    Open,
    /// Reading a file or a directory's entries.
    Read,
    /// Writing bytes to a file.
    Write,
    /// `sync_data` or `sync_all` of a file or directory.
    Sync,
    /// Renaming a file into place.
    Rename,
    /// Truncating a file (`set_len`).
    Truncate,
    /// Deleting a file.
    Remove,
    /// Reading metadata or following a symbolic link.
    Metadata,
    /// Setting a file's permissions.
    Permissions,
}

impl OpKind {
    /// Every kind.
    pub const ALL: [OpKind; 9] = [
        OpKind::Open,
        OpKind::Read,
        OpKind::Write,
        OpKind::Sync,
        OpKind::Rename,
        OpKind::Truncate,
        OpKind::Remove,
        OpKind::Metadata,
        OpKind::Permissions,
    ];

    /// The kind's lowercase name (`write`), as [`FaultPlan::parse`] reads it.
    pub fn name(self) -> &'static str {
        match self {
            OpKind::Open => "open",
            OpKind::Read => "read",
            OpKind::Write => "write",
            OpKind::Sync => "sync",
            OpKind::Rename => "rename",
            OpKind::Truncate => "truncate",
            OpKind::Remove => "remove",
            OpKind::Metadata => "metadata",
            OpKind::Permissions => "permissions",
        }
    }
}

/// Which operations fail, and how.
///
/// | field | default | meaning |
/// |---|---|---|
/// | `kinds` | all | the kinds of operation counted (and failed) |
/// | `nth` | 1 | the first counted operation that fails, from 1 |
/// | `persist` | false | every counted operation after the `nth` fails too (a disk that stays full, a process that is gone) |
/// | `torn` | false | a failing write first writes the first half of its bytes (a write cut short) |
/// | `path_contains` | any path | count only operations on paths containing this text |
/// | `error` | `StorageFull` | the error kind returned |
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FaultPlan {
    /// The kinds of operation counted; empty counts every kind.
    pub kinds: Vec<OpKind>,
    /// The first counted operation that fails, from 1.
    pub nth: u64,
    /// Whether every counted operation after the `nth` fails too.
    pub persist: bool,
    /// Whether a failing write first writes the first half of its bytes.
    pub torn: bool,
    /// Count only operations on paths containing this text.
    pub path_contains: Option<String>,
    /// The error kind of an injected failure.
    pub error: std::io::ErrorKind,
}

impl Default for FaultPlan {
    fn default() -> Self {
        Self {
            kinds: Vec::new(),
            nth: 1,
            persist: false,
            torn: false,
            path_contains: None,
            error: std::io::ErrorKind::StorageFull,
        }
    }
}

impl FaultPlan {
    /// Fails the `nth` operation (from 1) of the `kinds` (all kinds when empty).
    pub fn fail_nth(nth: u64, kinds: &[OpKind]) -> Self {
        Self {
            kinds: kinds.to_vec(),
            nth,
            ..Self::default()
        }
    }

    /// Counts only operations on paths under `dir` (containing its text).
    #[must_use]
    pub fn under(mut self, dir: &Path) -> Self {
        self.path_contains = Some(dir.to_string_lossy().into_owned());
        self
    }

    /// Every counted operation from the `nth` on fails.
    #[must_use]
    pub fn persist(mut self) -> Self {
        self.persist = true;
        self
    }

    /// A failing write first writes half of its bytes.
    #[must_use]
    pub fn torn(mut self) -> Self {
        self.torn = true;
        self
    }

    /// Reads a plan from text such as `op=write,nth=3,persist,torn,path=runs.jsonl`
    /// (`op` repeatable, or `op=write+sync`; every key optional), as a
    /// program may take it from an environment variable for its tests
    /// ([`install_from_env`]).
    ///
    /// # Errors
    /// An unknown key or kind, or a count that is not a positive integer.
    pub fn parse(text: &str) -> Result<Self, String> {
        let mut plan = Self::default();
        for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (key, value) = item.split_once('=').unwrap_or((item, ""));
            match key {
                "op" => {
                    for name in value.split('+') {
                        let kind = OpKind::ALL
                            .into_iter()
                            .find(|k| k.name() == name)
                            .ok_or_else(|| format!("unknown operation {name:?} in fault plan {text:?}"))?;
                        plan.kinds.push(kind);
                    }
                }
                "nth" => {
                    plan.nth = value
                        .parse()
                        .ok()
                        .filter(|n| *n >= 1)
                        .ok_or_else(|| format!("nth must be a positive integer in fault plan {text:?}"))?;
                }
                "persist" => plan.persist = true,
                "torn" => plan.torn = true,
                "path" => plan.path_contains = Some(value.to_string()),
                _ => return Err(format!("unknown key {key:?} in fault plan {text:?}")),
            }
        }
        Ok(plan)
    }

    fn counts(&self, kind: OpKind, path: &Path) -> bool {
        (self.kinds.is_empty() || self.kinds.contains(&kind))
            && self
                .path_contains
                .as_deref()
                .is_none_or(|p| path.to_string_lossy().contains(p))
    }
}

struct Installed {
    id: u64,
    plan: FaultPlan,
    seen: AtomicU64,
    fired: AtomicU64,
}

static ACTIVE: AtomicUsize = AtomicUsize::new(0);
static NEXT_ID: AtomicU64 = AtomicU64::new(1);
static PLANS: Mutex<Vec<Arc<Installed>>> = Mutex::new(Vec::new());

/// An installed [`FaultPlan`]; dropping it removes the plan.
#[must_use = "the plan is removed when the guard is dropped"]
pub struct FaultGuard {
    installed: Arc<Installed>,
}

impl std::fmt::Debug for FaultGuard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FaultGuard")
            .field("plan", &self.installed.plan)
            .field("seen", &self.seen())
            .field("fired", &self.fired())
            .finish()
    }
}

impl FaultGuard {
    /// Operations the plan counted so far.
    pub fn seen(&self) -> u64 {
        self.installed.seen.load(Ordering::SeqCst)
    }

    /// Operations the plan failed so far.
    pub fn fired(&self) -> u64 {
        self.installed.fired.load(Ordering::SeqCst)
    }
}

impl Drop for FaultGuard {
    fn drop(&mut self) {
        let mut plans = PLANS.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        plans.retain(|p| p.id != self.installed.id);
        ACTIVE.store(plans.len(), Ordering::SeqCst);
    }
}

/// Installs `plan` until the returned guard is dropped (several plans may
/// be installed at once; an operation fails if any of them fails it).
pub fn install(plan: FaultPlan) -> FaultGuard {
    let installed = Arc::new(Installed {
        id: NEXT_ID.fetch_add(1, Ordering::Relaxed),
        plan,
        seen: AtomicU64::new(0),
        fired: AtomicU64::new(0),
    });
    let mut plans = PLANS.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    plans.push(Arc::clone(&installed));
    ACTIVE.store(plans.len(), Ordering::SeqCst);
    FaultGuard { installed }
}

/// Installs the plan in the environment variable `var` ([`FaultPlan::parse`]),
/// if it is set: a test of a program can fail its saves from outside.
///
/// # Errors
/// The variable holds no valid plan.
pub fn install_from_env(var: &str) -> Result<Option<FaultGuard>, String> {
    match std::env::var(var) {
        Ok(text) => Ok(Some(install(FaultPlan::parse(&text)?))),
        Err(_) => Ok(None),
    }
}

/// An injected failure.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Fault {
    pub(crate) kind: OpKind,
    pub(crate) torn: bool,
    error: std::io::ErrorKind,
}

impl Fault {
    pub(crate) fn error(self) -> std::io::Error {
        std::io::Error::new(self.error, format!("injected fault: {} failed", self.kind.name()))
    }
}

/// Whether the operation `kind` on `path` is to fail: the one place every
/// operation of the crate consults.
pub(crate) fn check(kind: OpKind, path: &Path) -> Option<Fault> {
    if ACTIVE.load(Ordering::Relaxed) == 0 {
        return None;
    }
    let plans: Vec<Arc<Installed>> = PLANS.lock().unwrap_or_else(std::sync::PoisonError::into_inner).clone();
    let mut fault = None;
    for p in plans.iter().filter(|p| p.plan.counts(kind, path)) {
        let n = p.seen.fetch_add(1, Ordering::SeqCst) + 1;
        if n == p.plan.nth || (p.plan.persist && n > p.plan.nth) {
            p.fired.fetch_add(1, Ordering::SeqCst);
            fault = Some(Fault {
                kind,
                torn: p.plan.torn,
                error: p.plan.error,
            });
        }
    }
    fault
}

/// Runs the file system operation `f` of kind `kind` on `path`, unless an
/// installed plan fails it.
pub(crate) fn op<T>(kind: OpKind, path: &Path, f: impl FnOnce() -> std::io::Result<T>) -> std::io::Result<T> {
    match check(kind, path) {
        Some(fault) => Err(fault.error()),
        None => f(),
    }
}

/// Writes all of `bytes` to `file` (at `path`), unless an installed plan
/// fails the write (a torn failure writes half of them first).
pub(crate) fn write_all(file: &mut std::fs::File, path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write as _;
    match check(OpKind::Write, path) {
        Some(fault) => {
            if fault.torn {
                let _ = file.write_all(&bytes[..bytes.len() / 2]);
            }
            Err(fault.error())
        }
        None => file.write_all(bytes),
    }
}

/// The directory holding `path` (`.` for a bare file name).
pub(crate) fn parent_dir(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Syncs the directory `dir`, so that a rename or a new file in it survives
/// a crash of the machine (on Unix; elsewhere a directory cannot be opened
/// as a file, and the rename's own durability is what there is).
pub(crate) fn sync_dir(dir: &Path) -> std::io::Result<()> {
    if cfg!(unix) {
        let d = op(OpKind::Open, dir, || std::fs::File::open(dir))?;
        op(OpKind::Sync, dir, || d.sync_all())
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plans_parse_and_count_only_their_kinds_and_paths() {
        let plan = FaultPlan::parse("op=write+sync,nth=2,persist,path=runs").expect("plan");
        assert_eq!(plan.kinds, vec![OpKind::Write, OpKind::Sync]);
        assert_eq!((plan.nth, plan.persist, plan.torn), (2, true, false));
        assert!(FaultPlan::parse("op=fly").is_err());
        assert!(FaultPlan::parse("nth=0").is_err());
        assert!(FaultPlan::parse("colour=red").is_err());

        let tag = format!("fault-unit-{}", std::process::id());
        let guard = install(FaultPlan::parse(&format!("op=write,nth=2,path={tag}")).expect("plan"));
        let mine = PathBuf::from(format!("/x/{tag}/f"));
        assert!(check(OpKind::Sync, &mine).is_none());
        assert!(check(OpKind::Write, Path::new("/elsewhere")).is_none());
        assert!(check(OpKind::Write, &mine).is_none());
        assert!(check(OpKind::Write, &mine).is_some());
        assert!(check(OpKind::Write, &mine).is_none(), "not persistent");
        assert_eq!((guard.seen(), guard.fired()), (3, 1));
        drop(guard);
        assert!(check(OpKind::Write, &mine).is_none());
    }
}
