//! Tests of [`super`].

use super::*;
use crate::lod::scene::{full_scene, mixed_scene};
use crate::model::{Asset, AssetKind, LodGeometry, Polygon};
use crate::solar::poi_sky_view;

fn quad(x0: f64, x1: f64, y0: f64, y1: f64, z: f64) -> Polygon {
    Polygon::new(vec![
        DVec3::new(x0, y0, z),
        DVec3::new(x1, y0, z),
        DVec3::new(x1, y1, z),
        DVec3::new(x0, y1, z),
    ])
}

fn asset(kind: AssetKind, polys: Vec<Polygon>) -> Asset {
    Asset::new(
        kind,
        Some(&format!("{}", polys.len())),
        "X",
        vec![LodGeometry {
            lod: 3,
            property: "lod3MultiSurface".into(),
            polygons: polys,
            ..Default::default()
        }],
    )
}

/// An L-shaped canopy over the POI whose rough geometry is its full square (a rough
/// model too big), and a small roof far off that the selection dropped.
fn scene() -> (CityModel, Vec<RoughGeometry>, Vec<u8>) {
    let mut m = CityModel::default();
    m.assets.push(asset(
        AssetKind::Roof,
        vec![
            quad(-5.0, 5.0, -5.0, 0.0, 4.0),
            quad(-5.0, 0.0, 0.0, 5.0, 4.0),
        ],
    ));
    m.assets.push(asset(
        AssetKind::Roof,
        vec![quad(20.0, 30.0, -5.0, 5.0, 3.0)],
    ));
    let rough = vec![
        RoughGeometry {
            polygons: vec![quad(-5.0, 5.0, -5.0, 5.0, 4.0)],
            obb: None,
            lod: 3,
        },
        RoughGeometry {
            polygons: vec![quad(20.0, 30.0, -5.0, 5.0, 3.0)],
            obb: None,
            lod: 3,
        },
    ];
    (m, rough, vec![1, 0])
}

fn poi() -> Poi {
    Poi {
        id: "p".into(),
        position: DVec3::ZERO,
        normal: None,
    }
}

/// An SVF bound of `max_svf_error` with `svf_rays` rays, the rest by default.
fn svf_opts(max_svf_error: f64, svf_rays: usize) -> BoundOptions {
    BoundOptions {
        max_svf_error: Some(max_svf_error),
        svf_rays,
        ..Default::default()
    }
}

#[test]
fn figures_equal_poi_sky_view() {
    let (m, rough, levels) = scene();
    let opts = svf_opts(10.0, 4000);
    let b = bound(&m, &rough, &levels, &[poi()], &opts, None).unwrap();
    assert!(b.met && b.promotions.is_empty() && b.rounds == 1);
    // 3 polygons, thousands of rays: the whole model at once
    assert!(
        b.reference.whole && b.reference.assets == 2,
        "{:?}",
        b.reference
    );
    let bundles = SkyBundles::new(4000, 7).unwrap();
    let full = poi_sky_view(&full_scene(&m), &poi(), &bundles).svf;
    let lod = poi_sky_view(&mixed_scene(&m, &rough, &levels), &poi(), &bundles).svf;
    assert_eq!(b.pois[0].svf_full, full);
    assert_eq!(b.pois[0].svf_lod, lod);
    assert!(lod < full);
}

#[test]
fn promotes_the_too_big_rough_asset_and_not_the_far_one() {
    let (m, rough, levels) = scene();
    let opts = svf_opts(0.01, 4000);
    let b = bound(&m, &rough, &levels, &[poi()], &opts, None).unwrap();
    assert!(b.met);
    assert_eq!(b.levels, vec![2, 0]);
    assert_eq!(b.promotions.len(), 1);
    assert_eq!((b.promotions[0].asset, b.promotions[0].from), (0, 1));
    // what is left is the far roof, within the bound
    assert!(b.pois[0].svf_error > 0.0 && b.pois[0].svf_error <= 0.01);
}

#[test]
fn a_dropped_asset_that_is_seen_comes_back() {
    let (m, rough, _) = scene();
    // everything dropped: the LoD model sees the whole sky
    let opts = svf_opts(0.0, 4000);
    let b = bound(&m, &rough, &[0, 0], &[poi()], &opts, None).unwrap();
    assert!(b.met, "{:?}", b.pois);
    assert_eq!(b.levels[0], 2);
    assert!(b.promotions.iter().any(|p| p.from == 0));
}

