//! The rules every output of the workspace's programs follows: nothing is
//! written through a symbolic link, nothing but a regular file is replaced,
//! and a directory is locked by the program writing into it.
//!
//! | item | rule |
//! |---|---|
//! | [`check_output`] | what is at an output path may be replaced: nothing, or a regular file; a symbolic link, a device, a FIFO, a socket or a directory is refused, naming it |
//! | [`remove_output`] | `--force`: deletes a regular file or a link itself (never its target); refuses anything else |
//! | [`create_output_dir`] | creates an output directory; what is at its path must be a directory (a link to one the user named is followed; a dangling link or a file is refused, naming it) |
//! | [`remove_stale_temporaries`] | deletes the temporary files a killed writer left in a directory |
//! | [`DirLock`] | an exclusive lock on a directory, released when dropped or when the process ends |

use std::fs;
use std::path::{Path, PathBuf};

use crate::error::{Result, StoreError};
use crate::fault::{OpKind, op};

/// What a file type is, in words (`a symbolic link`, `a FIFO (named pipe)`), as errors say it.
pub fn describe(file_type: &fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt as _;
        if file_type.is_block_device() {
            return "a block device";
        }
        if file_type.is_char_device() {
            return "a character device";
        }
        if file_type.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if file_type.is_socket() {
            return "a socket";
        }
    }
    if file_type.is_symlink() {
        "a symbolic link"
    } else if file_type.is_dir() {
        "a directory"
    } else if file_type.is_file() {
        "a regular file"
    } else {
        "not a regular file"
    }
}

fn refused(path: &Path, file_type: &fs::FileType) -> StoreError {
    let link = file_type
        .is_symlink()
        .then(|| fs::read_link(path).ok())
        .flatten()
        .map(|t| format!(" to {}", t.display()))
        .unwrap_or_default();
    StoreError::NotRegular {
        path: path.to_path_buf(),
        found: format!("{}{link}", describe(file_type)),
    }
}

