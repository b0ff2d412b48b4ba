//! Tests of the hollow read: against the whole read, read back, twins, polygon ids.

use super::*;
use crate::io::citygml::read::read_file;
use crate::io::citygml::ReadOptions;
use crate::lod::rough::rough_model;
use crate::model::content_bbox;

/// The small synthetic fixture (`pipeline::test_support::fixture`'s: the pipeline is a later
/// group than `lod`).
fn fixture() -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/synth-small.gml")
}

#[test]
fn a_hollow_read_in_small_chunks_is_the_whole_read_without_its_polygons() {
    let path = fixture();
    let whole = read_file(&path).unwrap();
    let read = ReadOptions::default();
    let passes = Passes::new(&read, 1, &|_, _| {});
    let high = whole.bbox().center().z;
    let keep =
        |_: &CityModel, _: &[RoughGeometry], b: &[Bbox]| b.iter().map(|b| b.max.z > high).collect();
    let h = read_hollow(&path, &passes, &RoughOptions::default(), &keep).unwrap();
    assert!(h.summary.chunks > 2, "{} chunks", h.summary.chunks);
    assert!(h.kept.iter().any(|&k| k) && h.kept.iter().any(|&k| !k));
    assert_eq!(h.model, hollowed(whole.clone(), &h.kept));
    assert_eq!(h.rough, rough_model(&whole, &RoughOptions::default()));
    let boxes: Vec<Bbox> = whole.assets.iter().map(Asset::bbox).collect();
    assert_eq!(h.boxes, boxes);
    assert_eq!((h.detail.clone(), h.frame), detail_boxes(&whole));
    assert_eq!(h.content, content_bbox(&whole.assets, &whole.buildings));
    for (i, a) in whole.assets.iter().enumerate() {
        assert_eq!(h.polygon_count(i), a.polygon_count());
        let lod = a.max_lod().unwrap_or(0);
        assert_eq!(h.polygon_count_at(i, lod), a.polygons_at(lod).count());
    }
    assert_eq!(h.polygon_count(whole.assets.len()), 0);
}

/// Read without polygon ids ([`ReadOptions::polygon_ids`]), the kept assets given theirs
/// back ([`Hollow::kept_with_ids`]): the hollow read with them.
#[test]
fn a_read_without_polygon_ids_gives_the_kept_ones_theirs_back() {
    let path = fixture();
    let high = read_file(&path).unwrap().bbox().center().z;
    let keep =
        |_: &CityModel, _: &[RoughGeometry], b: &[Bbox]| b.iter().map(|b| b.max.z > high).collect();
    let hollow = |polygon_ids| {
        let read = ReadOptions {
            polygon_ids,
            ..ReadOptions::default()
        };
        let passes = Passes::new(&read, 1, &|_, _| {});
        read_hollow(&path, &passes, &RoughOptions::default(), &keep).unwrap()
    };
    let (with, mut without) = (hollow(true), hollow(false));
    let ids = |h: &Hollow| {
        (h.model.assets.iter().flat_map(|a| &a.geometries))
            .flat_map(|g| &g.polygons)
            .filter(|p| p.id.is_some())
            .count()
    };
    assert!(ids(&with) > 0 && with.kept.iter().any(|&k| !k));
    assert_eq!(ids(&without), 0);
    let rr = Reread::open(&path, &ReadOptions::default()).unwrap();
    without.kept_with_ids(&rr).unwrap();
    assert_eq!(ids(&without), ids(&with));
    assert_eq!(without.model, with.model);
    assert_eq!((&without.rough, &without.boxes), (&with.rough, &with.boxes));
    assert_eq!((&without.detail, &without.twin), (&with.detail, &with.twin));
    assert_eq!(without.kept, with.kept);
}

/// Six blocks of the small preset written in `dir`, and their options; `stacked`: the
/// members twice, at the same place, the copy's ids renamed (as the bench files repeat
/// a street).
fn six_blocks(
    dir: &Path,
    stacked: bool,
) -> (std::path::PathBuf, crate::model::synth::SynthOptions) {
    let small = crate::model::synth::SynthOptions {
        blocks_x: 3,
        blocks_y: 2,
        ..crate::model::synth::Preset::Small.defaults()
    };
    let path = dir.join("six.gml");
    let mut xml = Vec::new();
    crate::model::synth::generate(&small, &mut xml).unwrap();
    let mut xml = String::from_utf8(xml).unwrap();
    if stacked {
        // the members again, their ids and references renamed
        let (from, to) = (
            xml.find("<core:cityObjectMember>").unwrap(),
            xml.rfind("</core:cityObjectMember>").unwrap() + "</core:cityObjectMember>".len(),
        );
        let copy = (xml[from..to].replace("gml:id=\"", "gml:id=\"copy_"))
            .replace("xlink:href=\"#", "xlink:href=\"#copy_");
        xml.insert_str(to, &copy);
    }
    std::fs::write(&path, xml).unwrap();
    (path, small)
}

