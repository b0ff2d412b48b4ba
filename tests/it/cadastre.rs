//! `irradiance --surfaces roof,wall --table --points`: a solar cadastre of real files. The
//! surfaces and their areas against an independent reader (tests/oracle/cadastre_areas.py:
//! Python's XML parser, numpy, pyproj for a model in latitude and longitude), each surface's
//! row against its own points, and the refusals.

use crate::irradiance::tmy3;
use crate::util::*;
use std::collections::HashMap;
use std::ffi::{OsStr, OsString};
use std::path::Path;
use std::process::Command;

/// A CSV file as rows of column → value.
fn rows(path: &Path) -> Vec<HashMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let head: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    lines
        .map(|l| {
            head.iter()
                .cloned()
                .zip(l.split(',').map(str::to_string))
                .collect()
        })
        .collect()
}

/// `irradiance INPUT --weather TMY` at Greensboro's site.
fn irradiance_args(input: &Path, tmy: &Path) -> Vec<OsString> {
    [
        "irradiance".as_ref(),
        input.as_os_str(),
        "--weather".as_ref(),
        tmy.as_os_str(),
    ]
    .into_iter()
    .map(OsStr::to_os_string)
    .chain(["--lat", "36.1", "--lon", "-79.95"].map(OsString::from))
    .collect()
}

fn num(r: &HashMap<String, String>, k: &str) -> f64 {
    r[k].parse()
        .unwrap_or_else(|_| panic!("{k}: {:?} is not a number", r[k]))
}

