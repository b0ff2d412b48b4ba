//! Warnings that tell the truth (issue 21 item 3): inside a building judged on the full
//! geometry only (a courtyard POI is not flagged, by `svf` nor by `lod` whose scene is the
//! rough model), a POI far below every building around it, a normal into the surface the POI
//! lies on, and latitude/longitude given in the wrong order with `--poi-crs EPSG:4326`.
//!
//! The fixture is `fixtures/rough/courtyard-lod1.gml`: one closed LoD1 solid, a 60 x 60 m
//! block (x 690000..690060, y 5336000..5336060, EPSG:25832) 15 m high on z 100, with a
//! 30 x 30 m courtyard (x and y 15..45 m into the block).

use crate::util::{fixture, json, os, run, stderr};
use serde_json::Value;

fn courtyard() -> std::path::PathBuf {
    fixture("rough/courtyard-lod1.gml")
}

/// `skylod svf --json` of one `--poi` on the courtyard block: the POI's flags.
fn svf_flags(poi: &str) -> Vec<Value> {
    let input = courtyard();
    let o = run(&[
        os("svf"),
        input.as_os_str(),
        os("--poi"),
        os(poi),
        os("--json"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v = json(&o);
    v["pois"][0]["flags"]
        .as_array()
        .cloned()
        .unwrap_or_default()
}

/// `skylod lod` of one `--poi` on the courtyard block, with its report: the POI's flags.
fn lod_flags(poi: &str) -> Vec<Value> {
    let dir = tempfile::tempdir().unwrap();
    let (out, report) = (dir.path().join("out.gml"), dir.path().join("r.json"));
    let input = courtyard();
    let o = run(&[
        os("lod"),
        input.as_os_str(),
        os("--poi"),
        os(poi),
        os("--no-bound"),
        os("-o"),
        out.as_os_str(),
        os("--report"),
        report.as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    v["pois"][0]["flags"]
        .as_array()
        .cloned()
        .unwrap_or_default()
}

fn names(flags: &[Value]) -> Vec<&str> {
    flags.iter().filter_map(|f| f["flag"].as_str()).collect()
}

#[test]
fn courtyard_poi_is_not_inside_a_building() {
    // The block's box holds the courtyard POI; its full geometry does not enclose it.
    let poi = "690030,5336030,101.5";
    assert_eq!(names(&svf_flags(poi)), Vec::<&str>::new());
    assert_eq!(names(&lod_flags(poi)), Vec::<&str>::new());
    // The rough box of the whole block would enclose it: lod must not judge on that.
    let m = skylod::io::citygml::read_file(&courtyard()).unwrap();
    let boxes = skylod::lod::rough::all_boxes(&m);
    let rough = skylod::lod::rough_scene(&boxes);
    let p = skylod::lod::poi::Poi {
        id: "c".into(),
        position: glam::DVec3::new(690030.0, 5336030.0, 101.5),
        normal: None,
    };
    let on_boxes = skylod::lod::poi::poi_flags(&rough, &m, &p, None);
    assert!(
        matches!(
            on_boxes.as_slice(),
            [skylod::lod::poi::PoiFlag::InsideBuilding { .. }]
        ),
        "the box fills the courtyard: {on_boxes:?}"
    );
}

#[test]
fn poi_in_the_solid_is_inside_for_svf_and_lod() {
    // 5 m into the block from its west face, mid-height: inside the solid.
    let poi = "690005,5336030,107";
    for flags in [svf_flags(poi), lod_flags(poi)] {
        assert_eq!(names(&flags), ["inside_building"], "{flags:?}");
        assert_eq!(flags[0]["building"], "COURTYARD");
    }
}

#[test]
fn poi_far_below_every_building_is_flagged() {
    // 20 m west of the block, 60 m under its lowest point (z 100): a height above ground
    // given where the model wants an absolute one.
    let flags = svf_flags("689980,5336030,40");
    assert_eq!(names(&flags), ["far_below"], "{flags:?}");
    assert_eq!(flags[0]["below_m"], 60);
    // Lower than the margin (5 m) is not enough; nor is a street-level POI.
    assert_eq!(names(&svf_flags("689980,5336030,96")), Vec::<&str>::new());
    assert_eq!(
        names(&svf_flags("689980,5336030,101.5")),
        Vec::<&str>::new()
    );
    // Far from any building there is nothing to compare with.
    assert_eq!(names(&svf_flags("689700,5336030,40")), Vec::<&str>::new());
    // The lod report carries it too, and the warning says what to check.
    let input = courtyard();
    let o = run(&[
        os("svf"),
        input.as_os_str(),
        os("--poi"),
        os("689980,5336030,40"),
    ]);
    assert!(
        stderr(&o).contains("60 m below the lowest point"),
        "{}",
        stderr(&o)
    );
    assert_eq!(names(&lod_flags("689980,5336030,40")), ["far_below"]);
}

#[test]
fn normal_into_the_wall_it_lies_on_is_flagged() {
    // 5 cm out of the west face (x 690000, outward -x).
    let into = svf_flags("689999.95,5336030,107,1,0,0");
    assert!(names(&into).contains(&"normal_into_surface"), "{into:?}");
    let f = into
        .iter()
        .find(|f| f["flag"] == "normal_into_surface")
        .unwrap();
    // A closed solid: the outer side is the open one, whatever the ring says.
    assert_eq!(f["outward_from"], "solid", "{f}");
    // The same point facing away from the wall, and a POI 1 m out facing it, are not flagged.
    assert_eq!(
        names(&svf_flags("689999.95,5336030,107,-1,0,0")),
        Vec::<&str>::new()
    );
    assert!(!names(&svf_flags("689999,5336030,107,1,0,0")).contains(&"normal_into_surface"));
    // The courtyard's inner face (x 690015, outward +x into the courtyard) facing the wall.
    let inner = svf_flags("690015.05,5336030,107,-1,0,0");
    assert!(names(&inner).contains(&"normal_into_surface"), "{inner:?}");
    assert_eq!(
        names(&svf_flags("690015.05,5336030,107,1,0,0")),
        Vec::<&str>::new()
    );
    assert!(names(&lod_flags("689999.95,5336030,107,1,0,0")).contains(&"normal_into_surface"));
}

/// The courtyard's centre in EPSG:4326 (pyproj: EPSG:25832 690030, 5336030).
const LAT: f64 = 48.149_106_420_78;
const LON: f64 = 11.554_935_260_57;

#[test]
fn lon_lat_in_the_wrong_order_is_refused() {
    let input = courtyard();
    let svf = |poi: String| {
        run(&[
            os("svf"),
            input.as_os_str(),
            os("--poi-crs"),
            os("EPSG:4326"),
            os("--poi"),
            os(&poi),
        ])
    };
    let ok = svf(format!("{LAT},{LON},101.5"));
    assert_eq!(ok.status.code(), Some(0), "{}", stderr(&ok));
    let swapped = svf(format!("{LON},{LAT},101.5"));
    assert_eq!(swapped.status.code(), Some(2), "{}", stderr(&swapped));
    let e = stderr(&swapped);
    assert!(e.contains("probably swapped"), "{e}");
    assert!(e.contains("axis order is latitude, longitude"), "{e}");
    // A point far away in either order gets the ordinary refusal, not the swap hint.
    let far = svf("10.0,20.0,101.5".into());
    assert_eq!(far.status.code(), Some(2), "{}", stderr(&far));
    assert!(
        !stderr(&far).contains("probably swapped"),
        "{}",
        stderr(&far)
    );
}

/// Issue 21 item 5, one polygon count, on a PLATEAU tile (13 buildings with LoD0 footprints,
/// LoD1 solids and, for some, LoD2 roof / wall / ground surfaces whose polygons their
/// `lod2Solid` references by xlink). Counted independently in Python:
/// - *polygon elements*: every `gml:Polygon` once (811);
/// - *polygons*: those of the assets, i.e. of the thematic surfaces, plus all LoDs of the
///   buildings and parts that have no thematic surface (their own geometry is their body);
///   a building's own LoD0/LoD1 geometry beside its surfaces belongs to no asset (745);
/// - *traced polygons*: the same with each body at its highest LoD only (734).
///
/// `stats`, `convert`, `svf` and the `lod` report then all say *polygons*.
#[test]
fn one_polygon_count_on_a_plateau_tile() {
    let Some(data) = crate::util::shared_data() else {
        return;
    };
    let input = data.join("plateau/yokosuka/52397519_bldg_6697_op.gml");
    let oracle = std::process::Command::new("python3")
        .arg("-c")
        .arg(
            r#"
import sys, xml.etree.ElementTree as ET
r = ET.parse(sys.argv[1]).getroot()
loc = lambda e: e.tag.rsplit('}', 1)[-1]
par = {c: p for p in r.iter() for c in p}
def owner(e):
    lods = []
    while e in par:
        e = par[e]
        if loc(e).startswith('lod'):
            lods.append(int(loc(e)[3]))
        if loc(e).endswith('Surface') and loc(e) != 'CompositeSurface' and not loc(e).startswith('Multi') or loc(e) in ('Building', 'BuildingPart'):
            return e, lods[-1]
    return None, None
polys = [p for p in r.iter() if loc(p) == 'Polygon']
has_surfaces = set(par[par[s]] for s in r.iter() if loc(s) in ('RoofSurface', 'WallSurface', 'GroundSurface'))
asset = [(o, l) for o, l in map(owner, polys) if o is not None and (loc(o).endswith('Surface') or o not in has_surfaces)]
top = {}
for o, l in asset:
    top[o] = max(top.get(o, 0), l)
print(len(polys), len(asset), sum(1 for o, l in asset if l == top[o]))
"#,
        )
        .arg(&input)
        .output()
        .expect("python3");
    assert!(oracle.status.success(), "{}", stderr(&oracle));
    let want: Vec<u64> = String::from_utf8_lossy(&oracle.stdout)
        .split_whitespace()
        .map(|x| x.parse().unwrap())
        .collect();
    let o = run(&[os("stats"), input.as_os_str(), os("--json")]);
    let t = json(&o)["total"].clone();
    let got = [
        &t["polygon_elements"],
        &t["polygons"],
        &t["traced_polygons"],
    ]
    .map(|v| v.as_u64().unwrap());
    assert_eq!(got.to_vec(), want, "stats {t}");
    assert!(
        got[0] != got[1] && got[1] != got[2],
        "the tile shows all three: {got:?}"
    );
    let polygons = got[1];

    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("c.gml");
    let o = run(&[os("convert"), input.as_os_str(), os("-o"), out.as_os_str()]);
    assert!(
        stderr(&o).contains(&format!("polygons {polygons} -> {polygons}")),
        "{}",
        stderr(&o)
    );
    // A POI 5 m above the tile's centre (EPSG:6697: latitude, longitude, height).
    let b: Vec<f64> = t["bbox"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let poi = format!(
        "{},{},{}",
        (b[0] + b[3]) / 2.0,
        (b[1] + b[4]) / 2.0,
        b[5] + 5.0
    );
    let o = run(&[
        os("svf"),
        input.as_os_str(),
        os("--poi"),
        os(&poi),
        os("--json"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(json(&o)["polygons"].as_u64(), Some(polygons));
    let o = run(&[os("svf"), input.as_os_str(), os("--poi"), os(&poi)]);
    assert!(
        stderr(&o).contains(&format!("{polygons} polygons ({} traced)", got[2])),
        "{}",
        stderr(&o)
    );
    let (lod, report) = (dir.path().join("l.gml"), dir.path().join("r.json"));
    let o = run(&[
        os("lod"),
        input.as_os_str(),
        os("--poi"),
        os(&poi),
        os("--no-bound"),
        os("-o"),
        lod.as_os_str(),
        os("--report"),
        report.as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let r: Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert_eq!(r["totals"]["polygons_in"].as_u64(), Some(polygons), "{r}");
}

/// A `.gz` output's size is its size on disk (compressed), the uncompressed bytes beside it.
#[test]
fn gz_output_size_is_the_compressed_size() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("c.gml.gz");
    let o = run(&[
        os("convert"),
        courtyard().as_os_str(),
        os("-o"),
        out.as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let on_disk = std::fs::metadata(&out).unwrap().len();
    let mut plain = Vec::new();
    let gz = std::fs::File::open(&out).unwrap();
    std::io::Read::read_to_end(&mut flate2::read::GzDecoder::new(gz), &mut plain).unwrap();
    let plain = plain.len();
    assert!(on_disk < plain as u64);
    assert!(
        stderr(&o).contains(&format!("{on_disk} bytes ({plain} uncompressed)")),
        "{}",
        stderr(&o)
    );
}
