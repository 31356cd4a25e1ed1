//! The `swingup` program never loses what a user ran: a fresh learning run
//! or grid refuses a directory holding another one (and `--force` removes
//! only that run's files), a resume keeps the run's settings, and errors
//! print as one message without a backtrace.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

struct Scratch(PathBuf);

impl Scratch {
    fn new(tag: &str) -> Self {
        let p = std::env::temp_dir().join(format!("swingup-cli-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).expect("scratch dir");
        Self(p)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn swingup(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_swingup"))
        .args(args)
        .arg("--out")
        .arg(dir)
        .env("RUST_BACKTRACE", "1")
        .output()
        .expect("the swingup program runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn a_fresh_grid_never_empties_finished_runs() {
    let dir = Scratch::new("grid");
    let saved = "{\"not\": \"checked before the refusal\"}\n";
    std::fs::write(dir.0.join("runs.jsonl"), saved).expect("write");
    let o = swingup(&["experiments", "lambda", "--quick"], &dir.0);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("holds finished runs") && e.contains("--resume") && e.contains("--force"), "{e}");
    assert!(!e.contains("stack backtrace") && !e.contains("Stack backtrace"), "{e}");
    assert_eq!(std::fs::read_to_string(dir.0.join("runs.jsonl")).expect("kept"), saved);
}

#[test]
fn a_fresh_learning_run_never_overwrites_another() {
    let dir = Scratch::new("learn");
    let trial = "{\"a trial\": 3}";
    std::fs::write(dir.0.join("trial_03.json"), trial).expect("write");
    std::fs::write(dir.0.join("notes.txt"), "mine").expect("write");
    let o = swingup(&["learn", "--max-trials", "1"], &dir.0);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("holds another run") && e.contains("--force"), "{e}");
    assert_eq!(std::fs::read_to_string(dir.0.join("trial_03.json")).expect("kept"), trial);
    // --force deletes that run's files only, then runs
    let o = swingup(&["learn", "--max-trials", "1", "--force"], &dir.0);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!dir.0.join("trial_03.json").exists());
    assert!(dir.0.join("trial_01.json").exists());
    assert_eq!(std::fs::read_to_string(dir.0.join("notes.txt")).expect("kept"), "mine");
    // resuming keeps the saved settings: the cap may change, the seed not
    let o = swingup(&["learn", "--resume", "--seed", "5"], &dir.0);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("seed differs"), "{}", stderr(&o));
    let o = swingup(&["learn", "--resume", "--max-trials", "1"], &dir.0);
    assert!(o.status.success(), "{}", stderr(&o));
}
