//! One definition of a level's output (`skylod::lod::level`): on real LoD3 files, the polygons the
//! report counts, the polygons `evaluate` counts, the polygons the writer writes and the
//! polygons a reader finds in the written file are the same number, and `evaluate`'s LoD SVF is
//! the SVF of the written file read back and traced with the same rays.

use glam::DVec3;
use skylod::export::report::{Parameters, Report, Timings};
use skylod::io::citygml::read_file;
use skylod::io::citygml::WriteOptions;
use skylod::lod::poi::Poi;
use skylod::lod::write_mixed;
use skylod::lod::{evaluate, EvalOptions};
use skylod::lod::{full_scene, mixed_scene};
use skylod::lod::{lod, LodOptions};
use skylod::solar::{poi_sky_view, SkyBundles};
use skylod::Silent;

/// Files with installations (several below the roof edge, some with 3-polygon geometry that
/// the writer keeps verbatim at level 1), xlinked installation geometry, and CityGML 3.0.
const FILES: &[&str] = &[
    "ingolstadt-lod3/4018115.xml.gz",
    "ingolstadt-lod3/4018133.xml.gz",
    "ingolstadt-lod3/4018147.xml.gz",
    "ingolstadt-lod3/4018264.xml.gz",
    "ogc-citygml3-examples/XLink_examples/5_Building_with_Building_Installation/CityGML_2.gml.gz",
    "ogc-citygml3-examples/XLink_examples/5_Building_with_Building_Installation/CityGML_3.gml.gz",
    "kit-fzk-haus/citygml2/fzk_haus_lod3_v2.gml",
];

#[test]
fn report_evaluate_writer_and_written_file_agree() {
    let Some(data) = crate::util::shared_data() else {
        crate::util::missing("../shared/data");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let mut checked = 0;
    let mut level1_kept_verbatim = 0;
    for (k, rel) in FILES.iter().enumerate() {
        if cfg!(debug_assertions) && rel.contains("XLink") {
            // The full-detail BVH of this building is 204 levels deep: obvhs' debug-build
            // validation rejects it (so does `skylod svf` on it in a debug build; the release
            // build traces it). Checked in release builds only.
            eprintln!("{rel}: release builds only (obvhs debug validation, BVH depth)");
            checked += 1;
            continue;
        }
        let path = data.join(rel);
        let model = read_file(&path).unwrap_or_else(|e| panic!("{rel}: {e}"));
        let bb = model.bbox();
        // In front of the building at street level, looking at its facade and roof edge.
        let poi = Poi {
            id: "street".into(),
            position: DVec3::new(0.5 * (bb.min.x + bb.max.x), bb.min.y - 3.0, bb.min.z + 1.5),
            normal: None,
        };
        let lopts = LodOptions::default();
        let r = lod(&model, std::slice::from_ref(&poi), &lopts, &Silent).unwrap();
        let levels = &r.selection.levels;
        let report = Report::new(
            &model,
            &r.rough,
            &r.selection,
            std::slice::from_ref(&poi),
            Parameters::default(),
            Timings::default(),
        );
        let out = dir.path().join(format!("out{k}.gml"));
        let summary = write_mixed(
            (&model, 0),
            &r.rough,
            levels,
            &out,
            &WriteOptions::default(),
        )
        .unwrap();
        let back = read_file(&out).unwrap_or_else(|e| panic!("{rel} written: {e}"));
        let eopts = EvalOptions {
            lod: lopts,
            ..Default::default()
        };
        let e = evaluate(&model, std::slice::from_ref(&poi), &eopts, None).unwrap();
        let ev = &e.pois[0];
        let written_count = back.polygon_count();
        eprintln!(
            "{rel}: levels {:?}, polygons: report {}, evaluate {}, writer {}, written file {}",
            r.selection.level_counts(),
            report.totals.polygons_out,
            ev.lod.polygons,
            summary.polygons_out,
            written_count
        );
        assert!(
            ev.levels[1] + ev.levels[2] > 0,
            "{rel}: nothing kept, the test proves nothing"
        );
        assert_eq!(report.totals.polygons_out, ev.lod.polygons, "{rel}");
        assert_eq!(report.totals.polygons_out, summary.polygons_out, "{rel}");
        assert_eq!(report.totals.polygons_out, written_count, "{rel}");
        assert_eq!(ev.full.polygons, report.totals.polygons_in, "{rel}");

        // The LoD model evaluate traces is the written file's full model.
        let bundles = SkyBundles::new(eopts.svf_rays, eopts.svf_seed).unwrap();
        let traced_back = poi_sky_view(&full_scene(&back), &poi, &bundles);
        let traced_mem = poi_sky_view(&mixed_scene(&model, &r.rough, levels), &poi, &bundles);
        eprintln!(
            "  SVF: evaluate {:.6}, mixed scene {:.6}, written file {:.6}",
            ev.lod.svf, traced_mem.svf, traced_back.svf
        );
        assert_eq!(ev.lod.svf, traced_mem.svf, "{rel}");
        // Coordinates go through text: a ray grazing an edge may flip, nothing more.
        assert!(
            (traced_back.svf - ev.lod.svf).abs() < 2.0 / eopts.svf_rays as f64,
            "{rel}: evaluate {} vs written file {}",
            ev.lod.svf,
            traced_back.svf
        );
        level1_kept_verbatim += model
            .assets
            .iter()
            .zip(&r.rough)
            .zip(levels)
            .filter(|((a, rg), l)| {
                **l == 1
                    && skylod::lod::properties(a, Some(rg), 1)
                        .iter()
                        .any(|p| !p.rough && !p.polygons.is_empty())
            })
            .count();
        checked += 1;
    }
    assert_eq!(checked, FILES.len());
    // The case that made the consumers disagree must be among the inputs.
    assert!(level1_kept_verbatim > 0, "no level-1 asset kept verbatim");
}
