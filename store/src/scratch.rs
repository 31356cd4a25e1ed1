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

/// A tree of files outside a program's output directory, for tests that
/// plant links to it among the outputs: [`Sentinel::snapshot`] records
/// every entry's type, mode and contents, and [`Sentinel::changes`] lists
/// what differs since. It holds a regular file `victim.txt` (mode 600), a
/// directory `dir/` with a file, and, when the test runs as root (`mknod`
/// works), `null` and `full`: character devices with the numbers of
/// `/dev/null` and `/dev/full`, so that a program writing through a link
/// to a device is caught without risking the system's own devices.
///
/// ```
/// let s = store::Sentinel::new("sentinel-doc")?;
/// let before = s.snapshot();
/// std::fs::write(s.victim(), "overwritten")?;
/// assert_eq!(s.changes(&before), vec!["victim.txt: contents changed".to_string()]);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug)]
pub struct Sentinel {
    dir: ScratchDir,
    devices: bool,
}

/// One entry of a [`Sentinel`] tree: (type, mode, contents digest).
type Entry = (String, u32, String);

impl Sentinel {
    /// Makes the tree in a fresh scratch directory.
    ///
    /// # Errors
    /// The tree cannot be created.
    pub fn new(tag: &str) -> Result<Self> {
        let dir = ScratchDir::new(tag)?;
        let p = dir.path();
        let io = |what: &Path, e| StoreError::io("creating", what, e);
        std::fs::write(p.join("victim.txt"), "the user's own file\n").map_err(|e| io(&p.join("victim.txt"), e))?;
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt as _;
            std::fs::set_permissions(p.join("victim.txt"), std::fs::Permissions::from_mode(0o600))
                .map_err(|e| io(&p.join("victim.txt"), e))?;
        }
        std::fs::create_dir(p.join("dir")).map_err(|e| io(&p.join("dir"), e))?;
        std::fs::write(p.join("dir/kept.txt"), "kept\n").map_err(|e| io(&p.join("dir/kept.txt"), e))?;
        let mknod = |name: &str, minor: &str| {
            std::process::Command::new("mknod")
                .arg(p.join(name))
                .args(["c", "1", minor])
                .stderr(std::process::Stdio::null())
                .status()
                .is_ok_and(|s| s.success())
        };
        let devices = mknod("null", "3") && mknod("full", "7");
        Ok(Self { dir, devices })
    }

    /// The tree's root.
    pub fn path(&self) -> &Path {
        self.dir.path()
    }

    /// The regular file `victim.txt`.
    pub fn victim(&self) -> PathBuf {
        self.path().join("victim.txt")
    }

    /// The character devices `null` and `full`, when they could be made
    /// (as root).
    pub fn devices(&self) -> Option<(PathBuf, PathBuf)> {
        self.devices
            .then(|| (self.path().join("null"), self.path().join("full")))
    }

    /// Every entry of the tree, by relative path: its type, permission
    /// bits and (for a regular file) the digest of its contents.
    pub fn snapshot(&self) -> std::collections::BTreeMap<String, Entry> {
        fn walk(root: &Path, dir: &Path, out: &mut std::collections::BTreeMap<String, Entry>) {
            let Ok(entries) = std::fs::read_dir(dir) else { return };
            for entry in entries.flatten() {
                let path = entry.path();
                let Ok(m) = std::fs::symlink_metadata(&path) else {
                    continue;
                };
                let rel = path.strip_prefix(root).unwrap_or(&path).display().to_string();
                #[cfg(unix)]
                let mode = std::os::unix::fs::PermissionsExt::mode(&m.permissions());
                #[cfg(not(unix))]
                let mode = 0;
                let kind = crate::output::describe(&m.file_type()).to_string();
                let digest = if m.file_type().is_file() {
                    std::fs::read(&path).map(|b| crate::digest(&b)).unwrap_or_default()
                } else {
                    String::new()
                };
                out.insert(rel, (kind, mode, digest));
                if m.file_type().is_dir() {
                    walk(root, &path, out);
                }
            }
        }
        let mut out = std::collections::BTreeMap::new();
        walk(self.path(), self.path(), &mut out);
        out
    }

    /// Panics, naming `what` and every change, unless the tree is as it
    /// was in `before` (for tests).
    pub fn assert_unchanged(&self, before: &std::collections::BTreeMap<String, Entry>, what: impl std::fmt::Display) {
        let changes = self.changes(before);
        assert!(changes.is_empty(), "{what}: outside the output directory, {changes:?}");
    }

    /// What differs between `before` and the tree now, one line per entry
    /// (empty when nothing changed).
    pub fn changes(&self, before: &std::collections::BTreeMap<String, Entry>) -> Vec<String> {
        let now = self.snapshot();
        let mut out = Vec::new();
        for (name, was) in before {
            match now.get(name) {
                None => out.push(format!("{name}: removed")),
                Some(is) if is.0 != was.0 => out.push(format!("{name}: was {}, is {}", was.0, is.0)),
                Some(is) if is.1 != was.1 => out.push(format!("{name}: mode {:o} became {:o}", was.1, is.1)),
                Some(is) if is.2 != was.2 => out.push(format!("{name}: contents changed")),
                Some(_) => {}
            }
        }
        out.extend(
            now.keys()
                .filter(|k| !before.contains_key(*k))
                .map(|k| format!("{k}: added")),
        );
        out
    }
}

