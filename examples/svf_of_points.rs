//! Sky view factor of points against a CityGML model, through the library alone (no CLI):
//! a [`skylod::Scene`] read and framed with its POIs into a [`skylod::Study`], then
//! [`skylod::Study::svf`] (the path `skylod svf` takes: full-detail scene, POIs traced in
//! parallel). `cargo run --release --example svf_of_points -- MODEL.gml POIS.csv`
//! (without arguments: the committed synth fixture and its POIs).
use skylod::prelude::*;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let fixtures = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let mut args = std::env::args_os().skip(1).map(PathBuf::from);
    let model = args.next().unwrap_or(fixtures.join("synth-small.gml"));
    let csv = args.next().unwrap_or(fixtures.join("synth-small.pois.csv"));

    let scene = Scene::load(&[model], &SceneOptions::default(), &Silent)?;
    if let Some(e) = scene.failures().first() {
        return Err(e.to_string().into());
    }
    let pois = read_pois_csv(&csv)?.into_iter().map(|l| l.poi).collect();
    let study = scene.frame(pois)?;
    for w in study.warnings() {
        eprintln!("warning: {w}");
    }
    // 10,000 rays per bundle, seed 1 (as `skylod svf`).
    let bundles = SkyBundles::new(10_000, 1)?;
    let traced = study.svf(&bundles, &Silent)?;
    println!("id,svf,sky_exposure");
    for ((poi, v), flags) in study.pois().iter().zip(&traced.results).zip(&traced.flags) {
        println!("{},{:.4},{:.4}", poi.id, v.svf, v.sky_exposure);
        for f in flags {
            eprintln!("warning: {}", f.message(poi));
        }
    }
    Ok(())
}
