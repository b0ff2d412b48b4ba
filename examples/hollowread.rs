//! Profiling helper: the hollow read of `lod` ([`skylod::lod::hollow::read_hollow`], chunks of
//! 16 MiB, every asset hollowed) or, with `whole`, the whole read and the rough model of
//! `lod`, on one CityGML file; prints assets, polygons and chunks. Peak memory and CPU with
//! `/usr/bin/time -f '%e s %U u %M KiB'`.
//! `cargo run --release --example hollowread -- FILE.gml [whole]`
use skylod::io::citygml::read::{read_file, Passes, CHUNK_BYTES};
use skylod::io::citygml::ReadOptions;
use skylod::lod::hollow::read_hollow;
use skylod::lod::rough::{rough_model, RoughOptions};
use std::path::Path;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1).map(Path::new) else {
        eprintln!("usage: hollowread FILE.gml [whole]");
        std::process::exit(2);
    };
    let opts = RoughOptions::default();
    if args.get(2).map(String::as_str) == Some("whole") {
        let m = read_file(path).unwrap_or_else(|e| panic!("{e}"));
        let rough = rough_model(&m, &opts);
        println!(
            "whole: {} assets, {} polygons, {} rough polygons",
            m.assets.len(),
            m.polygon_count(),
            rough.iter().map(|r| r.polygon_count()).sum::<usize>()
        );
        std::mem::forget((m, rough));
        return;
    }
    let read = ReadOptions::default();
    let passes = Passes::new(&read, CHUNK_BYTES, &|_, _| {});
    let Some(h) = read_hollow(path, &passes, &opts, &|m, _, _| vec![false; m.assets.len()]) else {
        eprintln!("{}: the stream declines: read whole", path.display());
        std::process::exit(1);
    };
    let n = h.model.assets.len();
    println!(
        "hollow: {n} assets, {} polygons, {} rough polygons, {} chunks",
        (0..n).map(|a| h.polygon_count(a)).sum::<usize>(),
        h.rough.iter().map(|r| r.polygon_count()).sum::<usize>(),
        h.summary.chunks
    );
    std::mem::forget(h);
}
