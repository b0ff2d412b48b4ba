//! The inputs of a command: arguments expanded (standard input spooled to a file), read and
//! merged into one model, failures reported.

use crate::log::error;
use crate::Outcome;
use anyhow::{bail, Context};
use skylod::model::CityModel;
use std::path::PathBuf;

/// Standard input spooled to a temporary file (removed when this is dropped): the writer
/// re-reads its source, and a pipe can be read only once.
pub struct Spool(#[allow(dead_code)] Option<tempfile::TempDir>);

/// Expand the input arguments in place ([`skylod::batch::inputs::expand`]: files, directories,
/// glob patterns, `-`), spooling standard input to a temporary file. Keep the returned
/// [`Spool`] alive while the inputs are read and written.
pub fn expand_inputs(inputs: &mut Vec<PathBuf>) -> anyhow::Result<Spool> {
    let (expanded, spool) = expand_inputs_relative(inputs)?;
    *inputs = expanded.into_iter().map(|i| i.path).collect();
    Ok(spool)
}

/// [`expand_inputs`], keeping each input's path relative to its argument (for `-o DIR`; the
/// spooled standard input is `stdin.gml`).
pub fn expand_inputs_relative(
    inputs: &[PathBuf],
) -> anyhow::Result<(Vec<skylod::batch::inputs::Input>, Spool)> {
    let expanded = skylod::batch::inputs::expand(inputs)?;
    let mut spool = None;
    let mut out = Vec::with_capacity(expanded.len());
    for i in expanded {
        if i.path.as_os_str() == "-" {
            if spool.is_some() {
                bail!("standard input (-) can be read only once");
            }
            let dir = tempfile::Builder::new().prefix("skylod-stdin-").tempdir()?;
            let path = dir.path().join("stdin");
            let mut f = std::fs::File::create(&path)
                .with_context(|| format!("spooling standard input to {}", path.display()))?;
            std::io::copy(&mut std::io::stdin().lock(), &mut f)
                .context("reading standard input")?;
            out.push(skylod::batch::inputs::Input {
                path,
                relative: PathBuf::from("stdin.gml"),
            });
            spool = Some(dir);
        } else {
            out.push(i);
        }
    }
    Ok((out, Spool(spool)))
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
        if self.failed {
            Outcome::SomeFailed
        } else {
            Outcome::Ok
        }
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
