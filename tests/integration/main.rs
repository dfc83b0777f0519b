//! The integration tests, in one binary (one link instead of one per file): each module
//! is one concern, named by what it proves. `cargo test --test integration NAME` runs
//! one. The no-allocation test is its own binary (tests/no_alloc.rs): it replaces the
//! global allocator.

#[path = "../support/mod.rs"]
mod support;

mod accuracy;
mod band;
mod batch;
mod benchmark;
mod bounds;
mod check;
mod check_orders;
mod cli;
mod clock;
mod docs;
mod entry_points;
mod flac;
mod formats;
mod fuzz;
mod inputs;
mod lab_truth;
mod live;
mod machines;
mod man;
mod moving;
mod nothing_lost;
mod orientation;
mod outputs;
mod part_of_a_file;
mod plot;
mod rooms;
mod scores;
mod scoring_folders;
mod simulate;
mod sources;
mod talkers_at_once;
mod testdata;
mod tracking;
mod uncertainty;