/// The LoD2 FZK house and the Berlin building (thematic surfaces with gml:ids) and a PLATEAU
/// tile (LoD1 bodies in latitude and longitude, EPSG:6697, split into roof and wall faces):
/// every surface the oracle finds is a row, with its area within 1 % (measured: 0.001 %,
/// 0 %, 0.05 % — UTM against skylod's local frame); each row's points, mean, least and
/// greatest are those of its rows in `--points`, and so are its `--monthly` means; each
/// point's months sum to its year; the building's roof total is Σ mean × area of its roofs.
#[test]
fn surface_tables_match_their_polygons_and_points() {
    if !python_has("numpy", "pip install numpy") || !python_has("pyproj", "pip install pyproj") {
        return;
    }
    let Some(tmy) = tmy3() else { return };
    let Some(data) = shared_data() else { return };
    let dir = tempfile::tempdir().unwrap();
    let (table, points) = (dir.path().join("t.csv"), dir.path().join("p.csv"));
    let mut compared = 0;
    for (file, epsg) in [
        ("kit-fzk-haus/citygml2/fzk_haus_lod2_v2.gml", None),
        ("berlin/Berlin_Moabit_1Bldg_v2.gml", None),
        (
            "plateau/yokosuka/52397519_bldg_6697_op.gml",
            Some(("6697", "32654")),
        ),
    ] {
        let src = data.join(file);
        let o = run(&[
            os("irradiance"),
            os(&src),
            os("--surfaces"),
            os("roof,wall"),
            os("--weather"),
            os(&tmy),
            os("--lat"),
            os("36.1"),
            os("--lon"),
            os("-79.95"),
            os("--rays"),
            os("500"),
            os("--table"),
            os(&table),
            os("--points"),
            os(&points),
            os("--threshold"),
            os("900"),
            os("--monthly"),
            os("--overwrite"),
        ]);
        assert!(o.status.success(), "{file}: {}", stderr(&o));
        assert!(
            o.stdout.is_empty(),
            "{file}: the cadastre prints no POI table"
        );
        let mut cmd = Command::new("python3");
        cmd.arg(manifest_dir().join("tests/oracle/cadastre_areas.py"))
            .arg(&src);
        if let Some((from, to)) = epsg {
            cmd.args([from, to]);
        }
        let oracle = cmd.output().unwrap();
        assert!(oracle.status.success(), "{}", stderr(&oracle));
        let want: HashMap<String, f64> = serde_json::from_slice(&oracle.stdout).unwrap();
        assert!(!want.is_empty(), "{file}: the oracle found no surface");
        let table_rows = rows(&table);
        let by_name: HashMap<&str, &HashMap<String, String>> = table_rows
            .iter()
            .map(|r| (r["surface_id"].as_str(), r))
            .collect();
        for (name, area) in &want {
            let r = by_name
                .get(name.as_str())
                .unwrap_or_else(|| panic!("{file}: no row for {name}"));
            let got = num(r, "area_m2");
            assert!(
                (got - area).abs() <= 0.01 * area,
                "{file} {name}: area {got} vs {area}"
            );
            compared += 1;
        }
        // each row from its points; a point's months sum to its year, a row's months are
        // its points' means
        const MONTHS: [&str; 12] = [
            "jan", "feb", "mar", "apr", "may", "jun", "jul", "aug", "sep", "oct", "nov", "dec",
        ];
        let month = |r: &HashMap<String, String>, m: &str| num(r, &format!("{m}_kwh_m2"));
        let mut of: HashMap<String, Vec<f64>> = HashMap::new();
        let mut month_sums: HashMap<String, [f64; 12]> = HashMap::new();
        for p in rows(&points) {
            let year: f64 = MONTHS.iter().map(|m| month(&p, m)).sum();
            assert!((year - num(&p, "global_kwh_m2")).abs() < 0.01, "{p:?}");
            let e = month_sums.entry(p["surface_id"].clone()).or_default();
            for (k, m) in MONTHS.iter().enumerate() {
                e[k] += month(&p, m);
            }
            of.entry(p["surface_id"].clone())
                .or_default()
                .push(num(&p, "global_kwh_m2"));
        }
        let mut roofs: HashMap<String, f64> = HashMap::new();
        for r in &table_rows {
            let v = of.remove(&r["surface_id"]).unwrap_or_default();
            assert_eq!(num(r, "points") as usize, v.len(), "{file}: {r:?}");
            if v.is_empty() {
                continue;
            }
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            let min = v.iter().copied().fold(f64::INFINITY, f64::min);
            let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            for (k, want) in [
                ("mean_kwh_m2", mean),
                ("min_kwh_m2", min),
                ("max_kwh_m2", max),
            ] {
                assert!(
                    (num(r, k) - want).abs() < 2e-3,
                    "{file} {k}: {r:?} vs {want}"
                );
            }
            let sums = month_sums[&r["surface_id"]];
            for (k, m) in MONTHS.iter().enumerate() {
                let want = sums[k] / v.len() as f64;
                assert!((month(r, m) - want).abs() < 2e-3, "{file} {m}: {r:?}");
            }
            let share = v.iter().filter(|&&g| g >= 900.0).count() as f64 / v.len() as f64;
            let above = num(r, "area_above_m2");
            assert!((above - share * num(r, "area_m2")).abs() < 2e-3, "{r:?}");
            if r["kind"] == "roof" {
                *roofs.entry(r["building_id"].clone()).or_default() +=
                    num(r, "mean_kwh_m2") * num(r, "area_m2");
            }
        }
        assert!(of.is_empty(), "{file}: points of no row: {:?}", of.keys());
        for r in &table_rows {
            if let Some(total) = roofs.get(&r["building_id"]) {
                // from rounded means and areas
                assert!((num(r, "building_roof_kwh") - total).abs() < 1.0 + 1e-4 * total);
            }
        }
    }
    assert!(compared >= 6 + 2 + 20, "{compared}");
}

