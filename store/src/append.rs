//! A JSON-lines log of whole records.

use std::fs::{self, File, OpenOptions};
use std::io::Read as _;
use std::path::{Path, PathBuf};

use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::error::{Result, StoreError};
use crate::fault::{OpKind, op, parent_dir, sync_dir, write_all};
use crate::output::open_no_follow;

/// An incomplete last record of a log: a write cut short by a kill, a
/// crash or a full disk.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TornTail {
    /// The log.
    pub log: PathBuf,
    /// Its line number, from 1.
    pub line: usize,
    /// Its length in bytes.
    pub bytes: u64,
    /// Why it is not a record: no newline after it, or the parser's message.
    pub reason: String,
    /// Where [`AppendLog::open`] moved it (`LOG.torn-MS-PID`); `None`
    /// when only read ([`read_log`]).
    pub moved_to: Option<PathBuf>,
}

impl std::fmt::Display for TornTail {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} line {}: an incomplete last record ({} bytes, {})",
            self.log.display(),
            self.line,
            self.bytes,
            self.reason
        )?;
        match &self.moved_to {
            Some(to) => write!(f, " was moved to {}; the log keeps its whole records", to.display()),
            None => write!(f, " is skipped"),
        }
    }
}

/// The records of a log and its torn tail, if any.
#[derive(Debug, Clone)]
pub struct LogContents<T> {
    /// The whole records, in order.
    pub records: Vec<T>,
    /// The incomplete last record.
    pub torn: Option<TornTail>,
    /// The length of the whole records in bytes.
    pub whole_len: u64,
}

/// Splits `bytes` (the log `path`) into whole records and a torn tail.
fn parse<T: DeserializeOwned>(path: &Path, bytes: &[u8]) -> Result<LogContents<T>> {
    let mut records = Vec::new();
    let mut start = 0usize;
    let mut line = 0usize;
    let mut torn = None;
    while start < bytes.len() {
        line += 1;
        let (end, complete) = match bytes[start..].iter().position(|&b| b == b'\n') {
            Some(i) => (start + i, true),
            None => (bytes.len(), false),
        };
        let text = &bytes[start..end];
        let is_last = end + usize::from(complete) >= bytes.len();
        let parsed = if text.iter().all(u8::is_ascii_whitespace) && complete {
            None
        } else {
            Some(serde_json::from_slice::<T>(text))
        };
        match parsed {
            None => {}
            Some(Ok(record)) if complete => records.push(record),
            Some(Ok(_)) => {
                torn = Some((start, line, "no newline after it".to_string()));
                break;
            }
            Some(Err(e)) if is_last => {
                let why = if complete {
                    format!("it does not parse: {e}")
                } else {
                    "no newline after it".into()
                };
                torn = Some((start, line, why));
                break;
            }
            Some(Err(e)) => {
                return Err(StoreError::Corrupt {
                    path: path.to_path_buf(),
                    line,
                    message: e.to_string(),
                });
            }
        }
        start = end + 1;
    }
    let whole_len = torn.as_ref().map_or(bytes.len(), |t| t.0) as u64;
    Ok(LogContents {
        records,
        torn: torn.map(|(at, line, reason)| TornTail {
            log: path.to_path_buf(),
            line,
            bytes: (bytes.len() - at) as u64,
            reason,
            moved_to: None,
        }),
        whole_len,
    })
}

/// Reads the log `path` without changing it: its whole records, and a torn
/// last record reported (not moved). A missing file is an empty log.
///
/// # Errors
/// A link or anything but a regular file at `path`
/// ([`StoreError::NotRegular`]), the file cannot be read, or a whole
/// record other than the last does not parse ([`StoreError::Corrupt`]).
pub fn read_log<T: DeserializeOwned>(path: &Path) -> Result<LogContents<T>> {
    crate::check_output(path)?;
    let bytes = match op(OpKind::Read, path, || fs::read(path)) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
        Err(e) => return Err(StoreError::io("reading", path, e)),
    };
    parse(path, &bytes)
}

