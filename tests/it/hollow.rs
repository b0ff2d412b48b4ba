//! The hollow read of `lod` (`skylod::lod::hollow`): on every CityGML document of the shared
//! data, read one top-level member at a time, it is the whole read without its polygons, with
//! the rough forms, boxes and polygon counts of the whole model; its assets read back from the
//! document by span (`Hollow::read_back`) are the whole read's.

use crate::util::*;
use skylod::io::citygml::ReadOptions;
use skylod::io::citygml::{read_file, Passes, Reread};
use skylod::lod::detail_boxes;
use skylod::lod::rough::{rough_model, RoughGeometry, RoughOptions};
use skylod::lod::{hollowed, read_hollow};
use skylod::model::{content_bbox, Asset, Bbox, CityModel};

#[test]
fn shared_data_read_hollow_is_the_whole_read_without_its_polygons() {
    let Some(data) = shared_data() else {
        return;
    };
    let read = ReadOptions::default();
    // one member a chunk: every cut of the document is met
    let passes = Passes::new(&read, 1, &|_, _| {});
    let opts = RoughOptions::default();
    let (mut compared, mut read_back, mut declined) = (0, 0, Vec::new());
    for path in citygml_files(&data) {
        let Ok(whole) = read_file(&path) else {
            continue;
        };
        // the assets above the model's middle keep their polygons
        let high = whole.bbox().center().z;
        let keep = |_: &CityModel, _: &[RoughGeometry], b: &[Bbox]| {
            b.iter().map(|b| b.max.z > high).collect()
        };
        let Some(h) = read_hollow(&path, &passes, &opts, &keep) else {
            declined.push(short(&path));
            continue;
        };
        let name = short(&path);
        let want = hollowed(whole.clone(), &h.kept);
        assert_eq!(h.model.warnings, want.warnings, "{name}");
        let (f, g) = (&h.model.files, &want.files);
        assert!(
            f == g,
            "{name}: {:?}",
            (
                f.len(),
                g.len(),
                f.first().map(|f| (f.gzip, f.len, &f.source))
            )
        );
        assert!(h.model.buildings == want.buildings, "{name}: buildings");
        for (i, (a, b)) in h.model.assets.iter().zip(&want.assets).enumerate() {
            assert!(a == b, "{name}: asset {i}");
        }
        assert_eq!(h.model.assets.len(), want.assets.len(), "{name}");
        assert_eq!(h.rough, rough_model(&whole, &opts), "{name}");
        let boxes: Vec<Bbox> = whole.assets.iter().map(Asset::bbox).collect();
        assert_eq!(h.boxes, boxes, "{name}");
        assert_eq!((h.detail.clone(), h.frame), detail_boxes(&whole), "{name}");
        let content = content_bbox(&whole.assets, &whole.buildings);
        assert_eq!(h.content, content, "{name}");
        let mut counts = whole.assets.iter().enumerate();
        assert!(
            counts
                .clone()
                .all(|(i, a)| h.polygon_count(i) == a.polygon_count()),
            "{name}"
        );
        assert!(
            counts.all(|(i, a)| (0..=4).all(|l| h.polygon_count_at(i, l) == a.polygons_at(l).count())),
            "{name}"
        );
        // read back (chunks of 64 KiB: several members each), every third asset and all
        if let Some(rr) = Reread::open(&path, &read) {
            let wide = Passes::new(&read, 1 << 16, &|_, _| {});
            let none = |m: &CityModel, _: &[RoughGeometry], _: &[Bbox]| vec![false; m.assets.len()];
            let h = read_hollow(&path, &wide, &opts, &none).unwrap_or_else(|| panic!("{name}"));
            let n = whole.assets.len();
            let some: Vec<usize> = (0..n).step_by(3).collect();
            let got = h.read_back(&rr, &some).unwrap_or_else(|| panic!("{name}"));
            assert!(
                got.iter().zip(&some).all(|(a, &i)| *a == whole.assets[i]),
                "{name}"
            );
            let all: Vec<usize> = (0..n).collect();
            let got = h.read_back(&rr, &all).unwrap_or_else(|| panic!("{name}"));
            assert!(got == whole.assets, "{name}: read back");
            read_back += 1;
        }
        compared += 1;
    }
    eprintln!("{compared} documents read hollow ({read_back} read back); declined (read whole): {declined:?}");
    assert!(read_back >= 20, "only {read_back} documents read back");
    assert!(compared >= 20, "only {compared} documents compared");
}
