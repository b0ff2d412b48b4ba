//! Write a synthetic Eixample district and its POIs:
//! `cargo run --release --example synth -- <small|paper|city> <out.gml> [seed] [blocks_x blocks_y] [lod2]`
//! (POIs go to `<out>.pois.csv` beside it, `out.gml` -> `out.pois.csv`).

use skylod::synth::{generate, pois, write_pois_csv, Preset};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let preset = match args.get(1).map(String::as_str) {
        Some("small") => Preset::Small,
        Some("city") => Preset::City,
        _ => Preset::Paper,
    };
    let out = args
        .get(2)
        .cloned()
        .unwrap_or_else(|| "district.gml".into());
    let mut opts = preset.defaults();
    if let Some(s) = args.get(3) {
        opts.seed = s.parse()?;
    }
    if let (Some(x), Some(y)) = (args.get(4), args.get(5)) {
        opts.blocks_x = x.parse()?;
        opts.blocks_y = y.parse()?;
    }
    opts.with_lod2 = args.get(6).is_some_and(|s| s == "lod2");
    let t = Instant::now();
    let file = std::io::BufWriter::new(std::fs::File::create(&out)?);
    let sum = generate(&opts, file)?;
    let dt = t.elapsed().as_secs_f64();
    let csv = out.strip_suffix(".gml").unwrap_or(&out).to_string() + ".pois.csv";
    write_pois_csv(&pois(&opts), std::fs::File::create(&csv)?)?;
    println!("{sum:#?}");
    println!(
        "{:.3} s, {:.1} MB/s, {:.0} polygons/s -> {out}, {csv}",
        dt,
        sum.bytes as f64 / dt / 1e6,
        sum.polygons as f64 / dt
    );
    Ok(())
}
