//! What `lod` tells the user of its levels and report: the error bound's lines
//! ([`bound_lines`]) and the closing lines ([`lod_lines`]).

use skylod::export::report::{Guarantee, Report};
use skylod::Levels;

/// The lines of the error bound of `lv` (the guarantee first), and, when it cannot be met
/// (nothing is to be written then), why: the POIs that fail it.
pub(crate) fn bound_lines(lv: &Levels, guarantee: &Guarantee) -> (Vec<String>, Option<String>) {
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
pub(crate) fn lod_lines(report: &Report, lv: &Levels, pois: usize, region: bool) -> Vec<String> {
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
    use super::*;
    use skylod::pipeline::session::RunMs;
    use skylod::prelude::*;

    #[test]
    fn levels_and_timings_said_the_bound_s_guarantee_first() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/synth-small.gml");
        let scene = Scene::load(&[path], &SceneOptions::default(), &Silent).unwrap();
        let c = scene.model().bbox().center();
        let z = scene.model().bbox().min.z + 1.5;
        let pois = (0..3)
            .map(|i| Poi::at(format!("p{i}"), [c.x + f64::from(i) * 0.1, c.y, z]))
            .collect();
        let study = scene.frame(pois).unwrap();
        let opts = LevelsOptions::default();
        let lv = study.levels(&opts, &Silent).unwrap();
        let ms = RunMs {
            read: 1.0,
            write: 2.0,
            total: 30.0,
        };
        let guarantee = Guarantee::default();
        let out = vec![(0, "out.gml".to_string(), 0)];
        let report = study.lod_report(&lv, &opts.lod, ms, guarantee.clone(), out);
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
