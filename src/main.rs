//! The `ssl` binary: the command line over the `ssl` library.

mod cli;

fn main() {
    std::process::exit(cli::main());
}
