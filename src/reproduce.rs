//! `pumpcyl reproduce`: the article's whole workflow ([`pumpcyl_present::reproduce`]) into one folder,
//! with its progress on standard error and the comparison with the article on standard output.

use anyhow::Result;
use clap::Args;
use pumpcyl_present::reproduce::{comparison_text, reproduce, ComparisonRow, ReproduceOptions};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Debug, Args)]
pub struct ReproduceArgs {
    /// Output folder (created): figures/, identification/, records/, summary.json, report.html.
    #[arg(long, value_name = "DIR", default_value = "reproduce")]
    out: PathBuf,
}

/// `pumpcyl reproduce`.
pub fn run(args: &ReproduceArgs) -> Result<String> {
    // refuse a bad output folder before the work, not after it
    drop(crate::emit::out_dir(&args.out)?);
    let start = Instant::now();
    let bar = crate::emit::progress_bar(0);
    let on_step = |k: usize, total: usize, what: &str| {
        // the candidates' bar belongs to the identification step: gone once a later one starts
        if bar.length().unwrap_or(0) > 0 {
            bar.finish_and_clear();
        }
        eprintln!(
            "[{k}/{total} {:5.1} s] {what}",
            start.elapsed().as_secs_f64()
        );
    };
    let on_candidates = |n: u64, total: u64| {
        bar.set_length(total);
        bar.inc(n);
        true
    };
    let result = reproduce(&ReproduceOptions {
        on_step: Some(&on_step),
        on_candidates: Some(&on_candidates),
    });
    bar.finish_and_clear();
    let result = result?;
    let done = result.write_with(&args.out, &crate::emit::protected())?;
    crate::emit::tell_kept(&done, &args.out);
    Ok(terminal_table(
        &result.comparison,
        &args.out,
        result.seconds,
    ))
}

/// The comparison with the article as a terminal table, under where the result went.
fn terminal_table(rows: &[ComparisonRow], dir: &Path, seconds: f64) -> String {
    format!(
        "reproduced in {seconds:.1} s into {} (report.html, summary.json, figures/)\n\
         inputs: EMULATED records (records/README.md), not the article's measurements\n\n{}",
        dir.display(),
        comparison_text(rows, TERMINAL_WIDTH)
    )
}

/// The width the comparison is laid out for (characters).
const TERMINAL_WIDTH: usize = 120;
