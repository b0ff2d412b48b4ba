//! `examples/etl.rs`, the library program of the README (issue 27): a directory of tiles, POIs
//! from a CSV, levels, outputs mirrored below a folder, SVF and sun hours as JSON. It is
//! compiled into this test and run; its figures must be the CLI's (`skylod svf`, `skylod
//! sun-hours`), its outputs where the CLI's `-o DIR/` puts them, and it stays a short program
//! using only the crate root or the prelude.

#[allow(dead_code)]
#[path = "../../examples/etl.rs"]
mod example;

use crate::util::{fixture, manifest_dir, run};
use std::ffi::OsStr;

fn cli_json(cmd: &str, tiles: &std::path::Path, csv: &std::path::Path) -> serde_json::Value {
    let o = run(&[
        OsStr::new(cmd),
        tiles.as_os_str(),
        OsStr::new("--pois"),
        csv.as_os_str(),
        OsStr::new("--json"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn etl_example_gives_the_cli_s_figures_in_a_short_program() {
    let dir = tempfile::tempdir().unwrap();
    let tiles = dir.path().join("tiles");
    std::fs::create_dir_all(tiles.join("north")).unwrap();
    std::fs::copy(fixture("synth-small.gml"), tiles.join("north/t1.gml")).unwrap();
    let csv = fixture("synth-small.pois.csv");
    let out = dir.path().join("out/");
    let mut json = Vec::new();
    example::etl(&tiles, &csv, &out, &mut json).unwrap();
    // The output mirrors the tile's path below the folder, which is created.
    let written = dir.path().join("out/north/t1.gml");
    let text = std::fs::read_to_string(&written).unwrap();
    assert!(text.contains("CityModel"), "{}", written.display());

    let rows: serde_json::Value = serde_json::from_slice(&json).unwrap();
    let rows = rows.as_array().unwrap();
    let svf = cli_json("svf", &tiles, &csv);
    let sun = cli_json("sun-hours", &tiles, &csv);
    let (svf, sun) = (
        svf["pois"].as_array().unwrap(),
        sun["pois"].as_array().unwrap(),
    );
    assert_eq!(rows.len(), 3);
    assert_eq!((svf.len(), sun.len()), (3, 3));
    for ((r, v), s) in rows.iter().zip(svf).zip(sun) {
        assert_eq!(r["id"], v["id"]);
        assert_eq!(r["id"], s["id"]);
        // The CLI rounds to 4 decimals (SVF) and 2 (hours).
        let dv = r["svf"].as_f64().unwrap() - v["svf"].as_f64().unwrap();
        let ds = r["sun_hours"].as_f64().unwrap() - s["sun_hours"].as_f64().unwrap();
        assert!(dv.abs() <= 5e-5 && ds.abs() <= 5e-3, "{r} vs {v} / {s}");
        assert!(r["sun_hours"].as_f64().unwrap() > 0.0);
    }

    // A short program over the root and the prelude only.
    let src = std::fs::read_to_string(manifest_dir().join("examples/etl.rs")).unwrap();
    assert!(src.lines().count() <= 60, "{} lines", src.lines().count());
    for (i, l) in src.lines().enumerate() {
        let code = l.split("//").next().unwrap_or("");
        for (k, _) in code.match_indices("skylod::") {
            let rest = &code[k + "skylod::".len()..];
            let seg: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            // `skylod::item`, never `skylod::module::item` (other than the prelude)
            let root_item = seg == "prelude" || !rest[seg.len()..].starts_with("::");
            assert!(root_item, "examples/etl.rs:{}: {l}", i + 1);
        }
    }
}
