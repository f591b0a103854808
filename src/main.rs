//! The `pumpcyl` command line: a thin layer over the library (see `pumpcyl --help`).

fn main() {
    if let Err(e) = pumpcyl::cli::run() {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
