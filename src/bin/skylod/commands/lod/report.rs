//! The closing lines of `skylod lod` and its `--report`.

use super::Args;
use crate::commands::ms;
use crate::log::summary;
use anyhow::Context;
use skylod::citygml::write::atomic_write_bytes;
use skylod::output::report::{Report, Timings};
use skylod::pipeline::Levels;
use skylod::session::Study;
use std::time::Instant;

/// The timings of the report (ms): the stages of `lv`, reading, writing, the whole run.
pub fn timings(lv: &Levels, read: f64, write: f64, t_all: Instant) -> Timings {
    let result = &lv.lod;
    Timings {
        read,
        rough: result.rough_s * 1e3,
        bvh: result.bvh_s * 1e3,
        select: result.select_s * 1e3,
        write,
        total: ms(t_all),
    }
}

/// The outputs `written` recorded in `report` ([`Study::report`]), and the closing lines
/// (`region`: the POIs of --facade/--region are among them).
pub fn finish(
    report: &mut Report,
    study: &Study,
    lv: &Levels,
    written: Vec<Option<(String, usize)>>,
    region: bool,
) {
    for (f, w) in written.into_iter().enumerate() {
        if let Some((path, dropped)) = w {
            report.record_output(f, path, study.buildings_in(f), dropped);
        }
    }
    let (result, t, timings) = (&lv.lod, &report.totals, &report.timings_ms);
    let pois = study.pois().len();
    summary!(
        "{} POI(s), {} rays each: assets at level 0/1/2 = {}/{}/{}; polygons {} -> {} ({:.1}%); \
         {} triangles traced; read {:.0} ms, rough {:.0} ms, bvh {:.0} ms, select {:.0} ms, write {:.0} ms",
        pois,
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
    if region {
        summary!(
            "region: one model of {} polygons for {} POIs; their own models hold {:.0} on average, \
             {} at most ({:.2}x)",
            t.polygons_out,
            pois,
            t.single_poi_polygons_mean,
            t.single_poi_polygons_max,
            t.region_over_single_poi
        );
    }
}

/// Write `--report`, when asked for.
pub fn write(args: &Args, report: &Report) -> anyhow::Result<()> {
    if let Some(path) = &args.report {
        let mut json = serde_json::to_vec_pretty(report)?;
        json.push(b'\n');
        atomic_write_bytes(path, &json).context("writing the report")?;
    }
    Ok(())
}
