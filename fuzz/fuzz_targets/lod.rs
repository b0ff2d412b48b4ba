//! Fuzz target: the whole `lod` pipeline on small generated box scenes. The input bytes
//! choose 1-4 box buildings (footprint, height, a roof installation), the POI and its
//! normal, and the ray count; the scene is written as CityGML, read, roughened, traced,
//! selected and written back as mixed-LoD CityGML, which must read again with only assets
//! of the input and no more asset polygons. Never a panic.
#![no_main]

use glam::DVec3;
use libfuzzer_sys::fuzz_target;
use skylod::lod::write_mixed;
use skylod::io::citygml::read_file;
use skylod::io::citygml::WriteOptions;
use skylod::lod::{lod, LodOptions};
use skylod::lod::poi::Poi;
use skylod::lod::SelectOptions;
use skylod::model::synth::{BoxBuilding, boxes_citygml};

struct Bytes<'a>(&'a [u8], usize);

impl Bytes<'_> {
    fn next(&mut self) -> u8 {
        let b = self.0.get(self.1).copied().unwrap_or(0);
        self.1 += 1;
        b
    }
    /// A value in `lo..lo + span` on a quarter-metre grid.
    fn val(&mut self, lo: f64, span: f64) -> f64 {
        lo + (f64::from(self.next()) / 255.0 * span * 4.0).round() / 4.0
    }
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes(data, 0);
    let n = 1 + usize::from(b.next() % 4);
    let buildings: Vec<BoxBuilding> = (0..n)
        .map(|k| {
            let (x, y) = (b.val(-60.0, 120.0), b.val(-60.0, 120.0));
            let (w, d, h) = (b.val(0.25, 40.0), b.val(0.25, 40.0), b.val(0.25, 60.0));
            let inst = b.next();
            BoxBuilding {
                id: format!("B{k}"),
                min: [x, y],
                max: [x + w, y + d],
                height: h,
                installations: if inst % 2 == 1 {
                    let s = b.val(0.25, 3.0);
                    vec![[x, y, h, x + s, y + s, h + b.val(0.25, 8.0)]]
                } else {
                    vec![]
                },
            }
        })
        .collect();
    let origin = [430_000.0, 4_581_000.0, 10.0];
    let poi = DVec3::new(
        origin[0] + b.val(-80.0, 160.0),
        origin[1] + b.val(-80.0, 160.0),
        origin[2] + b.val(0.0, 70.0),
    );
    let normal = match b.next() % 6 {
        0 => None,
        1 => Some(DVec3::X),
        2 => Some(DVec3::NEG_Y),
        3 => Some(DVec3::Z),
        4 => Some(DVec3::new(1.0, 1.0, 0.0).normalize()),
        _ => Some(DVec3::new(0.0, 0.0, 0.0)), // degenerate: treated as horizontal
    };
    let rays = 1 + usize::from(b.next()) * 8;
    let threshold = match b.next() % 4 {
        0 => None,
        k => Some(f64::from(k) * 0.7),
    };

    let Ok(dir) = tempfile::tempdir() else { return };
    let input = dir.path().join("in.gml");
    if std::fs::write(&input, boxes_citygml(&buildings, origin)).is_err() {
        return;
    }
    let model = read_file(&input).expect("generated scenes read");
    let opts = LodOptions {
        select: SelectOptions {
            rays,
            threshold_deg: threshold,
            ..Default::default()
        },
        ..Default::default()
    };
    let pois = [Poi { id: "p".into(), position: poi, normal }];
    let r = lod(&model, &pois, &opts).expect("valid options");
    let out = dir.path().join("out.gml");
    let s = write_mixed(&model, 0, &r.rough, &r.selection.levels, &out, &WriteOptions::default())
        .expect("mixed output is written");
    assert!(s.polygons_out <= s.polygons_in);
    let again = read_file(&out).expect("mixed output reads");
    let ids: std::collections::HashSet<&str> =
        model.assets.iter().filter_map(|a| a.id.as_deref()).collect();
    for a in &again.assets {
        assert!(a.id.as_deref().is_some_and(|i| ids.contains(i)), "{:?}", a.id);
    }
});
