//! `skylod irradiance` against independent oracles (`tests/oracle/irradiance_pvlib.py`, pvlib
//! and its bundled TMY3 file of Greensboro, NC): unobstructed horizontal and vertical planes
//! against pvlib's `get_total_irradiance` (Perez and isotropic), the floor of an H = W street
//! canyon against the closed form, the same weather as EPW and TMY3, the site rules, the
//! `--hourly` and `--csv` outputs. The issue asks for 1 % (horizontal), 3 % (walls), 2 %
//! (canyon) and 0.5 % (EPW vs TMY3); measured: 0.02 %, 0.06 %, 0.4 % and identical, so the
//! tests hold 0.2 %, 0.5 %, 1 % and 1e-9.

use crate::util::*;
use serde_json::{json, Value};
use skylod::model::synth::{boxes_citygml, BoxBuilding};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

const ORIGIN: [f64; 3] = [430000.0, 4581000.0, 10.0];
const GREENSBORO: (f64, f64) = (36.1, -79.95);

/// pvlib's bundled TMY3 file, or `None` (a skip, a failure under CI) without pvlib.
pub(crate) fn tmy3() -> Option<PathBuf> {
    if !python_has("pvlib", "pip install pvlib") {
        return None;
    }
    let o = Command::new("python3")
        .args([
            "-c",
            "import pvlib, os; print(os.path.dirname(pvlib.__file__))",
        ])
        .output()
        .ok()?;
    let p = PathBuf::from(String::from_utf8_lossy(&o.stdout).trim()).join("data/723170TYA.CSV");
    assert!(p.is_file(), "pvlib has no {}", p.display());
    Some(p)
}

fn oracle(req: &Value) -> Value {
    let script = manifest_dir().join("tests/oracle/irradiance_pvlib.py");
    let mut child = Command::new("python3")
        .arg(script)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(req.to_string().as_bytes())
        .unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

/// A north-south canyon `w` wide between two 400 m long buildings `h` high.
fn canyon(dir: &Path, w: f64, h: f64) -> PathBuf {
    let b = |id: &str, x0: f64, x1: f64| BoxBuilding {
        id: id.into(),
        min: [x0, -200.0],
        max: [x1, 200.0],
        height: h,
        installations: vec![],
    };
    let p = dir.join("canyon.gml");
    let boxes = [
        b("W", -w / 2.0 - 15.0, -w / 2.0),
        b("E", w / 2.0, w / 2.0 + 15.0),
    ];
    std::fs::write(&p, boxes_citygml(&boxes, ORIGIN)).unwrap();
    p
}

fn poi(id: &str, local: [f64; 3], n: [f64; 3]) -> String {
    format!(
        "{id},{},{},{},{},{},{}\n",
        ORIGIN[0] + local[0],
        ORIGIN[1] + local[1],
        ORIGIN[2] + local[2],
        n[0],
        n[1],
        n[2]
    )
}

fn irradiance(args: &[&std::ffi::OsStr]) -> Value {
    let mut a = vec![os("irradiance")];
    a.extend_from_slice(args);
    json(&run(&a))
}

fn by_id<'a>(v: &'a Value, id: &str) -> &'a Value {
    v["pois"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["id"] == id)
        .unwrap()
}

fn close(what: &str, got: f64, want: f64, tol: f64) {
    let rel = (got - want).abs() / want.abs().max(1e-9);
    assert!(
        rel <= tol,
        "{what}: skylod {got:.2} vs oracle {want:.2} ({:.2} %)",
        rel * 100.0
    );
}

