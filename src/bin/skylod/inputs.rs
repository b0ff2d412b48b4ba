//! The inputs of a command: arguments expanded (standard input read into memory).

use crate::log::warning;
use skylod::pipeline::batch::Input;
use std::path::PathBuf;

pub use skylod::pipeline::batch::Spool;

/// Expand the input arguments in place ([`skylod::pipeline::batch::expand`]: files, directories,
/// glob patterns, `-`), reading standard input into memory.
pub fn expand_inputs(inputs: &mut Vec<PathBuf>) -> anyhow::Result<Spool> {
    let (expanded, spool) = expand_inputs_relative(inputs)?;
    *inputs = expanded.into_iter().map(|i| i.path).collect();
    Ok(spool)
}

/// [`expand_inputs`], keeping each input's path relative to its argument (for `-o DIR`; the
/// standard input is `stdin.gml`): [`skylod::pipeline::batch::expand_spooled`].
pub fn expand_inputs_relative(inputs: &[PathBuf]) -> anyhow::Result<(Vec<Input>, Spool)> {
    let (found, spool) =
        skylod::pipeline::batch::expand_spooled(inputs, &mut std::io::stdin().lock())?;
    // A `metadata.xml` beside the tiles of a municipal download is not an input.
    for s in &found.skipped {
        warning!("warning: {s}");
    }
    Ok((found.inputs, spool))
}
