//! `skylod completions SHELL` and `skylod man`: shell completion scripts (`clap_complete`)
//! and a roff manual page (`clap_mangen`), generated from the same definition as the parser.

use crate::Outcome;
use clap::CommandFactory;
use std::io::Write;

#[derive(clap::Args, Debug)]
pub struct CompletionArgs {
    /// The shell to complete for.
    #[arg(value_enum)]
    shell: clap_complete::Shell,
}

/// Print the completion script for a shell on standard output.
pub fn completions(args: CompletionArgs) -> anyhow::Result<Outcome> {
    let mut cmd = crate::Cli::command();
    let mut out = Vec::new();
    clap_complete::generate(args.shell, &mut cmd, "skylod", &mut out);
    std::io::stdout().lock().write_all(&out)?;
    Ok(Outcome::Ok)
}

#[derive(clap::Args, Debug)]
pub struct ManArgs {}

/// Print the manual page (roff) on standard output.
pub fn man(_: ManArgs) -> anyhow::Result<Outcome> {
    let mut out = Vec::new();
    clap_mangen::Man::new(crate::Cli::command()).render(&mut out)?;
    std::io::stdout().lock().write_all(&out)?;
    Ok(Outcome::Ok)
}