#[test]
fn unmet_bound_names_the_poi_and_bad_input_is_an_error() {
    let (m, rough, levels) = scene();
    let opts = BoundOptions {
        max_rounds: 0,
        ..svf_opts(0.0, 2000)
    };
    let b = bound(&m, &rough, &levels, &[poi()], &opts, None).unwrap();
    assert!(!b.met);
    assert_eq!(b.failing(), vec!["p"]);
    let bad = BoundOptions {
        max_svf_error: Some(f64::NAN),
        ..Default::default()
    };
    assert!(bound(&m, &rough, &levels, &[poi()], &bad, None).is_err());
    let sun = BoundOptions {
        max_sun_error: Some(0.01),
        ..Default::default()
    };
    assert!(matches!(
        bound(&m, &rough, &levels, &[poi()], &sun, None),
        Err(BoundError::NoSunTable)
    ));
    assert!(bound(&m, &rough, &[1], &[poi()], &opts, None).is_err());
}

#[test]
fn sun_hours_bound() {
    let (m, rough, levels) = scene();
    let site = crate::solar::Site::new(41.39, 2.17);
    let table = SunTable::year(2025, 60, &site).unwrap();
    let opts = BoundOptions {
        max_sun_error: Some(0.0),
        svf_rays: 1000,
        ..Default::default()
    };
    let b = bound(&m, &rough, &levels, &[poi()], &opts, Some(&table)).unwrap();
    assert!(b.met);
    let p = &b.pois[0];
    assert_eq!(p.sun_hours_error, Some(0.0));
    assert!(p.sun_hours_full.unwrap() > 0.0);
}

/// The full model's answers made first ([`full_answers`], before any level is known) and
/// used for two sets of levels give what [`bound`] gives; against another model they are
/// refused.
#[test]
fn full_answers_made_first_give_the_bound_of_any_levels() {
    let (m, rough, _) = scene();
    let pois = [poi()];
    let opts = svf_opts(0.01, 3000);
    let full = full_answers(&m, &pois, &opts, None, None).unwrap();
    for levels in [vec![1, 0], vec![0, 0], vec![2, 2]] {
        let once = bound_against(&m, &rough, &levels, &full).unwrap();
        assert_eq!(
            once,
            bound(&m, &rough, &levels, &pois, &opts, None).unwrap()
        );
    }
    assert!(format!("{full:?}").contains("rays"));
    let mut other = m.clone();
    other.assets.pop();
    let e = bound_against(&other, &rough[..1], &[1], &full).unwrap_err();
    assert!(matches!(e, BoundError::Mismatch { assets: 2, .. }), "{e}");
    assert!(matches!(
        full_answers(&m, &pois, &svf_opts(-1.0, 100), None, None),
        Err(BoundError::BadBound(_))
    ));
}

