//! Soak test (opt-in: `#[ignore]`, run with `--ignored`): the `lod` pipeline over a generated city of about
//! 1 GB of CityGML with 1,000 POIs, memory sampled.
//!
//! The city (`skylod::model::synth`, `SKYLOD_SOAK_BLOCKS`, default `18x18` blocks, ~1 GB) is streamed
//! to a temporary file, read, and the rough model and selection scene are built once. The
//! 1,000 POIs (seeded random street-level points over the district) are then selected in 20
//! batches of 50 while the resident set size is sampled after each batch: after the first
//! batch (warm-up) it must not grow by more than 5 % + 16 MiB. Finally the combined levels
//! are written as the mixed-LoD file. Then `skylod lod` itself runs on the city with 100 of
//! those POIs and its peak resident set is reported (and bounded per MB of XML).
//!
//! ```sh
//! cargo test --release --test it soak:: -- --ignored --nocapture
//! SKYLOD_SOAK_BLOCKS=4x4 cargo test --release --test it soak:: -- --ignored --nocapture  # quick
//! ```

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skylod::io::citygml::read_file;
use skylod::io::citygml::WriteOptions;
use skylod::lod::poi::Poi;
use skylod::lod::rough::{rough_model, RoughOptions};
use skylod::lod::selection_scene;
use skylod::lod::write_mixed;
use skylod::lod::{select, SelectOptions};
use skylod::model::synth::{generate, Preset};
use std::io::BufWriter;
use std::time::Instant;

/// Resident set size of this process in bytes (Linux), 0 where unknown.
fn rss() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmRSS:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

const MIB: f64 = 1024.0 * 1024.0;

