//! The `magopt` command line: a thin layer over the library.

fn main() {
    std::process::exit(magopt::cli::main());
}
