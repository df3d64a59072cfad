//! The `ghm` command line (see `ghm --help`).
fn main() {
    std::process::exit(ghm::cli::main());
}
