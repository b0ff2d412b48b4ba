//! Mixed-LoD output: `skylod rough` (every asset at level 1) and `write_mixed` with random
//! levels on every fixture and shared file: XSD-valid output for valid input, every local
//! reference resolves, level attributes, counts consistent with the levels; building drop;
//! appearance pruning.

use crate::util::*;
use rand::{Rng, SeedableRng};
use skylod::export::report::Stats;
use skylod::io::citygml::read_file;
use skylod::io::citygml::WriteOptions;
use skylod::lod::rough::{rough_model, RoughOptions};
use skylod::lod::{write_mixed, MixedSummary};
use skylod::model::{AssetKind, CityModel};
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

fn inputs() -> Vec<PathBuf> {
    all_inputs()
        .into_iter()
        .filter(|p| !p.ends_with("val3dity/csol1b.gml")) // plain GML, not CityGML
        .collect()
}

fn decompressed(p: &Path) -> Vec<u8> {
    let (mut r, _) = skylod::io::citygml::open(p).unwrap();
    let mut v = Vec::new();
    std::io::Read::read_to_end(&mut r, &mut v).unwrap();
    v
}

/// Level written for each asset of a re-read output: the `skylod_level` generic attribute found
/// between the asset's start tag and its first geometry property.
fn written_levels(model: &CityModel, text: &[u8]) -> Vec<Option<u8>> {
    model
        .assets
        .iter()
        .map(|a| {
            let end = a
                .geometries
                .iter()
                .map(|g| g.span.start)
                .min()
                .unwrap_or(a.span.end);
            let head = String::from_utf8_lossy(&text[a.span.start as usize..end as usize]);
            let i = head.find("skylod_level")?;
            let rest = &head[i..];
            let v = rest.find("value>")?;
            rest[v + 6..].chars().next()?.to_digit(10).map(|d| d as u8)
        })
        .collect()
}

fn buildings(s: &Stats) -> usize {
    s.buildings + s.building_parts
}

#[test]
fn rough_command_on_every_file() {
    let dir = tempfile::tempdir().unwrap();
    let mut problems = Vec::new();
    let mut pairs = Vec::new();
    let mut figures = Vec::new();
    for (i, input) in inputs().iter().enumerate() {
        let name = short(input);
        let before = match read_file(input) {
            Ok(m) => m,
            Err(e) => {
                problems.push(format!("{name}: input does not read: {e}"));
                continue;
            }
        };
        let out = dir.path().join(format!("{i:03}.gml"));
        let o = run(&[
            "rough".as_ref(),
            input.as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
        ]);
        if !o.status.success() {
            problems.push(format!(
                "{name}: rough failed ({:?}): {}",
                o.status.code(),
                String::from_utf8_lossy(&o.stderr)
            ));
            continue;
        }
        let after = match read_file(&out) {
            Ok(m) => m,
            Err(e) => {
                problems.push(format!("{name}: output does not read: {e}"));
                continue;
            }
        };
        let (sb, sa) = (Stats::of(&before), Stats::of(&after));
        if buildings(&sa) != buildings(&sb) {
            problems.push(format!(
                "{name}: buildings {} -> {}",
                buildings(&sb),
                buildings(&sa)
            ));
        }
        if sa.polygons > sb.polygons {
            problems.push(format!(
                "{name}: polygons increased {} -> {}",
                sb.polygons, sa.polygons
            ));
        }
        if sa.assets != sb.assets {
            problems.push(format!("{name}: assets {} -> {}", sb.assets, sa.assets));
        }
        let text = decompressed(&out);
        let lv = written_levels(&after, &text);
        let bad = lv.iter().filter(|l| **l != Some(1)).count();
        if bad > 0 {
            problems.push(format!("{name}: {bad} asset(s) without skylod_level 1"));
        }
        check_refs(input, &out, &mut problems);
        figures.push(format!(
            "{name}: polygons {} -> {}",
            sb.polygons, sa.polygons
        ));
        pairs.push((input.clone(), out, sb.citygml_version.unwrap_or_default()));
    }
    check_xsd(&pairs, &mut problems);
    for f in &figures {
        eprintln!("{f}");
    }
    assert!(
        problems.is_empty(),
        "{} problem(s):\n{}",
        problems.len(),
        problems.join("\n")
    );
}