#[test]
fn unobstructed_planes_match_pvlib() {
    let Some(tmy) = tmy3() else { return };
    let dir = tempfile::tempdir().unwrap();
    let gml = canyon(dir.path(), 20.0, 20.0);
    // 200 m above the canyon: nothing above any plane. (pvlib azimuth, normal)
    let planes = [
        ("N", 0.0, [0.0, 1.0, 0.0]),
        ("E", 90.0, [1.0, 0.0, 0.0]),
        ("S", 180.0, [0.0, -1.0, 0.0]),
        ("W", 270.0, [-1.0, 0.0, 0.0]),
    ];
    let mut csv = String::from("id,x,y,z,nx,ny,nz\n");
    csv.push_str(&poi("up", [0.0, 0.0, 200.0], [0.0, 0.0, 1.0]));
    for (id, _, n) in planes {
        csv.push_str(&poi(id, [0.0, 0.0, 200.0], n));
    }
    let pois = dir.path().join("pois.csv");
    std::fs::write(&pois, csv).unwrap();
    let req = json!({"tmy3": tmy, "lat": GREENSBORO.0, "lon": GREENSBORO.1, "albedo": 0.2,
        "planes": planes.iter().map(|p| json!({"tilt": 90, "azimuth": p.1})).collect::<Vec<_>>()});
    let want = oracle(&req);
    for sky in ["all-weather", "perez", "isotropic"] {
        let (lat, lon) = (GREENSBORO.0.to_string(), GREENSBORO.1.to_string());
        let got = irradiance(&[
            os(&gml),
            os("--pois"),
            os(&pois),
            os("--weather"),
            os(&tmy),
            os("--sky"),
            os(sky),
            os("--lat"),
            os(&lat),
            os("--lon"),
            os(&lon),
            os("--json"),
        ]);
        check_stdout_schema(
            "irradiance.schema.json",
            &run(&[
                os("irradiance"),
                os(&gml),
                os("--pois"),
                os(&pois),
                os("--weather"),
                os(&tmy),
                os("--lat"),
                os(&lat),
                os("--lon"),
                os(&lon),
                os("--json"),
                os("--rays"),
                os("500"),
            ]),
        );
        let up = by_id(&got, "up");
        let h = want["horizontal_beam_plus_dhi"].as_f64().unwrap();
        close(
            &format!("{sky} horizontal"),
            up["global_kwh_m2"].as_f64().unwrap(),
            h,
            0.002,
        );
        for (id, az, _) in planes {
            // pvlib has no all-weather sky: its direct and reflected parts are Perez's
            let all_weather = sky == "all-weather";
            let w = &want[format!("90/{az}/{}", if all_weather { "perez" } else { sky })];
            let g = by_id(&got, id);
            let parts: &[&str] = if all_weather {
                &["direct", "reflected"]
            } else {
                &["global", "direct", "diffuse", "reflected"]
            };
            for &part in parts {
                let key = format!("{part}_kwh_m2");
                let what = format!("{sky} wall {id} {part}");
                close(
                    &what,
                    g[&key].as_f64().unwrap(),
                    w[part].as_f64().unwrap(),
                    0.005,
                );
            }
        }
    }
}