/// A model without roofs or walls is refused with what is missing; `--table` without
/// `--surfaces` is a usage error; a weather file short of a year is refused naming its line;
/// nothing is written in any case.
#[test]
fn surfaces_refuse_what_they_cannot_do() {
    let Some(tmy) = tmy3() else { return };
    let Some(data) = shared_data() else { return };
    let dir = tempfile::tempdir().unwrap();
    let table = dir.path().join("t.csv");
    let base = |input: &Path| {
        let mut a = irradiance_args(input, &tmy);
        a.extend(["--table".into(), table.clone().into_os_string()]);
        a
    };
    let mut a = base(&data.join("val3dity/csol1.gml"));
    a.extend(["--surfaces".into(), "roof,wall".into()]);
    let args: Vec<&std::ffi::OsStr> = a.iter().map(|s| s.as_os_str()).collect();
    let o = run(&args);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("no roof or wall surface"),
        "{}",
        stderr(&o)
    );
    let mut a = base(&data.join("berlin/Berlin_Moabit_1Bldg_v2.gml"));
    a.extend(["--poi".into(), "0,0,0".into()]);
    let args: Vec<&std::ffi::OsStr> = a.iter().map(|s| s.as_os_str()).collect();
    let o = run(&args);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--surfaces"), "{}", stderr(&o));
    // a cadastre is annual: a weather file short of a year is refused at its last line
    let short = dir.path().join("short.csv");
    let text = std::fs::read_to_string(&tmy).unwrap();
    let kept: Vec<&str> = text.lines().take(2 + 8000).collect();
    std::fs::write(&short, kept.join("\n") + "\n").unwrap();
    let mut a = irradiance_args(&data.join("berlin/Berlin_Moabit_1Bldg_v2.gml"), &short);
    a.extend([
        "--surfaces".into(),
        "roof".into(),
        "--table".into(),
        table.clone().into(),
    ]);
    let args: Vec<&std::ffi::OsStr> = a.iter().map(|s| s.as_os_str()).collect();
    let o = run(&args);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("short.csv:8002: 8000 hours: an annual figure needs one year"),
        "{}",
        stderr(&o)
    );
    assert!(!table.exists());
}

/// `--shard I/N` splits the surfaces between buildings: the parts' `--table` and `--points`
/// files, concatenated in shard order, are the serial run's byte for byte (the header in part
/// 0 only), on a PLATEAU tile of 14 buildings.
#[test]
fn shards_concatenated_are_the_serial_tables() {
    let Some(tmy) = tmy3() else { return };
    let Some(data) = shared_data() else { return };
    let src = data.join("plateau/yokosuka/52397519_bldg_6697_op.gml");
    let dir = tempfile::tempdir().unwrap();
    let go = |shard: Option<&str>, tag: &str| {
        let (t, p) = (
            dir.path().join(format!("t{tag}.csv")),
            dir.path().join(format!("p{tag}.csv")),
        );
        let mut a = irradiance_args(&src, &tmy);
        a.extend([
            "--surfaces".into(),
            "roof,wall".into(),
            "--rays".into(),
            "300".into(),
            "--table".into(),
            t.clone().into_os_string(),
            "--points".into(),
            p.clone().into_os_string(),
        ]);
        if let Some(s) = shard {
            a.extend(["--shard".into(), s.into()]);
        }
        let args: Vec<&std::ffi::OsStr> = a.iter().map(|s| s.as_os_str()).collect();
        let o = run(&args);
        assert!(o.status.success(), "{shard:?}: {}", stderr(&o));
        (std::fs::read(t).unwrap(), std::fs::read(p).unwrap())
    };
    let (table, points) = go(None, "all");
    let (mut t3, mut p3) = (Vec::new(), Vec::new());
    let mut rows = Vec::new();
    for k in 0..3 {
        let (t, p) = go(Some(&format!("{k}/3")), &k.to_string());
        rows.push(t.iter().filter(|&&b| b == b'\n').count());
        t3.extend(t);
        p3.extend(p);
    }
    assert!(rows.iter().all(|&n| n > 0), "an empty part: {rows:?}");
    assert!(
        t3 == table,
        "the parts' tables differ from the serial table"
    );
    assert!(
        p3 == points,
        "the parts' points differ from the serial points"
    );
}