#[test]
#[ignore = "generates and reads a ~1 GB city for minutes; run with --ignored"]
fn soak_lod_on_a_generated_city() {
    let blocks = std::env::var("SKYLOD_SOAK_BLOCKS").unwrap_or_else(|_| "18x18".into());
    let (bx, by) = blocks
        .split_once('x')
        .and_then(|(a, b)| Some((a.parse::<u32>().ok()?, b.parse::<u32>().ok()?)))
        .expect("SKYLOD_SOAK_BLOCKS as WxH");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("city.gml");
    let mut opts = Preset::City.defaults();
    opts.blocks_x = bx;
    opts.blocks_y = by;
    let t = Instant::now();
    let file = std::fs::File::create(&path).unwrap();
    let summary = generate(&opts, BufWriter::new(file)).unwrap();
    let bytes = std::fs::metadata(&path).unwrap().len();
    eprintln!(
        "city {blocks}: {} buildings, {} polygons, {:.0} MiB in {:.1} s",
        summary.buildings,
        summary.polygons,
        bytes as f64 / MIB,
        t.elapsed().as_secs_f64()
    );

    let t = Instant::now();
    let model = read_file(&path).unwrap();
    eprintln!(
        "read: {:.1} s, RSS {:.0} MiB",
        t.elapsed().as_secs_f64(),
        rss() as f64 / MIB
    );
    let rough = rough_model(&model, &RoughOptions::default());
    let scene = selection_scene(&model, &rough);
    let bbox = model.bbox();
    eprintln!(
        "rough + scene ({} triangles): RSS {:.0} MiB",
        scene.len(),
        rss() as f64 / MIB
    );

    let mut rng = ChaCha8Rng::seed_from_u64(1000);
    let pois: Vec<Poi> = (0..1000)
        .map(|i| Poi {
            id: format!("p{i}"),
            position: DVec3::new(
                rng.random_range(bbox.min.x..bbox.max.x),
                rng.random_range(bbox.min.y..bbox.max.y),
                bbox.min.z + 1.5,
            ),
            normal: None,
        })
        .collect();
    let sopts = SelectOptions::default();
    let mut levels = vec![0u8; model.assets.len()];
    let mut samples = Vec::new();
    let t = Instant::now();
    for batch in pois.chunks(50) {
        let s = select(&model, &rough, &scene, batch, &sopts).unwrap();
        for (l, x) in levels.iter_mut().zip(&s.levels) {
            *l = (*l).max(*x);
        }
        samples.push(rss());
    }
    let per_poi = t.elapsed().as_secs_f64() * 1e3 / pois.len() as f64;
    let mib: Vec<String> = samples
        .iter()
        .map(|b| format!("{:.0}", *b as f64 / MIB))
        .collect();
    eprintln!(
        "selection: {per_poi:.1} ms per POI; RSS per batch (MiB): {}",
        mib.join(" ")
    );
    let warm = samples[0];
    let max_after = samples[1..].iter().copied().max().unwrap_or(warm);
    assert!(
        (max_after as f64) <= warm as f64 * 1.05 + 16.0 * MIB,
        "memory grows after warm-up: {warm} -> {max_after} bytes"
    );

    let out = dir.path().join("city-lod.gml");
    let t = Instant::now();
    let s = write_mixed((&model, 0), &rough, &levels, &out, &WriteOptions::default()).unwrap();
    eprintln!(
        "write: {:.1} s, levels {:?}, polygons {} -> {}, RSS {:.0} MiB",
        t.elapsed().as_secs_f64(),
        s.levels,
        s.polygons_in,
        s.polygons_out,
        rss() as f64 / MIB
    );
    assert!(s.polygons_out < s.polygons_in);
    drop((model, rough, scene, levels));

    // The whole command as a user runs it: `skylod lod` on the city with 100 street-level
    // POIs (the first 100 above), its peak resident set (VmHWM) sampled until it exits.
    let csv = dir.path().join("pois.csv");
    let mut text = String::from("id,x,y,z\n");
    for p in &pois[..100] {
        let q = p.position;
        text.push_str(&format!("{},{:.3},{:.3},{:.3}\n", p.id, q.x, q.y, q.z));
    }
    std::fs::write(&csv, text).unwrap();
    let t = Instant::now();
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_skylod"))
        .arg("lod")
        .arg(&path)
        .arg("--pois")
        .arg(&csv)
        .arg("-o")
        .arg(dir.path().join("cli-lod.gml"))
        .arg("-q")
        .spawn()
        .unwrap();
    let status_file = format!("/proc/{}/status", child.id());
    let mut peak = 0u64;
    let status = loop {
        if let Some(kb) = std::fs::read_to_string(&status_file).ok().and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<u64>().ok())
        }) {
            peak = peak.max(kb * 1024);
        }
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    };
    assert!(status.success(), "skylod lod: {status}");
    let per_mb = peak as f64 / MIB / (bytes as f64 / 1e6);
    eprintln!(
        "skylod lod, 100 POIs: {:.1} s, peak RSS {:.0} MiB ({per_mb:.2} MiB per MB of XML)",
        t.elapsed().as_secs_f64(),
        peak as f64 / MIB
    );
    // Recorded 2026-11-22 (branch mem, this test): 18x18 (1,007 MB) 13.2 s, peak 1,356 MiB =
    // 1.35 MiB per MB (main before: 2,142 MiB). Branch mem2 (compact polygons and ids, lists at
    // their size, freed pages given back between stages; `skylod lod` with 100 random POIs on
    // the same city): 1,005 MiB (1,017 MiB merged with main's BVH rule) = 1.0 MiB per MB, at the
    // selection scene's BVH build; the read alone 796 MiB; 4x4: 81 MiB. Goal (issue 11): below 1 GiB. A regression past 1.2 MiB per
    // MB of XML plus 64 MiB (the process's own, what a 4x4 city shows) fails.
    if peak > 0 {
        let limit = 1.2 * bytes as f64 / 1e6 + 64.0;
        assert!(
            (peak as f64 / MIB) < limit,
            "peak RSS {:.0} MiB ({per_mb:.2} MiB per MB of XML), limit {limit:.0} MiB",
            peak as f64 / MIB
        );
    }
}
