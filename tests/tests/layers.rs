//! The workspace's module structure: no import cycle between the source
//! files of any crate, and `swingup`'s modules in layers whose imports run
//! one way (base, plant, config, records, models, planning, learning,
//! experiments, output, program).
//!
//! A file's imports are its `crate::...` and `super::...` paths outside
//! comments and its `#[cfg(test)] mod tests`; a path names the longest
//! module it reaches. A parent module's `pub use child::...` re-exports
//! and `mod child;` declarations are not imports.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// Every `.rs` file under `src/` as (module path, file), `lib.rs` and
/// `main.rs` left out (they only declare modules and run the program).
fn modules(src: &Path) -> BTreeMap<String, PathBuf> {
    fn walk(dir: &Path, src: &Path, out: &mut BTreeMap<String, PathBuf>) {
        for entry in fs::read_dir(dir).expect("readable src") {
            let path = entry.expect("entry").path();
            if path.is_dir() {
                walk(&path, src, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let rel = path.strip_prefix(src).expect("under src").with_extension("");
                let mut parts: Vec<String> = rel.iter().map(|p| p.to_string_lossy().into_owned()).collect();
                if parts.last().is_some_and(|p| p == "mod") {
                    parts.pop();
                }
                if parts == ["lib"] || parts == ["main"] || parts.first().is_some_and(|p| p == "bin") {
                    continue;
                }
                out.insert(parts.join("::"), path);
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(src, src, &mut out);
    out
}

/// The source without comments and without its unit-test module.
fn code(text: &str) -> String {
    let text = match text.find("#[cfg(test)]\nmod tests") {
        Some(i) => &text[..i],
        None => text,
    };
    text.lines()
        .map(|l| match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The identifier paths following each occurrence of `prefix` in `code`.
fn paths_after<'a>(code: &'a str, prefix: &str) -> Vec<Vec<&'a str>> {
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(i) = rest.find(prefix) {
        let before = rest[..i].chars().next_back();
        rest = &rest[i + prefix.len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
            continue;
        }
        let mut segs = Vec::new();
        let mut s = rest;
        loop {
            let end = s
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(s.len());
            if end == 0 {
                break;
            }
            segs.push(&s[..end]);
            s = &s[end..];
            match s.strip_prefix("::") {
                Some(t) => s = t,
                None => break,
            }
        }
        out.push(segs);
    }
    out
}

/// Module -> the other modules of the crate it imports.
fn imports(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mods = modules(src);
    let resolve = |segs: &[&str]| -> Option<String> {
        (1..=segs.len())
            .rev()
            .map(|k| segs[..k].join("::"))
            .find(|m| mods.contains_key(m))
    };
    let mut edges = BTreeMap::new();
    for (m, path) in &mods {
        let text = code(&fs::read_to_string(path).expect("readable source"));
        let mut to = BTreeSet::new();
        for segs in paths_after(&text, "crate::") {
            if let Some(t) = resolve(&segs) {
                to.insert(t);
            }
        }
        let parent: Vec<&str> = m.split("::").collect();
        let parent = &parent[..parent.len() - 1];
        for segs in paths_after(&text, "super::") {
            let full: Vec<&str> = parent.iter().copied().chain(segs).collect();
            if let Some(t) = resolve(&full) {
                to.insert(t);
            }
        }
        // a module reaching into itself or its own children is no import
        to.retain(|t| t != m && !t.starts_with(&format!("{m}::")) && !m.starts_with(&format!("{t}::")));
        edges.insert(m.clone(), to);
    }
    edges
}

/// One cycle of `edges`, if there is any.
fn find_cycle(edges: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        v: &str,
        edges: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(v.to_string(), 1);
        stack.push(v.to_string());
        for w in edges.get(v).into_iter().flatten() {
            match state.get(w.as_str()).copied().unwrap_or(0) {
                0 => {
                    if let Some(c) = visit(w, edges, state, stack) {
                        return Some(c);
                    }
                }
                1 => {
                    let start = stack.iter().position(|s| s == w).expect("on the stack");
                    let mut cycle = stack[start..].to_vec();
                    cycle.push(w.clone());
                    return Some(cycle);
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(v.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for v in edges.keys() {
        if state.get(v.as_str()).copied().unwrap_or(0) == 0
            && let Some(c) = visit(v, edges, &mut state, &mut Vec::new())
        {
            return Some(c);
        }
    }
    None
}

fn crate_src(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(name).join("src")
}

#[test]
fn no_crate_has_an_import_cycle_between_its_files() {
    for krate in ["lwr", "splines", "systems", "trajopt", "ddp", "swingup", "bench"] {
        let edges = imports(&crate_src(krate));
        assert!(edges.len() > 3, "{krate}: found only {} modules", edges.len());
        if let Some(cycle) = find_cycle(&edges) {
            panic!("{krate}: import cycle {}", cycle.join(" -> "));
        }
    }
}

/// `swingup`'s layers, lowest first; a module may import only from its own
/// layer or lower ones.
const LAYERS: [(&str, &[&str]); 10] = [
    ("base", &["error", "format"]),
    ("plant", &["plant"]),
    ("config", &["config"]),
    ("records", &["record"]),
    ("models", &["models"]),
    ("planning", &["planning"]),
    ("learning", &["learn", "diagnostics", "cartpole"]),
    ("experiments", &["experiments"]),
    ("output", &["output", "fit_cmd"]),
    // the binary's subcommands (src/cli/, declared by main.rs)
    ("program", &["cli"]),
];

fn layer_of(module: &str) -> Option<usize> {
    let top = module.split("::").next()?;
    LAYERS.iter().position(|(_, mods)| mods.contains(&top))
}

#[test]
fn swingup_imports_run_one_way_through_its_layers() {
    let edges = imports(&crate_src("swingup"));
    let mut wrong = Vec::new();
    for (m, to) in &edges {
        let Some(lm) = layer_of(m) else {
            panic!("swingup::{m} belongs to no layer: add it to LAYERS and to the crate docs' table");
        };
        for t in to {
            let lt = layer_of(t).unwrap_or(usize::MAX);
            if lt > lm {
                wrong.push(format!(
                    "{m} ({}) imports {t} ({})",
                    LAYERS[lm].0,
                    LAYERS.get(lt).map_or("?", |l| l.0)
                ));
            }
        }
    }
    assert!(wrong.is_empty(), "imports against the layers:\n{}", wrong.join("\n"));
}

/// The checker itself: a planted cycle and a planted upward import are found.
#[test]
fn the_checker_finds_a_cycle_and_reads_paths() {
    let mut edges = BTreeMap::new();
    edges.insert("a".to_string(), BTreeSet::from(["b".to_string()]));
    edges.insert("b".to_string(), BTreeSet::from(["c".to_string()]));
    edges.insert("c".to_string(), BTreeSet::from(["a".to_string()]));
    assert_eq!(find_cycle(&edges).map(|c| c.len()), Some(4));
    edges.insert("c".to_string(), BTreeSet::new());
    assert_eq!(find_cycle(&edges), None);
    let code =
        code("use crate::models::learned::{a, b}; // crate::output\nx = crate::planning::eq3::plan(); my_crate::x");
    let paths = paths_after(&code, "crate::");
    assert_eq!(paths, vec![vec!["models", "learned"], vec!["planning", "eq3", "plan"]]);
}

/// The crates people reuse, the benchmark included, do not depend on the
/// `swingup` program (its `[dependencies]` and `[dev-dependencies]` alike):
/// the workspace's layers run library -> program, never back.
#[test]
fn no_library_crate_depends_on_the_program() {
    for krate in ["lwr", "splines", "systems", "solve", "store", "trajopt", "ddp", "bench"] {
        let manifest = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("..")
            .join(krate)
            .join("Cargo.toml");
        let text = fs::read_to_string(&manifest).expect("Cargo.toml");
        let value: toml::Table = text.parse().expect("valid TOML");
        for table in ["dependencies", "dev-dependencies", "build-dependencies"] {
            let deps = value.get(table).and_then(toml::Value::as_table);
            assert!(
                !deps.is_some_and(|d| d.contains_key("swingup")),
                "{krate}'s [{table}] names the swingup program"
            );
        }
    }
}

/// The Python bindings live in their own crate (`python/`, its own
/// workspace): no crate of the Rust workspace depends on PyO3 or numpy.
#[test]
fn no_workspace_crate_depends_on_python() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let workspace: toml::Table = fs::read_to_string(root.join("Cargo.toml"))
        .expect("the workspace's Cargo.toml")
        .parse()
        .expect("valid TOML");
    let members = workspace["workspace"]["members"].as_array().expect("members");
    assert!(!members.iter().any(|m| m.as_str() == Some("python")));
    for member in members.iter().filter_map(toml::Value::as_str) {
        let text = fs::read_to_string(root.join(member).join("Cargo.toml")).expect("a member's Cargo.toml");
        let value: toml::Table = text.parse().expect("valid TOML");
        for table in ["dependencies", "dev-dependencies", "build-dependencies"] {
            let deps = value.get(table).and_then(toml::Value::as_table);
            for python in ["pyo3", "numpy"] {
                assert!(
                    !deps.is_some_and(|d| d.contains_key(python)),
                    "{member}'s [{table}] names {python}"
                );
            }
        }
    }
}
