//! `skylod lod` in an array job: a shard writes its levels ([`skylod::batch::shard_levels`]),
//! `--reduce` writes the model from all shards' levels ([`skylod::batch::reduce`]).

use crate::commands::lod::Args;
use crate::commands::ms;
use crate::inputs::Spool;
use crate::Outcome;
use anyhow::{bail, Context};
use skylod::batch::reduce::Reduce;
use skylod::batch::shard::Shard;
use skylod::batch::shard_levels;
use skylod::citygml::write::{check_target, is_stdout, WriteOptions};
use skylod::lod::LodOptions;
use std::path::PathBuf;
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
    let name = args.out.output.to_string_lossy().to_ascii_lowercase();
    if !name.ends_with(".jsonl") || name.ends_with(".city.jsonl") || is_stdout(&args.out.output) {
        bail!(
            "shard {s} writes its levels, not a model: -o names its levels file \
             (e.g. -o levels-{}.jsonl); then `skylod lod INPUTS -o OUT --reduce levels-*.jsonl` \
             writes the model",
            s.index()
        );
    }
    let wopts = WriteOptions {
        overwrite: args.out.overwrite,
        protect: args.pois.inputs.clone(),
        keep_envelopes: false,
    };
    check_target(
        &args.out.output,
        &wopts,
        args.pois.inputs.iter().map(PathBuf::as_path),
    )?;
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
    let (source, pois) = (study.source(), study.pois());
    let header = shard_levels::header(s, source, &opts, &result.selection, result.triangles);
    let out = std::mem::take(&mut args.out.output);
    shard_levels::write_levels_file(
        &out,
        &header,
        source,
        pois,
        &result.selection,
        &result.flags,
    )
    .with_context(|| format!("writing {}", out.display()))?;
    let [l0, l1, l2] = result.selection.level_counts();
    crate::log::summary!(
        "lod: shard {s}: {} POI(s) -> {}: assets at level 0/1/2 = {l0}/{l1}/{l2}; read {:.0} ms, \
         select {:.0} ms, total {:.0} ms",
        pois.len(),
        out.display(),
        session.read_ms,
        result.select_s * 1e3,
        ms(t_all)
    );
    Ok(session.outcome())
}

/// Read the `--reduce` files (none: `Ok(None)`), and take the options of the lod run from
/// them (`--rays`, `--seed`, `--threshold`, `--roof-tolerance`, `--angle`, `--thickness`,
/// `--no-lod2`): the model is written exactly as the shards selected it.
pub fn read(args: &mut Args) -> anyhow::Result<Option<Reduce>> {
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
    let LodOptions { rough, select } = r.options();
    args.select.rays = select.rays;
    args.select.seed = select.seed;
    args.select.silhouette.threshold = select.threshold_deg;
    args.select.silhouette.roof_tolerance = select.roof_tolerance_m;
    args.rough.angle = rough.angle_deg;
    args.rough.thickness = rough.thickness_m;
    args.rough.no_lod2 = !rough.prefer_lod2;
    crate::log::summary!(
        "lod: reducing {} levels file(s) of a {}-shard run",
        r.files(),
        r.header().count
    );
    Ok(Some(r))
}
