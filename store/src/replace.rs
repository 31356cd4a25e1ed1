//! Atomic replacement of a whole file.

use std::fs::{self, OpenOptions};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Result, StoreError};
use crate::fault::{OpKind, op, parent_dir, sync_dir, write_all};

/// Temporary files created by this process so far (part of their names).
static COUNTER: AtomicU64 = AtomicU64::new(0);

/// At most this many bytes of a file's name go into its temporary file's
/// name, so that a valid long name (up to 255 bytes) stays valid.
const NAME_PREFIX: usize = 40;

/// Whether `name` is the name of one of [`replace_file`]'s temporary files
/// (`.NAME.tmp-PID-N-NANOS`, `NAME` cut to 40 bytes): a reader listing a
/// directory must skip them.
pub fn is_temporary(name: &str) -> bool {
    name.starts_with('.') && name.contains(".tmp-")
}

/// Replaces the contents of `path` with `bytes`, atomically: a reader (or
/// the file after a crash) sees either the old contents or the new ones,
/// never a mix.
///
/// The bytes go to a temporary file of a unique name in the same
/// directory (`.NAME.tmp-PID-N-NANOS`, `NAME` cut to its first 40 bytes,
/// created with `create_new`, so two processes or threads never share
/// one), which is synced, renamed over `path`, and the directory synced.
/// An existing file keeps its permissions. Nothing is written through a
/// link: a symbolic link at `path` (to anything), a device, a FIFO, a
/// socket or a directory is refused ([`StoreError::NotRegular`]) and left
/// as it is ([`crate::check_output`]; a program's `--force` deletes a link
/// first with [`crate::remove_output`]). On failure the temporary file is
/// removed (if that too fails, it is left under its temporary name, which
/// [`is_temporary`] tells readers to skip and
/// [`crate::remove_stale_temporaries`] deletes once its writer is gone)
/// and `path` is unchanged, unless only the final directory sync failed.
///
/// ```
/// let dir = std::env::temp_dir().join(format!("store-replace-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// let file = dir.join("report.json");
/// store::replace_file(&file, b"{\"runs\": 1}\n").unwrap();
/// store::replace_file(&file, b"{\"runs\": 2}\n").unwrap();
/// assert_eq!(std::fs::read_to_string(&file).unwrap(), "{\"runs\": 2}\n");
/// assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1); // no temporary file left
/// std::fs::remove_dir_all(&dir).unwrap();
/// ```
///
/// # Errors
/// [`StoreError::NotRegular`] naming `path`, or [`StoreError::Io`] naming
/// the file (the temporary one, or `path`) whose operation failed.
pub fn replace_file(path: &Path, bytes: &[u8]) -> Result<()> {
    let target = path.to_path_buf();
    let dir = parent_dir(&target);
    let permissions = crate::check_output(&target)?.map(|m| m.permissions());
    let name = target.file_name().unwrap_or_default().to_string_lossy();
    let mut cut = name.len().min(NAME_PREFIX);
    while !name.is_char_boundary(cut) {
        cut -= 1;
    }
    let name = name[..cut].to_string();
    let (tmp, mut file) = create_temporary(&dir, &name)?;
    let written = (|| {
        write_all(&mut file, &tmp, bytes).map_err(|e| StoreError::io("writing", &tmp, e))?;
        if let Some(p) = permissions {
            op(OpKind::Permissions, &tmp, || file.set_permissions(p))
                .map_err(|e| StoreError::io("setting the permissions of", &tmp, e))?;
        }
        op(OpKind::Sync, &tmp, || file.sync_all()).map_err(|e| StoreError::io("syncing", &tmp, e))?;
        drop(file);
        op(OpKind::Rename, &target, || fs::rename(&tmp, &target))
            .map_err(|e| StoreError::io("renaming into place", &target, e))
    })();
    if let Err(e) = written {
        let _ = op(OpKind::Remove, &tmp, || fs::remove_file(&tmp));
        return Err(e);
    }
    sync_dir(&dir).map_err(|e| StoreError::io("syncing the directory", &dir, e))
}

