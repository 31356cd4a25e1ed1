//! The READMEs' generated sections are what their generating commands would
//! write from the saved results in `results/`: a table typed by hand, or
//! results regenerated without rewriting the README (or the other way
//! round), fails here.

use integration_tests::read_workspace_file as read;
use swingup::experiments::ExperimentsReport;
use swingup::experiments::sensitivity::SensitivityReport;

/// The text between `<!-- NAME:start -->\n` and `<!-- NAME:end -->`, as
/// `swingup::output::run_report::update_between` writes it.
fn section<'a>(text: &'a str, file: &str, name: &str) -> &'a str {
    let start = format!("<!-- {name}:start -->\n");
    let end = format!("<!-- {name}:end -->");
    let a = text
        .find(&start)
        .unwrap_or_else(|| panic!("{file} has no {start:?} line"))
        + start.len();
    let b = text[a..]
        .find(&end)
        .unwrap_or_else(|| panic!("{file} has no {end:?} line after {start:?}"));
    &text[a..a + b]
}

#[test]
fn the_claims_table_is_the_one_results_gives() {
    let report: ExperimentsReport =
        serde_json::from_str(&read("results/experiments.json")).expect("results/experiments.json parses");
    let expected = format!(
        "{}\n\n{}",
        swingup::output::grid_report::provenance(&report),
        swingup::output::grid_report::claims_table(&report.claims)
    );
    let readme = read("README.md");
    assert_eq!(
        section(&readme, "README.md", "claims"),
        expected,
        "README.md's claims table is stale: run `cargo run --release -p swingup -- experiments --out results --resume --report-only --update-readme README.md`"
    );
    // the full report in results/ is the one the same saved runs give
    assert_eq!(
        read("results/experiments.md"),
        swingup::output::grid_report::markdown(&report),
        "results/experiments.md is stale against results/experiments.json"
    );
}

#[test]
fn the_mpc_table_is_the_one_results_gives() {
    let report: ExperimentsReport =
        serde_json::from_str(&read("results/mpc/experiments.json")).expect("results/mpc/experiments.json parses");
    let expected = swingup::output::grid_report::mpc_readme_block(&report);
    assert!(expected.contains("| lwr |"), "no MPC rows in results/mpc");
    assert!(
        expected.contains("| LWR + MPC (ours) |") && expected.contains("| PILCO | 17.5 s |"),
        "no cart-pole table in results/mpc"
    );
    assert_eq!(
        section(&read("README.md"), "README.md", "mpc"),
        expected,
        "README.md's MPC tables are stale: run `cargo run --release -p swingup -- experiments mpc --out results/mpc --resume --report-only --update-readme README.md`"
    );
    assert_eq!(
        read("results/mpc/experiments.md"),
        swingup::output::grid_report::markdown(&report),
        "results/mpc/experiments.md is stale against results/mpc/experiments.json"
    );
}

#[test]
fn the_sensitivity_summary_is_the_one_results_gives() {
    let report: SensitivityReport =
        serde_json::from_str(&read("results/sensitivity.json")).expect("results/sensitivity.json parses");
    let readme = read("swingup/README.md");
    assert_eq!(
        section(&readme, "swingup/README.md", "sensitivity"),
        report.readme_summary(),
        "swingup/README.md's sensitivity summary is stale: run `cargo run --release -p swingup -- sensitivity --out results --update-readme swingup/README.md`"
    );
    assert_eq!(
        read("results/sensitivity.md"),
        report.markdown(),
        "results/sensitivity.md is stale against results/sensitivity.json"
    );
}

#[test]
fn the_benchmark_summary_is_the_one_results_gives() {
    let readme = read("README.md");
    assert_eq!(
        section(&readme, "README.md", "benchmarks"),
        read("results/benchmarks_summary.md"),
        "README.md's benchmark summary is stale: run `cargo run --release -p nprl-bench -- --update-readme README.md`"
    );
}

/// The section finder reads what `update_between` writes.
#[test]
fn sections_round_trip_through_update_between() {
    let scratch = store::ScratchDir::new("readme-test").expect("scratch dir");
    let dir = scratch.path();
    let path = dir.join("README.md");
    std::fs::write(&path, "intro\n<!-- t:start -->\nold\n<!-- t:end -->\noutro\n").expect("write");
    swingup::output::run_report::update_between(&path, "<!-- t:start -->", "<!-- t:end -->", "new\nlines\n")
        .expect("update");
    let text = std::fs::read_to_string(&path).expect("read");
    assert_eq!(section(&text, "README.md", "t"), "new\nlines\n");
    assert!(text.starts_with("intro\n") && text.ends_with("<!-- t:end -->\noutro\n"));
}
