//! Reading real CityGML files and the hand-made fixtures.
//!
//! Counts are checked against an independent oracle (`tests/oracle/count_citygml.py`, Python
//! standard library) that implements the asset mapping of DESIGN.md on its own.
//!
//! One document read in chunks by several cores (`ReadOptions::chunk_bytes`): forced on every
//! real file, every fixture and the bad-input corpus, the model (buildings, assets, geometry,
//! warnings with their lines and columns, per-file counts) and the errors are exactly those of
//! the read as one chunk; broken copies of real files fail with its message and position.

use crate::util::*;
use glam::DVec3;
use skylod::export::report::Stats;
use skylod::io::citygml::{read_file, ReadError};
use skylod::io::citygml::{read_file_chunked, read_file_with, ReadOptions};
use skylod::model::{AssetKind, CityModel, Polygon};
use std::path::{Path, PathBuf};

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
        // the oracle counts polygon elements in the document, each once
        ("polygons", json!(s.polygon_elements)),
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
        assert_eq!(s.polygon_elements, 14, "{name}: polygon elements");
        assert_eq!(s.polygons, 14, "{name}: polygons");
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
        // buildings, parts, roofs, walls, closures, installations, windows, doors, polygon elements
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
            s.polygon_elements,
        );
        assert_eq!(got, e, "{}", short(f));
    }
}

/// The document read as one chunk, by one core.
fn serial() -> ReadOptions {
    ReadOptions {
        chunk_bytes: u64::MAX,
        ..ReadOptions::default()
    }
}

