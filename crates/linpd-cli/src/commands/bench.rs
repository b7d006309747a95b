//! `linpd bench`: the benchmarks of linpd-bench.

use crate::{CliError, UntilClosed};

/// Runs the benchmarks of `args`, prints their table and where the document was written.
pub(crate) fn bench(args: &linpd_bench::BenchArgs) -> Result<(), CliError> {
    let doc = linpd_bench::run(args)?;
    // a closed stdout (`linpd bench | head`) only cuts the table: the document is written
    linpd_bench::print_table(&doc, &mut UntilClosed(Some(std::io::stdout().lock()))).map_err(CliError::Stdout)?;
    say!("wrote {}", args.out.display())?;
    Ok(())
}
