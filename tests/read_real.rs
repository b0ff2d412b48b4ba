//! Reading real CityGML files and the hand-made fixtures.
//!
//! Counts are checked against an independent oracle (`tests/oracle/count_citygml.py`, Python
//! standard library) that implements the asset mapping of DESIGN.md on its own.

mod common;

use common::*;
use glam::DVec3;
use skylod::citygml::{read_file, ReadError};
use skylod::model::{AssetKind, CityModel, Polygon};
use skylod::output::stats::Stats;
use std::path::Path;

/// The one shared file that is plain GML, not CityGML.
fn is_plain_gml(p: &Path) -> bool {
    p.ends_with("val3dity/csol1b.gml")
}

#[test]
fn every_shared_file_reads() {
    let Some(data) = shared_data() else { return };
    let files = citygml_files(&data);
    assert!(files.len() > 100, "only {} files found", files.len());
    let mut problems = Vec::new();
    for f in &files {
        let r = std::panic::catch_unwind(|| read_file(f));
        match (r, is_plain_gml(f)) {
            (Err(_), _) => problems.push(format!("{}: reader panicked", short(f))),
            (Ok(Ok(_)), false) => {}
            (Ok(Err(ReadError::NotCityGml { .. })), true) => {}
            (Ok(Ok(_)), true) => problems.push(format!("{}: plain GML accepted", short(f))),
            (Ok(Err(e)), _) => problems.push(format!("{}: {e}", short(f))),
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// Fields compared with the oracle: (oracle key, value from Stats).
fn fields(s: &Stats) -> Vec<(&'static str, serde_json::Value)> {
    use serde_json::json;
    vec![
        ("citygml_version", json!(s.citygml_version)),
        ("buildings", json!(s.buildings)),
        ("building_parts", json!(s.building_parts)),
        ("roof_surfaces", json!(s.roof_surfaces)),
        ("wall_surfaces", json!(s.wall_surfaces)),
        ("ground_surfaces", json!(s.ground_surfaces)),
        ("closure_surfaces", json!(s.closure_surfaces)),
        ("outer_ceiling_surfaces", json!(s.outer_ceiling_surfaces)),
        ("outer_floor_surfaces", json!(s.outer_floor_surfaces)),
        ("installations", json!(s.installations)),
        ("windows", json!(s.windows)),
        ("doors", json!(s.doors)),
        ("polygons", json!(s.polygons)),
        ("implicit_geometries", json!(s.implicit_geometries)),
        ("features", json!(s.features)),
    ]
}

fn compare_with_oracle(files: &[std::path::PathBuf]) {
    let Some(oracle) = oracle_counts(files) else {
        return;
    };
    let mut mismatches = Vec::new();
    for f in files {
        let key = f.display().to_string();
        let o = oracle
            .get(&key)
            .unwrap_or_else(|| panic!("oracle has no {key}"));
        let r = read_file(f);
        match (o.get("error").and_then(|e| e.as_str()), r) {
            (Some("not_citygml"), Err(ReadError::NotCityGml { .. })) => {}
            (Some(err), r) => mismatches.push(format!(
                "{}: oracle error {err}, reader {:?}",
                short(f),
                r.map(|_| "ok").map_err(|e| e.to_string())
            )),
            (None, Err(e)) => mismatches.push(format!("{}: reader error {e}", short(f))),
            (None, Ok(m)) => {
                let s = Stats::of(&m);
                for (k, v) in fields(&s) {
                    if o.get(k) != Some(&v) {
                        mismatches.push(format!(
                            "{}: {k}: oracle {}, skylod {v}",
                            short(f),
                            o.get(k).map(|x| x.to_string()).unwrap_or_default()
                        ));
                    }
                }
            }
        }
    }
    assert!(
        mismatches.is_empty(),
        "{} mismatch(es) against the oracle:\n{}",
        mismatches.len(),
        mismatches.join("\n")
    );
}

#[test]
fn shared_files_match_the_oracle() {
    let Some(data) = shared_data() else { return };
    compare_with_oracle(&citygml_files(&data));
}

#[test]
fn fixtures_match_the_oracle() {
    compare_with_oracle(&fixture_files());
}

const FLAVOURS: [&str; 4] = [
    "chimney-citygml1.gml",
    "chimney-citygml2.gml",
    "chimney-citygml3.gml",
    "default-namespace.gml",
];

fn read_fixture(name: &str) -> CityModel {
    read_file(&fixture(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn asset<'a>(m: &'a CityModel, id: &str) -> (usize, &'a skylod::model::Asset) {
    m.assets
        .iter()
        .enumerate()
        .find(|(_, a)| a.id.as_deref() == Some(id))
        .unwrap_or_else(|| panic!("no asset {id}"))
}

/// Ring as a sorted list of points (rounded to mm) so that rings compare independent of start.
fn key(ring: &[DVec3]) -> Vec<[i64; 3]> {
    let mut v: Vec<[i64; 3]> = ring
        .iter()
        .map(|p| {
            [
                (p.x * 1000.0).round() as i64,
                (p.y * 1000.0).round() as i64,
                (p.z * 1000.0).round() as i64,
            ]
        })
        .collect();
    v.sort();
    v
}

fn poly_key(p: &Polygon) -> (Vec<[i64; 3]>, Vec<Vec<[i64; 3]>>) {
    (key(p.exterior()), p.interiors().map(key).collect())
}

#[test]
fn fixture_exact_counts() {
    for name in FLAVOURS {
        let m = read_fixture(name);
        let s = Stats::of(&m);
        let got = (
            s.buildings,
            s.building_parts,
            s.roof_surfaces,
            s.wall_surfaces,
            s.ground_surfaces,
            s.closure_surfaces,
            s.installations,
            s.windows,
            s.doors,
            s.bodies,
            s.other_objects,
            s.assets,
        );
        assert_eq!(got, (1, 0, 1, 4, 1, 0, 1, 1, 1, 0, 0, 9), "{name}: {s:?}");
        assert_eq!(s.polygons, 14, "{name}: polygon elements");
        assert_eq!(s.asset_polygons, 14, "{name}: asset polygons");
        assert_eq!(s.lods, vec![3], "{name}");
        assert_eq!(s.implicit_geometries, 0, "{name}");
        assert_eq!(s.warnings, 0, "{name}: {:?}", m.warnings);
        assert_eq!(
            s.srs_name.as_deref(),
            Some("urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::7837"),
            "{name}"
        );
        let expected = match name {
            "chimney-citygml1.gml" => "1.0",
            "chimney-citygml3.gml" => "3.0",
            _ => "2.0",
        };
        assert_eq!(s.citygml_version.as_deref(), Some(expected), "{name}");
        for (id, kind, n) in [
            ("ROOF_1", AssetKind::Roof, 1),
            ("WALL_S", AssetKind::Wall, 1),
            ("WALL_E", AssetKind::Wall, 1),
            ("WALL_N", AssetKind::Wall, 1),
            ("WALL_W", AssetKind::Wall, 1),
            ("GROUND_1", AssetKind::Ground, 1),
            ("WINDOW_1", AssetKind::Window, 1),
            ("DOOR_1", AssetKind::Door, 1),
            ("CHIMNEY_1", AssetKind::Installation, 6),
        ] {
            let (_, a) = asset(&m, id);
            assert_eq!(a.kind, kind, "{name}: {id}");
            assert_eq!(a.polygon_count(), n, "{name}: {id} polygons");
            assert_eq!(a.max_lod(), Some(3), "{name}: {id} LoD");
            assert_eq!(a.building, Some(0), "{name}: {id} building");
        }
    }
}

#[test]
fn fixture_openings_belong_to_their_walls() {
    for name in FLAVOURS {
        let m = read_fixture(name);
        let (ws, _) = asset(&m, "WALL_S");
        let (we, _) = asset(&m, "WALL_E");
        assert_eq!(
            asset(&m, "WINDOW_1").1.parent,
            Some(ws),
            "{name}: window parent"
        );
        assert_eq!(
            asset(&m, "DOOR_1").1.parent,
            Some(we),
            "{name}: door parent"
        );
    }
}

#[test]
fn fixture_xlinks_resolved_including_forward_reference() {
    for name in FLAVOURS {
        let m = read_fixture(name);
        assert_eq!(m.buildings.len(), 1);
        let b = &m.buildings[0];
        assert_eq!(b.id.as_deref(), Some("BLDG_1"));
        let solid: Vec<&Polygon> = b
            .geometries
            .iter()
            .filter(|g| g.lod == 3)
            .flat_map(|g| g.polygons.iter())
            .collect();
        assert_eq!(
            solid.len(),
            8,
            "{name}: lod3Solid members (7 hrefs + 1 inline)"
        );
        // The GroundSurface's only polygon is a forward xlink to the solid's inline polygon.
        let ground = asset(&m, "GROUND_1").1.detail_polygons();
        assert_eq!(ground.len(), 1, "{name}");
        assert_eq!(ground[0].exterior().len(), 4, "{name}: ground ring (open)");
        assert!(
            ground[0]
                .exterior()
                .iter()
                .all(|p| (p.z - 500.0).abs() < 1e-9),
            "{name}: ground at z=500"
        );
        // Solid polygons == the shell surface + opening polygons (as sets of rings).
        let mut surf: Vec<_> = m
            .assets
            .iter()
            .filter(|a| a.kind != AssetKind::Installation)
            .flat_map(|a| a.detail_polygons().iter().map(poly_key))
            .collect();
        let mut sol: Vec<_> = solid.iter().map(|p| poly_key(p)).collect();
        surf.sort();
        sol.sort();
        assert_eq!(
            sol, surf,
            "{name}: solid polygons differ from surface polygons"
        );
    }
}

#[test]
fn fixture_window_hole_is_an_interior_ring() {
    for name in FLAVOURS {
        let m = read_fixture(name);
        let wall = &asset(&m, "WALL_S").1.detail_polygons()[0];
        assert_eq!(
            wall.exterior().len(),
            4,
            "{name}: wall exterior (open ring)"
        );
        assert_eq!(wall.interior_count(), 1, "{name}: one hole");
        let window = &asset(&m, "WINDOW_1").1.detail_polygons()[0];
        assert_eq!(
            key(wall.interior(0).unwrap()),
            key(window.exterior()),
            "{name}"
        );
        // 10 m x 6 m wall minus a 2 m x 1.5 m hole.
        assert!(
            (wall.area() - 57.0).abs() < 1e-6,
            "{name}: area {}",
            wall.area()
        );
        let east = &asset(&m, "WALL_E").1.detail_polygons()[0];
        assert_eq!(east.exterior().len(), 8, "{name}: notched east wall");
        assert!(east.interior_count() == 0);
    }
}

#[test]
fn fixture_chimney_has_function_and_stands_on_the_roof() {
    for name in FLAVOURS {
        let m = read_fixture(name);
        let c = asset(&m, "CHIMNEY_1").1;
        assert_eq!(c.function.as_deref(), Some("chimney"), "{name}");
        let b = c.bbox();
        assert_eq!(b.min, DVec3::new(690006.0, 5336005.0, 506.0), "{name}");
        assert_eq!(b.max, DVec3::new(690007.0, 5336006.0, 507.5), "{name}");
        // Closed box: Newell normals of the six faces sum to zero, each face 1 or 1.5 m².
        let n: DVec3 = c.detail_polygons().iter().map(|p| p.newell_normal()).sum();
        assert!(n.length() < 1e-6, "{name}: box not closed, {n}");
    }
}

#[test]
fn fixture_flavours_agree() {
    let all: Vec<Stats> = FLAVOURS
        .iter()
        .map(|n| Stats::of(&read_fixture(n)))
        .collect();
    // The asset counts agree; the element names differ by version (CityGML 3.0 writes
    // `WindowSurface` where 2.0 writes `Window`), which `features` shows as it is.
    let strip = |s: &Stats| Stats {
        citygml_version: None,
        features: Default::default(),
        ..s.clone()
    };
    for (n, s) in FLAVOURS.iter().zip(&all) {
        assert_eq!(strip(s), strip(&all[0]), "{n} differs from {}", FLAVOURS[0]);
    }
    assert_eq!(
        all[0].bbox,
        Some([690000.0, 5336000.0, 500.0, 690010.0, 5336008.0, 507.5])
    );
    // Same polygons with the same ids in every flavour (document order differs in 3.0, where
    // the installation follows the boundaries).
    let polys = |n: &str| -> Vec<(Option<String>, Vec<[i64; 3]>)> {
        let mut v: Vec<_> = read_fixture(n)
            .assets
            .iter()
            .flat_map(|a| a.detail_polygons().iter())
            .map(|p| (p.id.as_deref().map(str::to_owned), key(p.exterior())))
            .collect();
        v.sort();
        v
    };
    let first = polys(FLAVOURS[0]);
    for n in &FLAVOURS[1..] {
        assert_eq!(polys(n), first, "{n}");
    }
}

/// Nesting rules of the asset mapping (not XSD-checked, schema-lax on purpose): surfaces of
/// installations, interior walls, doors of interior walls, interior installations, windows of
/// constructive elements and bridge roofs are not building assets.
#[test]
fn nesting_rules() {
    let dir = manifest_dir().join("tests/data");
    let files = vec![
        dir.join("nesting-citygml2.gml"),
        dir.join("nesting-citygml3.gml"),
    ];
    compare_with_oracle(&files);
    let expected = [
        // buildings, parts, roofs, walls, closures, installations, windows, doors, polygons
        (1, 1, 0, 1, 1, 1, 0, 0, 8),
        (1, 0, 0, 1, 1, 2, 0, 0, 10),
    ];
    for (f, e) in files.iter().zip(expected) {
        let s = Stats::of(&read_file(f).unwrap());
        let got = (
            s.buildings,
            s.building_parts,
            s.roof_surfaces,
            s.wall_surfaces,
            s.closure_surfaces,
            s.installations,
            s.windows,
            s.doors,
            s.polygons,
        );
        assert_eq!(got, e, "{}", short(f));
    }
}
