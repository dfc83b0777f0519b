//! The `ssl` binary: the command line of the `ssl` library (`src/cli/`).

fn main() {
    std::process::exit(ssl::cli::main());
}