#[test]
fn canyon_floor_matches_the_closed_form_and_epw_equals_tmy3() {
    let Some(tmy) = tmy3() else { return };
    let dir = tempfile::tempdir().unwrap();
    let gml = canyon(dir.path(), 20.0, 20.0);
    let want = oracle(
        &json!({"tmy3": tmy, "lat": GREENSBORO.0, "lon": GREENSBORO.1,
        "albedo": 0.0, "planes": [], "canyon": {"w": 20.0, "h": 20.0}}),
    );
    let c = &want["canyon"];
    let p = poi("floor", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
    let p = p.trim().trim_start_matches("floor,");
    let (lat, lon) = (GREENSBORO.0.to_string(), GREENSBORO.1.to_string());
    let run_with = |weather: &Path| {
        irradiance(&[
            os(&gml),
            os("--poi"),
            os(p),
            os("--weather"),
            os(weather),
            os("--sky"),
            os("isotropic"),
            os("--albedo"),
            os("0"),
            os("--lat"),
            os(&lat),
            os("--lon"),
            os(&lon),
            os("--json"),
        ])
    };
    let got = run_with(&tmy);
    let f = &got["pois"][0];
    close(
        "canyon direct",
        f["direct_kwh_m2"].as_f64().unwrap(),
        c["direct"].as_f64().unwrap(),
        0.01,
    );
    close(
        "canyon diffuse",
        f["diffuse_kwh_m2"].as_f64().unwrap(),
        c["diffuse"].as_f64().unwrap(),
        0.01,
    );
    assert_eq!(f["reflected_kwh_m2"].as_f64(), Some(0.0));
    // The same hours written as an EPW (by Python's csv, not by skylod) give the same result.
    let epw = dir.path().join("greensboro.epw");
    let script = r#"
import csv, sys
src, dst = sys.argv[1], sys.argv[2]
rows = list(csv.reader(open(src, newline="")))
st, head, data = rows[0], rows[1], rows[2:]
col = {h.split(" (")[0]: i for i, h in enumerate(head)}
with open(dst, "w", newline="") as f:
    f.write(f"LOCATION,{st[1]},{st[2]},USA,TMY3,{st[0]},{st[4]},{st[5]},{st[3]},{st[6]}\n")
    for l in ["DESIGN CONDITIONS,0", "TYPICAL/EXTREME PERIODS,0", "GROUND TEMPERATURES,0",
              "HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0", "COMMENTS 1,from TMY3", "COMMENTS 2,",
              "DATA PERIODS,1,1,Data,Sunday, 1/ 1,12/31"]:
        f.write(l + "\n")
    for r in data:
        m, d, y = r[col["Date"]].split("/")
        h = int(r[col["Time"]].split(":")[0])
        vals = [y, str(int(m)), str(int(d)), str(h), "60", "?", "10", "5", "70", "101325",
                "0", "0", "300", r[col["GHI"]], r[col["DNI"]], r[col["DHI"]]] + ["0"] * 19
        f.write(",".join(vals) + "\n")
"#;
    let o = Command::new("python3")
        .args(["-c", script])
        .arg(&tmy)
        .arg(&epw)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let from_epw = run_with(&epw);
    assert_eq!(from_epw["weather"]["format"], "epw");
    for k in ["global_kwh_m2", "direct_kwh_m2", "diffuse_kwh_m2"] {
        let (a, b) = (
            f[k].as_f64().unwrap(),
            from_epw["pois"][0][k].as_f64().unwrap(),
        );
        close(&format!("EPW vs TMY3 {k}"), b, a, 1e-9);
    }
}

#[test]
fn site_rules_hourly_and_csv() {
    let Some(tmy) = tmy3() else { return };
    let dir = tempfile::tempdir().unwrap();
    // A model in Barcelona (EPSG:25831), the weather of North Carolina: refused, exit 2.
    let (bcn, bcn_pois) = (fixture("synth-small.gml"), fixture("synth-small.pois.csv"));
    let o = run(&[
        os("irradiance"),
        os(&bcn),
        os("--pois"),
        os(&bcn_pois),
        os("--weather"),
        os(&tmy),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("6871 km from the weather station") && e.contains("--lat/--lon"),
        "{e}"
    );
    // A model with no CRS takes the station's site, and says so.
    let gml = canyon(dir.path(), 20.0, 20.0);
    let p = poi("a", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
    let p = p.trim().trim_start_matches("a,");
    let o = run(&[
        os("irradiance"),
        os(&gml),
        os("--poi"),
        os(p),
        os("--weather"),
        os(&tmy),
        os("--rays"),
        os("500"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("site of the weather station \"GREENSBORO"),
        "{}",
        stderr(&o)
    );
    // --lat/--lon say where; --hourly holds every hour, summing to the annual figure.
    let hourly = dir.path().join("hourly.csv");
    let args = [
        os(&gml),
        os("--poi"),
        os(p),
        os("--poi"),
        os(p),
        os("--weather"),
        os(&tmy),
        os("--lat"),
        os("36.1"),
        os("--lon"),
        os("-79.95"),
        os("--rays"),
        os("2000"),
    ];
    let mut a = args.to_vec();
    a.extend([os("--json"), os("--hourly"), os(&hourly)]);
    let v = irradiance(&a);
    let text = std::fs::read_to_string(&hourly).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("time_utc,poi-1,poi-2"));
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 8760);
    assert!(
        rows[12].starts_with("1988-01-01T17:30:00Z,"),
        "{}",
        rows[12]
    );
    let sum: f64 = rows
        .iter()
        .map(|r| r.split(',').nth(1).unwrap().parse::<f64>().unwrap())
        .sum();
    close(
        "hourly sum",
        sum / 1000.0,
        v["pois"][0]["global_kwh_m2"].as_f64().unwrap(),
        1e-4,
    );
    // The hourly file is not overwritten without --overwrite.
    let o = run(&[&[os("irradiance")][..], &a].concat());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    // CSV: one row per POI with the JSON's figures.
    let mut a = args.to_vec();
    a.push(os("--csv"));
    let mut cmd = vec![os("irradiance")];
    cmd.extend(a);
    let o = run(&cmd);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let mut r = csv::Reader::from_reader(&o.stdout[..]);
    let recs: Vec<csv::StringRecord> = r.records().map(|x| x.unwrap()).collect();
    assert_eq!(recs.len(), 2);
    let g: f64 = recs[0][4].parse().unwrap();
    close(
        "csv global",
        g,
        v["pois"][0]["global_kwh_m2"].as_f64().unwrap(),
        1e-4,
    );
}

/// Points of the shared Ingolstadt street (all 53 tiles as one scene) against Radiance's
/// daylight coefficients (tests/oracle/irradiance_radiance.py: gendaymtx's Perez all-weather
/// sky on 2 305 patches, rcontrib, dctimestep on the full model's OBJ files), with pvlib's
/// Greensboro year at its own site and no reflection (`--albedo 0`, Radiance's surfaces
/// black, ground 0): obstructed facade points on every side (`p10` under its neighbours, SVF
/// 0.30; `p17` north-north-west, mostly diffuse), large walls of five buildings, four roofs
/// (pitched south, east and north, the last under a neighbour, and flat) and two street
/// points at 1.6 m. Every point: global within 2 %, direct and diffuse each
/// within 3 % (or 1 kWh/m² for a part smaller than 33). The oracle is a Monte Carlo estimate
/// (65,536 hemisphere samples per point): in five runs Radiance put `p17`'s direct at 60.2,
/// 60.7, 61.0, 61.0 and 61.3 kWh/m² (skylod: 61.4, deterministic).
#[test]
fn ingolstadt_street_matches_radiance() {
    if !python_has("pyradiance", "pip install pyradiance") {
        return;
    }
    let Some(tmy) = tmy3() else { return };
    let Some(data) = shared_data() else {
        missing("../shared/data");
        return;
    };
    let tiles = citygml_files(&data.join("ingolstadt-lod3"));
    assert!(tiles.len() >= 50, "Ingolstadt tiles missing");
    let dir = tempfile::tempdir().unwrap();
    let objs = dir.path().join("full");
    std::fs::create_dir(&objs).unwrap();
    let mut obj_files = Vec::new();
    for t in &tiles {
        let name =
            skylod::export::Format::Obj.output_name(&t.file_name().unwrap().to_string_lossy());
        let out = objs.join(name);
        let o = run(&[os("convert"), os(t), os("-o"), os(&out)]);
        assert!(o.status.success(), "{}", stderr(&o));
        obj_files.push(out);
    }
    let pois = dir.path().join("street.csv");
    std::fs::write(
        &pois,
        "id,x,y,z,nx,ny,nz\n\
         p10,678059.6655187339,5403839.330360163,419.223,-0.9196253204468902,-0.39279672859248016,0\n\
         p17,678063.2096485974,5403842.637248613,419.222998888,-0.4008275642240393,0.9161535151189956,0\n\
         readme,678095,5403890,418,0,-1,0\n\
         w4018257,678184.488,5403910.026,421.429,0.3969,-0.9178,0\n\
         w4018156,678146.706,5403898.825,421.289,0.2584,-0.9660,0\n\
         w4018149b,678086.159,5403875.438,421.434,0.9321,0.3623,0\n\
         w4018142,678150.193,5403776.433,419.363,-0.8357,-0.5492,0\n\
         w4018215,678111.129,5403764.510,420.585,-0.8520,-0.5236,0\n\
         r4018156,678148.511,5403901.079,428.939,0.1974,-0.7379,0.6454\n\
         r4018149b,678083.499,5403871.120,431.831,0.5633,0.2241,0.7953\n\
         r4018133,678109.656,5403816.015,422.169,-0.4231,0.6914,0.5856\n\
         r4018215,678119.501,5403761.658,429.180,0,0,1\n\
         s1,678095,5403885,418,0,0,1\n\
         s2,678092,5403860,418,0,0,1\n",
    )
    .unwrap();
    let mut a = vec![os("irradiance")];
    a.extend(tiles.iter().map(os));
    let (lat, lon) = (GREENSBORO.0.to_string(), GREENSBORO.1.to_string());
    a.extend([os("--pois"), os(&pois), os("--weather"), os(&tmy)]);
    a.extend([os("--albedo"), os("0")]);
    a.extend([os("--lat"), os(&lat), os("--lon"), os(&lon), os("--json")]);
    let ours = json(&run(&a));
    let o = Command::new("python3")
        .arg(manifest_dir().join("tests/oracle/irradiance_radiance.py"))
        .arg(&tmy)
        .arg(&pois)
        .args(&obj_files)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rad: Value = serde_json::from_slice(&o.stdout).unwrap();
    let ids: Vec<String> = ours["pois"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["id"].as_str().unwrap().to_string())
        .collect();
    assert_eq!(ids.len(), 14);
    for id in &ids {
        let (s, r) = (by_id(&ours, id), &rad[id.as_str()]);
        let f = |v: &Value, k: &str| v[format!("{k}_kwh_m2")].as_f64().unwrap();
        eprintln!(
            "{id}: SVF {:.3}; skylod global {:.1} direct {:.1} diffuse {:.1}; Radiance global {:.1} direct {:.1} diffuse {:.1} kWh/m²",
            s["svf"].as_f64().unwrap(),
            f(s, "global"),
            f(s, "direct"),
            f(s, "diffuse"),
            f(r, "global"),
            f(r, "direct"),
            f(r, "diffuse")
        );
        assert!(s["svf"].as_f64().unwrap() > 0.1, "{id} sees no sky");
        close(
            &format!("{id} global"),
            f(s, "global"),
            f(r, "global"),
            0.02,
        );
        for part in ["direct", "diffuse"] {
            let (a, b) = (f(s, part), f(r, part));
            if b < 33.0 {
                assert!((a - b).abs() <= 1.0, "{id} {part}: {a:.2} vs {b:.2}");
            } else {
                close(&format!("{id} {part}"), a, b, 0.03);
            }
        }
    }
    assert!(by_id(&ours, "p10")["svf"].as_f64().unwrap() < 0.6);
}
