//! What the fuzz targets of `fuzz_parsers.rs` share: the mutator (edits
//! of a seed file, with each target's dictionary of tokens), the tally of
//! accepted inputs and scratch files. The seed files are read with
//! [`integration_tests::read_workspace_file`].

use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

use bolero::TypeGenerator;

/// The first `n` lines of `text`, each with its line break.
pub(crate) fn head(text: &str, n: usize) -> String {
    text.split_inclusive('\n').take(n).collect()
}

/// One edit of a seed file. Positions are fractions of the length (0 the
/// start, `u16::MAX` the end), so the same edit lands in files of any size.
#[derive(Debug, Clone, TypeGenerator)]
pub(crate) enum Edit {
    /// Replace a byte.
    Byte { at: u16, byte: u8 },
    /// Insert a byte.
    Insert { at: u16, byte: u8 },
    /// Delete up to `len` bytes.
    Delete { at: u16, len: u8 },
    /// Insert a token of the target's dictionary.
    Token { at: u16, token: u8 },
    /// Replace up to `len` bytes by a token (a number by `nan`, ...).
    Overwrite { at: u16, len: u8, token: u8 },
    /// Copy up to `len` bytes from one place to another (repeated keys,
    /// lines, cells).
    Copy { from: u16, len: u8, to: u16 },
    /// Cut the file here (a torn write).
    Truncate { at: u16 },
    /// Replace the `nth` number of the file (modulo their count: a run of
    /// digits, signs, points and exponents) by a token: the value-level
    /// edit that byte edits rarely make whole.
    Number { nth: u16, token: u8 },
}

/// A fuzz input: a seed file, or a few random bytes, after a few edits.
#[derive(Debug, Clone, TypeGenerator)]
pub(crate) struct Input {
    /// The seed file (modulo their number); from [`RAW`] on, `raw` instead.
    pub(crate) seed: u8,
    /// The edits, few: each edit is likelier to break the file than to
    /// lead somewhere new.
    #[generator(bolero::generator::produce::<Vec<Edit>>().with().len(0usize..=4))]
    pub(crate) edits: Vec<Edit>,
    /// Random bytes (the parsers' first line of defence).
    #[generator(bolero::generator::produce::<Vec<u8>>().with().len(0usize..=48))]
    pub(crate) raw: Vec<u8>,
}

/// The `seed` from which an [`Input`] starts from its random bytes (1 in 16).
pub(crate) const RAW: u8 = 240;

impl Input {
    /// The bytes this input stands for, given the target's seeds and tokens.
    pub(crate) fn bytes(&self, seeds: &[Vec<u8>], tokens: &[&[u8]]) -> Vec<u8> {
        let mut out = if self.seed >= RAW {
            self.raw.clone()
        } else {
            seeds[usize::from(self.seed) % seeds.len()].clone()
        };
        for edit in &self.edits {
            apply(&mut out, edit, tokens);
        }
        out
    }

    /// The seed file this input starts from, if it starts from one.
    pub(crate) fn seed_index(&self, seeds: usize) -> Option<usize> {
        (self.seed < RAW).then(|| usize::from(self.seed) % seeds)
    }
}

/// How many inputs a target saw and how many its parser accepted: a
/// target whose inputs almost never parse tests only the error paths.
#[derive(Default)]
pub(crate) struct Tally {
    seen: AtomicUsize,
    accepted: AtomicUsize,
}

impl Tally {
    pub(crate) fn count(&self, accepted: bool) {
        self.seen.fetch_add(1, Relaxed);
        self.accepted.fetch_add(usize::from(accepted), Relaxed);
    }

    /// Panics unless at least `share` of the inputs were accepted.
    pub(crate) fn assert_accepted(&self, what: &str, share: f64) {
        let (seen, accepted) = (self.seen.load(Relaxed), self.accepted.load(Relaxed));
        println!("{what}: {accepted} of {seen} inputs accepted");
        assert!(
            accepted as f64 >= share * seen as f64,
            "{what}: only {accepted} of {seen} inputs accepted; the seeds or the mutator are broken"
        );
    }
}

/// A position in a buffer of `len` bytes for the fraction `at`.
pub(crate) fn place(at: u16, len: usize) -> usize {
    (usize::from(at) * (len + 1)) >> 16
}

pub(crate) fn apply(buf: &mut Vec<u8>, edit: &Edit, tokens: &[&[u8]]) {
    let token = |t: u8| tokens[usize::from(t) % tokens.len()];
    match *edit {
        Edit::Byte { at, byte } => {
            if !buf.is_empty() {
                let i = place(at, buf.len() - 1);
                buf[i] = byte;
            }
        }
        Edit::Insert { at, byte } => buf.insert(place(at, buf.len()), byte),
        Edit::Delete { at, len } => {
            let i = place(at, buf.len());
            let end = (i + usize::from(len)).min(buf.len());
            buf.drain(i..end);
        }
        Edit::Token { at, token: t } => {
            let i = place(at, buf.len());
            buf.splice(i..i, token(t).iter().copied());
        }
        Edit::Overwrite { at, len, token: t } => {
            let i = place(at, buf.len());
            let end = (i + usize::from(len)).min(buf.len());
            buf.splice(i..end, token(t).iter().copied());
        }
        Edit::Copy { from, len, to } => {
            let i = place(from, buf.len());
            let end = (i + usize::from(len)).min(buf.len());
            let piece = buf[i..end].to_vec();
            let j = place(to, buf.len());
            buf.splice(j..j, piece);
        }
        Edit::Truncate { at } => buf.truncate(place(at, buf.len())),
        Edit::Number { nth, token: t } => {
            let numbers = numbers(buf);
            if !numbers.is_empty() {
                let (i, end) = numbers[usize::from(nth) % numbers.len()];
                buf.splice(i..end, token(t).iter().copied());
            }
        }
    }
}

/// The byte ranges of the numbers in `buf`: the longest runs of
/// `0-9 + - . e E` that hold a digit.
pub(crate) fn numbers(buf: &[u8]) -> Vec<(usize, usize)> {
    let in_number = |b: u8| b.is_ascii_digit() || matches!(b, b'+' | b'-' | b'.' | b'e' | b'E');
    let mut out = Vec::new();
    let mut i = 0;
    while i < buf.len() {
        if in_number(buf[i]) {
            let start = i;
            while i < buf.len() && in_number(buf[i]) {
                i += 1;
            }
            if buf[start..i].iter().any(u8::is_ascii_digit) {
                out.push((start, i));
            }
        } else {
            i += 1;
        }
    }
    out
}

/// Runs `f` on a fresh scratch file holding `bytes` (the log and table
/// readers read files), removed afterwards. A new name each time: ext4
/// flushes a file truncated and rewritten when it is closed, which would
/// make each input cost a disk write.
pub(crate) fn with_file<R>(name: &str, bytes: &[u8], f: impl FnOnce(&Path) -> R) -> R {
    static COUNT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    // one directory for every run, each file named by process and count
    let dir = std::env::temp_dir().join("nprl-fuzz");
    std::fs::create_dir_all(&dir).expect("scratch directory");
    let n = COUNT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let path = dir.join(format!("{}-{n}-{name}", std::process::id()));
    std::fs::write(&path, bytes).expect("scratch file");
    let result = f(&path);
    std::fs::remove_file(&path).expect("scratch file removed");
    result
}