/// A JSON-lines log open for appending whole records.
///
/// Each record is one line written with one `write_all` and followed by
/// `sync_data`, so after a kill or a crash the log holds whole records and
/// at most one torn last line, which the next [`AppendLog::open`] moves
/// aside (to `LOG.torn-MS-PID`, never deleting it) and reports. After a
/// failed append the log refuses further ones ([`StoreError::Poisoned`]).
///
/// ```
/// use store::AppendLog;
///
/// let dir = std::env::temp_dir().join(format!("store-append-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("runs.jsonl");
/// let mut log = AppendLog::create(&path).unwrap();
/// log.append(&serde_json::json!({"seed": 1})).unwrap();
/// drop(log);
/// // a kill in the middle of the next record
/// std::fs::write(&path, "{\"seed\":1}\n{\"se").unwrap();
/// let (log, contents) = AppendLog::open::<serde_json::Value>(&path).unwrap();
/// assert_eq!(contents.records.len(), 1);
/// let torn = contents.torn.unwrap();
/// assert!(torn.moved_to.as_ref().unwrap().exists());
/// assert_eq!(std::fs::read_to_string(log.path()).unwrap(), "{\"seed\":1}\n");
/// std::fs::remove_dir_all(&dir).unwrap();
/// ```
#[derive(Debug)]
pub struct AppendLog {
    path: PathBuf,
    file: File,
    len: u64,
    poisoned: bool,
}

impl AppendLog {
    /// Creates the log `path` empty (truncating a log that is there).
    ///
    /// # Errors
    /// A symbolic link or anything but a regular file at `path`
    /// ([`StoreError::NotRegular`]); the file cannot be created, truncated
    /// or synced.
    pub fn create(path: &Path) -> Result<Self> {
        crate::check_output(path)?;
        let file = op(OpKind::Open, path, || {
            open_no_follow(path, OpenOptions::new().read(true).append(true).create(true))
        })
        .map_err(|e| StoreError::io("opening", path, e))?;
        op(OpKind::Truncate, path, || file.set_len(0)).map_err(|e| StoreError::io("emptying", path, e))?;
        op(OpKind::Sync, path, || file.sync_all()).map_err(|e| StoreError::io("syncing", path, e))?;
        let dir = parent_dir(path);
        sync_dir(&dir).map_err(|e| StoreError::io("syncing the directory", &dir, e))?;
        Ok(Self {
            path: path.to_path_buf(),
            file,
            len: 0,
            poisoned: false,
        })
    }

    /// Opens the log `path` (created if missing) and reads its records. A
    /// torn last record (no newline after it, or a last line that does not
    /// parse) is copied to a new file `LOG.torn-MS-PID` beside the log,
    /// then cut from the log, and returned in [`LogContents::torn`] so that
    /// the caller can say so, naming both files.
    ///
    /// # Errors
    /// A symbolic link or anything but a regular file at `path`
    /// ([`StoreError::NotRegular`]); the file cannot be opened, read or
    /// repaired, or a whole record
    /// other than the last does not parse ([`StoreError::Corrupt`]: an
    /// edited or damaged log is never changed).
    pub fn open<T: DeserializeOwned>(path: &Path) -> Result<(Self, LogContents<T>)> {
        crate::check_output(path)?;
        let mut file = op(OpKind::Open, path, || {
            open_no_follow(path, OpenOptions::new().read(true).append(true).create(true))
        })
        .map_err(|e| StoreError::io("opening", path, e))?;
        let mut bytes = Vec::new();
        op(OpKind::Read, path, || file.read_to_end(&mut bytes)).map_err(|e| StoreError::io("reading", path, e))?;
        let mut contents: LogContents<T> = parse(path, &bytes)?;
        if let Some(torn) = &mut contents.torn {
            let side = move_aside(path, &bytes[contents.whole_len as usize..])?;
            op(OpKind::Truncate, path, || file.set_len(contents.whole_len))
                .map_err(|e| StoreError::io("cutting the torn record from", path, e))?;
            op(OpKind::Sync, path, || file.sync_all()).map_err(|e| StoreError::io("syncing", path, e))?;
            torn.moved_to = Some(side);
        }
        let len = contents.whole_len;
        Ok((
            Self {
                path: path.to_path_buf(),
                file,
                len,
                poisoned: false,
            },
            contents,
        ))
    }

