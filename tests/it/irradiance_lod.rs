//! Annual irradiation through the LoD pipeline, on real LoD3 facades of the shared Ingolstadt
//! street with pvlib's bundled TMY3 year placed at Ingolstadt: `evaluate --weather` (the full
//! model's figure is `skylod irradiance`'s with the same bundle, the errors are the
//! differences; without `--weather` nothing changes) and `lod --max-irradiance-error` (the
//! written model, read back by `skylod irradiance`, within the bound at every facade point of
//! a building where the unbounded model is not).

use crate::bound::low_facade_pois;
use crate::irradiance::tmy3;
use crate::util::*;
use glam::DVec3;
use serde_json::Value;
use skylod::io::citygml::read_file;
use skylod::lod::poi::Poi;
use std::ffi::OsString;
use std::path::PathBuf;

/// One building of the street (the sun-hours bound's) and, with its low facade point, a
/// point 3 m in front of its south side.
fn building() -> Option<(PathBuf, Vec<Poi>)> {
    let Some(data) = shared_data() else {
        missing("../shared/data");
        return None;
    };
    let input = data.join("ingolstadt-lod3/4018115.xml.gz");
    let full = read_file(&input).unwrap_or_else(|e| panic!("{e}"));
    let bb = full.bbox();
    let street = Poi {
        id: "street".into(),
        position: DVec3::new(0.5 * (bb.min.x + bb.max.x), bb.min.y - 3.0, bb.min.z + 1.5),
        normal: None,
    };
    let pois = low_facade_pois(&full, 1)
        .into_iter()
        .chain([street])
        .collect();
    Some((input, pois))
}

/// `--poi` arguments for `pois`.
fn poi_args(pois: &[Poi]) -> Vec<OsString> {
    pois.iter()
        .flat_map(|p| {
            let n = p.normal.unwrap_or(DVec3::Z);
            let v = format!(
                "{},{},{},{},{},{}",
                p.position.x, p.position.y, p.position.z, n.x, n.y, n.z
            );
            [OsString::from("--poi"), OsString::from(v)]
        })
        .collect()
}

fn run_os(args: &[OsString]) -> std::process::Output {
    let a: Vec<&std::ffi::OsStr> = args.iter().map(|s| s.as_os_str()).collect();
    run(&a)
}

