//! Printing that never panics: `println!` and `eprintln!` panic on a
//! closed or full stream (`swingup ... | head -1`, `> /dev/full`), and a
//! program's work must go on and be saved. [`say_line`] drops its line
//! once stdout has failed, says so once on stderr, and [`stdout_failed`]
//! lets the program end with status 1 after its work.

use std::sync::atomic::{AtomicBool, Ordering};

/// Set once stdout is found closed or full: output is dropped from then
/// on, the work goes on and is saved.
static STDOUT_CLOSED: AtomicBool = AtomicBool::new(false);

/// Writes a line to stdout; a closed or full stdout never stops the work:
/// the line is dropped, and the first failure is said on stderr.
pub fn say_line(args: std::fmt::Arguments<'_>) {
    use std::io::Write as _;
    if STDOUT_CLOSED.load(Ordering::Relaxed) {
        return;
    }
    let mut out = std::io::stdout().lock();
    if out
        .write_fmt(args)
        .and_then(|()| out.write_all(b"\n"))
        .and_then(|()| out.flush())
        .is_err()
        && !STDOUT_CLOSED.swap(true, Ordering::Relaxed)
    {
        note_line(format_args!(
            "note: stdout is closed or full; the program goes on and saves its results without showing them"
        ));
    }
}

/// Writes a line to stderr, ignoring a closed stderr.
pub fn note_line(args: std::fmt::Arguments<'_>) {
    use std::io::Write as _;
    let mut err = std::io::stderr().lock();
    let _ = err.write_fmt(args).and_then(|()| err.write_all(b"\n"));
}

/// Whether a line written by [`say_line`] was lost (stdout closed or full).
pub fn stdout_failed() -> bool {
    STDOUT_CLOSED.load(Ordering::Relaxed)
}

/// `println!` that never panics ([`say_line`]).
#[macro_export]
macro_rules! say {
    ($($arg:tt)*) => { $crate::output::console::say_line(format_args!($($arg)*)) };
}

/// `eprintln!` that never panics ([`note_line`]).
#[macro_export]
macro_rules! note {
    ($($arg:tt)*) => { $crate::output::console::note_line(format_args!($($arg)*)) };
}
