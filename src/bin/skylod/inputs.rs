//! The inputs of a command: arguments expanded (standard input read into memory), read and
//! merged into one model, failures reported.

use crate::log::{error, warning};
use crate::Outcome;
use skylod::batch::inputs::Input;
use skylod::model::CityModel;
use std::path::PathBuf;

pub use skylod::batch::inputs::Spool;

/// Expand the input arguments in place ([`skylod::batch::inputs::expand`]: files, directories,
/// glob patterns, `-`), reading standard input into memory.
pub fn expand_inputs(inputs: &mut Vec<PathBuf>) -> anyhow::Result<Spool> {
    let (expanded, spool) = expand_inputs_relative(inputs)?;
    *inputs = expanded.into_iter().map(|i| i.path).collect();
    Ok(spool)
}

/// [`expand_inputs`], keeping each input's path relative to its argument (for `-o DIR`; the
/// standard input is `stdin.gml`): [`skylod::batch::inputs::expand_spooled`].
pub fn expand_inputs_relative(inputs: &[PathBuf]) -> anyhow::Result<(Vec<Input>, Spool)> {
    let (found, spool) =
        skylod::batch::inputs::expand_spooled(inputs, &mut std::io::stdin().lock())?;
    // A `metadata.xml` beside the tiles of a municipal download is not an input.
    for s in &found.skipped {
        warning!("warning: {s}");
    }
    Ok((found.inputs, spool))
}

/// The inputs that could be read, merged in input order ([`skylod::pipeline::Inputs`]).
pub struct Loaded {
    pub model: CityModel,
    /// Paths read successfully.
    pub inputs: Vec<String>,
    /// Some input failed (reported on stderr).
    pub failed: bool,
    pub read_ms: f64,
}

impl Loaded {
    /// [`skylod::pipeline::Inputs::check`].
    pub fn check(&self, allow_mixed_crs: bool) -> anyhow::Result<()> {
        if !self.inputs.is_empty() {
            skylod::pipeline::check_model(&self.model, allow_mixed_crs)?;
        }
        Ok(())
    }
}

impl Loaded {
    /// Exit outcome: some inputs failed, or all were read.
    pub fn outcome(&self) -> Outcome {
        Outcome::failed_if(self.failed)
    }
}

/// Read every input in parallel and merge them ([`skylod::pipeline::read_inputs`], with
/// progress); errors go to stderr.
pub fn load(inputs: &[PathBuf]) -> anyhow::Result<Loaded> {
    let r = skylod::pipeline::read_inputs(inputs, &crate::log::reporter())?;
    for e in &r.failures {
        error!("{e}");
    }
    Ok(Loaded {
        model: r.model,
        inputs: r.read.iter().map(|p| p.display().to_string()).collect(),
        failed: !r.failures.is_empty(),
        read_ms: (r.read_s * 1e4).round() / 10.0,
    })
}