/// Creates a fresh temporary file for `name` in `dir`.
fn create_temporary(dir: &Path, name: &str) -> Result<(PathBuf, fs::File)> {
    let mut last = None;
    for _ in 0..16 {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        let tmp = dir.join(format!(
            ".{name}.tmp-{}-{}-{nanos}",
            std::process::id(),
            COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        match op(OpKind::Open, &tmp, || {
            OpenOptions::new().write(true).create_new(true).open(&tmp)
        }) {
            Ok(file) => return Ok((tmp, file)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => last = Some((tmp, e)),
            Err(e) => return Err(StoreError::io("creating", tmp, e)),
        }
    }
    let (tmp, e) = last.unwrap_or_else(|| (dir.join(name), std::io::Error::other("no temporary name")));
    Err(StoreError::io("creating", tmp, e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ScratchDir;
    use crate::fault::{FaultPlan, install};

    #[test]
    fn replaces_contents_and_leaves_nothing_else() {
        let dir = ScratchDir::new("replace-basic").expect("scratch dir");
        let f = dir.path().join("a.json");
        replace_file(&f, b"one").expect("create");
        replace_file(&f, b"two").expect("replace");
        assert_eq!(fs::read(&f).expect("read"), b"two");
        assert_eq!(fs::read_dir(dir.path()).expect("dir").count(), 1);
    }

    #[cfg(unix)]
    #[test]
    fn keeps_permissions_and_never_writes_through_a_link() {
        use std::os::unix::fs::PermissionsExt as _;
        let dir = ScratchDir::new("replace-link").expect("scratch dir");
        let real = dir.path().join("real.md");
        fs::write(&real, "old").expect("write");
        fs::set_permissions(&real, fs::Permissions::from_mode(0o600)).expect("chmod");
        replace_file(&real, b"new").expect("replace");
        let mode = fs::metadata(&real).expect("meta").permissions().mode() & 0o777;
        assert_eq!(mode, 0o600);
        let link = dir.path().join("README.md");
        std::os::unix::fs::symlink("real.md", &link).expect("symlink");
        let err = replace_file(&link, b"through").expect_err("a link");
        assert!(matches!(err, StoreError::NotRegular { .. }), "{err}");
        assert!(fs::symlink_metadata(&link).expect("link").file_type().is_symlink());
        assert_eq!(fs::read(&real).expect("read"), b"new");
        let sub = dir.path().join("sub.json");
        fs::create_dir(&sub).expect("mkdir");
        assert!(replace_file(&sub, b"x").is_err());
        assert!(sub.is_dir());
        assert_eq!(fs::read_dir(dir.path()).expect("dir").count(), 3, "no temporary left");
    }

    #[test]
    fn a_name_of_255_bytes_gets_a_short_temporary_name() {
        let dir = ScratchDir::new("replace-long").expect("scratch dir");
        let f = dir.path().join(format!("{}.json", "é".repeat(125)));
        replace_file(&f, b"long").expect("a valid name");
        assert_eq!(fs::read(&f).expect("read"), b"long");
    }

    #[test]
    fn threads_replacing_one_file_never_collide() {
        let dir = ScratchDir::new("replace-threads").expect("scratch dir");
        let f = dir.path().join("experiments.json");
        std::thread::scope(|s| {
            for t in 0..4 {
                let f = &f;
                s.spawn(move || {
                    for i in 0..50 {
                        replace_file(f, format!("{t}-{i}").as_bytes()).expect("replace");
                    }
                });
            }
        });
        assert_eq!(fs::read_dir(dir.path()).expect("dir").count(), 1);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(48))]

        /// Any contents, a failure at any operation (once or from then on,
        /// the write cut in half or not): the file holds the old or the new
        /// contents, whole, and the directory holds nothing else.
        #[test]
        fn a_replacement_under_any_failure_is_old_or_new(
            old in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..300),
            new in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..300),
            n in 1u64..12,
            persist in proptest::prelude::any::<bool>(),
            torn in proptest::prelude::any::<bool>(),
        ) {
            let dir = ScratchDir::new("replace-prop").expect("scratch dir");
            let f = dir.path().join("report.md");
            replace_file(&f, &old).expect("old");
            let mut plan = FaultPlan::fail_nth(n, &[]).under(dir.path());
            plan.persist = persist;
            plan.torn = torn;
            let guard = install(plan);
            let result = replace_file(&f, &new);
            let fired = guard.fired();
            drop(guard);
            let now = fs::read(&f).expect("read");
            proptest::prop_assert!(now == old || now == new);
            if fired == 0 {
                proptest::prop_assert!(result.is_ok());
                proptest::prop_assert_eq!(&now, &new);
            }
            let others: Vec<String> = fs::read_dir(dir.path())
                .expect("dir")
                .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
                .filter(|n| n != "report.md")
                .collect();
            // a temporary file is left only when its removal failed too, and
            // is then named as one, for readers to skip
            proptest::prop_assert!(others.iter().all(|n| is_temporary(n)), "{:?}", others);
            proptest::prop_assert!(others.is_empty() || persist, "{:?}", others);
        }
    }

    /// Under a failure at each operation in turn, the file holds the old or
    /// the new contents and no temporary file is left.
    #[test]
    fn a_failure_at_any_operation_leaves_old_or_new() {
        let dir = ScratchDir::new("replace-fault").expect("scratch dir");
        let f = dir.path().join("r.json");
        for n in 1.. {
            replace_file(&f, b"old contents").expect("old");
            let guard = install(FaultPlan::fail_nth(n, &[]).under(dir.path()).torn());
            let result = replace_file(&f, b"new contents, longer");
            let fired = guard.fired();
            drop(guard);
            let now = fs::read(&f).expect("read");
            assert!(now == b"old contents" || now == b"new contents, longer", "{now:?}");
            let names: Vec<String> = fs::read_dir(dir.path())
                .expect("dir")
                .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
                .collect();
            assert_eq!(names, vec!["r.json".to_string()], "op {n}");
            if fired == 0 {
                result.expect("no fault, no error");
                break;
            }
            assert!(result.is_err(), "op {n} failed silently");
        }
    }
}
