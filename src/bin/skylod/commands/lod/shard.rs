//! `skylod lod` in an array job: a shard writes its levels ([`skylod::pipeline::batch::shard_levels`]),
//! `--reduce` writes the model from all shards' levels ([`skylod::pipeline::batch::reduce`]).

use crate::commands::lod::Args;
use crate::inputs::Spool;
use crate::Outcome;
use anyhow::{bail, Context};
use skylod::lod::LodOptions;
use skylod::pipeline::batch::Reduce;
use skylod::pipeline::batch::Shard;
use skylod::pipeline::batch::{check_levels_target, write_shard};
use skylod::pipeline::session::ms_since;
use std::time::Instant;

/// Run one shard of `lod`: trace this shard's POIs and write their levels to `-o`.
pub fn shard(mut args: Args, s: Shard, spool: Spool, t_all: Instant) -> anyhow::Result<Outcome> {
    if !args.reduce.is_empty() {
        bail!(
            "--reduce combines the levels of every shard: run it once, without --shard (and \
             outside the array job's JOB_COMPLETION_INDEX / SLURM_ARRAY_TASK_ID / \
             AWS_BATCH_JOB_ARRAY_INDEX)"
        );
    }
    if args.bound.explicit() {
        bail!(
            "the error bound (--max-svf-error, --max-sun-hours-error, --max-irradiance-error, \
             --weather) needs every POI: give it \
             to the --reduce step, not to shard {s}"
        );
    }
    if args.report.is_some() {
        bail!("shard {s} writes levels, not a model: give --report to the --reduce step");
    }
    let out = std::mem::take(&mut args.out.output);
    check_levels_target(&out, s, args.out.overwrite, &args.pois.inputs)?;
    let pois = args.region.points(&args.pois)?;
    let region = args.region.active();
    args.scene
        .filter(&mut args.pois, &pois, Some(s), region, "lod")?;
    let Some(scene) = args.pois.scene()? else {
        return Ok(Outcome::SomeFailed);
    };
    let pois = args.region.extend(pois, scene.model())?;
    let pois = crate::args::shard::pois(Some(s), pois, "lod");
    let opts = LodOptions {
        rough: args.rough.options()?,
        select: args.select.options(),
    };
    let session = args.pois.study(scene, pois, Some(s), spool, "lod")?;
    let study = &session.study;
    let result = study.lod(&opts, &crate::log::reporter())?;
    session.warn_flags(&result.flags);
    let w = write_shard(&out, s, study.source(), study.pois(), &opts, &result)
        .with_context(|| format!("writing {}", out.display()))?;
    crate::log::summary!("lod: {}", w.line(session.read_ms, ms_since(t_all)));
    Ok(session.outcome())
}

/// Read the `--reduce` files (none: `Ok(None)`); the options of the lod run (`--rays`,
/// `--seed`, `--threshold`, `--roof-tolerance`, `--angle`, `--thickness`, `--no-lod2`) are
/// theirs ([`Reduce::options`]).
pub fn read(args: &Args) -> anyhow::Result<Option<Reduce>> {
    if args.reduce.is_empty() {
        return Ok(None);
    }
    if !args.pois.poi.is_empty() || args.pois.pois.is_some() || args.region.active() {
        bail!(
            "--reduce takes the POIs from the levels files: leave out --poi, --pois, --facade \
             and --region"
        );
    }
    let r = Reduce::read(&args.reduce)?;
    crate::log::summary!("lod: {}", r.line());
    Ok(Some(r))
}
