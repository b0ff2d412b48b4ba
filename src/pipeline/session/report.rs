//! The finished report of a `lod` run ([`Study::lod_report`]: timings, guarantee, the
//! outputs written) and what to tell the user of it: the error bound's lines
//! ([`bound_lines`]) and the closing lines ([`lod_lines`]).

use super::Study;
use crate::export::report::report::{Guarantee, Report, Timings};
use crate::lod::LodOptions;
use crate::model::CityModel;
use crate::pipeline::Levels;

/// The times of a `lod` run measured outside [`Levels`] (ms).
#[derive(Debug, Clone, Copy, Default)]
pub struct RunMs {
    /// Reading the inputs.
    pub read: f64,
    /// Writing the outputs.
    pub write: f64,
    /// The whole run.
    pub total: f64,
}

impl Study {
    /// [`Study::report`] of `lv` with its timings (the stages of `lv`, and `ms`), the
    /// `guarantee` of the error bound, and each output `written` recorded ((input file,
    /// output path shown, buildings dropped) : [`Report::record_output`]).
    pub fn lod_report(
        &self,
        lv: &Levels,
        opts: &LodOptions,
        ms: RunMs,
        guarantee: Guarantee,
        written: impl IntoIterator<Item = (usize, String, usize)>,
    ) -> Report {
        let report = self.report(lv, opts, timings_of(lv, ms));
        finished(report, self.source(), guarantee, written)
    }
}

/// The timings of a `lod` report: the stages of `lv`, and `ms`.
pub(super) fn timings_of(lv: &Levels, ms: RunMs) -> Timings {
    let r = &lv.lod;
    Timings {
        read: ms.read,
        rough: r.rough_s * 1e3,
        bvh: r.bvh_s * 1e3,
        select: r.select_s * 1e3,
        write: ms.write,
        total: ms.total,
    }
}

/// `report` of `model` with the `guarantee` of the error bound and each output `written`
/// recorded ([`Study::lod_report`]).
pub(super) fn finished(
    mut report: Report,
    model: &CityModel,
    guarantee: Guarantee,
    written: impl IntoIterator<Item = (usize, String, usize)>,
) -> Report {
    report.guarantee = guarantee;
    for (f, path, dropped) in written {
        report.record_output(f, path, super::lod::buildings_in(model, f), dropped);
    }
    report
}

/// The lines of the error bound of `lv` (the guarantee first), and, when it cannot be met
/// (nothing is to be written then), why: the POIs that fail it.
pub fn bound_lines(lv: &Levels, guarantee: &Guarantee) -> (Vec<String>, Option<String>) {
    let mut said = vec![guarantee.line()];
    let Some(b) = &lv.bound else {
        return (said, None);
    };
    said.push(format!(
        "error bound: {} promotion(s) in {} round(s), largest SVF error {:.3}%, {:.0} ms",
        b.promotions.len(),
        b.rounds,
        100.0 * b.pois.iter().map(|p| p.svf_error).fold(0.0, f64::max),
        lv.bound_s * 1e3
    ));
    let irr = b.pois.iter().filter_map(|p| p.irradiance_error);
    if let Some(e) = irr.reduce(f64::max) {
        said.push(format!(
            "error bound: largest irradiation error {:.3}%",
            100.0 * e
        ));
    }
    let failed = (!b.met).then(|| {
        format!(
            "the error bound cannot be met at these POIs (nothing written):\n{}",
            b.failing_lines()
        )
    });
    (said, failed)
}

/// The closing lines of `report` of `lv` for `pois` POIs: levels, polygons, timings; with
/// `region` (the POIs of a facade or a region), the one model against the POIs' own.
pub fn lod_lines(report: &Report, lv: &Levels, pois: usize, region: bool) -> Vec<String> {
    let (result, t, timings) = (&lv.lod, &report.totals, &report.timings_ms);
    let mut lines = vec![format!(
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
    )];
    if region {
        lines.push(format!(
            "region: one model of {} polygons for {} POIs; their own models hold {:.0} on average, \
             {} at most ({:.2}x)",
            t.polygons_out,
            pois,
            t.single_poi_polygons_mean,
            t.single_poi_polygons_max,
            t.region_over_single_poi
        ));
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::super::{Scene, SceneOptions};
    use super::*;
    use crate::model::runtime::progress::Silent;
    use crate::pipeline::test_support::*;

    #[test]
    fn report_timed_outputs_recorded_and_said() {
        let scene = Scene::load(&[fixture()], &SceneOptions::default(), &Silent).unwrap();
        let pois = grid_pois(scene.model(), 3);
        let study = scene.frame(pois).unwrap();
        let opts = crate::pipeline::LevelsOptions::default();
        let lv = study.levels(&opts, &Silent).unwrap();
        let ms = RunMs {
            read: 1.0,
            write: 2.0,
            total: 30.0,
        };
        let guarantee = Guarantee::default();
        let out = vec![(0, "out.gml".to_string(), 0)];
        let report = study.lod_report(&lv, &opts.lod, ms, guarantee.clone(), out);
        let t = &report.timings_ms;
        assert_eq!((t.read, t.write, t.total), (1.0, 2.0, 30.0));
        assert_eq!(t.select, lv.lod.select_s * 1e3);
        assert_eq!(report.inputs[0].output.as_deref(), Some("out.gml"));
        assert_eq!(report.inputs[0].buildings_out, study.buildings_in(0));
        let lines = lod_lines(&report, &lv, 3, false);
        assert_eq!(lines.len(), 1);
        assert!(lines[0].starts_with("3 POI(s), "), "{}", lines[0]);
        assert!(lines[0].ends_with("write 2 ms"), "{}", lines[0]);
        assert_eq!(lod_lines(&report, &lv, 3, true).len(), 2);
        // No bound asked for: the guarantee's line only, and nothing fails.
        let (said, failed) = bound_lines(&lv, &guarantee);
        assert_eq!(said, vec![guarantee.line()]);
        assert!(failed.is_none());
    }
}