/// `args` as `OsString`s.
fn oss(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Vec<OsString> {
    args.iter().map(|a| a.as_ref().to_os_string()).collect()
}

const SITE: [&str; 4] = ["--lat", "48.7665", "--lon", "11.4258"];

#[test]
fn evaluate_weather_adds_irradiance_of_each_model() {
    let Some(tmy) = tmy3() else { return };
    let Some((input, pois)) = building() else {
        return;
    };
    let mut base = oss(&[
        &"evaluate",
        &input,
        &"--svf-rays",
        &"4000",
        &"--step",
        &"60",
    ]);
    base.extend(SITE.iter().map(OsString::from));
    base.extend(poi_args(&pois));
    let mut with = base.clone();
    with.extend(oss(&[&"--weather", &tmy, &"--json"]));
    let o = run_os(&with);
    assert!(o.status.success(), "{}", stderr(&o));
    check_stdout_schema("evaluate.schema.json", &o);
    let v = json(&o);
    assert_eq!(v["weather"]["weather"]["format"], "tmy3");
    assert_eq!(v["weather"]["sky"], "all-weather");
    // The full model's figure is `skylod irradiance`'s with the same bundle (4000 rays, seed 7).
    let mut irr = oss(&[
        &"irradiance",
        &input,
        &"--weather",
        &tmy,
        &"--rays",
        &"4000",
    ]);
    irr.extend(oss(&[&"--seed", &"7", &"--json"]));
    irr.extend(SITE.iter().map(OsString::from));
    irr.extend(poi_args(&pois));
    let o = run_os(&irr);
    assert!(o.status.success(), "{}", stderr(&o));
    let alone = json(&o);
    for (k, p) in v["pois"].as_array().unwrap().iter().enumerate() {
        let g = |m: &str| p[m]["global_kwh_m2"].as_f64().unwrap();
        let want = alone["pois"][k]["global_kwh_m2"].as_f64().unwrap();
        assert!(
            (g("full") - want).abs() < 1e-9,
            "{}: {} vs {want}",
            p["id"],
            g("full")
        );
        assert!(g("full") > 100.0, "{p}");
        for m in ["lod", "boxes"] {
            let abs = p[format!("{m}_irradiance_abs_error_kwh_m2")]
                .as_f64()
                .unwrap();
            let rel = p[format!("{m}_irradiance_error")].as_f64().unwrap();
            assert!((abs - (g(m) - g("full"))).abs() < 1e-9, "{m}: {p}");
            assert!((rel - abs.abs() / g("full")).abs() < 1e-12, "{m}: {p}");
        }
        eprintln!(
            "{}: full {:.1} kWh/m², LoD {:.1} ({:.3} %), boxes {:.1}",
            p["id"],
            g("full"),
            g("lod"),
            100.0 * p["lod_irradiance_error"].as_f64().unwrap(),
            g("boxes")
        );
    }
    // The table has the three columns; without --weather, neither the table nor the JSON
    // has any of it.
    let mut t = base.clone();
    t.extend(oss(&[&"--weather", &tmy]));
    let o = run_os(&t);
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(
        text.lines()
            .next()
            .unwrap()
            .ends_with("kWh/m2   irr abs   irr err"),
        "{text}"
    );
    assert_eq!(text.lines().count(), 1 + 3 * pois.len());
    let o = run_os(&base);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(
        text.lines().next().unwrap().ends_with("select ms"),
        "{text}"
    );
    assert!(!text.contains("kWh") && !stderr(&o).contains("irradiance"));
    let mut j = base.clone();
    j.push("--json".into());
    let plain = run_os(&j).stdout;
    let plain = String::from_utf8_lossy(&plain);
    assert!(!plain.contains("irradiance") && !plain.contains("weather") && !plain.contains("kwh"));
    // --sky and --albedo need --weather; the albedo is a reflectance.
    let mut bad = base.clone();
    bad.extend(oss(&[&"--albedo", &"0.5"]));
    assert_eq!(run_os(&bad).status.code(), Some(2));
    let mut bad = base;
    bad.extend(oss(&[&"--weather", &tmy, &"--albedo", &"1.5"]));
    assert_eq!(run_os(&bad).status.code(), Some(2));
}

/// `skylod irradiance --json` of `inputs` at the POIs of `pois_csv` (or `extra` region
/// flags), 20,000 rays with seed 1 (the bound's bundle with `lod`'s default seed), the
/// Greensboro TMY3 year at its own site.
fn irradiance_json(inputs: &[PathBuf], tmy: &std::path::Path, extra: &[&str]) -> Value {
    let mut a = oss(&[&"irradiance"]);
    a.extend(inputs.iter().map(|p| p.clone().into_os_string()));
    a.extend(oss(&[
        &"--weather",
        &tmy,
        &"--rays",
        &"20000",
        &"--seed",
        &"1",
        &"--json",
    ]));
    a.extend(GREENSBORO_SITE.iter().chain(extra).map(OsString::from));
    let o = run_os(&a);
    assert!(o.status.success(), "{}", stderr(&o));
    json(&o)
}

/// The weather's own site (the street placed in Greensboro: hours and sun agree).
const GREENSBORO_SITE: [&str; 4] = ["--lat", "36.1", "--lon", "-79.95"];

/// Global irradiation per POI id.
fn globals(v: &Value) -> Vec<(String, f64)> {
    (v["pois"].as_array().unwrap().iter())
        .map(|p| {
            let g = p["global_kwh_m2"].as_f64().unwrap();
            (p["id"].as_str().unwrap().to_string(), g)
        })
        .collect()
}

/// Relative error of `lod` against `full` per POI.
fn errors(full: &[(String, f64)], lod: &[(String, f64)]) -> Vec<f64> {
    assert_eq!(full.len(), lod.len());
    (full.iter().zip(lod))
        .map(|(f, l)| {
            assert_eq!(f.0, l.0);
            if f.1 == 0.0 {
                l.1.abs()
            } else {
                (l.1 - f.1).abs() / f.1
            }
        })
        .collect()
}

#[test]
fn lod_bounds_the_irradiation_error() {
    let Some(tmy) = tmy3() else { return };
    let Some(data) = shared_data() else {
        missing("../shared/data");
        return;
    };
    const E: f64 = 0.005;
    let inputs = citygml_files(&data.join("ingolstadt-lod3"));
    let dir = tempfile::tempdir().unwrap();
    // The facade points of building 4018115 every 3 m, written as a POI file.
    let v = irradiance_json(&inputs, &tmy, &["--facade", "4018115", "--spacing", "3"]);
    let mut csv = String::from("id,x,y,z,nx,ny,nz\n");
    for p in v["pois"].as_array().unwrap() {
        let (q, n) = (&p["poi"], &p["normal"]);
        let id = p["id"].as_str().unwrap().replace(':', "_");
        csv.push_str(&format!(
            "{id},{},{},{},{},{},{}\n",
            q[0], q[1], q[2], n[0], n[1], n[2]
        ));
    }
    let pois = dir.path().join("facade.csv");
    std::fs::write(&pois, csv).unwrap();
    let poi_flag = pois.display().to_string();
    let full = globals(&irradiance_json(&inputs, &tmy, &["--pois", &poi_flag]));
    assert!(full.len() > 50, "{} POIs", full.len());
    let lod = |name: &str, flags: &[&str]| -> (Vec<f64>, Option<Value>) {
        let out = dir.path().join(name);
        let rep = dir.path().join(format!("{name}.json"));
        let mut a = oss(&[&"lod"]);
        a.extend(inputs.iter().map(|p| p.clone().into_os_string()));
        a.extend(oss(&[&"--pois", &pois, &"-o", &out, &"--report", &rep]));
        a.extend(flags.iter().map(OsString::from));
        let o = run_os(&a);
        assert!(o.status.success(), "lod {flags:?}: {}", stderr(&o));
        let written = citygml_files(&out);
        let got = globals(&irradiance_json(&written, &tmy, &["--pois", &poi_flag]));
        check_json_schema("report.schema.json", &rep);
        let report: Value = serde_json::from_str(&std::fs::read_to_string(&rep).unwrap()).unwrap();
        (errors(&full, &got), report.get("bound").cloned())
    };
    // Without the bound some POI is over E (else the test proves nothing).
    let (free, _) = lod("free", &["--no-bound"]);
    let worst = free.iter().copied().fold(0.0, f64::max);
    eprintln!("unbounded: worst irradiation error {:.3} %", 100.0 * worst);
    assert!(worst > E, "no POI over {E} without the bound: {worst}");
    // Bounded on irradiance alone (SVF and sun hours left loose), with --weather.
    let w = tmy.display().to_string();
    let e = E.to_string();
    let mut flags = vec!["--weather", &w, "--max-irradiance-error", &e];
    flags.extend(["--max-svf-error", "1", "--max-sun-hours-error", "1"]);
    flags.extend(GREENSBORO_SITE);
    let (bounded, b) = lod("bounded", &flags);
    let b = b.expect("a bound section");
    assert_eq!(b["met"], Value::Bool(true));
    assert_eq!(b["max_irradiance_error"].as_f64(), Some(E));
    let promotions = b["promotions"].as_array().unwrap().len();
    let worst = bounded.iter().copied().fold(0.0, f64::max);
    eprintln!(
        "bounded: {promotions} promotion(s), worst {:.3} %",
        100.0 * worst
    );
    assert!(promotions > 0);
    // The written model read back: within E at every POI, and the bound's own figures are
    // skylod irradiance's on the full model (same bundle).
    for (k, (p, err)) in b["pois"]
        .as_array()
        .unwrap()
        .iter()
        .zip(&bounded)
        .enumerate()
    {
        assert!(*err <= E, "{}: {:.3} %", full[k].0, 100.0 * err);
        let f = p["irradiance_full_kwh_m2"].as_f64().unwrap();
        assert!(
            (f - full[k].1).abs() <= 1e-9 * f.max(1.0),
            "{}: {f} vs {}",
            full[k].0,
            full[k].1
        );
        assert!(p["irradiance_error"].as_f64().unwrap() <= E);
    }
}

#[test]
fn lod_irradiance_bound_needs_weather() {
    let o = run(&[
        os("lod"),
        os(&fixture("synth-small.gml")),
        os("--pois"),
        os(&fixture("synth-small.pois.csv")),
        os("-o"),
        os("/nonexistent/x.gml"),
        os("--max-irradiance-error"),
        os("0.01"),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("--max-irradiance-error needs --weather"),
        "{}",
        stderr(&o)
    );
}

/// The oracle of `--output-attributes` (tests/oracle/surface_attributes.py) on `out`.
fn surface_oracle(out: &std::path::Path, rows: &std::path::Path) -> Value {
    let o = std::process::Command::new("python3")
        .arg(manifest_dir().join("tests/oracle/surface_attributes.py"))
        .arg(out)
        .arg(rows)
        .arg("0.05")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn output_attributes_write_the_mean_of_each_surface() {
    let Some(tmy) = tmy3() else { return };
    let Some(data) = shared_data() else {
        missing("../shared/data");
        return;
    };
    if !python_has("numpy", "pip install numpy") {
        return;
    }
    let input = data.join("ingolstadt-lod3/4018115.xml.gz");
    let dir = tempfile::tempdir().unwrap();
    let mut outs = Vec::new();
    for name in ["attr.gml", "attr.city.json"] {
        let out = dir.path().join(name);
        let rows = dir.path().join(format!("{name}.rows.json"));
        let mut a = oss(&[
            &"irradiance",
            &input,
            &"--facade",
            &"4018115",
            &"--spacing",
            &"3",
        ]);
        a.extend(oss(&[&"--weather", &tmy, &"--rays", &"2000", &"--json"]));
        a.extend(oss(&[&"--output-attributes", &"-o", &out]));
        a.extend(GREENSBORO_SITE.iter().map(OsString::from));
        let o = run_os(&a);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(stderr(&o).contains("surface(s) given skylodAnnualIrradiation"));
        std::fs::write(&rows, &o.stdout).unwrap();
        let n_rows = json(&o)["pois"].as_array().unwrap().len();
        let v = surface_oracle(&out, &rows);
        eprintln!("{name}: {v}");
        assert_eq!(v["held"].as_u64(), Some(n_rows as u64), "{v}");
        assert!(v["surfaces"].as_u64().unwrap() > 10, "{v}");
        outs.push((out, v));
    }
    // CityGML: every surface holding POIs has the mean of their rows, none other has one;
    // valid against the CityGML 2.0 XSDs, and the rest of the document unchanged.
    let (gml, v) = &outs[0];
    assert_eq!(
        (v["missing"].as_u64(), v["stray"].as_u64()),
        (Some(0), Some(0)),
        "{v}"
    );
    assert!(v["max_rel"].as_f64().unwrap() < 1e-9, "{v}");
    // (the Ingolstadt files' own ids are not valid xs:IDs: the XSD check is on the synthetic
    // district below)
    let text = std::fs::read_to_string(gml).unwrap();
    let inserted = regex_free_strip(&text);
    let mut source = String::new();
    std::io::Read::read_to_string(
        &mut flate2::read::GzDecoder::new(std::fs::File::open(&input).unwrap()),
        &mut source,
    )
    .unwrap();
    assert_eq!(inserted, source, "only the attributes were added");
    // CityJSON: the same values on the semantic surfaces (its millimetre vertices cannot
    // tell the Ingolstadt data's coincident duplicate walls apart, so not surface by surface).
    let (_, j) = &outs[1];
    assert_eq!(j["values"], v["values"]);
    // XSD-valid: the synthetic district's first building, every wall given the attribute.
    if have_xmllint() {
        let synth = dir.path().join("synth.gml");
        let mut a = oss(&[
            &"irradiance",
            &fixture("synth-small.gml"),
            &"--facade",
            &"B0_0_0",
        ]);
        a.extend(oss(&[
            &"--weather",
            &tmy,
            &"--rays",
            &"500",
            &"--output-attributes",
            &"-o",
        ]));
        a.push(synth.clone().into_os_string());
        a.extend(GREENSBORO_SITE.iter().map(OsString::from));
        let o = run_os(&a);
        assert!(o.status.success(), "{}", stderr(&o));
        xmllint_validate(&synth, "2.0").unwrap_or_else(|e| panic!("{e}"));
        let text = std::fs::read_to_string(&synth).unwrap();
        assert!(text.matches("skylodAnnualIrradiation").count() >= 3);
    }
    // Refused: without a region, or to a format that holds no attributes.
    let mut a = oss(&[
        &"irradiance",
        &input,
        &"--poi",
        &"678065,5403812,416",
        &"--weather",
        &tmy,
    ]);
    a.extend(oss(&[
        &"--output-attributes",
        &"-o",
        &dir.path().join("x.gml"),
    ]));
    let o = run_os(&a);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("needs --facade or --region"),
        "{}",
        stderr(&o)
    );
    let mut a = oss(&[
        &"irradiance",
        &input,
        &"--facade",
        &"4018115",
        &"--weather",
        &tmy,
    ]);
    a.extend(oss(&[
        &"--output-attributes",
        &"-o",
        &dir.path().join("x.obj"),
    ]));
    assert_eq!(run_os(&a).status.code(), Some(2));
}

/// `text` without the generic attributes `--output-attributes` adds.
fn regex_free_strip(text: &str) -> String {
    let open = "<gen:doubleAttribute xmlns:gen=\"http://www.opengis.net/citygml/generics/2.0\" name=\"skylodAnnualIrradiation\">";
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(k) = rest.find(open) {
        out.push_str(&rest[..k]);
        let end =
            rest[k..].find("</gen:doubleAttribute>").unwrap() + "</gen:doubleAttribute>".len();
        rest = &rest[k + end..];
    }
    out.push_str(rest);
    out
}
