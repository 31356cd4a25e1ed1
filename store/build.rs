//! Stamps the storage layer, and through it every program of the workspace
//! that writes results (`swingup`, `nprl-bench`), with the commit their code
//! was built from (`NPRL_CODE_VERSION`, read by `store::code_version`), so
//! that the results a binary writes name the code that made them, wherever
//! it is run from and whatever the checkout's HEAD has become since (a
//! runtime `git describe` in the working directory named neither reliably).
//!
//! The stamp is `commit <hash>`, with `-dirty` when a tracked code file of
//! the workspace (`*.rs`, `Cargo.toml`, `Cargo.lock`, `swingup/assets`)
//! differs from that commit; results and READMEs the program itself writes
//! do not count. Outside this workspace's git checkout (a packaged crate, no
//! git) it is `an unknown commit`.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The trimmed standard output of `git args` run in `dir`, if it succeeded.
fn git(dir: &Path, args: &[&str]) -> Option<String> {
    let out = Command::new("git").current_dir(dir).args(args).output().ok()?;
    if !out.status.success() {
        return None;
    }
    String::from_utf8(out.stdout).ok().map(|s| s.trim().to_string())
}

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let Some(root) = manifest.parent().map(Path::to_path_buf) else {
        println!("cargo:rustc-env=NPRL_CODE_VERSION=an unknown commit");
        return;
    };
    // the workspace's own checkout only: a packaged crate built inside some
    // other repository must not take that repository's commit
    let ours = git(&root, &["rev-parse", "--show-toplevel"])
        .is_some_and(|top| Path::new(&top).canonicalize().ok() == root.canonicalize().ok());
    let hash = ours.then(|| git(&root, &["rev-parse", "--short=7", "HEAD"])).flatten();
    let version = match hash {
        Some(hash) => {
            let changed = git(
                &root,
                &[
                    "status",
                    "--porcelain",
                    "--untracked-files=no",
                    "--",
                    ":(glob)**/*.rs",
                    ":(glob)**/Cargo.toml",
                    "Cargo.lock",
                    "swingup/assets",
                    "bench/data",
                ],
            );
            let dirty = changed.is_none_or(|s| !s.is_empty());
            format!("commit {hash}{}", if dirty { "-dirty" } else { "" })
        }
        None => "an unknown commit".to_string(),
    };
    println!("cargo:rustc-env=NPRL_CODE_VERSION={version}");

    // A packaged crate (crates.io, a vendored copy) has no sibling folders:
    // watching paths that do not exist would rerun this script on every
    // build of every crate that depends on it, so it watches only itself.
    if !ours {
        println!("cargo:rerun-if-changed=build.rs");
        return;
    }
    // rebuilt when the code or the commit changes (a directory is scanned
    // for any modified file)
    for path in [
        "lwr",
        "splines",
        "systems",
        "trajopt",
        "ddp",
        "swingup/src",
        "swingup/assets",
        "bench/src",
        "bench/data",
        "store/src",
        "store/build.rs",
        "Cargo.toml",
        "Cargo.lock",
    ] {
        println!("cargo:rerun-if-changed={}", root.join(path).display());
    }
    let dir = |flag: &str| git(&root, &["rev-parse", flag]).map(PathBuf::from);
    if let Some(git_dir) = dir("--absolute-git-dir") {
        for file in ["HEAD", "index"] {
            println!("cargo:rerun-if-changed={}", git_dir.join(file).display());
        }
    }
    if let Some(common) = dir("--git-common-dir") {
        let common = if common.is_absolute() {
            common
        } else {
            root.join(common)
        };
        println!("cargo:rerun-if-changed={}", common.join("packed-refs").display());
        if let Some(head_ref) = git(&root, &["symbolic-ref", "-q", "HEAD"]) {
            println!("cargo:rerun-if-changed={}", common.join(head_ref).display());
        }
    }
}