/// The lazy reference trace gives every ray the answer of the whole-model scene (same
/// asset, same distance to the bit) on a synth district with low sun rays, while it
/// builds only part of the model.
#[test]
fn restricted_full_scene_answers_as_the_whole_model() {
    use crate::model::synth::{generate, pois, Preset};
    let mut opts = Preset::Paper.defaults();
    (opts.blocks_x, opts.blocks_y) = (3, 2);
    let mut xml = Vec::new();
    generate(&opts, &mut xml).unwrap();
    let model = crate::io::citygml::read::read_bytes(&xml, "paper.gml").unwrap();
    let mut ps: Vec<Poi> = pois(&opts).into_iter().map(Into::into).collect();
    // and a POI on the ground in the open, facing up
    ps.push(Poi {
        id: "open".into(),
        position: ps[0].position + DVec3::new(3.0, -2.0, 0.0),
        normal: None,
    });
    assert!(ps.len() >= 3);
    let site = crate::solar::Site::new(48.76, 11.42);
    let table = SunTable::year(2025, 30, &site).unwrap();
    let bundles = SkyBundles::new(3000, 7).unwrap();
    let probes: Vec<Probe> = ps
        .iter()
        .map(|p| probe(p, &bundles, Some(&table), None))
        .collect();
    let whole = full_scene(&model);
    // seeded with one box per ray (many rounds) and with the default
    let mut rounds = Vec::new();
    for seed in [1, 3, SEED_BOXES] {
        let (hits, reference) =
            lazy_hits_with(&model, &probes, &AssetBoxes::new(&model), seed).unwrap();
        let (mut compared, mut hit) = (0, 0);
        for (p, got) in probes.iter().zip(&hits) {
            assert_eq!(got.len(), p.len());
            for (j, g) in got.iter().enumerate() {
                let want = whole
                    .first_hit(p.origin, p.dir(j), POI_OFFSET, f64::INFINITY)
                    .map(|h| (h.tag, h.t));
                match (g, want) {
                    (Some((a, t)), Some((b, u))) => {
                        assert_eq!((*a, t.to_bits()), (b, u.to_bits()), "ray {j}, seed {seed}");
                        hit += 1;
                    }
                    (a, b) => {
                        assert_eq!(a.map(|x| x.0), b.map(|x| x.0), "ray {j}, seed {seed}")
                    }
                }
                compared += 1;
            }
        }
        assert!(hit > 100 && hit < compared, "{hit} of {compared} rays hit");
        assert!(
            reference.assets > 0 && reference.assets < reference.of && !reference.whole,
            "{reference:?}"
        );
        rounds.push(reference.rounds);
    }
    // the parts built round after round are merged (each round builds only its new assets)
    assert!(rounds[0] >= 3, "{rounds:?}");
    let (hits, _) = lazy_hits(&model, &probes);
    // `bound` uses these tags, or (more rays than polygons here) the whole model's
    let (tags, r) = full_tags(&model, &probes, &AssetBoxes::new(&model)).unwrap();
    assert!(r.whole, "{r:?}");
    for (p, (t, h)) in probes.iter().zip(tags.iter().zip(&hits)) {
        assert_eq!(t, &tags_of(&whole, p));
        assert_eq!(t, &h.iter().map(|h| h.map(|h| h.0)).collect::<Vec<_>>());
    }
}

fn tags_of(scene: &TraceScene, p: &Probe) -> Vec<Option<u32>> {
    tags(scene, p)
}

/// The reference's frame is the box of the whole full scene's triangles, also when many
/// assets' point boxes reach farther than their triangles (points of rings that make no
/// triangle): the walk on a side then goes past the boxes sorted first.
#[test]
fn reference_frame_is_the_full_scene_box() {
    for (far, reaching) in [(0usize, 0usize), (3, 10), (150, 150)] {
        let mut m = CityModel::default();
        for i in 0..400 {
            let x = (i % 20) as f64 * 7.0;
            let y = (i / 20) as f64 * 5.0;
            let mut polys = vec![quad(x, x + 3.0, y, y + 2.0, (i % 7) as f64)];
            if i < far {
                // a ring folded onto a line far out: points in the box, no triangle
                polys.push(Polygon::new(vec![
                    DVec3::new(x, y, 1.0),
                    DVec3::new(900.0 + i as f64, y, 1.0),
                    DVec3::new(x, y, 1.0),
                ]));
            }
            if i < reaching {
                // and one whose triangles do reach out, on the other side
                polys.push(quad(-300.0 - i as f64, -299.0, y, y + 1.0, 2.0));
            }
            m.assets.push(asset(AssetKind::Roof, polys));
        }
        let (_, frame) = crate::lod::scene::detail_boxes(&m);
        let whole = full_scene(&m).bbox();
        assert_eq!(
            (frame.min, frame.max),
            (whole.min, whole.max),
            "{far} {reaching}"
        );
        assert!(frame.max.x < 900.0, "{far}: {:?}", frame.max);
    }
}

#[test]
fn relative_error_against_the_reference() {
    assert_eq!(super::rel(3.0, 2.0), 0.5);
    assert_eq!(super::rel(1.0, -2.0), 1.5);
    assert_eq!(super::rel(0.0, 0.0), 0.0);
    assert_eq!(super::rel(0.1, 0.0), f64::INFINITY);
    assert_eq!(super::rel(0.0, 2.0), 1.0);
}
