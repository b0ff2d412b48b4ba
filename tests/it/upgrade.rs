//! `skylod upgrade` (CityGML 1.0 / 2.0 → 3.0) on every 1.0 / 2.0 file of the shared data and
//! the fixtures: XSD validity by xmllint against the 3.0 schemas (where the source is valid
//! against its own version's; where it is not, no new kind of error), counts by an independent
//! reader (`tests/oracle/citygml_upgrade.py`, Python's `xml.etree`), and `skylod stats` on the
//! output against the source.

use crate::util::*;
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The CityGML 1.0 / 2.0 documents of the shared data and the fixtures (by their root's
/// namespace in the first bytes).
fn sources() -> Option<Vec<PathBuf>> {
    let data = shared_data()?;
    let mut v = citygml_files(&data);
    v.extend(fixture_files());
    v.retain(|p| {
        let mut head = Vec::new();
        let f = std::fs::File::open(p).unwrap();
        let mut r: Box<dyn std::io::Read> = if p.extension().is_some_and(|e| e == "gz") {
            Box::new(flate2::read::MultiGzDecoder::new(f))
        } else {
            Box::new(f)
        };
        let _ = std::io::Read::read_to_end(&mut std::io::Read::take(&mut r, 6000), &mut head);
        let h = String::from_utf8_lossy(&head);
        h.contains("http://www.opengis.net/citygml/") && !h.contains("citygml/3.0")
    });
    Some(v)
}

fn oracle(files: &[PathBuf]) -> Vec<Value> {
    let o = Command::new("python3")
        .arg(manifest_dir().join("tests/oracle/citygml_upgrade.py"))
        .args(files)
        .output()
        .expect("python3");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: Value = serde_json::from_slice(&o.stdout).expect("oracle JSON");
    v.as_array().unwrap().clone()
}

fn out_name(dir: &Path, src: &Path) -> PathBuf {
    let s = short(src).replace('/', "__");
    dir.join(s.strip_suffix(".gz").unwrap_or(&s))
}

/// Upgrade `src` into `out` with `flags`; the summary line.
fn upgrade(src: &Path, out: &Path, flags: &[&str]) -> String {
    let mut a = vec![os("upgrade"), src.as_os_str(), os("-o"), out.as_os_str()];
    a.extend(flags.iter().map(os));
    let o = run(&a);
    assert!(o.status.success(), "{}: {}", short(src), stderr(&o));
    stderr(&o)
}

/// xmllint's messages per file (all of them), against `version`'s XSD.
fn lint(files: &[PathBuf], version: &str) -> BTreeMap<PathBuf, Vec<String>> {
    let schemas = shared_schemas().expect("shared schemas");
    let mut out = BTreeMap::new();
    for chunk in files.chunks(20) {
        let o = Command::new("xmllint")
            .env("XML_CATALOG_FILES", schemas.join("catalog.xml"))
            .args(["--nonet", "--noout", "--schema"])
            .arg(xsd(&schemas, version))
            .args(chunk)
            .output()
            .expect("xmllint");
        let text = String::from_utf8_lossy(&o.stderr);
        for f in chunk {
            let name = f.display().to_string();
            let msgs: Vec<String> = text
                .lines()
                .filter(|l| l.starts_with(&format!("{name}:")) && !l.contains("Skipping import"))
                .map(str::to_string)
                .collect();
            let verdict = text.lines().any(|l| l == format!("{name} validates"));
            assert!(
                verdict || !msgs.is_empty() || text.contains(&format!("{name} fails")),
                "no verdict for {name}: {text}"
            );
            out.insert(f.clone(), if verdict { Vec::new() } else { msgs });
        }
    }
    out
}

/// The kind of an xmllint error: its element, attribute and problem, without file, line,
/// values, namespaces and versions.
fn kind(msg: &str) -> String {
    let after = msg.splitn(3, ':').nth(2).unwrap_or(msg);
    let mut k = String::new();
    let mut chars = after.chars().peekable();
    let (mut in_q, mut in_ns) = (false, false);
    for c in chars.by_ref() {
        match c {
            '{' => in_ns = true,
            '}' => in_ns = false,
            '\'' => {
                in_q = !in_q;
                k.push(c);
            }
            _ if in_ns => {}
            _ => k.push(c),
        }
    }
    let _ = in_q;
    let k = k.split(" Expected is").next().unwrap_or(&k).to_string();
    // values of attributes and text ('0000000' is not a valid ...) are not the kind
    let re_value = k
        .split('\'')
        .enumerate()
        .map(|(i, part)| {
            if i % 2 == 1 && (part.contains(' ') || part.chars().any(|c| c.is_ascii_digit())) {
                "_"
            } else {
                part
            }
        })
        .collect::<Vec<_>>()
        .join("'");
    // the error is the same on the element's 3.0 name
    let mut k = re_value.trim().to_string();
    for (old, new) in [
        ("Window", "WindowSurface"),
        ("Door", "DoorSurface"),
        ("Room", "BuildingRoom"),
        ("IntBuildingInstallation", "BuildingInstallation"),
        ("GenericCityObject", "GenericOccupiedSpace"),
    ] {
        k = k
            .replace(&format!("element {old}:"), &format!("element {new}:"))
            .replace(&format!("'{old}'"), &format!("'{new}'"));
    }
    k
}

#[test]
fn kinds_leave_out_lines_values_and_versions() {
    let a = "/x/a.gml:12: element Polygon: Schemas validity error : Element '{http://www.opengis.net/gml}Polygon', attribute '{http://www.opengis.net/gml}id': '4018_PG.x' is not a valid value of the atomic type 'xs:ID'.";
    let b = "/y/b.gml:99: element Polygon: Schemas validity error : Element '{http://www.opengis.net/gml/3.2}Polygon', attribute '{http://www.opengis.net/gml/3.2}id': '9_PG.y' is not a valid value of the atomic type 'xs:ID'.";
    assert_eq!(kind(a), kind(b));
    let c = "/x/a.gml:5: element Foo: Schemas validity error : Element '{urn:a}Foo': This element is not expected. Expected is one of ( {x}y ).";
    assert_ne!(kind(a), kind(c));
    assert!(
        kind(c).contains("Foo': This element is not expected"),
        "{}",
        kind(c)
    );
}

/// Every 1.0 / 2.0 file upgraded with the roof-edge and LoD1 mappings: XSD-valid where the
/// source is, counts as the oracle expects (LoD4 dropped).
#[test]
fn shared_data_upgraded_valid_and_counted() {
    let Some(srcs) = sources() else { return };
    if !have_xmllint() || !python_has("json", "python3") {
        return;
    }
    assert!(
        srcs.len() >= 50,
        "only {} CityGML 1.0/2.0 files",
        srcs.len()
    );
    let dir = tempfile::tempdir().unwrap();
    let outs: Vec<PathBuf> = srcs.iter().map(|s| out_name(dir.path(), s)).collect();
    for (s, o) in srcs.iter().zip(&outs) {
        let line = upgrade(s, o, &["-r", "-m"]);
        assert!(line.contains("-> 3.0"), "{line}");
    }
    let before = oracle(&srcs);
    let after = oracle(&outs);
    let mut problems = Vec::new();
    for ((s, b), a) in srcs.iter().zip(&before).zip(&after) {
        let name = short(s);
        if let Some(e) = b.get("error") {
            // the source is not namespace-well-formed (xml.etree cannot read it)
            // (the output keeps the unbound prefix: its namespace is unknown)
            println!("{name}: not counted, the oracle cannot read the source: {e}");
            continue;
        }
        let n = |v: &Value, k: &str| v[k].as_u64().unwrap();
        if a["version"] != "3.0" {
            problems.push(format!("{name}: output version {}", a["version"]));
        }
        let mut types: BTreeMap<String, u64> = b["types"]
            .as_object()
            .unwrap()
            .iter()
            .map(|(k, v)| (k.clone(), v.as_u64().unwrap()))
            .collect();
        if n(b, "roof_edges") > 0 {
            *types.entry("RoofSurface".into()).or_default() += n(b, "roof_edges");
        }
        if n(b, "lod1_surfaces") > 0 {
            *types.entry("GenericThematicSurface".into()).or_default() += n(b, "lod1_surfaces");
        }
        let got: BTreeMap<String, u64> = a["types"]
            .as_object()
            .unwrap()
            .iter()
            .map(|(k, v)| (k.clone(), v.as_u64().unwrap()))
            .collect();
        if got != types {
            problems.push(format!("{name}: city objects {got:?}, expected {types:?}"));
        }
        for (what, lod4) in [("polygons", "lod4_polygons"), ("tuples", "lod4_tuples")] {
            if n(a, what) != n(b, what) - n(b, lod4) {
                problems.push(format!(
                    "{name}: {what} {} in 3.0, {} - {} (LoD4) in the source",
                    n(a, what),
                    n(b, what),
                    n(b, lod4)
                ));
            }
        }
        for k in ["generic", "targets"] {
            if a[k] != b[k] {
                problems.push(format!("{name}: {k} differ"));
            }
        }
    }
    // XSD validity
    let mut by_version: BTreeMap<String, Vec<PathBuf>> = BTreeMap::new();
    for (s, b) in srcs.iter().zip(&before) {
        by_version
            .entry(b["version"].as_str().unwrap_or("2.0").to_string())
            .or_default()
            .push(s.clone());
    }
    let mut src_lint = BTreeMap::new();
    for (v, fs) in &by_version {
        src_lint.extend(lint(fs, v));
    }
    let out_lint = lint(&outs, "3.0");
    let mut valid = 0;
    for (s, o) in srcs.iter().zip(&outs) {
        let (src_msgs, out_msgs) = (&src_lint[s], &out_lint[o]);
        if src_msgs.is_empty() {
            if out_msgs.is_empty() {
                valid += 1;
            } else {
                problems.push(format!(
                    "{}: valid source, invalid 3.0: {}",
                    short(s),
                    out_msgs[..out_msgs.len().min(3)].join("\n")
                ));
            }
            continue;
        }
        let old: BTreeSet<String> = src_msgs.iter().map(|m| kind(m)).collect();
        let new: BTreeSet<String> = out_msgs
            .iter()
            .map(|m| kind(m))
            .filter(|k| !old.contains(k) && !k.ends_with("fails to validate"))
            .collect();
        if !new.is_empty() {
            problems.push(format!("{}: new kinds of error {new:?}", short(s)));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    assert!(valid >= 40, "only {valid} valid outputs");
    println!(
        "{} files upgraded, {valid} from valid sources valid against 3.0",
        srcs.len()
    );
}

/// `--use-lod4-as-lod3`: LoD4 geometry becomes LoD3, replacing the LoD3 of the same objects;
/// every other polygon and tuple kept.
#[test]
fn lod4_as_lod3_keeps_the_interior() {
    let Some(srcs) = sources() else { return };
    let before = oracle(&srcs);
    let with4: Vec<(PathBuf, &Value)> = srcs
        .iter()
        .zip(&before)
        .filter(|(_, b)| b["lod4_polygons"].as_u64().unwrap_or(0) > 0)
        .map(|(s, b)| (s.clone(), b))
        .collect();
    assert!(with4.len() >= 2, "{} files with LoD4", with4.len());
    let dir = tempfile::tempdir().unwrap();
    for (s, b) in with4 {
        let out = out_name(dir.path(), &s);
        let line = upgrade(&s, &out, &["-u", "-r", "-m"]);
        assert!(line.contains("as LoD3"), "{line}");
        let a = &oracle(std::slice::from_ref(&out))[0];
        let n = |v: &Value, k: &str| v[k].as_u64().unwrap();
        assert_eq!(n(a, "lod4_polygons"), 0);
        for (what, gone) in [
            ("polygons", "lod3_replaced_polygons"),
            ("tuples", "lod3_replaced_tuples"),
        ] {
            assert_eq!(n(a, what), n(b, what) - n(b, gone), "{}: {what}", short(&s));
        }
        assert!(
            a["types"]["BuildingRoom"].as_u64().unwrap_or(0)
                >= b["types"]["BuildingRoom"].as_u64().unwrap_or(0)
        );
    }
}

fn stats(p: &Path) -> Value {
    let o = run(&[os("stats"), os("--json"), p.as_os_str()]);
    json(&o)["total"].clone()
}

/// Our reader reads the 3.0 output as it read the source: same assets, polygons, box.
#[test]
fn stats_of_the_upgrade_match_the_source() {
    let Some(srcs) = sources() else { return };
    let dir = tempfile::tempdir().unwrap();
    let mut compared = 0;
    for s in &srcs {
        let out = out_name(dir.path(), s);
        let line = upgrade(s, &out, &[]);
        if line.contains("dropped") || line.contains("mapped") || line.contains("top-level") {
            // the summary says what differs from the source
            continue;
        }
        let (a, b) = (stats(s), stats(&out));
        for k in [
            "buildings",
            "building_parts",
            "roof_surfaces",
            "wall_surfaces",
            "ground_surfaces",
            "installations",
            "windows",
            "doors",
            "assets",
            "polygons",
            "bbox",
        ] {
            assert_eq!(a[k], b[k], "{}: {k}", short(s));
        }
        compared += 1;
    }
    assert!(compared >= 40, "only {compared} files compared");
}

#[test]
fn version_3_refused_and_batches_mirrored() {
    let Some(data) = shared_data() else { return };
    let dir = tempfile::tempdir().unwrap();
    let v3 = data.join("kit-fzk-haus/citygml3/FZK-Haus-LoD2-KIT-IAI-KHH-B36-V1__v3.gml");
    let o = run(&[
        os("upgrade"),
        v3.as_os_str(),
        os("-o"),
        dir.path().join("x.gml").as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("already CityGML 3.0"), "{}", stderr(&o));
    // a directory in, a mirrored directory out, one summary line per file
    let src = data.join("kit-fzk-haus/citygml2");
    let out = dir.path().join("out");
    let o = run(&[os("upgrade"), src.as_os_str(), os("-o"), out.as_os_str()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let n = std::fs::read_dir(&out).unwrap().count();
    assert_eq!(n, 5, "{}", stderr(&o));
    assert_eq!(stderr(&o).matches("-> 3.0").count(), 5, "{}", stderr(&o));
    // standard output
    let one = src.join("fzk_haus_lod2_v2.gml");
    let o = run(&[os("upgrade"), one.as_os_str(), os("-o"), os("-")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("<core:CityModel") && text.contains("<con:RoofSurface"));
}