/// Runs `command` to its end with its standard output and error captured,
/// killing it after `limit` (a test of a program that might block, on a
/// FIFO for instance, fails instead of hanging). Returns its output and
/// whether it finished in time.
///
/// # Errors
/// The program cannot be started or waited for.
pub fn output_within(
    command: &mut std::process::Command,
    limit: std::time::Duration,
) -> std::io::Result<(std::process::Output, bool)> {
    use std::io::Read as _;
    let mut child = command
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()?;
    // drain both pipes beside the wait, so a chatty child never blocks on them
    let mut out = child.stdout.take();
    let mut err = child.stderr.take();
    let reader = std::thread::spawn(move || {
        let mut o = Vec::new();
        if let Some(s) = out.as_mut() {
            let _ = s.read_to_end(&mut o);
        }
        o
    });
    let err_reader = std::thread::spawn(move || {
        let mut e = Vec::new();
        if let Some(s) = err.as_mut() {
            let _ = s.read_to_end(&mut e);
        }
        e
    });
    let started = std::time::Instant::now();
    let (status, in_time) = loop {
        if let Some(status) = child.try_wait()? {
            break (status, true);
        }
        if started.elapsed() > limit {
            let _ = child.kill();
            break (child.wait()?, false);
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let stdout = reader.join().unwrap_or_default();
    let stderr = err_reader.join().unwrap_or_default();
    Ok((std::process::Output { status, stdout, stderr }, in_time))
}

/// A small file system of `bytes` bytes mounted (tmpfs) on a scratch
/// directory, for tests of a full disk; unmounted when dropped. `None`
/// where it cannot be mounted (not root, or no `mount`): such a test is
/// skipped there.
#[derive(Debug)]
pub struct SmallDisk {
    dir: ScratchDir,
}

impl SmallDisk {
    /// Mounts a tmpfs of `bytes` bytes, if this process may.
    pub fn mount(tag: &str, bytes: u64) -> Option<Self> {
        let dir = ScratchDir::new(tag).ok()?;
        let mounted = std::process::Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={bytes}"), "tmpfs"])
            .arg(dir.path())
            .stderr(std::process::Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        mounted.then_some(Self { dir })
    }

    /// The mounted directory.
    pub fn path(&self) -> &Path {
        self.dir.path()
    }
}

impl Drop for SmallDisk {
    fn drop(&mut self) {
        let _ = std::process::Command::new("umount").arg(self.dir.path()).status();
    }
}
