//! The crate's error type: every error names the file it concerns.

use std::path::PathBuf;

/// The errors of the storage layer; each names its file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StoreError {
    /// A file system operation failed (or was failed by an installed
    /// [`FaultPlan`](crate::FaultPlan)).
    #[error("{action} {}: {error}", path.display())]
    Io {
        /// What was being done: `opening`, `writing`, `syncing`, `renaming into place`, ...
        action: &'static str,
        /// The file or directory.
        path: PathBuf,
        /// The operating system's error (in the message, so not a separate
        /// cause in the chain).
        error: std::io::Error,
    },
    /// A whole record (a line ending in a newline, not the last one) of an
    /// append log does not parse: the log was edited or damaged, and is
    /// not repaired automatically.
    #[error("{} line {line}: not a record of this log ({message}); the log was edited or damaged", path.display())]
    Corrupt {
        /// The log.
        path: PathBuf,
        /// The line, from 1.
        line: usize,
        /// The parser's message.
        message: String,
    },
    /// A manifest file that cannot be read as one.
    #[error("{}: not a directory manifest ({message})", path.display())]
    BadManifest {
        /// The manifest file.
        path: PathBuf,
        /// The parser's message.
        message: String,
    },
    /// A directory reopened by another program or for another task than
    /// the one its manifest records.
    #[error(
        "{} was made by {saved_program} for the task {saved_task:?}, not by {program} for {task:?}; \
         choose another directory",
        path.display()
    )]
    TaskMismatch {
        /// The manifest file.
        path: PathBuf,
        /// The program recorded in it.
        saved_program: String,
        /// The task recorded in it.
        saved_task: String,
        /// The program reopening the directory.
        program: String,
        /// The task it asked for.
        task: String,
    },
    /// A directory reopened with other settings than its manifest records.
    #[error(
        "{} records other settings: {} differ{} (first: {first}); the directory's settings never change \
         under its records",
        path.display(),
        keys.join(", "),
        if keys.len() == 1 { "s" } else { "" }
    )]
    SettingsMismatch {
        /// The manifest file.
        path: PathBuf,
        /// The dotted keys whose values differ (`cartpole.max_trials`), sorted.
        keys: Vec<String>,
        /// The first key's saved and new values, for the message.
        first: String,
    },
    /// An append log refuses further appends after one failed: the record
    /// may be partly on disk, and only reopening the log (which repairs
    /// it) makes it safe to append again.
    #[error("{}: an earlier append failed; reopen the log before appending again", path.display())]
    Poisoned {
        /// The log.
        path: PathBuf,
    },
    /// An output path holds something a program must not write through or
    /// replace: a symbolic link, a device, a FIFO, a socket or a directory
    /// (or, for an output directory, a dangling link or a file).
    #[error(
        "{} is {found}: outputs are never written through links or over anything but a regular file; \
         remove it or choose another path",
        path.display()
    )]
    NotRegular {
        /// The path.
        path: PathBuf,
        /// What is there, in words (`a symbolic link to /dev/null`).
        found: String,
    },
    /// Another process holds the lock of a directory.
    #[error(
        "another program is writing into {} (it holds {}); wait for it to finish, or choose another directory",
        dir.display(),
        path.display()
    )]
    Locked {
        /// The directory.
        dir: PathBuf,
        /// Its lock file.
        path: PathBuf,
    },
    /// A record or manifest could not be serialised as JSON.
    #[error("serialising a record for {}: {message}", path.display())]
    Serialize {
        /// The file it was meant for.
        path: PathBuf,
        /// The serialiser's message.
        message: String,
    },
}

impl StoreError {
    pub(crate) fn io(action: &'static str, path: impl Into<PathBuf>, error: std::io::Error) -> Self {
        Self::Io {
            action,
            path: path.into(),
            error,
        }
    }

    /// The file the error concerns.
    pub fn path(&self) -> &std::path::Path {
        match self {
            Self::Io { path, .. }
            | Self::Corrupt { path, .. }
            | Self::BadManifest { path, .. }
            | Self::TaskMismatch { path, .. }
            | Self::SettingsMismatch { path, .. }
            | Self::Poisoned { path }
            | Self::Serialize { path, .. }
            | Self::NotRegular { path, .. }
            | Self::Locked { path, .. } => path,
        }
    }

    /// The operating system's error kind, for an [`StoreError::Io`] error.
    pub fn io_kind(&self) -> Option<std::io::ErrorKind> {
        match self {
            Self::Io { error, .. } => Some(error.kind()),
            _ => None,
        }
    }
}

/// The crate's result type.
pub type Result<T, E = StoreError> = std::result::Result<T, E>;
