//! Selection on the hand-made scenes of `fixtures/scenes/` (see its README): each scene has
//! a known level for the named assets, seen from its POI.

use glam::DVec3;
use skylod::io::citygml::read_file;
use skylod::lod::poi::Poi;
use skylod::lod::SelectOptions;
use skylod::lod::{lod, LodOptions};
use skylod::model::CityModel;

const X0: f64 = 430_000.0;
const Y0: f64 = 4_581_000.0;
const Z0: f64 = 10.0;

fn poi(x: f64, y: f64, z: f64) -> Poi {
    Poi {
        id: "poi".into(),
        position: DVec3::new(X0 + x, Y0 + y, Z0 + z),
        normal: None,
    }
}

fn levels(scene: &str, p: Poi, rays: usize) -> (CityModel, Vec<u8>) {
    let path = crate::util::fixture(&format!("scenes/{scene}"));
    let model = read_file(&path).unwrap_or_else(|e| panic!("{e}"));
    let opts = LodOptions {
        select: SelectOptions {
            rays,
            ..Default::default()
        },
        ..Default::default()
    };
    let r = lod(&model, &[p], &opts, &skylod::Silent).unwrap_or_else(|e| panic!("{e}"));
    (model, r.selection.levels)
}

fn level_of(model: &CityModel, levels: &[u8], id: &str) -> u8 {
    let i = model
        .assets
        .iter()
        .position(|a| a.id.as_deref() == Some(id))
        .unwrap_or_else(|| panic!("no asset {id}"));
    levels[i]
}

/// Levels of every asset whose id starts with `prefix`.
fn levels_of_prefix(model: &CityModel, levels: &[u8], prefix: &str) -> Vec<u8> {
    model
        .assets
        .iter()
        .zip(levels)
        .filter(|(a, _)| a.id.as_deref().is_some_and(|i| i.starts_with(prefix)))
        .map(|(_, l)| *l)
        .collect()
}

#[test]
fn chimney_hidden_behind_a_taller_building() {
    for rays in [2_000, 10_000, 40_000] {
        let (m, l) = levels("hidden-chimney.gml", poi(0.0, 0.0, 1.5), rays);
        assert_eq!(level_of(&m, &l, "CHIMNEY_HIDDEN"), 0, "{rays} rays");
        assert_eq!(level_of(&m, &l, "NEAR_wall3"), 1, "{rays} rays");
        assert!(
            levels_of_prefix(&m, &l, "FAR").iter().all(|&x| x == 0),
            "FAR is hidden"
        );
    }
}

#[test]
fn roof_edge_on_the_skyline_keeps_full_detail() {
    for rays in [2_000, 10_000, 40_000] {
        let (m, l) = levels("skyline-roof.gml", poi(0.0, 0.0, 1.5), rays);
        assert_eq!(level_of(&m, &l, "HOUSE_roof_w"), 2, "{rays} rays");
        assert_eq!(level_of(&m, &l, "HOUSE_roof_e"), 0, "{rays} rays");
        assert_eq!(level_of(&m, &l, "HOUSE_wall3"), 1, "{rays} rays");
        assert_eq!(level_of(&m, &l, "HOUSE_wall1"), 0, "east wall faces away");
    }
}

#[test]
fn wall_below_another_roofline_is_rough() {
    let (m, l) = levels("wall-below-roofline.gml", poi(0.0, 0.0, 1.5), 10_000);
    assert_eq!(level_of(&m, &l, "TOWER_wall3"), 1);
    assert_eq!(level_of(&m, &l, "LOW_wall3"), 1);
    assert_eq!(level_of(&m, &l, "LOW_roof"), 0, "flat roof is edge-on");
    assert_eq!(level_of(&m, &l, "TOWER_roof"), 0);
}

#[test]
fn tanks_against_sky_and_against_a_facade() {
    for rays in [5_000, 10_000, 40_000] {
        let (m, l) = levels("roof-tanks.gml", poi(0.0, 0.0, 11.0), rays);
        assert_eq!(level_of(&m, &l, "TANK_SKY"), 2, "{rays} rays");
        assert_eq!(level_of(&m, &l, "TANK_WALL"), 1, "{rays} rays");
        assert_eq!(level_of(&m, &l, "BACK_wall3"), 1, "{rays} rays");
    }
}

#[test]
fn closed_courtyard_sees_only_its_yard_walls() {
    let (m, l) = levels("courtyard.gml", poi(15.0, 15.0, 1.5), 10_000);
    assert_eq!(level_of(&m, &l, "WING_S_wall2"), 1);
    assert_eq!(level_of(&m, &l, "WING_N_wall0"), 1);
    assert_eq!(level_of(&m, &l, "WING_W_wall1"), 1);
    assert_eq!(level_of(&m, &l, "WING_E_wall3"), 1);
    assert_eq!(level_of(&m, &l, "WING_S_wall0"), 0, "outer wall");
    assert!(levels_of_prefix(&m, &l, "OUTSIDE").iter().all(|&x| x == 0));
    // Exactly the four yard walls are hit.
    assert_eq!(l.iter().filter(|&&x| x > 0).count(), 4);
}

#[test]
fn levels_do_not_depend_on_the_thread_count() {
    let run = || levels("roof-tanks.gml", poi(0.0, 0.0, 11.0), 10_000).1;
    let a = run();
    let b = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(run);
    assert_eq!(a, b);
}

#[test]
fn levels_are_invariant_under_a_large_translation() {
    // The scenes sit at UTM-sized coordinates already; shift the whole scene and the POI
    // back to the origin and compare.
    let path = crate::util::fixture("scenes/roof-tanks.gml");
    let mut model = read_file(&path).unwrap();
    let shift = DVec3::new(X0, Y0, 0.0);
    for a in &mut model.assets {
        for g in &mut a.geometries {
            for p in &mut g.polygons {
                p.points_mut().iter_mut().for_each(|q| *q -= shift);
            }
        }
    }
    let mut p = poi(0.0, 0.0, 11.0);
    p.position -= shift;
    let shifted = lod(&model, &[p], &LodOptions::default(), &skylod::Silent).unwrap();
    let (_, original) = levels("roof-tanks.gml", poi(0.0, 0.0, 11.0), 10_000);
    assert_eq!(shifted.selection.levels, original);
}