/// [`six_blocks`] read whole, two of its POIs, and read hollow in chunks of
/// `chunk_bytes` with the POIs' surroundings kept ([`near_pois`]).
fn six_read(
    dir: &Path,
    chunk_bytes: u64,
    stacked: bool,
) -> (
    std::path::PathBuf,
    CityModel,
    Vec<crate::model::Poi>,
    Hollow,
) {
    let (path, small) = six_blocks(dir, stacked);
    let whole = read_file(&path).unwrap();
    let pois: Vec<crate::model::Poi> = (crate::model::synth::pois(&small).into_iter())
        .take(2)
        .map(Into::into)
        .collect();
    let points: Vec<DVec3> = pois.iter().map(|p| p.position).collect();
    let read = ReadOptions::default();
    let passes = Passes::new(&read, chunk_bytes, &|_, _| {});
    let rough = RoughOptions::default();
    let h = read_hollow(&path, &passes, &rough, &near_pois(&points)).unwrap();
    (path, whole, pois, h)
}

/// Every asset of a hollow read in small chunks read back ([`Hollow::read_back`]), some
/// at a time and all at once, is the whole read's.
#[test]
fn assets_read_back_are_the_whole_reads() {
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = six_blocks(dir.path(), false);
    let whole = read_file(&path).unwrap();
    let read = ReadOptions::default();
    let passes = Passes::new(&read, 1 << 16, &|_, _| {});
    let none = |m: &CityModel, _: &[RoughGeometry], _: &[Bbox]| vec![false; m.assets.len()];
    let h = read_hollow(&path, &passes, &RoughOptions::default(), &none).unwrap();
    assert!(h.summary.chunks > 2, "{} chunks", h.summary.chunks);
    let rr = Reread::open(&path, &read).unwrap();
    let n = whole.assets.len();
    let all: Vec<usize> = (0..n).collect();
    assert_eq!(h.read_back(&rr, &all).unwrap(), whole.assets);
    // every seventh asset, backwards, and the last chunk's first
    let some: Vec<usize> = (0..n).rev().step_by(7).collect();
    let got = h.read_back(&rr, &some).unwrap();
    for (a, i) in got.iter().zip(&some) {
        assert_eq!(a, &whole.assets[*i], "asset {i}");
    }
    assert!(h.read_back(&rr, &[n]).is_none());
    // a member of a chunk of several reads alone: fewer assets than its chunk
    let alone = (0..n).find_map(|i| {
        let start = &h.starts[h.chunk_of[i] as usize];
        let one = rr.parse(
            start,
            Some(rr.members(start, {
                let a = &h.model.assets[i];
                h.anchor(a.building, &a.span)
            })),
        );
        let chunk = rr.parse(start, None).unwrap();
        let one = one.unwrap();
        assert!(!one.assets.is_empty());
        (one.assets.len() < chunk.assets.len()).then_some((i, one))
    });
    let (i, one) = alone.unwrap();
    assert_eq!(one.assets[0].geometries, whole.assets[i].geometries);
    // the other assets of the member read for `i` come with it, the whole read's
    let others: Vec<usize> = (0..n).filter(|&k| k != i).collect();
    let (got, more) = h.read_back_keeping(&rr, &[i], &others).unwrap();
    assert_eq!(got, [whole.assets[i].clone()]);
    assert!(
        !more.is_empty() && more.len() < n - 1,
        "{} of {n}",
        more.len()
    );
    for (k, a) in &more {
        assert_eq!(a, &whole.assets[*k], "asset {k}");
    }
}

/// A [`HollowSource`](crate::lod::bound::HollowSource) keeps, of the members it parses,
/// the assets it is told may be asked for later, and gives them as the whole read has
/// them; told no more, it keeps nothing.
#[test]
fn a_hollow_source_keeps_what_it_parses_on_the_way() {
    use crate::lod::bound::{FullSource, HollowSource};
    let dir = tempfile::tempdir().unwrap();
    let (path, whole, _, h) = six_read(dir.path(), 1 << 16, false);
    let rr = Reread::open(&path, &ReadOptions::default()).unwrap();
    let src = HollowSource::new(&h, &rr);
    let n = whole.assets.len();
    let (first, rest): (Vec<usize>, Vec<usize>) = (0..n).partition(|i| i % 5 == 0);
    src.expect(Some(&vec![true; n]));
    let got = src.assets(&first).unwrap();
    assert!(got.iter().zip(&first).all(|(a, &i)| **a == whole.assets[i]));
    assert_eq!(src.from_kept(), 0);
    let got = src.assets(&rest).unwrap();
    assert!(got.iter().zip(&rest).all(|(a, &i)| **a == whole.assets[i]));
    let kept = src.from_kept();
    assert!(kept > 0 && kept <= rest.len(), "{kept} of {}", rest.len());
    src.expect(None);
    let got = src.assets(&first).unwrap();
    assert!(got.iter().zip(&first).all(|(a, &i)| **a == whole.assets[i]));
    assert_eq!(src.from_kept(), kept);
    assert_eq!(src.read_back(), 2 * first.len() + rest.len());
}