    /// The log's file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Appends `record` as one line (one write, then `sync_data`).
    ///
    /// # Errors
    /// The record cannot be serialised, the write or the sync fails (the
    /// log then tries to cut what was written, and refuses further
    /// appends), or an earlier append failed ([`StoreError::Poisoned`]).
    pub fn append<T: Serialize + ?Sized>(&mut self, record: &T) -> Result<()> {
        if self.poisoned {
            return Err(StoreError::Poisoned {
                path: self.path.clone(),
            });
        }
        let mut line = serde_json::to_vec(record).map_err(|e| StoreError::Serialize {
            path: self.path.clone(),
            message: e.to_string(),
        })?;
        debug_assert!(!line.contains(&b'\n'), "serde_json writes no raw newline");
        line.push(b'\n');
        let path = &self.path;
        let file = &mut self.file;
        let written = write_all(file, path, &line)
            .map_err(|e| StoreError::io("writing a record to", path, e))
            .and_then(|()| op(OpKind::Sync, path, || file.sync_data()).map_err(|e| StoreError::io("syncing", path, e)));
        match written {
            Ok(()) => {
                self.len += line.len() as u64;
                Ok(())
            }
            Err(e) => {
                self.poisoned = true;
                let len = self.len;
                let _ = op(OpKind::Truncate, path, || file.set_len(len));
                Err(e)
            }
        }
    }
}