/// Checks that an output may be written at `path`: returns `None` when
/// nothing is there and the file's metadata when it is a regular file.
/// Links are not followed: a symbolic link (to anything), a device, a
/// FIFO, a socket or a directory at `path` is refused
/// ([`StoreError::NotRegular`], naming the path and what it is).
///
/// ```
/// let dir = store::ScratchDir::new("check-output-doc").unwrap();
/// let file = dir.path().join("report.md");
/// assert!(store::check_output(&file).unwrap().is_none());
/// std::fs::write(&file, "old").unwrap();
/// assert!(store::check_output(&file).unwrap().is_some());
/// # #[cfg(unix)] {
/// let link = dir.path().join("link.md");
/// std::os::unix::fs::symlink("/dev/null", &link).unwrap();
/// let err = store::check_output(&link).unwrap_err();
/// assert!(err.to_string().contains("symbolic link to /dev/null"), "{err}");
/// # }
/// ```
///
/// # Errors
/// [`StoreError::NotRegular`], or the metadata cannot be read.
pub fn check_output(path: &Path) -> Result<Option<fs::Metadata>> {
    match op(OpKind::Metadata, path, || fs::symlink_metadata(path)) {
        Ok(m) if m.file_type().is_file() => Ok(Some(m)),
        Ok(m) => Err(refused(path, &m.file_type())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(StoreError::io("reading the metadata of", path, e)),
    }
}

/// Deletes the output `path` for a program's `--force`: a regular file or
/// a symbolic link itself (never the link's target). Returns whether
/// something was deleted. A device, FIFO, socket or directory is refused
/// ([`StoreError::NotRegular`]): `--force` never deletes what a program
/// did not write.
///
/// # Errors
/// [`StoreError::NotRegular`], or the removal fails.
pub fn remove_output(path: &Path) -> Result<bool> {
    match op(OpKind::Metadata, path, || fs::symlink_metadata(path)) {
        Ok(m) if m.file_type().is_file() || m.file_type().is_symlink() => {
            op(OpKind::Remove, path, || fs::remove_file(path)).map_err(|e| StoreError::io("deleting", path, e))?;
            Ok(true)
        }
        Ok(m) => Err(refused(path, &m.file_type())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(false),
        Err(e) => Err(StoreError::io("reading the metadata of", path, e)),
    }
}

/// Creates the output directory `dir` and its parents. The path a user
/// names may be a symbolic link to an existing directory (it is followed,
/// as `cd` would); a dangling link, or anything that is not a directory,
/// is refused ([`StoreError::NotRegular`] naming it). Directories inside
/// an output directory are created by [`create_output_subdir`], which
/// follows no link.
///
/// # Errors
/// [`StoreError::NotRegular`], or the directory cannot be created.
pub fn create_output_dir(dir: &Path) -> Result<()> {
    match op(OpKind::Metadata, dir, || fs::metadata(dir)) {
        Ok(m) if m.is_dir() => return Ok(()),
        Ok(m) => return Err(refused(dir, &m.file_type())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(StoreError::io("reading the metadata of", dir, e)),
    }
    if let Ok(m) = fs::symlink_metadata(dir) {
        // the path exists but its target does not: a dangling link
        return Err(StoreError::NotRegular {
            path: dir.to_path_buf(),
            found: format!(
                "{} whose target{} does not exist",
                describe(&m.file_type()),
                fs::read_link(dir)
                    .map(|t| format!(" {}", t.display()))
                    .unwrap_or_default()
            ),
        });
    }
    op(OpKind::Open, dir, || fs::create_dir_all(dir)).map_err(|e| StoreError::io("creating", dir, e))
}

/// Creates the directory `dir` inside an output directory (its parent
/// must exist): a symbolic link or anything but a directory at `dir` is
/// refused, naming it, so that nothing is written through a link planted
/// among a program's outputs.
///
/// # Errors
/// [`StoreError::NotRegular`], or the directory cannot be created.
pub fn create_output_subdir(dir: &Path) -> Result<()> {
    match op(OpKind::Metadata, dir, || fs::symlink_metadata(dir)) {
        Ok(m) if m.is_dir() => Ok(()),
        Ok(m) => Err(refused(dir, &m.file_type())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => match fs::create_dir(dir) {
            Ok(()) => Ok(()),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => create_output_subdir(dir),
            Err(e) => Err(StoreError::io("creating", dir, e)),
        },
        Err(e) => Err(StoreError::io("reading the metadata of", dir, e)),
    }
}

/// The process id a temporary file's name records, if `name` is one of
/// [`replace_file`](crate::replace_file)'s temporary files.
fn temporary_pid(name: &str) -> Option<u32> {
    let rest = name.strip_prefix('.')?;
    let tail = &rest[rest.rfind(".tmp-")? + ".tmp-".len()..];
    let mut parts = tail.split('-');
    let pid = parts.next()?.parse().ok()?;
    let numbers = parts.collect::<Vec<_>>();
    (numbers.len() == 2
        && numbers
            .iter()
            .all(|p| !p.is_empty() && p.bytes().all(|b| b.is_ascii_digit())))
    .then_some(pid)
}

/// Whether the process `pid` is running: on Linux, whether `/proc/PID`
/// exists; elsewhere (no `/proc`) every process is taken to be running,
/// so nothing is deleted.
fn process_alive(pid: u32) -> bool {
    let proc_root = Path::new("/proc/self");
    if !proc_root.exists() {
        return true;
    }
    pid == std::process::id() || Path::new("/proc").join(pid.to_string()).exists()
}

/// Deletes the temporary files that [`replace_file`](crate::replace_file)
/// left in `dir` when the process writing them was killed (their names
/// record its process id, and that process is gone). Only regular files
/// with such names are deleted; returns their paths. Where running
/// processes cannot be listed (no `/proc`), nothing is deleted.
///
/// # Errors
/// The directory cannot be listed, or a stale file cannot be deleted.
pub fn remove_stale_temporaries(dir: &Path) -> Result<Vec<PathBuf>> {
    let entries = match op(OpKind::Read, dir, || fs::read_dir(dir)) {
        Ok(entries) => entries,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(StoreError::io("listing", dir, e)),
    };
    let mut removed = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| StoreError::io("listing", dir, e))?;
        let name = entry.file_name();
        let Some(pid) = name.to_str().and_then(temporary_pid) else {
            continue;
        };
        let path = entry.path();
        let regular = fs::symlink_metadata(&path).is_ok_and(|m| m.file_type().is_file());
        if regular && !process_alive(pid) {
            op(OpKind::Remove, &path, || fs::remove_file(&path))
                .map_err(|e| StoreError::io("deleting the stale temporary file", &path, e))?;
            removed.push(path);
        }
    }
    Ok(removed)
}

/// An exclusive lock on a directory, held until the value is dropped or
/// the process ends (however it ends: the operating system releases it).
#[derive(Debug)]
pub struct DirLock {
    path: PathBuf,
    _file: fs::File,
}

impl DirLock {
    /// Takes the exclusive lock on the file `name` in the existing
    /// directory `dir` (created empty if missing; a link or a non-regular
    /// file there is refused), waiting at most `patience`: a lock is shared
    /// with a child process between its fork and its exec, so a lock just
    /// released can stay held for a moment.
    ///
    /// ```
    /// let dir = store::ScratchDir::new("lock-doc").unwrap();
    /// let held = store::DirLock::acquire(dir.path(), ".demo.lock", std::time::Duration::ZERO).unwrap();
    /// let again = store::DirLock::acquire(dir.path(), ".demo.lock", std::time::Duration::ZERO);
    /// assert!(matches!(again, Err(store::StoreError::Locked { .. })));
    /// drop(held);
    /// store::DirLock::acquire(dir.path(), ".demo.lock", std::time::Duration::ZERO).unwrap();
    /// ```
    ///
    /// # Errors
    /// [`StoreError::Locked`] when another process (or another lock in
    /// this one) holds it; [`StoreError::NotRegular`] or an I/O error
    /// naming the lock file.
    pub fn acquire(dir: &Path, name: &str, patience: std::time::Duration) -> Result<Self> {
        let path = dir.join(name);
        check_output(&path)?;
        let file = open_no_follow(&path, fs::OpenOptions::new().create(true).truncate(false).write(true))
            .map_err(|e| StoreError::io("opening the lock file", &path, e))?;
        let waited = std::time::Instant::now();
        loop {
            match file.try_lock() {
                Ok(()) => return Ok(Self { path, _file: file }),
                Err(fs::TryLockError::WouldBlock) if waited.elapsed() < patience => {
                    std::thread::sleep(std::time::Duration::from_millis(50));
                }
                Err(fs::TryLockError::WouldBlock) => {
                    return Err(StoreError::Locked {
                        dir: dir.to_path_buf(),
                        path,
                    });
                }
                Err(fs::TryLockError::Error(e)) => return Err(StoreError::io("locking", &path, e)),
            }
        }
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// Opens `path` with `options`, never through a symbolic link at its last
/// component (`O_NOFOLLOW` on Unix), and checks that what was opened is a
/// regular file.
pub(crate) fn open_no_follow(path: &Path, options: &mut fs::OpenOptions) -> std::io::Result<fs::File> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt as _;
        // O_NONBLOCK: a FIFO swapped in after the check must not block the open
        options.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(|e| {
        if fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) {
            std::io::Error::other("it is a symbolic link; outputs are never written through links")
        } else {
            e
        }
    })?;
    let file_type = file.metadata()?.file_type();
    if !file_type.is_file() {
        return Err(std::io::Error::other(format!(
            "it is {}, not a regular file",
            describe(&file_type)
        )));
    }
    Ok(file)
}

/// The longest input an error message echoes ([`shorten`]).
pub const ECHO_LIMIT: usize = 200;

/// `text` as an error message echoes it: whole up to [`ECHO_LIMIT`]
/// bytes, else its start (cut at a character boundary) and how long it
/// was, so that a 1 MB cell or a 200 KB line never floods a terminal.
///
/// ```
/// assert_eq!(store::shorten("x1"), "x1");
/// let long = "9".repeat(1_000_000);
/// let s = store::shorten(&long);
/// assert!(s.len() < 300 && s.ends_with("(1000000 bytes in all)"), "{s}");
/// ```
pub fn shorten(text: &str) -> std::borrow::Cow<'_, str> {
    if text.len() <= ECHO_LIMIT {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut cut = ECHO_LIMIT;
    while !text.is_char_boundary(cut) {
        cut -= 1;
    }
    std::borrow::Cow::Owned(format!("{}... ({} bytes in all)", &text[..cut], text.len()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ScratchDir;

    #[test]
    fn temporary_names_are_recognised_strictly() {
        assert_eq!(temporary_pid(".report.md.tmp-123-4-567"), Some(123));
        assert_eq!(temporary_pid(".a.tmp-b.tmp-9-1-2"), Some(9));
        assert_eq!(temporary_pid("report.md.tmp-123-4-567"), None);
        assert_eq!(temporary_pid(".report.md.tmp-123-4"), None);
        assert_eq!(temporary_pid(".report.md.tmp-x-4-5"), None);
        assert_eq!(temporary_pid(".report.md.tmp-1-4-5x"), None);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn stale_temporaries_of_dead_processes_are_removed_and_nothing_else() {
        let dir = ScratchDir::new("stale-tmp").expect("scratch");
        // a pid above the kernel's maximum is never running
        let dead = dir.path().join(".runs.json.tmp-4194305-0-1");
        let mine = dir.path().join(format!(".runs.json.tmp-{}-0-1", std::process::id()));
        let user = dir.path().join("notes.tmp-1-2-3");
        for f in [&dead, &mine, &user] {
            fs::write(f, "x").expect("write");
        }
        let link = dir.path().join(".x.tmp-4194305-0-2");
        std::os::unix::fs::symlink(&user, &link).expect("link");
        let removed = remove_stale_temporaries(dir.path()).expect("clean");
        assert_eq!(removed, vec![dead.clone()]);
        assert!(!dead.exists() && mine.exists() && user.exists());
        assert!(fs::symlink_metadata(&link).is_ok(), "a link is not ours to delete");
    }

    #[cfg(unix)]
    #[test]
    fn links_and_special_files_are_refused_and_force_deletes_links_only() {
        let dir = ScratchDir::new("check-output").expect("scratch");
        let target = dir.path().join("target.txt");
        fs::write(&target, "keep").expect("write");
        let link = dir.path().join("out.json");
        std::os::unix::fs::symlink(&target, &link).expect("link");
        let err = check_output(&link).expect_err("a link");
        assert!(err.to_string().contains("symbolic link"), "{err}");
        let sub = dir.path().join("sub");
        fs::create_dir(&sub).expect("mkdir");
        assert!(
            check_output(&sub)
                .expect_err("a dir")
                .to_string()
                .contains("a directory")
        );
        assert!(remove_output(&sub).is_err());
        assert!(remove_output(&link).expect("remove"));
        assert!(fs::symlink_metadata(&link).is_err());
        assert_eq!(fs::read_to_string(&target).expect("read"), "keep");
        assert!(!remove_output(&link).expect("nothing there"));
        // a dangling link as an output directory, a file as one
        let dangling = dir.path().join("gone");
        std::os::unix::fs::symlink(dir.path().join("missing"), &dangling).expect("link");
        let err = create_output_dir(&dangling).expect_err("dangling");
        assert!(err.to_string().contains("does not exist"), "{err}");
        assert!(create_output_dir(&target).is_err());
        // a link to a directory inside an output directory
        let inner = dir.path().join("inner");
        std::os::unix::fs::symlink(&sub, &inner).expect("link");
        assert!(create_output_subdir(&inner).is_err());
        create_output_subdir(&dir.path().join("new")).expect("subdir");
        assert!(dir.path().join("new").is_dir());
    }

    #[cfg(unix)]
    #[test]
    fn a_fifo_is_refused_without_blocking() {
        let dir = ScratchDir::new("fifo-output").expect("scratch");
        let fifo = dir.path().join("runs.json");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            return; // no mkfifo here: nothing to test
        }
        let err = check_output(&fifo).expect_err("a fifo");
        assert!(err.to_string().contains("FIFO"), "{err}");
        let err = open_no_follow(&fifo, fs::OpenOptions::new().read(true).append(true)).expect_err("a fifo");
        assert!(err.to_string().contains("FIFO"), "{err}");
        assert!(remove_output(&fifo).is_err());
    }
}