/// The POI checks of `lod` on a model read hollow with [`near_pois`] kept: the same
/// flags as on the whole model, and the same answers of the rough-box test of the
/// selection.
#[test]
fn poi_checks_on_a_hollow_model_are_the_whole_models() {
    use crate::lod::poi::checks::poi_flags_around;
    use crate::lod::select::rough_holds_poi_full_not;
    let path = fixture();
    let whole = read_file(&path).unwrap();
    // inside the first asset's box (its building's assets kept), and out of every box
    let (a, b) = (whole.assets[0].bbox(), whole.bbox());
    let pois = [
        crate::model::Poi::at("in", a.center().to_array()),
        crate::model::Poi::at("out", (b.max + 10.0).to_array()),
    ];
    let points: Vec<DVec3> = pois.iter().map(|p| p.position).collect();
    let read = ReadOptions::default();
    let passes = Passes::new(&read, 1, &|_, _| {});
    let opts = RoughOptions::default();
    let h = read_hollow(&path, &passes, &opts, &near_pois(&points)).unwrap();
    assert!(h.kept.iter().any(|&k| !k));
    let flags = |m: &CityModel, around: &Surroundings| -> Vec<_> {
        let scene = around.scene_holding(m, &points, ON_SURFACE);
        let each = pois.iter();
        each.map(|p| poi_flags_around(&scene, m, around, p, None))
            .collect()
    };
    let want = flags(&whole, &Surroundings::new(&whole));
    assert!(want.iter().any(|f| !f.is_empty()), "{want:?}");
    assert_eq!(
        flags(&h.model, &Surroundings::with_boxes(&h.model, &h.boxes)),
        want
    );
    let rough = rough_model(&whole, &opts);
    let mut held = 0;
    for (i, r) in rough.iter().enumerate() {
        for &p in &points {
            let full = rough_holds_poi_full_not(&whole.assets[i], r, p);
            assert_eq!(rough_holds_poi_full_not(&h.model.assets[i], r, p), full);
            held += usize::from(r.obb.as_ref().is_some_and(|b| b.contains(p, 0.0)));
        }
    }
    assert!(held > 0);
}

/// The error bound on a hollow read, its assets read back by span
/// ([`crate::lod::bound::HollowSource`]), is the whole read's: levels, promotions, each
/// POI's figures and the reference, with the lazy reference and with the whole one.
#[test]
fn the_bound_on_a_hollow_read_is_the_whole_reads() {
    use crate::lod::bound::HollowSource;
    use crate::lod::bound::{bound, bound_against_from, full_answers_from, BoundOptions};
    use crate::lod::{lod, LodOptions};
    use crate::model::runtime::progress::Silent;
    let dir = tempfile::tempdir().unwrap();
    let (path, whole, pois, h) = six_read(dir.path(), 1 << 16, false);
    let (opts, read) = (LodOptions::default(), ReadOptions::default());
    let rr = Reread::open(&path, &read).unwrap();
    let w = lod(&whole, &pois, &opts, &Silent).unwrap();
    let l = lod(&h, &pois, &opts, &Silent).unwrap();
    let site = crate::solar::Site::new(48.76, 11.42);
    let sun = crate::solar::SunTable::year(2025, 120, &site).unwrap();
    let mut whole_ref = Vec::new();
    for rays in [1000, 200_000] {
        let b = BoundOptions {
            max_svf_error: Some(0.0005),
            max_sun_error: Some(0.0005),
            svf_rays: rays,
            ..Default::default()
        };
        let levels = &w.selection.levels;
        let want = bound(&whole, &w.rough, levels, &pois, &b, Some(&sun)).unwrap();
        let src = HollowSource::new(&h, &rr);
        let full = full_answers_from(&src, &pois, &b, Some(&sun), None).unwrap();
        let got = bound_against_from(&src, &l.rough, &l.selection.levels, &full).unwrap();
        assert!(!want.promotions.is_empty(), "{rays} rays: {want:?}");
        assert_eq!(got, want, "{rays} rays");
        let n = whole.assets.len();
        assert!(src.read_back() > 0, "{rays} rays");
        whole_ref.push(want.reference.whole);
        if !want.reference.whole {
            assert!(want.reference.assets < n, "{:?}", want.reference);
        }
    }
    assert_eq!(whole_ref, [false, true]);
}