/// Copies `tail` into a new file beside `log`, named `LOG.torn-MS-PID`
/// (with `-N` added if that exists), synced.
fn move_aside(log: &Path, tail: &[u8]) -> Result<PathBuf> {
    let ms = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_millis());
    let name = log.file_name().unwrap_or_default().to_string_lossy().into_owned();
    for n in 0..1000 {
        let suffix = if n == 0 { String::new() } else { format!("-{n}") };
        let side = parent_dir(log).join(format!("{name}.torn-{ms}-{}{suffix}", std::process::id()));
        let mut file = match op(OpKind::Open, &side, || {
            OpenOptions::new().write(true).create_new(true).open(&side)
        }) {
            Ok(f) => f,
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(StoreError::io("creating", side, e)),
        };
        let saved = write_all(&mut file, &side, tail)
            .map_err(|e| StoreError::io("writing", &side, e))
            .and_then(|()| {
                op(OpKind::Sync, &side, || file.sync_all()).map_err(|e| StoreError::io("syncing", &side, e))
            });
        if let Err(e) = saved {
            let _ = op(OpKind::Remove, &side, || fs::remove_file(&side));
            return Err(e);
        }
        return Ok(side);
    }
    Err(StoreError::io(
        "creating a side file for",
        log,
        std::io::Error::other("1000 side files exist"),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ScratchDir;
    use crate::fault::{FaultPlan, install};
    use proptest::prelude::*;
    use serde_json::{Value, json};

    #[test]
    fn a_whole_line_in_the_middle_that_does_not_parse_is_an_error_naming_it() {
        let dir = ScratchDir::new("append-corrupt").expect("scratch dir");
        let path = dir.path().join("runs.jsonl");
        fs::write(&path, "{\"a\":1}\nnot json\n{\"a\":2}\n").expect("write");
        let e = AppendLog::open::<Value>(&path).expect_err("corrupt").to_string();
        assert!(e.contains("runs.jsonl line 2"), "{e}");
        assert_eq!(
            fs::read_to_string(&path).expect("kept"),
            "{\"a\":1}\nnot json\n{\"a\":2}\n"
        );
    }

    #[test]
    fn a_last_line_that_does_not_parse_is_torn_even_with_its_newline() {
        let dir = ScratchDir::new("append-badlast").expect("scratch dir");
        let path = dir.path().join("runs.jsonl");
        fs::write(&path, "{\"a\":1}\n{\"a\":\n").expect("write");
        let (mut log, contents) = AppendLog::open::<Value>(&path).expect("open");
        let torn = contents.torn.expect("torn");
        assert_eq!((torn.line, torn.bytes), (2, 6));
        assert_eq!(
            fs::read_to_string(torn.moved_to.expect("moved")).expect("side"),
            "{\"a\":\n"
        );
        log.append(&json!({"a": 2})).expect("append");
        assert_eq!(fs::read_to_string(&path).expect("log"), "{\"a\":1}\n{\"a\":2}\n");
    }

    #[test]
    fn a_failed_append_poisons_the_log_and_leaves_whole_records() {
        let dir = ScratchDir::new("append-poison").expect("scratch dir");
        let path = dir.path().join("runs.jsonl");
        let mut log = AppendLog::create(&path).expect("create");
        log.append(&json!({"a": 1})).expect("first");
        let guard = install(FaultPlan::fail_nth(1, &[OpKind::Write]).under(dir.path()).torn());
        let e = log.append(&json!({"a": 2})).expect_err("injected").to_string();
        drop(guard);
        assert!(e.contains("runs.jsonl"), "{e}");
        assert!(matches!(log.append(&json!({"a": 3})), Err(StoreError::Poisoned { .. })));
        assert_eq!(fs::read_to_string(&path).expect("log"), "{\"a\":1}\n");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Appends, then a torn record cut at a random byte: reopening keeps
        /// exactly the whole records, moves the fragment aside intact, and
        /// appends after them.
        #[test]
        fn reopening_keeps_exactly_the_whole_records(
            values in proptest::collection::vec(any::<(u32, String)>(), 0..12),
            cut in 0.0f64..1.0,
        ) {
            let dir = ScratchDir::new("append-prop").expect("scratch dir");
            let path = dir.path().join("runs.jsonl");
            let mut log = AppendLog::create(&path).expect("create");
            for v in &values {
                log.append(v).expect("append");
            }
            drop(log);
            let next = serde_json::to_string(&(7u32, "next".to_string())).expect("json");
            let at = ((next.len() as f64) * cut) as usize;
            let mut bytes = fs::read(&path).expect("read");
            bytes.extend_from_slice(&next.as_bytes()[..at]);
            fs::write(&path, &bytes).expect("torn");
            let (mut log, contents) = AppendLog::open::<(u32, String)>(&path).expect("open");
            prop_assert_eq!(&contents.records, &values);
            match contents.torn {
                Some(t) => {
                    prop_assert!(at > 0);
                    let side = fs::read(t.moved_to.expect("moved")).expect("side");
                    prop_assert_eq!(side, next.as_bytes()[..at].to_vec());
                }
                None => prop_assert_eq!(at, 0),
            }
            log.append(&(8u32, "after".to_string())).expect("append");
            drop(log);
            let (_, again) = AppendLog::open::<(u32, String)>(&path).expect("reopen");
            prop_assert!(again.torn.is_none());
            let mut want = values.clone();
            want.push((8, "after".into()));
            prop_assert_eq!(again.records, want);
        }

        /// A failure injected at any operation of an append leaves whole
        /// records only: reopening gives the earlier records, with or
        /// without the new one, never a part of it.
        #[test]
        fn an_append_under_a_failure_is_whole_or_absent(n in 1u64..6, torn in any::<bool>()) {
            let dir = ScratchDir::new("append-fault").expect("scratch dir");
            let path = dir.path().join("runs.jsonl");
            let mut log = AppendLog::create(&path).expect("create");
            log.append(&1u32).expect("first");
            let mut plan = FaultPlan::fail_nth(n, &[]).under(dir.path()).persist();
            plan.torn = torn;
            let guard = install(plan);
            let _ = log.append(&22u32);
            drop(guard);
            drop(log);
            let (_, contents) = AppendLog::open::<u32>(&path).expect("reopen");
            prop_assert!(contents.records == vec![1] || contents.records == vec![1, 22], "{:?}", contents.records);
        }
    }
}
