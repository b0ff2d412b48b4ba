//! An ETL step embedding skylod (`default-features = false` is enough): read a directory of
//! tiles, POIs from a CSV, choose levels, write the mixed-LoD tiles, then SVF and sun hours of
//! the POIs as JSON. `cargo run --example etl -- TILES POIS.csv OUT_DIR/`
//! (without arguments: the committed synth fixture, written to a temporary directory).
use skylod::prelude::*;
use std::path::{Path, PathBuf};

/// One row of the JSON: a POI and its figures.
#[derive(serde::Serialize)]
struct Row<'a> {
    id: &'a str,
    svf: f64,
    sun_hours: f64,
    flags: usize,
}

/// Read `tiles`, POIs from `csv`, write the levels below `out`, print the JSON to `json`.
pub fn etl(tiles: &Path, csv: &Path, out: &Path, json: impl std::io::Write) -> Result<()> {
    let scene = Scene::load(&[tiles], &SceneOptions::default(), &Silent)?;
    for e in scene.failures() {
        eprintln!("etl: skipped {e}");
    }
    let pois = read_pois_csv(csv)?.into_iter().map(|l| l.poi).collect();
    let mut study = scene.frame(pois)?;
    let levels = study.levels(&LevelsOptions::default(), &Silent)?;
    for (path, w) in study.write_levels(&levels, out, None, true, &Silent)? {
        let [l0, l1, l2] = w.levels;
        eprintln!("etl: {} levels 0/1/2 = {l0}/{l1}/{l2}", path.display());
    }
    // One full-detail scene and one sun table (site from the CRS, 2025, 15 min) for both.
    let svf = study.svf(&SkyBundles::default(), &Silent)?;
    let sun = study.sun_hours(&SunOptions::default(), &Silent)?;
    let rows: Vec<Row> = (study.pois().iter().zip(&svf.results).zip(&sun.results))
        .zip(&svf.flags)
        .map(|(((p, v), s), f)| Row {
            id: &p.id,
            svf: v.svf,
            sun_hours: s.hours,
            flags: f.len(),
        })
        .collect();
    serde_json::to_writer_pretty(json, &rows).map_err(std::io::Error::from)?;
    Ok(())
}

fn main() -> std::result::Result<(), Box<dyn std::error::Error>> {
    let fixtures = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let tmp = tempfile::tempdir()?;
    let mut args = std::env::args_os().skip(1).map(PathBuf::from);
    let tiles = args.next().unwrap_or(fixtures.join("synth-small.gml"));
    let csv = args.next().unwrap_or(fixtures.join("synth-small.pois.csv"));
    let out = args.next().unwrap_or(tmp.path().join("lod/"));
    etl(&tiles, &csv, &out, std::io::stdout().lock())?;
    println!();
    Ok(())
}