/// On a document of two copies of the same blocks at the same place (as the bench
/// files repeat a street), every asset of the second copy with full-detail polygons
/// is the twin of the first copy's ([`Hollow::twin`]); the bound on the hollow read,
/// which traces one of each twins, is the whole read's, and reads fewer assets back.
#[test]
fn the_bound_traces_twins_once_and_is_the_whole_reads() {
    use crate::lod::bound::{bound, bound_against_from, full_answers_from, BoundOptions};
    use crate::lod::bound::{FullSource, HollowSource};
    use crate::lod::{lod, LodOptions};
    use crate::model::runtime::progress::Silent;
    let dir = tempfile::tempdir().unwrap();
    let (path, whole, pois, h) = six_read(dir.path(), 1 << 16, true);
    let opts = LodOptions::default();
    assert!(h.summary.chunks > 2, "{} chunks", h.summary.chunks);
    // each asset's twin: the first of the whole read's with its full-detail polygons
    let n = whole.assets.len();
    let rings = |a: &Asset| -> Vec<Vec<DVec3>> {
        (a.detail_polygons().iter())
            .flat_map(|p| {
                std::iter::once(p.exterior())
                    .chain(p.interiors())
                    .chain([&[][..]])
            })
            .map(<[DVec3]>::to_vec)
            .collect()
    };
    let mut twins = 0;
    for (i, a) in whole.assets.iter().enumerate() {
        let first = (0..n)
            .find(|&k| !a.detail_polygons().is_empty() && rings(&whole.assets[k]) == rings(a));
        assert_eq!(h.twin[i] as usize, first.unwrap_or(i), "asset {i}");
        twins += usize::from(h.twin[i] as usize != i);
    }
    assert!(twins * 2 >= n - 10, "{twins} twins of {n} assets");
    let rr = Reread::open(&path, &ReadOptions::default()).unwrap();
    let w = lod(&whole, &pois, &opts, &Silent).unwrap();
    let l = lod(&h, &pois, &opts, &Silent).unwrap();
    let b = BoundOptions {
        max_svf_error: Some(0.0005),
        max_sun_error: Some(0.0005),
        svf_rays: 1000,
        ..Default::default()
    };
    let site = crate::solar::Site::new(48.76, 11.42);
    let sun = crate::solar::SunTable::year(2025, 120, &site).unwrap();
    let levels = &w.selection.levels;
    let want = bound(&whole, &w.rough, levels, &pois, &b, Some(&sun)).unwrap();
    assert!(
        !want.reference.whole && !want.promotions.is_empty(),
        "{want:?}"
    );
    let mut read_back = Vec::new();
    for h in [
        h.clone(),
        Hollow {
            twin: Vec::new(),
            ..h
        },
    ] {
        let src = HollowSource::new(&h, &rr);
        assert_eq!(src.twins().is_some(), !h.twin.is_empty());
        let full = full_answers_from(&src, &pois, &b, Some(&sun), None).unwrap();
        let got = bound_against_from(&src, &l.rough, &l.selection.levels, &full).unwrap();
        assert_eq!(got, want, "twins: {}", !h.twin.is_empty());
        read_back.push(src.read_back());
    }
    // with twins, the second copy is not read back for the reference
    assert!(read_back[0] < read_back[1], "{read_back:?}");
}

/// The selection of `lod` on a hollow read ([`crate::lod::lod`]) is the whole
/// read's: levels, hits, each POI's figures and flags, the selection scene.
#[test]
fn the_selection_on_a_hollow_read_is_the_whole_reads() {
    use crate::lod::{lod, LodOptions};
    use crate::model::runtime::progress::Silent;
    // six blocks of the small preset, the first block's POIs
    let dir = tempfile::tempdir().unwrap();
    let (_, whole, pois, h) = six_read(dir.path(), 1, false);
    let opts = LodOptions::default();
    assert!(h.kept.iter().any(|&k| !k));
    let want = lod(&whole, &pois, &opts, &Silent).unwrap();
    let mut got = lod(&h, &pois, &opts, &Silent).unwrap();
    // each POI's time aside
    for (g, w) in got.selection.pois.iter_mut().zip(&want.selection.pois) {
        g.seconds = w.seconds;
    }
    let [_, l1, l2] = want.selection.level_counts();
    assert!(l1 > 0 && l2 > 0, "{l1} {l2}");
    assert_eq!(got.selection, want.selection);
    assert_eq!(got.flags, want.flags);
    assert_eq!((got.rough, got.triangles), (want.rough, want.triangles));
}
