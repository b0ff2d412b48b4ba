//! Sky view factor of points against a CityGML model, through the library alone (no CLI):
//! the inputs and scene steps of [`skylod::pipeline`], then [`skylod::pipeline::svf`] (the
//! path `skylod svf` takes: full-detail scene, POIs traced in parallel). `cargo run --release --example svf_of_points -- MODEL.gml POIS.csv`
//! (without arguments: the committed synth fixture and its POIs).
use skylod::lod::poi::read_pois_csv;
use skylod::model::Silent;
use skylod::pipeline::{frame, read_inputs, svf, FrameOptions};
use skylod::solar::SkyBundles;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let fixtures = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let mut args = std::env::args_os().skip(1).map(PathBuf::from);
    let model = args.next().unwrap_or(fixtures.join("synth-small.gml"));
    let csv = args.next().unwrap_or(fixtures.join("synth-small.pois.csv"));

    let mut inputs = read_inputs(&[model], &Silent)?;
    if let Some(e) = inputs.failures.first() {
        return Err(e.to_string().into());
    }
    inputs.check(false)?;
    let pois = read_pois_csv(&csv)?.into_iter().map(|l| l.poi).collect();
    let framed = frame(&mut inputs.model, pois, &FrameOptions::default())?;
    for w in &framed.warnings {
        eprintln!("warning: {w}");
    }
    // 10,000 rays per bundle, seed 1 (as `skylod svf`).
    let bundles = SkyBundles::new(10_000, 1)?;
    let traced = svf(&framed, &bundles, &Silent)?;
    println!("id,svf,sky_exposure");
    for ((poi, v), flags) in framed.pois.iter().zip(&traced.results).zip(&traced.flags) {
        println!("{},{:.4},{:.4}", poi.id, v.svf, v.sky_exposure);
        for f in flags {
            eprintln!("warning: {}", f.message(poi));
        }
    }
    Ok(())
}
