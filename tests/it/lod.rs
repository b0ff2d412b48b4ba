//! `skylod lod` end to end: the hand-made scenes, the synthetic district and the Ingolstadt
//! street (all files as one scene). Outputs are XSD-valid (for valid inputs), every reference
//! resolves, every output asset exists in the input with the level the report gives it, the
//! report follows `schemas/report.schema.json`, and the output depends only on the arguments
//! (same seed, same bytes; any thread count).

use glam::DVec3;
use serde_json::Value;
use skylod::io::citygml::read_file;
use skylod::model::{AssetKind, CityModel};
use std::collections::HashMap;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn lod(args: &[&OsStr], threads: Option<usize>) -> Output {
    let mut c = Command::new(crate::util::BIN);
    c.arg("lod").args(args);
    if let Some(n) = threads {
        c.env("RAYON_NUM_THREADS", n.to_string());
    }
    c.output().expect("cannot start skylod")
}

fn ok(o: &Output) {
    assert!(
        o.status.success(),
        "skylod failed ({:?}): {}",
        o.status.code(),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Validate a report against `schemas/report.schema.json` (Python's `jsonschema`).
fn check_report_schema(report: &Path) {
    crate::util::check_json_schema("report.schema.json", report);
}

fn report(path: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// Level per asset id in the report.
fn report_levels(r: &Value) -> HashMap<String, u64> {
    r["assets"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|a| Some((a["id"].as_str()?.to_string(), a["level"].as_u64()?)))
        .collect()
}

/// Every asset with geometry in `out` exists in `input`, with the level the report gives it;
/// every kept asset of the report is in the output.
fn check_output_against_input(input: &CityModel, out: &Path, levels: &HashMap<String, u64>) {
    let o = read_file(out).unwrap_or_else(|e| panic!("re-reading {}: {e}", out.display()));
    let in_ids: std::collections::HashSet<&str> = input
        .assets
        .iter()
        .filter_map(|a| a.id.as_deref())
        .collect();
    let text = String::from_utf8(decompress(out)).unwrap();
    let building_ids: std::collections::HashSet<&str> = input
        .buildings
        .iter()
        .filter_map(|b| b.id.as_deref())
        .collect();
    for a in &o.assets {
        let Some(id) = a.id.as_deref() else { continue };
        if a.kind == AssetKind::Body && building_ids.contains(id) {
            // A building's own geometry beside its thematic surfaces is not an asset in the
            // input (and is kept verbatim); alone in the output it reads as a body.
            continue;
        }
        assert!(in_ids.contains(id), "{id} is not in the input");
        if a.polygon_count() > 0 {
            let l = levels.get(id).copied().unwrap_or(99);
            assert!(l == 1 || l == 2, "{id} is written but has level {l}");
        }
    }
    let out_ids: std::collections::HashSet<&str> =
        o.assets.iter().filter_map(|a| a.id.as_deref()).collect();
    for (id, l) in levels {
        if in_ids.contains(id.as_str()) && *l > 0 {
            assert!(out_ids.contains(id.as_str()), "kept asset {id} is missing");
        }
    }
    let real_asset = |a: &&skylod::model::Asset| {
        !(a.kind == AssetKind::Body && a.id.as_deref().is_some_and(|i| building_ids.contains(i)))
    };
    if o.assets
        .iter()
        .filter(real_asset)
        .any(|a| a.polygon_count() > 0)
    {
        assert!(
            text.contains("skylod_level"),
            "kept assets carry their level"
        );
    }
    let unresolved = crate::util::unresolved_refs(out).unwrap();
    assert!(
        unresolved.is_empty(),
        "unresolved references: {unresolved:?}"
    );
}

fn decompress(p: &Path) -> Vec<u8> {
    let raw = std::fs::read(p).unwrap();
    if raw.starts_with(&[0x1f, 0x8b]) {
        use std::io::Read;
        let mut v = Vec::new();
        flate2::read::MultiGzDecoder::new(&raw[..])
            .read_to_end(&mut v)
            .unwrap();
        v
    } else {
        raw
    }
}

fn xsd_valid(path: &Path, version: &str) {
    if crate::util::have_xmllint() {
        if let Err(e) = crate::util::xmllint_validate(path, version) {
            panic!("{} is not XSD-valid:\n{e}", path.display());
        }
    }
}

#[test]
fn scene_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let input = crate::util::fixture("scenes/roof-tanks.gml");
    let out = dir.path().join("tanks-lod.gml");
    let rep = dir.path().join("report.json");
    let o = lod(
        &[
            input.as_os_str(),
            OsStr::new("--poi"),
            OsStr::new("430000,4581000,21"),
            OsStr::new("-o"),
            out.as_os_str(),
            OsStr::new("--report"),
            rep.as_os_str(),
        ],
        None,
    );
    ok(&o);
    xsd_valid(&out, "2.0");
    check_report_schema(&rep);
    let r = report(&rep);
    let levels = report_levels(&r);
    assert_eq!(levels["TANK_SKY"], 2);
    assert_eq!(levels["TANK_WALL"], 1);
    assert_eq!(levels["BASE_wall1"], 0, "east wall faces away from the POI");
    let model = read_file(&input).unwrap();
    check_output_against_input(&model, &out, &levels);
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(!text.contains("BASE_wall1"), "level-0 wall is dropped");
    assert_eq!(
        r["inputs"][0]["output"].as_str(),
        Some(out.display().to_string().as_str())
    );
    let t = &r["totals"];
    assert!(t["polygons_out"].as_u64().unwrap() < t["polygons_in"].as_u64().unwrap());
    // A second run refuses to overwrite without --overwrite, and leaves the file alone.
    let before = std::fs::read(&out).unwrap();
    let o = lod(
        &[
            input.as_os_str(),
            OsStr::new("--poi"),
            OsStr::new("430000,4581000,21"),
            OsStr::new("-o"),
            out.as_os_str(),
        ],
        None,
    );
    // Refused before any work: the inputs form one scene, so the whole run is refused.
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("output exists (use --overwrite)"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(std::fs::read(&out).unwrap(), before);
}

#[test]
fn same_seed_same_bytes_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let input = crate::util::fixture("synth-small.gml");
    let pois = crate::util::fixture("synth-small.pois.csv");
    let run = |name: &str, threads: usize, seed: &str| {
        let out = dir.path().join(name);
        let o = lod(
            &[
                input.as_os_str(),
                OsStr::new("--pois"),
                pois.as_os_str(),
                OsStr::new("--poi"),
                OsStr::new("430005,4581005,13.5"),
                OsStr::new("--seed"),
                OsStr::new(seed),
                OsStr::new("-o"),
                out.as_os_str(),
            ],
            Some(threads),
        );
        ok(&o);
        std::fs::read(out).unwrap()
    };
    let a = run("a.gml", 1, "3");
    let b = run("b.gml", 2, "3");
    let c = run("c.gml", 4, "3");
    assert!(a == b && b == c, "output depends on the thread count");
    let path = dir.path().join("a.gml");
    xsd_valid(&path, "2.0");
    let text = String::from_utf8(a).unwrap();
    assert!(text.contains("skylod_level"));
    // Another seed jitters the rays differently: the run still works and is valid.
    let d = run("d.gml", 2, "4");
    assert!(!d.is_empty());
}

/// Facade POIs on the Ingolstadt street: the centres of the largest wall polygons of
/// the first three buildings, 0.2 m in front of the wall.
pub(crate) fn ingolstadt_pois(model: &CityModel) -> Vec<String> {
    let mut out = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for a in &model.assets {
        if a.kind != AssetKind::Wall || out.len() >= 3 {
            continue;
        }
        let Some(b) = a.building.map(|b| model.root_building(b)) else {
            continue;
        };
        if seen.contains(&b) {
            continue;
        }
        let Some(p) = a
            .detail_polygons()
            .iter()
            .max_by(|x, y| x.area().total_cmp(&y.area()))
        else {
            continue;
        };
        let n = p.newell_normal().normalize_or_zero();
        if n.z.abs() > 0.2 || p.area() < 20.0 {
            continue;
        }
        let c = p.exterior().iter().fold(DVec3::ZERO, |s, q| s + *q) / p.exterior().len() as f64;
        let q = c + n * 0.2;
        seen.insert(b);
        out.push(format!("{},{},{},{},{},{}", q.x, q.y, q.z, n.x, n.y, n.z));
    }
    out
}

#[test]
fn ingolstadt_street_as_one_scene() {
    let Some(data) = crate::util::shared_data() else {
        return;
    };
    let inputs: Vec<PathBuf> = crate::util::citygml_files(&data.join("ingolstadt-lod3"));
    assert!(inputs.len() >= 50, "{} Ingolstadt files", inputs.len());
    let mut model = CityModel::default();
    for i in &inputs {
        model.merge(read_file(i).unwrap());
    }
    let pois = ingolstadt_pois(&model);
    assert_eq!(pois.len(), 3);
    let dir = tempfile::tempdir().unwrap();
    let outdir = dir.path().join("out");
    let rep = dir.path().join("report.json");
    let mut args: Vec<&OsStr> = inputs.iter().map(|p| p.as_os_str()).collect();
    for p in &pois {
        args.push(OsStr::new("--poi"));
        args.push(OsStr::new(p));
    }
    args.extend([
        OsStr::new("-o"),
        outdir.as_os_str(),
        OsStr::new("--report"),
        rep.as_os_str(),
    ]);
    let o = lod(&args, None);
    ok(&o);
    check_report_schema(&rep);
    let r = report(&rep);
    let levels = report_levels(&r);
    let t = &r["totals"];
    let kept = t["levels"][1].as_u64().unwrap() + t["levels"][2].as_u64().unwrap();
    assert!(kept > 0, "the POIs see something");
    assert!(t["polygons_out"].as_u64().unwrap() < t["polygons_in"].as_u64().unwrap());
    eprintln!(
        "Ingolstadt, 3 facade POIs: polygons {} -> {} ({:.2}%), levels {}",
        t["polygons_in"],
        t["polygons_out"],
        100.0 * t["polygon_fraction"].as_f64().unwrap(),
        t["levels"]
    );
    // One output per input that kept something; each consistent with the input and the report.
    let mut written = 0;
    for (i, entry) in r["inputs"].as_array().unwrap().iter().enumerate() {
        let Some(out) = entry["output"].as_str() else {
            continue;
        };
        written += 1;
        let single = read_file(&inputs[i]).unwrap();
        check_output_against_input(&single, Path::new(out), &levels);
    }
    assert_eq!(written, inputs.len());
}

#[test]
fn usage_and_input_errors() {
    let dir = tempfile::tempdir().unwrap();
    let a = crate::util::fixture("scenes/courtyard.gml");
    let b = crate::util::fixture("scenes/roof-tanks.gml");
    // No POI: usage error.
    let o = lod(
        &[
            a.as_os_str(),
            OsStr::new("-o"),
            dir.path().join("x.gml").as_os_str(),
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(2));
    // Several inputs and -o an existing file: usage error.
    let file = dir.path().join("file.gml");
    std::fs::write(&file, b"x").unwrap();
    let o = lod(
        &[
            a.as_os_str(),
            b.as_os_str(),
            OsStr::new("--poi"),
            OsStr::new("430015,4581015,11.5"),
            OsStr::new("-o"),
            file.as_os_str(),
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(2));
    // An unreadable input among good ones: exit 1, the good one is written.
    let missing = dir.path().join("missing.gml");
    let outdir = dir.path().join("o");
    let o = lod(
        &[
            a.as_os_str(),
            missing.as_os_str(),
            OsStr::new("--poi"),
            OsStr::new("430015,4581015,11.5"),
            OsStr::new("-o"),
            outdir.as_os_str(),
        ],
        None,
    );
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(outdir.join("courtyard.gml").is_file());
    assert!(!outdir.join("missing.gml").exists());
    assert!(String::from_utf8_lossy(&o.stderr).contains("missing.gml"));
    // Output equal to an input: refused, input unchanged.
    let copy = dir.path().join("in.gml");
    std::fs::copy(&a, &copy).unwrap();
    let before = std::fs::read(&copy).unwrap();
    let o = lod(
        &[
            copy.as_os_str(),
            OsStr::new("--poi"),
            OsStr::new("430015,4581015,11.5"),
            OsStr::new("-o"),
            copy.as_os_str(),
            OsStr::new("--overwrite"),
        ],
        None,
    );
    assert_ne!(o.status.code(), Some(0));
    assert_eq!(std::fs::read(&copy).unwrap(), before);
}

/// `Building` and `BuildingPart` elements (any prefix) in a written CityGML file.
fn buildings_in_output(path: &Path) -> u64 {
    let raw = std::fs::read(path).unwrap_or_default();
    let text = if raw.starts_with(&[0x1f, 0x8b]) {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut flate2::read::MultiGzDecoder::new(&raw[..]), &mut s)
            .unwrap();
        s
    } else {
        String::from_utf8_lossy(&raw).into_owned()
    };
    let mut n = 0;
    for (i, _) in text.match_indices("Building") {
        let before = text[..i].rfind('<').map(|lt| &text[lt + 1..i]);
        // A start tag: `<Building`, `<bldg:Building` (no `/`, no space in the prefix).
        let is_start = before.is_some_and(|p| {
            !p.contains(['/', ' ', '>', '\n']) && (p.is_empty() || p.ends_with(':'))
        });
        let rest = &text[i + "Building".len()..];
        let rest = rest.strip_prefix("Part").unwrap_or(rest);
        if is_start && rest.starts_with([' ', '>', '\n', '\t', '\r']) {
            n += 1;
        }
    }
    n
}

/// `skylod lod` on every shared file and fixture, with a POI at the middle of the model
/// (1.5 m above its lowest point) and one outside a corner: XSD-valid output for valid input,
/// no new unresolved references, a schema-valid report, never a crash.
#[test]
fn lod_on_every_file() {
    let inputs: Vec<PathBuf> = crate::util::all_inputs()
        .into_iter()
        .filter(|p| !p.ends_with("val3dity/csol1b.gml")) // plain GML, not CityGML
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let mut problems = Vec::new();
    let mut pairs = Vec::new();
    let mut reports = 0;
    let (mut unreadable, mut flat, mut empty) = (0, 0, 0);
    for (k, input) in inputs.iter().enumerate() {
        let name = input.file_name().unwrap().to_string_lossy().to_string();
        let out = dir.path().join(format!("{k}-{name}"));
        let rep = dir.path().join(format!("{k}.json"));
        let model = match read_file(input) {
            Ok(m) => m,
            Err(e) => {
                // An input the reader refuses: lod fails it (exit 1), names it, writes nothing.
                unreadable += 1;
                let o = lod(
                    &[
                        input.as_os_str(),
                        OsStr::new("--poi"),
                        OsStr::new("0,0,0"),
                        OsStr::new("-o"),
                        out.as_os_str(),
                    ],
                    None,
                );
                let err = String::from_utf8_lossy(&o.stderr);
                if o.status.code() != Some(1) || !err.contains(&name) || out.exists() {
                    problems.push(format!(
                        "{}: unreadable ({e}) but lod gave exit {:?}: {err}",
                        crate::util::short(input),
                        o.status.code()
                    ));
                }
                continue;
            }
        };
        let Some([x0, y0, z0, x1, y1, z1]) = model.bbox().to_array() else {
            empty += 1;
            continue;
        };
        let mid = format!("{},{},{}", (x0 + x1) / 2.0, (y0 + y1) / 2.0, z0 + 1.5);
        // 5 m beyond the corner, in the model's units (about 5e-5 degrees in a geographic CRS).
        let srs = model.files[0].srs_name.as_deref().unwrap_or("");
        let step = match skylod::model::crs::Crs::parse(srs).kind {
            skylod::model::crs::CrsKind::Geographic { .. } => 5e-5,
            _ => 5.0,
        };
        let corner = format!("{},{},{}", x0 - step, y0 - step, z0 + 1.5);
        if z1 - z0 <= 1e-3 {
            // No heights: refused before tracing (exit 2), nothing written.
            flat += 1;
            let o = lod(
                &[
                    input.as_os_str(),
                    OsStr::new("--poi"),
                    OsStr::new(&mid),
                    OsStr::new("-o"),
                    out.as_os_str(),
                ],
                None,
            );
            let err = String::from_utf8_lossy(&o.stderr);
            if o.status.code() != Some(2) || !err.contains("no heights") || out.exists() {
                problems.push(format!(
                    "{}: flat model but lod gave exit {:?}: {err}",
                    crate::util::short(input),
                    o.status.code()
                ));
            }
            continue;
        }
        let o = lod(
            &[
                input.as_os_str(),
                OsStr::new("--poi"),
                OsStr::new(&mid),
                OsStr::new("--poi"),
                OsStr::new(&corner),
                OsStr::new("--rays"),
                OsStr::new("2000"),
                OsStr::new("-o"),
                out.as_os_str(),
                OsStr::new("--report"),
                rep.as_os_str(),
            ],
            None,
        );
        if !o.status.success() {
            problems.push(format!(
                "{}: exit {:?}: {}",
                crate::util::short(input),
                o.status.code(),
                String::from_utf8_lossy(&o.stderr)
            ));
            continue;
        }
        if k % 10 == 0 {
            check_report_schema(&rep);
            reports += 1;
        }
        // The report counts the buildings and parts the file holds.
        let held = buildings_in_output(&out);
        let said = report(&rep)["totals"]["buildings_out"]
            .as_u64()
            .unwrap_or(u64::MAX);
        if held != said {
            problems.push(format!(
                "{}: the report says {said} buildings out, the file holds {held}",
                crate::util::short(input)
            ));
        }
        crate::util::check_refs(input, &out, &mut problems);
        pairs.push((
            input.clone(),
            out,
            model.files[0].version.as_str().to_string(),
        ));
    }
    crate::util::check_xsd(&pairs, &mut problems);
    eprintln!(
        "{} inputs, {} reports schema-checked; {unreadable} unreadable, {flat} flat and {empty} empty inputs refused",
        pairs.len(),
        reports
    );
    assert!(pairs.len() > 50, "only {} inputs ran", pairs.len());
    assert!(
        problems.is_empty(),
        "{} problem(s):\n{}",
        problems.len(),
        problems.join("\n")
    );
}

/// The README's first command, run as written (its outputs in `target/` redirected to a
/// temporary directory): it prints what the README shows, timings aside, writes both outputs
/// and keeps a level-2 asset.
#[test]
fn readme_first_command_prints_what_the_readme_shows() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let section = &readme[readme.find("## The two commands").expect("section")..];
    let block = |from: usize, fence: &str| {
        let start = section[from..].find(fence).unwrap() + from + fence.len();
        let end = section[start..].find("```").unwrap() + start;
        (section[start..end].to_string(), end + 3)
    };
    let (command, after) = block(0, "```sh\n");
    let (printed, _) = block(after, "```\n");
    let command = command.replace("\\\n", " ");
    let words: Vec<&str> = command.split_whitespace().collect();
    assert_eq!(
        &words[..4],
        ["cargo", "run", "--release", "--"],
        "{command}"
    );
    // The README writes into `target/` (git-ignored); the test writes into a temporary
    // directory and shows that directory as `target/` again in what the run printed.
    let dir = tempfile::tempdir().unwrap();
    let args: Vec<String> = words[4..]
        .iter()
        .map(|w| match w.strip_prefix("target/") {
            Some(name @ ("small-lod.gml" | "small-report.json")) => {
                dir.path().join(name).display().to_string()
            }
            _ => w.to_string(),
        })
        .collect();
    let o = Command::new(crate::util::BIN)
        .args(&args)
        .current_dir(root)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr)
        .replace(&format!("{}/", dir.path().display()), "target/");
    assert!(o.status.success(), "{err}");
    assert!(
        dir.path().join("small-lod.gml").is_file(),
        "the README's command does not write target/small-lod.gml: {command}"
    );
    let untimed = |t: &str| -> Vec<String> {
        t.lines()
            .map(|l| l.split("; read ").next().unwrap_or(l))
            .map(|l| match l.strip_suffix(" ms") {
                // "error bound: …, 71 ms": the bound check's time varies too
                Some(head) if l.starts_with("error bound:") => {
                    head.rsplit_once(", ").map_or(l, |(h, _)| h).to_string()
                }
                _ => l.to_string(),
            })
            .collect()
    };
    assert_eq!(
        untimed(&err),
        untimed(&printed),
        "README shows:\n{printed}\nthe run printed:\n{err}"
    );
    let r = report(&dir.path().join("small-report.json"));
    assert!(
        r["totals"]["levels"][2].as_u64().unwrap() > 0,
        "no level-2 asset"
    );
}
