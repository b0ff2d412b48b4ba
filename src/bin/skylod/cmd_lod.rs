//! `skylod lod`: the skyline-controlled mixed-LoD model for a set of POIs.

use crate::common::{ms, non_negative, positive, warn_flags, PoiArgs};
use crate::outputs::Plan;
use crate::Outcome;
use anyhow::{bail, Context};
use rayon::prelude::*;
use skylod::citygml::mixed::write_mixed;
use skylod::citygml::write::{atomic_write, check_target, is_stdout, WriteOptions};
use skylod::export::{Content, Format};
use skylod::lod::{lod, LodOptions};
use skylod::report::{Parameters, Report, Timings};
use skylod::rough::RoughOptions;
use skylod::select::SelectOptions;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pois: PoiArgs,
    #[command(flatten)]
    region: crate::region_args::RegionArgs,
    /// Output file for one input (`-` for standard output; `.gz` compresses; the format
    /// follows the name: .gml/.xml CityGML, .obj OBJ, .city.json CityJSON, .city.jsonl
    /// CityJSONSeq); a directory that mirrors the input tree (created if missing); or, for
    /// several inputs, one CityGML file (or `-`) that merges them.
    #[arg(short, long)]
    output: PathBuf,
    /// Output format when the output's name does not tell it (in a directory: the format of
    /// every output, named after its input with the format's ending).
    #[arg(long, value_name = "citygml|obj|cityjson|cityjsonseq", value_parser = crate::export::parse_format)]
    format: Option<Format>,
    /// Rays per POI (cells of the equal-solid-angle hemisphere partition).
    #[arg(long, default_value_t = 10_000)]
    rays: usize,
    /// Seed of the ray jitter inside each cell (same seed, same output).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Silhouette threshold in degrees (default: 1.5 x the cell's angular size).
    #[arg(long, value_name = "DEG", value_parser = positive, allow_hyphen_values = true)]
    threshold: Option<f64>,
    /// How far (m) below the lowest roof edge an installation may start and still count as
    /// standing on the roof.
    #[arg(long, default_value_t = 0.5, value_name = "M", value_parser = non_negative, allow_hyphen_values = true)]
    roof_tolerance: f64,
    /// Rough model: largest angle (degrees) between normals of one plane.
    #[arg(long, default_value_t = 5.0, value_name = "DEG", value_parser = non_negative, allow_hyphen_values = true)]
    angle: f64,
    /// Rough model: largest distance (m) of a polygon from its plane to be merged.
    #[arg(long, default_value_t = 0.3, value_name = "M", value_parser = non_negative, allow_hyphen_values = true)]
    thickness: f64,
    /// Rough model: do not use an asset's LoD2 geometry when it also has a higher LoD.
    #[arg(long)]
    no_lod2: bool,
    /// Write a JSON report (schemas/report.schema.json; `-` for standard output).
    #[arg(long, value_name = "FILE.json")]
    report: Option<PathBuf>,
    /// Replace existing output files.
    #[arg(long)]
    overwrite: bool,
    #[command(flatten)]
    bound: crate::bound_args::BoundArgs,
}

/// One file written: its summary line (CityGML) and the buildings it dropped.
type Written = anyhow::Result<(Option<String>, usize)>;

pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    let (inputs, _spool) = crate::common::expand_inputs_relative(&args.pois.inputs)?;
    args.pois.inputs = inputs.iter().map(|i| i.path.clone()).collect();
    let t_all = Instant::now();
    args.bound.check()?;
    let pois = args.region.points(&args.pois)?;
    let (plan, format) = crate::outputs::plan(&inputs, &args.output, args.format)?;
    // A merge (-o FILE or -o - for several inputs): each input's model is written to a
    // staging directory, then merged into the target.
    let staging = match &plan {
        Plan::Merge(t) => Some(crate::outputs::Staging::new(t)?),
        _ => None,
    };
    let (outputs, mirror): (Vec<PathBuf>, bool) = match (plan.per_input(), &staging) {
        (Some((v, m)), _) => (v.to_vec(), m),
        (None, Some(st)) => ((0..inputs.len()).map(|k| st.part(k)).collect(), false),
        (None, None) => (Vec::new(), false),
    };
    // Every target is checked before any work: a refusal after minutes of reading and
    // tracing helps nobody.
    let wopts = WriteOptions {
        overwrite: args.overwrite,
        protect: args.pois.inputs.clone(),
        keep_envelopes: false,
    };
    let part_opts = WriteOptions {
        overwrite: true,
        ..wopts.clone()
    };
    if let Plan::Merge(t) = &plan {
        check_target(t, &wopts, args.pois.inputs.iter().map(PathBuf::as_path))?;
    } else {
        for out in &outputs {
            check_target(out, &wopts, args.pois.inputs.iter().map(PathBuf::as_path))?;
        }
    }
    let write_opts = if staging.is_some() {
        &part_opts
    } else {
        &wopts
    };
    if let Some(path) = &args.report {
        if is_stdout(path) && is_stdout(&args.output) {
            bail!("the model and the report cannot both go to standard output");
        }
        check_report_target(path, &args)?;
    }
    let rough_opts = RoughOptions {
        angle_deg: args.angle,
        thickness_m: args.thickness,
        prefer_lod2: !args.no_lod2,
    };
    let select_opts = SelectOptions {
        rays: args.rays,
        seed: args.seed,
        threshold_deg: args.threshold,
        roof_tolerance_m: args.roof_tolerance,
    };
    let mut loaded = args.pois.load_checked()?;
    if loaded.inputs.is_empty() {
        return Ok(Outcome::SomeFailed);
    }
    let pois = args.region.extend(pois, &loaded.model)?;
    let mut failed = loaded.failed;
    let framed = args.pois.frame_checked(&mut loaded.model, pois, "lod")?;
    let mut result = lod(
        &framed.model,
        &framed.local_pois,
        &LodOptions {
            rough: rough_opts,
            select: select_opts,
        },
    )?;
    warn_flags(&framed.pois, &result.flags);
    let mut bound_report = None;
    if args.bound.active() {
        let t = Instant::now();
        let (levels, b) = args.bound.run(
            framed.source,
            &framed.model,
            &result.rough,
            &result.selection.levels,
            &framed.local_pois,
            args.seed,
        )?;
        eprintln!(
            "error bound: {} promotion(s) in {} round(s), largest SVF error {:.3}%, {:.0} ms",
            b.promotions.len(),
            b.rounds,
            100.0 * b.pois.iter().map(|p| p.svf_error).fold(0.0, f64::max),
            ms(t)
        );
        if !b.met {
            eprintln!(
                "error: the error bound cannot be met at these POIs (nothing written):\n{}",
                crate::bound_args::failing_lines(&b)
            );
            return Ok(Outcome::SomeFailed);
        }
        result.selection.levels = levels;
        bound_report = Some(b);
    }
    // Written geometry and the report are in the input's CRS.
    let model = framed.source;
    let pois = &framed.pois;
    let rough = framed
        .frame
        .rough_to_source(&framed.model, model, &result.rough);

    let t_write = Instant::now();
    let mut written: Vec<Option<(String, usize)>> = vec![None; model.files.len()];
    // Files of the model are the inputs that could be read, in input order. They are written
    // in parallel (--jobs); messages follow in input order.
    let jobs: Vec<(usize, &PathBuf)> = model
        .files
        .iter()
        .enumerate()
        .filter_map(|(f, src)| {
            let k = args.pois.inputs.iter().position(|p| p == &src.path)?;
            Some((f, outputs.get(k)?))
        })
        .collect();
    let levels = &result.selection.levels;
    let results: Vec<(usize, String, Written)> = jobs
        .par_iter()
        .map(|&(f, out)| {
            // In a merge, the report names the merged document.
            let shown = match &plan {
                Plan::Merge(t) => t.display().to_string(),
                _ => out.display().to_string(),
            };
            let r = (|| {
                if mirror {
                    crate::outputs::create_parent(out)?;
                }
                if format != Format::CityGml {
                    let content = Content::Levels {
                        rough: &rough,
                        levels,
                    };
                    crate::export::write(format, model, f, content, out, write_opts)?;
                    return Ok((None, buildings_without_kept_assets(model, f, levels)));
                }
                let s = write_mixed(model, f, &rough, levels, out, write_opts)?;
                let line = format!(
                    "{} -> {}: assets at level 0/1/2 = {}/{}/{}, polygons {} -> {}, {} building(s) dropped",
                    model.files[f].path.display(),
                    shown,
                    s.levels[0],
                    s.levels[1],
                    s.levels[2],
                    s.polygons_in,
                    s.polygons_out,
                    s.buildings_dropped
                );
                Ok((Some(line), s.buildings_dropped))
            })();
            (f, shown, r)
        })
        .collect();
    for (f, shown, r) in results {
        match r {
            Ok((line, dropped)) => {
                if let Some(line) = line {
                    eprintln!("{line}");
                }
                if let Some(w) = written.get_mut(f) {
                    *w = Some((shown, dropped));
                }
            }
            Err(e) => {
                eprintln!("error: {e:#}");
                failed = true;
            }
        }
    }
    if let (Some(st), Plan::Merge(t)) = (&staging, &plan) {
        let (parts, names): (Vec<PathBuf>, Vec<PathBuf>) = model
            .files
            .iter()
            .enumerate()
            .filter(|(f, _)| written.get(*f).is_some_and(Option::is_some))
            .filter_map(|(_, src)| {
                let k = args.pois.inputs.iter().position(|p| p == &src.path)?;
                Some((outputs.get(k)?.clone(), src.path.clone()))
            })
            .unzip();
        if parts.is_empty() {
            eprintln!("error: nothing to merge; {} not written", t.display());
            failed = true;
        } else {
            match st.merge(&parts, &names, t, &wopts) {
                Ok(s) => eprintln!("{}", crate::outputs::merge_line(&s, t)),
                Err(e) => {
                    eprintln!("error: {e:#}");
                    failed = true;
                    written.iter_mut().for_each(|w| *w = None);
                }
            }
        }
    }
    let write_ms = ms(t_write);

    let timings = Timings {
        read: loaded.read_ms,
        rough: result.rough_s * 1e3,
        bvh: result.bvh_s * 1e3,
        select: result.select_s * 1e3,
        write: write_ms,
        total: ms(t_all),
    };
    let mut report = Report::new(
        model,
        &rough,
        &result.selection,
        pois,
        Parameters::of(
            &result.selection,
            args.seed,
            args.roof_tolerance,
            &rough_opts,
        ),
        timings,
    );
    report.set_flags(&result.flags);
    report.bound = bound_report;
    for (f, w) in written.into_iter().enumerate() {
        if let Some((path, dropped)) = w {
            let in_file = model.buildings.iter().filter(|b| b.file == f).count();
            report.record_output(f, path, in_file, dropped);
        }
    }
    let t = &report.totals;
    eprintln!(
        "{} POI(s), {} rays each: assets at level 0/1/2 = {}/{}/{}; polygons {} -> {} ({:.1}%); \
         {} triangles traced; read {:.0} ms, rough {:.0} ms, bvh {:.0} ms, select {:.0} ms, write {:.0} ms",
        pois.len(),
        result.selection.rays,
        t.levels[0],
        t.levels[1],
        t.levels[2],
        t.polygons_in,
        t.polygons_out,
        100.0 * t.polygon_fraction,
        result.triangles,
        timings.read,
        timings.rough,
        timings.bvh,
        timings.select,
        timings.write
    );
    if args.region.active() {
        eprintln!(
            "region: one model of {} polygons for {} POIs; their own models hold {:.0} on average, \
             {} at most ({:.2}x)",
            t.polygons_out,
            pois.len(),
            t.single_poi_polygons_mean,
            t.single_poi_polygons_max,
            t.region_over_single_poi
        );
    }
    if let Some(path) = &args.report {
        let json = serde_json::to_vec_pretty(&report)?;
        atomic_write(path, |w| {
            w.write_all(&json)
                .and_then(|_| w.write_all(b"\n"))
                .map_err(|e| skylod::citygml::WriteError::Io {
                    file: path.clone(),
                    source: e,
                })?;
            Ok(json.len() as u64 + 1)
        })
        .context("writing the report")?;
    }
    Ok(if failed {
        Outcome::SomeFailed
    } else {
        Outcome::Ok
    })
}

/// Buildings and parts of file `f` that keep no asset (through any part below them): what
/// the OBJ and CityJSON writers leave out.
fn buildings_without_kept_assets(
    model: &skylod::model::CityModel,
    f: usize,
    levels: &[u8],
) -> usize {
    let mut kept = vec![false; model.buildings.len()];
    for (a, l) in model.assets.iter().zip(levels) {
        if *l == 0 {
            continue;
        }
        let mut b = a.building;
        let mut steps = 0;
        while let Some(k) = b {
            if let Some(x) = kept.get_mut(k) {
                *x = true;
            }
            b = model.buildings.get(k).and_then(|x| x.parent);
            steps += 1;
            if steps > model.buildings.len() {
                break;
            }
        }
    }
    model
        .buildings
        .iter()
        .zip(&kept)
        .filter(|(b, k)| b.file == f && !**k)
        .count()
}

fn check_report_target(path: &Path, args: &Args) -> anyhow::Result<()> {
    let opts = WriteOptions {
        overwrite: args.overwrite,
        ..Default::default()
    };
    skylod::citygml::write::check_target(path, &opts, args.pois.inputs.iter().map(|p| p.as_path()))
        .context("the report")?;
    Ok(())
}