/// The document at `path` read in `parts` chunks, about.
fn forced(path: &Path, parts: u64) -> ReadOptions {
    let len = std::fs::metadata(path).map_or(0, |m| m.len());
    ReadOptions {
        chunk_bytes: (len / parts).max(1),
        ..ReadOptions::default()
    }
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

fn show(r: &Result<CityModel, skylod::io::citygml::ReadError>) -> String {
    match r {
        Ok(m) => format!(
            "ok: {} buildings, {} assets, {} warnings",
            m.buildings.len(),
            m.assets.len(),
            m.warnings.len()
        ),
        Err(e) => format!("error: {e}"),
    }
}

/// Read `path` as one chunk and in about 2 and 3 chunks on two threads: the results must be
/// equal. Returns how many of the chunked reads were really chunked (not declined).
fn check(path: &Path) -> usize {
    let want = read_file_with(path, &serial());
    let mut split = 0;
    for parts in [2, 3] {
        let opts = forced(path, parts);
        let (got, only) = pool(2).install(|| {
            (
                read_file_with(path, &opts),
                read_file_chunked(path, &opts).unwrap(),
            )
        });
        match (&want, &got) {
            (Ok(a), Ok(b)) => assert!(a == b, "{}: {parts} parts: model differs", short(path)),
            (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string(), "{}", short(path)),
            _ => panic!(
                "{}: {parts} chunks: one chunk {} but chunked {}",
                short(path),
                show(&want),
                show(&got)
            ),
        }
        if let Some(m) = only {
            let Ok(a) = &want else {
                panic!(
                    "{}: the chunked read read a file the read as one chunk refuses",
                    short(path)
                );
            };
            assert!(
                *a == m,
                "{}: {parts} chunks: chunked model differs",
                short(path)
            );
            split += 1;
        }
    }
    split
}

#[test]
fn every_input_reads_in_chunks_as_in_one() {
    let files = all_inputs();
    let mut split = 0;
    let mut splittable = 0;
    let mut never = Vec::new();
    for f in &files {
        let n = check(f);
        split += n;
        // documents with several top-level members and no DOCTYPE are read in chunks
        let text = std::fs::read(f).unwrap();
        let members = memchr::memmem::find_iter(&text, b"cityObjectMember>").count() / 2;
        let doctype = memchr::memmem::find(&text, b"<!DOCTYPE").is_some();
        let plain = !text.starts_with(&[0x1f, 0x8b]);
        if members >= 3 && !doctype && plain && read_file_with(f, &serial()).is_ok() {
            splittable += 1;
            if n == 0 {
                never.push(short(f));
            }
        }
    }
    eprintln!(
        "{} files, {split} chunked reads, {splittable} files with 3+ members, never chunked: {never:?}",
        files.len()
    );
    // what is read as one chunk: the cross-member xlink example, the file whose root is no
    // CityModel (a reference from one chunk into another, or no root to cut under)
    assert!(never.len() <= 2, "never chunked: {never:?}");
    assert!(
        files.len() < 20 || split >= files.len(),
        "too few chunked reads"
    );
}

#[test]
fn bad_inputs_fail_in_chunks_as_in_one() {
    for f in citygml_files(&manifest_dir().join("fixtures").join("bad")) {
        check(&f);
    }
}

/// Copies of real files, broken in a later part: truncated, a tag corrupted, an undeclared
/// xlink target, a duplicate gml:id across parts.
#[test]
fn broken_real_files_fail_in_chunks_as_in_one() {
    let Some(data) = crate::util::shared_data() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let mut sources: Vec<PathBuf> = citygml_files(&data)
        .into_iter()
        .filter(|p| {
            let t = std::fs::read(p).unwrap_or_default();
            !t.starts_with(&[0x1f, 0x8b])
                && memchr::memmem::find_iter(&t, b"cityObjectMember>").count() >= 12
                && read_file_with(p, &serial()).is_ok()
        })
        .collect();
    sources.sort_by_key(|p| std::fs::metadata(p).map(|m| m.len()).unwrap_or(0));
    sources.truncate(6);
    assert!(!sources.is_empty(), "no real file with members");
    let mut errors = 0;
    for (i, src) in sources.iter().enumerate() {
        let text = std::fs::read(src).unwrap();
        let len = text.len();
        let mut variants: Vec<Vec<u8>> =
            vec![text[..len * 2 / 3].to_vec(), text[..len - 20].to_vec()];
        // an end tag in the last third corrupted
        if let Some(at) = memchr::memmem::find(&text[len * 2 / 3..], b"</") {
            let mut v = text.clone();
            v[len * 2 / 3 + at + 1] = b'x';
            variants.push(v);
        }
        // a gml:id of the first third again in the last third, and an xlink to nowhere
        if let Some(at) = memchr::memmem::find(&text, b"gml:id=\"") {
            let start = at + 8;
            let end = start + memchr::memchr(b'"', &text[start..]).unwrap();
            let id = String::from_utf8_lossy(&text[start..end]).to_string();
            if let Some(late) = memchr::memmem::find(&text[len * 2 / 3..], b"gml:id=\"") {
                let late = len * 2 / 3 + late + 8;
                let late_end = late + memchr::memchr(b'"', &text[late..]).unwrap();
                let mut v = text[..late].to_vec();
                v.extend_from_slice(id.as_bytes());
                v.extend_from_slice(&text[late_end..]);
                variants.push(v);
            }
        }
        if let Some(at) = memchr::memmem::find(&text[len / 2..], b"<gml:Polygon") {
            let at = len / 2 + at;
            let mut v = text[..at].to_vec();
            v.extend_from_slice(b"<gml:Polygon xlink:href=\"#nowhere\" xmlns:xlink=\"http://www.w3.org/1999/xlink\"/>");
            v.extend_from_slice(&text[at..]);
            variants.push(v);
        }
        for (j, v) in variants.iter().enumerate() {
            let path = dir.path().join(format!("broken-{i}-{j}.gml"));
            std::fs::write(&path, v).unwrap();
            check(&path);
            if read_file_with(&path, &serial()).is_err() {
                errors += 1;
            }
        }
    }
    assert!(
        errors >= sources.len() * 2,
        "only {errors} broken copies fail"
    );
}

const HEAD: &str = r#"<?xml version="1.0"?>
<CityModel xmlns="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml"
  xmlns:bldg="http://www.opengis.net/citygml/building/2.0">
"#;

fn member(id: &str) -> String {
    format!(
        r#"  <cityObjectMember><bldg:Building gml:id="{id}"><bldg:lod2MultiSurface><gml:MultiSurface>
    <gml:surfaceMember><gml:Polygon><gml:exterior><gml:LinearRing><gml:posList>
      0 0 5 1 0 5 1 1 5 0 0 5</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember>
  </gml:MultiSurface></bldg:lod2MultiSurface></bldg:Building></cityObjectMember>
"#
    )
}

#[test]
fn doctype_and_one_thread_read_serially() {
    let dir = tempfile::tempdir().unwrap();
    let body: String = (0..20).map(|i| member(&format!("b{i}"))).collect();
    let plain = dir.path().join("plain.gml");
    std::fs::write(&plain, format!("{HEAD}{body}</CityModel>\n")).unwrap();
    let with_doctype = dir.path().join("doctype.gml");
    let doc = format!("{HEAD}{body}</CityModel>\n").replacen(
        "<?xml version=\"1.0\"?>\n",
        "<?xml version=\"1.0\"?>\n<!DOCTYPE CityModel [<!ENTITY e \"x\">]>\n",
        1,
    );
    std::fs::write(&with_doctype, doc).unwrap();
    let two = pool(2);
    let three = forced(&plain, 3);
    let chunked = two.install(|| read_file_chunked(&plain, &three).unwrap());
    let m = chunked.expect("a plain document is read in chunks");
    assert_eq!(m.buildings.len(), 20);
    assert!(two
        .install(|| read_file_chunked(&with_doctype, &three))
        .unwrap()
        .is_none());
    check(&with_doctype);
    // one thread (--jobs 1): the same chunks, parsed in turn
    let one = pool(1).install(|| read_file_chunked(&plain, &three).unwrap());
    assert_eq!(one.as_ref(), Some(&m));
    // gzip: streamed by one core
    let gz = gzip_copy(&plain, dir.path());
    assert!(two
        .install(|| read_file_chunked(&gz, &three))
        .unwrap()
        .is_none());
    let streamed = two.install(|| read_file_with(&gz, &three)).unwrap();
    assert!(streamed.assets == m.assets && streamed.buildings == m.buildings);
    // one chunk as large as the document: read as one chunk
    assert!(two
        .install(|| read_file_chunked(&plain, &serial()))
        .unwrap()
        .is_none());
}

#[test]
fn cut_inside_a_comment_or_nested_member_reads_serially() {
    let dir = tempfile::tempdir().unwrap();
    let body: String = (0..12).map(|i| member(&format!("b{i}"))).collect();
    // a fake end tag in a comment near the middle, where a cut is looked for
    let (a, b) = body.split_at(body.len() / 2);
    let a_end = a.rfind('\n').unwrap();
    let fake = format!(
        "{}<!-- </cityObjectMember> -->{}{}",
        &a[..a_end],
        &a[a_end..],
        b
    );
    let path = dir.path().join("comment.gml");
    std::fs::write(&path, format!("{HEAD}{fake}</CityModel>\n")).unwrap();
    check(&path);
    // members nested deeper (a cut after one is not between children of the root)
    let nested = body.replace(
        "</bldg:Building>",
        "<bldg:x><cityObjectMember><bldg:Building/></cityObjectMember></bldg:x></bldg:Building>",
    );
    let path = dir.path().join("nested.gml");
    std::fs::write(&path, format!("{HEAD}{nested}</CityModel>\n")).unwrap();
    check(&path);
    // warnings on later lines keep their line and column
    let warned = body.replace("0 0 5 1 0 5 1 1 5 0 0 5", "0 0 5 1 0 5 1 1 5");
    let path = dir.path().join("warn.gml");
    std::fs::write(&path, format!("{HEAD}{warned}</CityModel>\n")).unwrap();
    assert_eq!(check(&path), 2);
    let m = read_file_with(&path, &serial()).unwrap();
    assert_eq!(m.warnings.len(), 13, "{:?}", m.warnings);
    // all members on one line: the later parts' first line continues the line before them
    let path = dir.path().join("one-line.gml");
    std::fs::write(
        &path,
        format!("{HEAD}{}</CityModel>\n", warned.replace('\n', " ")),
    )
    .unwrap();
    assert_eq!(check(&path), 2);
    let m = read_file_with(&path, &serial()).unwrap();
    let rings: Vec<_> = m
        .warnings
        .iter()
        .filter(|w| w.message.starts_with("ring is not closed"))
        .collect();
    assert_eq!(rings.len(), 12);
    assert!(rings.iter().all(|w| w.line == rings[0].line));
    assert!(rings.windows(2).all(|w| w[0].column < w[1].column));
}

#[test]
fn ids_met_in_two_parts_are_warned_where_the_serial_read_warns() {
    let dir = tempfile::tempdir().unwrap();
    // ids of the first members again in later ones: as a building's id (nearest id: the
    // root's), a polygon's (nearest: its building's), twice in one part, with an entity
    let mut body = String::new();
    for i in 0..12 {
        let id = if i % 4 == 3 {
            format!("b{}", i % 3)
        } else {
            format!("b{i}")
        };
        let m = member(&id).replace(
            "<gml:Polygon>",
            &format!("<gml:Polygon gml:id=\"p{}&amp;\">", i % 5),
        );
        body.push_str(&m);
    }
    let root = HEAD.replacen("<CityModel ", "<CityModel gml:id=\"root\" ", 1);
    let path = dir.path().join("dups.gml");
    std::fs::write(&path, format!("{root}{body}</CityModel>\n")).unwrap();
    assert_eq!(check(&path), 2, "both chunked reads taken");
    let m = read_file_with(&path, &serial()).unwrap();
    let dups: Vec<_> = m
        .warnings
        .iter()
        .filter(|w| w.message.starts_with("duplicate"))
        .collect();
    assert_eq!(dups.len(), 3 + 7, "{dups:?}");
    assert!(dups.iter().any(|w| w.gml_id.as_deref() == Some("root")));
    assert!(dups.iter().any(|w| w.message.contains("p1&")));
}

/// `xlink:href`s to polygon ids that repeat in later parts, to ids first met in the last part
/// (one from the first member: a reference forward across parts) resolve to the first element
/// holding the id, split as serially: the split read registers ids by their entry in the
/// merged gml:id log, which must keep the document's order.
#[test]
fn hrefs_to_ids_met_in_two_parts_resolve_to_the_first_element() {
    let dir = tempfile::tempdir().unwrap();
    let polygon = |id: String, z: f64| {
        format!(
            "<gml:surfaceMember><gml:Polygon gml:id=\"{id}\"><gml:exterior><gml:LinearRing>\
             <gml:posList>0 0 {z} 1 0 {z} 1 1 {z} 0 0 {z}</gml:posList></gml:LinearRing>\
             </gml:exterior></gml:Polygon></gml:surfaceMember>"
        )
    };
    let href = |id: String| format!("<gml:surfaceMember xlink:href=\"#{id}\"/>");
    let mut body = String::new();
    for i in 0..12usize {
        // member i holds polygon p{i % 4} at height i and, from member 6 on, q{i} at 100 + i;
        // member 0 points at p1 and at q11 (the last member), members 8.. at p{(i + 1) % 4}
        let mut surfaces = polygon(format!("p{}", i % 4), i as f64);
        if i >= 6 {
            surfaces.push_str(&polygon(format!("q{i}"), 100.0 + i as f64));
        }
        if i == 0 {
            surfaces.push_str(&href("p1".into()));
            surfaces.push_str(&href("q11".into()));
        }
        if i >= 8 {
            surfaces.push_str(&href(format!("p{}", (i + 1) % 4)));
        }
        body.push_str(&format!(
            "  <cityObjectMember><bldg:Building gml:id=\"b{i}\"><bldg:lod2MultiSurface>\
             <gml:MultiSurface>{surfaces}</gml:MultiSurface></bldg:lod2MultiSurface>\
             </bldg:Building></cityObjectMember>\n"
        ));
    }
    let root = HEAD.replacen(
        "<CityModel ",
        "<CityModel xmlns:xlink=\"http://www.w3.org/1999/xlink\" ",
        1,
    );
    let path = dir.path().join("hrefs.gml");
    std::fs::write(&path, format!("{root}{body}</CityModel>\n")).unwrap();
    // a reference from one chunk into another: read as one chunk, the same model
    check(&path);
    let m = read_file_with(&path, &serial()).unwrap();
    let heights = |i: usize| -> Vec<f64> {
        let id = format!("b{i}");
        let b = m
            .buildings
            .iter()
            .position(|b| b.id.as_deref() == Some(&*id));
        (m.assets.iter())
            .filter(|a| a.building == Some(b.unwrap()))
            .flat_map(|a| a.geometries.iter().flat_map(|g| &g.polygons))
            .map(|p| p.exterior()[0].z)
            .collect()
    };
    assert_eq!(heights(0), vec![0.0, 1.0, 111.0]);
    for i in 8..12usize {
        // its own polygons, then the first p{(i + 1) % 4}'s
        let first = ((i + 1) % 4) as f64;
        assert_eq!(heights(i), vec![i as f64, 100.0 + i as f64, first], "b{i}");
    }
}
