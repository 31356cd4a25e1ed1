//! Timing drivers for the side-by-side comparison scripts in `scripts/`
//! (`compare_splines.py`, `compare_lwr.py`, `compare_trajopt.py`,
//! `compare_powell.py`, `compare_ddp.py`). Each binary times one library
//! operation on inputs the script gives and prints what the script parses;
//! they are not examples to learn from (those are in each crate's
//! `examples/`). Run one with
//! `cargo run --release -p nprl-drivers --bin NAME -- ARGS`.