#[test]
fn rough_command_batch_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    let outdir = dir.path().join("out");
    let gz = gzip_copy(&fixture("chimney-citygml2.gml"), dir.path());
    let missing = dir.path().join("missing.gml");
    let o = run(&[
        "rough".as_ref(),
        fixture("chimney-citygml3.gml").as_os_str(),
        gz.as_os_str(),
        missing.as_os_str(),
        "-o".as_ref(),
        outdir.as_os_str(),
    ]);
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("polygons"), "{err}");
    assert!(outdir.join("chimney-citygml3.gml").is_file());
    let raw = std::fs::read(outdir.join("chimney-citygml2.gml.gz")).unwrap();
    assert_eq!(&raw[..2], &[0x1f, 0x8b]);
    // existing outputs are not replaced without --overwrite
    let o = run(&[
        "rough".as_ref(),
        fixture("chimney-citygml3.gml").as_os_str(),
        gz.as_os_str(),
        "-o".as_ref(),
        outdir.as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    // usage errors: several inputs into a file; bad angle
    let f = dir.path().join("file.gml");
    std::fs::write(&f, "x").unwrap();
    let o = run(&[
        "rough".as_ref(),
        fixture("chimney-citygml3.gml").as_os_str(),
        gz.as_os_str(),
        "-o".as_ref(),
        f.as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let o = run(&[
        "rough".as_ref(),
        fixture("chimney-citygml3.gml").as_os_str(),
        "-o".as_ref(),
        dir.path().join("x.gml").as_os_str(),
        "--angle".as_ref(),
        "-3".as_ref(),
    ]);
    assert_eq!(o.status.code(), Some(2));
}

fn mixed(
    model: &CityModel,
    levels: &[u8],
    out: &Path,
) -> Result<MixedSummary, skylod::io::citygml::WriteError> {
    let rough = rough_model(model, &RoughOptions::default());
    write_mixed((model, 0), &rough, levels, out, &WriteOptions::default())
}

fn unique_ids(model: &CityModel) -> HashMap<&str, usize> {
    let mut count: HashMap<&str, usize> = HashMap::new();
    for a in &model.assets {
        if let Some(id) = &a.id {
            *count.entry(id.as_str()).or_default() += 1;
        }
    }
    model
        .assets
        .iter()
        .enumerate()
        .filter_map(|(i, a)| {
            a.id.as_deref()
                .filter(|id| count[id] == 1)
                .map(|id| (id, i))
        })
        .collect()
}

#[test]
fn random_levels_on_every_file() {
    let dir = tempfile::tempdir().unwrap();
    let mut problems = Vec::new();
    let mut pairs = Vec::new();
    for (i, input) in inputs().iter().enumerate() {
        let name = short(input);
        let Ok(model) = read_file(input) else {
            problems.push(format!("{name}: input does not read"));
            continue;
        };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x5eed + i as u64);
        let levels: Vec<u8> = (0..model.assets.len())
            .map(|_| rng.random_range(0..3u8))
            .collect();
        let out = dir.path().join(format!("{i:03}.gml"));
        let s = match mixed(&model, &levels, &out) {
            Ok(s) => s,
            Err(e) => {
                problems.push(format!("{name}: write_mixed failed: {e}"));
                continue;
            }
        };
        let after = match read_file(&out) {
            Ok(m) => m,
            Err(e) => {
                problems.push(format!("{name}: output does not read: {e}"));
                continue;
            }
        };
        let expect: [usize; 3] = [0, 1, 2].map(|l| levels.iter().filter(|&&x| x == l).count());
        if s.levels != expect {
            problems.push(format!(
                "{name}: summary levels {:?} != {expect:?}",
                s.levels
            ));
        }
        // level-0 assets are absent, kept ones present with their level
        let ids_in = unique_ids(&model);
        let ids_out = unique_ids(&after);
        let lv = written_levels(&after, &decompressed(&out));
        for (id, &a) in &ids_in {
            let kind = model.assets[a].kind;
            match (levels[a], ids_out.get(id)) {
                // a container of kept assets: no geometry, level 0
                (0, Some(&b))
                    if kind != AssetKind::Body
                        && (!after.assets[b].geometries.is_empty() || lv[b] != Some(0)) =>
                {
                    problems.push(format!("{name}: level-0 asset {id} is still an asset"))
                }
                (1 | 2, Some(&b)) if lv[b] != Some(levels[a]) => {
                    problems.push(format!(
                        "{name}: asset {id}: level {} written as {:?}",
                        levels[a], lv[b]
                    ));
                }
                (1 | 2, None) => problems.push(format!(
                    "{name}: kept asset {id} (level {}) missing",
                    levels[a]
                )),
                _ => {}
            }
        }
        // stats consistent with the levels
        // kept assets plus level-0 containers of kept assets
        let mut kept_below = vec![false; model.assets.len()];
        for (asset, &level) in model.assets.iter().zip(&levels) {
            let mut p = asset.parent;
            if level > 0 {
                while let Some(x) = p {
                    kept_below[x] = true;
                    p = model.assets[x].parent;
                }
            }
        }
        let kept_of = |k: AssetKind| {
            (0..model.assets.len())
                .filter(|&a| model.assets[a].kind == k && (levels[a] > 0 || kept_below[a]))
                .count()
        };
        let sa = Stats::of(&after);
        let sb = Stats::of(&model);
        for (k, got) in [
            (AssetKind::Roof, sa.roof_surfaces),
            (AssetKind::Wall, sa.wall_surfaces),
            (AssetKind::Ground, sa.ground_surfaces),
            (AssetKind::Installation, sa.installations),
            (AssetKind::Window, sa.windows),
            (AssetKind::Door, sa.doors),
            (AssetKind::Other, sa.other_objects),
        ] {
            if got != kept_of(k) {
                problems.push(format!(
                    "{name}: {k}: {got} in the output, {} kept",
                    kept_of(k)
                ));
            }
        }
        if buildings(&sa) + s.buildings_dropped + s.parts_dropped != buildings(&sb) {
            problems.push(format!(
                "{name}: buildings {} -> {} with {} dropped",
                buildings(&sb),
                buildings(&sa),
                s.buildings_dropped
            ));
        }
        if sa.buildings + s.buildings_dropped != sb.buildings {
            problems.push(format!(
                "{name}: top-level buildings {} -> {} with {} dropped (parts counted apart)",
                sb.buildings, sa.buildings, s.buildings_dropped
            ));
        }
        check_refs(input, &out, &mut problems);
        pairs.push((input.clone(), out, sb.citygml_version.unwrap_or_default()));
    }
    check_xsd(&pairs, &mut problems);
    assert!(
        problems.is_empty(),
        "{} problem(s):\n{}",
        problems.len(),
        problems.join("\n")
    );
}

#[test]
fn building_with_every_asset_at_level_0_is_dropped() {
    let Some(data) = shared_data() else { return };
    let input = data.join("ogc-citygml2-examples/building/Building_and_garage_LOD2-EPSG25832.gml");
    let model = read_file(&input).unwrap();
    let first = model.root_building(0);
    let levels: Vec<u8> = model
        .assets
        .iter()
        .map(|a| match a.building.map(|b| model.root_building(b)) {
            Some(b) if b == first => 0,
            _ => 2,
        })
        .collect();
    assert!(levels.contains(&0) && levels.contains(&2));
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.gml");
    let s = mixed(&model, &levels, &out).unwrap();
    assert!(s.buildings_dropped >= 1);
    let after = read_file(&out).unwrap();
    let id = model.buildings[first].id.clone().unwrap();
    assert!(after
        .buildings
        .iter()
        .all(|b| b.id.as_deref() != Some(id.as_str())));
    assert_eq!(
        after.buildings.len(),
        model.buildings.len() - s.buildings_dropped - s.parts_dropped
    );
    let text = String::from_utf8(decompressed(&out)).unwrap();
    assert!(
        !text.contains(&format!("\"{id}\"")),
        "building element removed"
    );
    check_refs(&input, &out, &mut Vec::new());
    if have_xmllint() {
        xmllint_validate(&out, "2.0").unwrap();
    }
}

#[test]
fn appearance_targets_are_pruned() {
    let Some(data) = shared_data() else { return };
    let input = data.join("ogc-citygml2-examples/appearance/Appearance-EPSG25832.gml");
    let model = read_file(&input).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut seen: BTreeMap<String, MixedSummary> = BTreeMap::new();
    for (name, level) in [("rough", 1u8), ("none", 0u8)] {
        let levels = vec![level; model.assets.len()];
        let out = dir.path().join(format!("{name}.gml"));
        let s = mixed(&model, &levels, &out).unwrap();
        assert!(s.appearance_targets_pruned > 0, "{name}: {s:?}");
        let unresolved = unresolved_refs(&out).unwrap();
        assert!(unresolved.is_empty(), "{name}: {unresolved:?}");
        if have_xmllint() {
            xmllint_validate(&out, "2.0").unwrap();
        }
        let text = String::from_utf8(decompressed(&out)).unwrap();
        if level == 0 {
            assert!(
                !text.contains("appearanceMember"),
                "no target left: appearances dropped"
            );
            assert!(!text.contains("<app:target"));
        }
        seen.insert(name.into(), s);
    }
    // level 2 everywhere: nothing pruned
    let out = dir.path().join("full.gml");
    let s = mixed(&model, &vec![2; model.assets.len()], &out).unwrap();
    assert_eq!((s.appearance_targets_pruned, s.hrefs_pruned), (0, 0));
    let n_targets = |p: &Path| {
        String::from_utf8(decompressed(p))
            .unwrap()
            .matches("<app:target")
            .count()
    };
    assert_eq!(n_targets(&out), n_targets(&input));
}

#[test]
fn relation_to_a_dropped_object_is_removed() {
    // CityGML 3.0 XLink example 4: walls ts_p_w_2 and ts_b2_p_w_4 relate to each other
    // (core:relatedTo/CityObjectRelation/relatedTo). Dropping one must remove the other's
    // relation whole: a CityObjectRelation without its relatedTo is schema-invalid.
    let Some(data) = crate::util::shared_data() else {
        return;
    };
    let input =
        data.join("ogc-citygml3-examples/XLink_examples/4_Cross-Top-Level-XLink/CityGML_3.gml");
    let model = read_file(&input).unwrap();
    let levels: Vec<u8> = model
        .assets
        .iter()
        .map(|a| u8::from(a.id.as_deref() != Some("ts_b2_p_w_4")))
        .collect();
    assert!(levels.contains(&0), "the wall exists");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.gml");
    mixed(&model, &levels, &out).unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(!text.contains("gml:id=\"ts_b2_p_w_4\""));
    assert!(!text.contains("href=\"#ts_b2_p_w_4\""));
    assert!(
        !text.contains("CityObjectRelation"),
        "the dangling relation is gone"
    );
    assert!(crate::util::unresolved_refs(&out).unwrap().is_empty());
    if crate::util::have_xmllint() {
        crate::util::xmllint_validate(&out, "3.0").unwrap_or_else(|e| panic!("{e}"));
    }
}
