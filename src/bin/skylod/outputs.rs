//! `-o` of the commands that write per input (`convert`, `rough`, `lod`, `reproject`,
//! `subset`, `filter-lods`): the library lays the outputs out, merges and says what to tell
//! the user ([`skylod::pipeline::batch::outputs`], [`skylod::pipeline::batch::run`]); this module prints it (in
//! the flags' words: [`skylod::pipeline::session::flags`]).

use crate::log::{error, summary, warning};
use anyhow::anyhow;
use skylod::export::Format;
use skylod::io::citygml::WriteOptions;
use skylod::pipeline::batch::Input;
use skylod::pipeline::batch::Shard;
use skylod::pipeline::batch::Targets;
use skylod::pipeline::batch::{Batch, Said};
use std::path::{Path, PathBuf};

use skylod::pipeline::batch::Done;

/// [`skylod::pipeline::batch::Plan::targets`] for `cmd`: this shard's files said on stderr, each refused target
/// reported with `refused` (its input fails without being read); the number refused
/// (`reproject`).
#[cfg(feature = "proj")]
pub fn targets(
    plan: &skylod::pipeline::batch::Plan,
    inputs: &[PathBuf],
    wopts: &WriteOptions,
    shard: Option<Shard>,
    cmd: &str,
    keeps_crs: bool,
    refused: impl Fn(&anyhow::Error),
) -> anyhow::Result<(Targets, usize)> {
    let mut t = plan.targets(inputs, wopts, shard, (keeps_crs, true))?;
    let n = refused_said(&mut t, shard, inputs.len(), cmd, refused);
    Ok((t, n))
}

/// This shard's files said, the refused targets of `t` taken and reported; their number.
fn refused_said(
    t: &mut Targets,
    shard: Option<Shard>,
    inputs: usize,
    cmd: &str,
    refused: impl Fn(&anyhow::Error),
) -> usize {
    if let Some(s) = shard {
        crate::args::shard::say(s, s.files(inputs), inputs, cmd, "files");
    }
    let n = t.refused.len();
    for e in std::mem::take(&mut t.refused) {
        refused(&anyhow!("{}", crate::flags::cli_text(&e)));
    }
    n
}

/// Print what the library said, each line at its level.
pub fn say(said: Vec<Said>) {
    for s in said {
        match s {
            Said::Summary(l) => summary!("{l}"),
            Said::Warning(l) => warning!("{l}"),
            Said::Error(l) => error!("{l}"),
        }
    }
}

/// `cmd`'s [`Batch`] of `inputs` for `-o`, `--format`, `--overwrite`: this shard's files
/// said, each refused target reported (its input fails without being read).
pub fn batch(
    cmd: &str,
    inputs: &[Input],
    out: (&Path, Option<Format>, bool),
    keep_envelopes: bool,
    shard: Option<Shard>,
) -> anyhow::Result<Batch> {
    let mut b = Batch::new(inputs, out, keep_envelopes, shard)?;
    refused_said(&mut b.targets, shard, inputs.len(), cmd, |e| error!("{e}"));
    Ok(b)
}

/// [`Batch::finish`] with each failure said by `failure`, printed; the exit outcome.
pub fn finish(
    batch: &Batch,
    cmd: &str,
    results: Vec<(PathBuf, PathBuf, anyhow::Result<Done>)>,
    failure: impl Fn(&anyhow::Error) -> String,
    inputs: usize,
    t0: std::time::Instant,
) -> crate::Outcome {
    let results = results
        .into_iter()
        .map(|(i, o, r)| (i, o, r.map_err(|e| failure(&e))))
        .collect();
    let f = batch.finish(cmd, results, inputs, t0);
    say(f.said);
    crate::Outcome::failed_if(f.failed > 0)
}

/// Run `edit` on every input of `a` as `cmd` (`subset`, `filter-lods`, `upgrade`): a
/// [`Batch`] (targets checked before any work, an error per input does not stop it, several
/// inputs into one file merged), with `--jobs` inputs at once; the lines said in input order,
/// the outputs the same whatever the number.
pub fn per_input_jobs(
    a: &crate::args::citygml_io::CityGmlIoArgs,
    cmd: &str,
    jobs: &crate::args::jobs::JobsArgs,
    edit: skylod::pipeline::batch::Transform,
) -> anyhow::Result<crate::Outcome> {
    let t0 = std::time::Instant::now();
    let shard = a.shard.resolve()?;
    let (inputs, _spool) = crate::inputs::expand_inputs_relative(&a.inputs)?;
    let out = (a.output.as_path(), Some(Format::CityGml), a.overwrite);
    let mut b = Batch::for_edits(&inputs, out, true, shard)?;
    refused_said(&mut b.targets, shard, inputs.len(), cmd, |e| error!("{e}"));
    b.counts_polygons = false;
    let each = |i: &Path, o: &Path, shown: &Path, w: &WriteOptions| {
        let done = edit.apply(i, o, shown, w).map(Done::with_line);
        done.map_err(|e| anyhow!(crate::flags::cli_text(&e)))
    };
    let results = jobs.install(|| b.run_each(&inputs, true, &each))?;
    let failure = |e: &anyhow::Error| e.to_string();
    Ok(finish(&b, cmd, results, failure, inputs.len(), t0))
}
