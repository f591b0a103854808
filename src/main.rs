//! The `pumpcyl` command line: a thin layer over the library (see `pumpcyl --help`).

fn main() {
    if let Err(e) = pumpcyl::cli::run() {
        eprintln!(
            "error: {}",
            pumpcyl::cli::escape_controls(&format!("{e:#}"))
        );
        std::process::exit(1);
    }
}