/// Cadastre points of PLATEAU Yokosuka (28 buildings, latitude and longitude) and Rotterdam
/// (two buildings, RD New) against Radiance's daylight coefficients on geometry the oracle
/// reads and writes itself (tests/oracle/cadastre_radiance.py: Python's XML parser, every
/// building at its most detailed LoD as Radiance polygons, pyproj for latitude and
/// longitude; the sun a ray per hour placed by pvlib, the sky by daylight coefficients),
/// Greensboro's year with no reflection (`--albedo 0`). Per file and class, the points at
/// seven quantiles of skylod's annual global (least to greatest, so the most shaded ones
/// too): global within 2 % (or 1 kWh/m² under 50), direct and diffuse each within 3 % (or
/// 1 kWh/m² for a part under 33).
#[test]
fn cadastre_matches_radiance_on_geometry_the_test_reads() {
    if !python_has("pyradiance", "pip install pyradiance")
        || !python_has("pyproj", "pip install pyproj")
    {
        return;
    }
    let Some(tmy) = tmy3() else { return };
    let Some(data) = shared_data() else { return };
    let dir = tempfile::tempdir().unwrap();
    let (points, chosen) = (dir.path().join("p.csv"), dir.path().join("chosen.csv"));
    let mut compared = 0;
    for (file, epsg) in [
        ("plateau/yokosuka/52397519_bldg_6697_op.gml", Some("6697")),
        ("rotterdam/Source.gml", None),
    ] {
        let src = data.join(file);
        let mut a = irradiance_args(&src, &tmy);
        a.extend(["--surfaces", "roof,wall", "--albedo", "0", "--points"].map(OsString::from));
        a.extend([points.clone().into_os_string(), "--overwrite".into()]);
        let args: Vec<&OsStr> = a.iter().map(OsString::as_os_str).collect();
        let o = run(&args);
        assert!(o.status.success(), "{file}: {}", stderr(&o));
        let all = rows(&points);
        let mut csv = String::from("id,x,y,z,nx,ny,nz\n");
        let mut picked = Vec::new();
        for kind in ["roof", "wall"] {
            // a body's faces are `<id>:roof` / `<id>:wall`; thematic surfaces by their id
            let is_roof = |r: &&HashMap<String, String>| num(r, "nz") > 0.25;
            let mut of: Vec<&HashMap<String, String>> = all
                .iter()
                .filter(|r| is_roof(r) == (kind == "roof"))
                .collect();
            of.sort_by(|a, b| num(a, "global_kwh_m2").total_cmp(&num(b, "global_kwh_m2")));
            assert!(!of.is_empty(), "{file}: no {kind} point");
            let mut at: Vec<usize> = [0.0, 0.1, 0.25, 0.5, 0.75, 0.9, 1.0]
                .iter()
                .map(|q| ((of.len() - 1) as f64 * q).round() as usize)
                .collect();
            at.dedup();
            for k in at {
                let r = of[k];
                let id = format!("{kind}{k}");
                csv += &format!(
                    "{id},{},{},{},{},{},{}\n",
                    r["x"], r["y"], r["z"], r["nx"], r["ny"], r["nz"]
                );
                picked.push((id, r));
            }
        }
        std::fs::write(&chosen, csv).unwrap();
        let mut cmd = Command::new("python3");
        cmd.arg(manifest_dir().join("tests/oracle/cadastre_radiance.py"))
            .args([tmy.as_os_str(), src.as_os_str(), chosen.as_os_str()]);
        if let Some(e) = epsg {
            cmd.arg(e);
        }
        let o = cmd.output().unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        let rad: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        for (id, r) in picked {
            let want = |k: &str| rad[&id][format!("{k}_kwh_m2")].as_f64().unwrap();
            let got = |k: &str| num(r, &format!("{k}_kwh_m2"));
            eprintln!(
                "{file} {id} ({}): skylod global {:.1} direct {:.1} diffuse {:.1}; Radiance {:.1} {:.1} {:.1}",
                r["surface_id"],
                got("global"),
                got("direct"),
                got("diffuse"),
                want("global"),
                want("direct"),
                want("diffuse")
            );
            let (g, w) = (got("global"), want("global"));
            let tol = if w < 50.0 { 1.0 } else { 0.02 * w };
            assert!((g - w).abs() <= tol, "{file} {id}: global {g} vs {w}");
            for part in ["direct", "diffuse"] {
                let (g, w) = (got(part), want(part));
                let tol = if w < 33.0 { 1.0 } else { 0.03 * w };
                assert!((g - w).abs() <= tol, "{file} {id}: {part} {g} vs {w}");
            }
            compared += 1;
        }
    }
    assert!(compared >= 20, "{compared}");
}
