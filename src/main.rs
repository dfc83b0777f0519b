//! The `ssl` binary: everything lives in the library; see `ssl::cli`.

fn main() {
    std::process::exit(ssl::cli::main());
}
