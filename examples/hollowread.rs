//! Profiling helper: the hollow read of `lod` ([`skylod::lod::read_hollow`], chunks of
//! 16 MiB, every asset hollowed) or, with `whole`, the whole read and the rough model of
//! `lod`, on one CityGML file; prints assets, polygons and chunks. Peak memory and CPU with
//! `/usr/bin/time -f '%e s %U u %M KiB'`.
//! `cargo run --release --example hollowread -- FILE.gml [whole]`
//!
//! With `bound` (`FILE.gml bound [whole]`): `lod`'s selection and its default error bound
//! (SVF and sun hours within 1 %, the sun of Ingolstadt) at the two street POIs of the
//! bench files' `lod` runs (678095,5403890,418 and 678150,5403776,419), on the hollow read
//! with the bound's assets read back by span ([`skylod::lod::HollowSource`]) or on
//! the whole read; prints the levels, promotions and reference (the same both ways) and, on
//! stderr, each stage's seconds.
use skylod::io::citygml::ReadOptions;
use skylod::io::citygml::{read_file, Passes, Reread, CHUNK_BYTES};
use skylod::lod::rough::{rough_model, RoughOptions};
use skylod::lod::{bound_against_from, full_answers_from, BoundOptions, FullSource};
use skylod::lod::{lod, LodOptions, LodResult};
use skylod::lod::{near_pois, read_hollow};
use skylod::lod::{Bounded, HollowSource};
use skylod::model::Poi;
use skylod::model::Silent;
use std::path::Path;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1).map(Path::new) else {
        eprintln!("usage: hollowread FILE.gml [bound] [whole]");
        std::process::exit(2);
    };
    let whole = args.iter().skip(2).any(|a| a == "whole");
    if args.iter().skip(2).any(|a| a == "bound") {
        bound(path, whole);
        return;
    }
    let opts = RoughOptions::default();
    if whole {
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

/// The selection and the default bound at the two street POIs, hollow or `whole`.
fn bound(path: &Path, whole: bool) {
    let pois = vec![
        Poi::at("a", [678095.0, 5403890.0, 418.0]),
        Poi::at("b", [678150.0, 5403776.0, 419.0]),
    ];
    let site = skylod::solar::Site::new(48.76, 11.42);
    let sun = skylod::solar::SunTable::year(
        skylod::solar::DEFAULT_YEAR,
        skylod::solar::DEFAULT_STEP_MIN,
        &site,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let b = BoundOptions {
        max_svf_error: Some(0.01),
        max_sun_error: Some(0.01),
        ..Default::default()
    };
    let opts = LodOptions::default();
    let t = Instant::now();
    let lap = |what: &str, t: &mut Instant| {
        eprintln!("{what}: {:.2} s", t.elapsed().as_secs_f64());
        *t = Instant::now();
    };
    let mut at = t;
    let run = |src: &dyn FullSource, lod: &LodResult, at: &mut Instant| -> Bounded {
        let full = full_answers_from(src, &pois, &b, Some(&sun), None);
        let full = full.unwrap_or_else(|e| panic!("{e}"));
        lap("reference", at);
        let levels = &lod.selection.levels;
        let r = bound_against_from(src, &lod.rough, levels, &full);
        let r = r.unwrap_or_else(|e| panic!("{e}"));
        lap("bound", at);
        r
    };
    let (lod, bounded) = if whole {
        let m = read_file(path).unwrap_or_else(|e| panic!("{e}"));
        lap("read", &mut at);
        let lod = lod(&m, &pois, &opts, &Silent).unwrap_or_else(|e| panic!("{e}"));
        lap("selection", &mut at);
        let r = run(&m, &lod, &mut at);
        std::mem::forget(m);
        (lod, r)
    } else {
        let read = ReadOptions::default();
        let passes = Passes::new(&read, CHUNK_BYTES, &|_, _| {});
        let points: Vec<glam::DVec3> = pois.iter().map(|p| p.position).collect();
        let Some(h) = read_hollow(path, &passes, &opts.rough, &near_pois(&points)) else {
            eprintln!("{}: the stream declines: read whole", path.display());
            std::process::exit(1);
        };
        lap("read", &mut at);
        let lod = lod(&h, &pois, &opts, &Silent).unwrap_or_else(|e| panic!("{e}"));
        lap("selection", &mut at);
        let Some(rr) = Reread::open(path, &read) else {
            eprintln!("{}: cannot be read back", path.display());
            std::process::exit(1);
        };
        let src = HollowSource::new(&h, &rr);
        let r = run(&src, &lod, &mut at);
        eprintln!("assets read back: {}", src.read_back());
        std::mem::forget(h);
        (lod, r)
    };
    let [l0, l1, l2] = lod.selection.level_counts();
    println!("selection: levels 0/1/2 = {l0}/{l1}/{l2}");
    let mut count = [0usize; 3];
    bounded
        .levels
        .iter()
        .for_each(|&l| count[usize::from(l.min(2))] += 1);
    println!("bound: levels 0/1/2 = {count:?}, met {}", bounded.met);
    println!(
        "bound: {} promotions, {} rounds",
        bounded.promotions.len(),
        bounded.rounds
    );
    println!("reference: {:?}", bounded.reference);
    for p in &bounded.pois {
        println!(
            "{}: svf {} / {}, sun {:?} / {:?}",
            p.id, p.svf_full, p.svf_lod, p.sun_hours_full, p.sun_hours_lod
        );
    }
    let levels: u64 = (bounded.levels.iter().enumerate()).fold(0u64, |h, (i, &l)| {
        h.rotate_left(5) ^ (i as u64).wrapping_mul(u64::from(l) + 1)
    });
    println!("levels hash {levels:016x}");
    eprintln!("total: {:.2} s", t.elapsed().as_secs_f64());
    std::mem::forget((lod, bounded));
}
