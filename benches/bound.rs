//! The cost of `lod`'s default error bound (the goal: the default `lod` on the paper district
//! at most 2.5× a raw scan of the file), in the same run, on the `paper` preset district
//! (generated once into a temporary file, ~125 MB, with its 6 POIs):
//!
//! * `raw_scan_floats` (baseline, what `qxscan FILE floats` does): the file read and every
//!   event of a namespace-resolving `quick_xml` scan, every number parsed;
//! * `lod --no-bound`: the file read into a model, framed, rough model, selection;
//! * `lod (default bound)`: the same, with the sun table of the model's site and the
//!   default bound (SVF and sun hours within 1 %, 20,000 rays).
//!
//! Writing the model is left out of both `lod` figures (it does not depend on the bound).
//! The ratios to the baseline are the figures to read (the machine is shared); never
//! asserted anywhere.

use criterion::{criterion_group, criterion_main, Criterion};
use quick_xml::events::Event;
use quick_xml::NsReader;
use skylod::lod::BoundOptions;
use skylod::lod::LodOptions;
use skylod::model::synth::{generate, pois, Preset};
use skylod::pipeline::BoundSpec;
use skylod::{LevelsOptions, Poi, Scene, SceneOptions, Silent, SunOptions};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

/// The baseline: `../shared/tools/qxscan FILE floats`, the file read and scanned.
fn raw_scan_floats(path: &Path) -> f64 {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut r = NsReader::from_reader(&bytes[..]);
    let mut buf = Vec::new();
    let mut sum = 0.0;
    loop {
        match r.read_resolved_event_into(&mut buf) {
            Ok((_, Event::Eof)) | Err(_) => break,
            Ok((_, Event::Text(t))) => {
                for tok in t.split(|b| b.is_ascii_whitespace()) {
                    if let Some(v) = std::str::from_utf8(tok)
                        .ok()
                        .and_then(|s| s.parse::<f64>().ok())
                    {
                        sum += v;
                    }
                }
            }
            Ok(_) => {}
        }
        buf.clear();
    }
    sum
}

/// `lod` up to the levels (no writing), with the default bound or none; the levels kept.
fn lod(path: &Path, pois: &[Poi], bound: bool) -> usize {
    let scene = Scene::load(&[path], &SceneOptions::default(), &Silent)
        .unwrap_or_else(|e| panic!("load: {e}"));
    let study = scene
        .frame(pois.to_vec())
        .unwrap_or_else(|e| panic!("frame: {e}"));
    let lod = LodOptions::default();
    let bound = bound.then(|| {
        let sun = study
            .sun_table(&SunOptions::default())
            .unwrap_or_else(|e| panic!("sun table: {e}"));
        BoundSpec {
            options: BoundOptions {
                max_svf_error: Some(0.01),
                max_sun_error: Some(0.01),
                svf_rays: 20_000,
                svf_seed: lod.select.seed,
                ..Default::default()
            },
            sun: Some((*sun).clone()),
            irradiance: None,
        }
    });
    let lv = study
        .levels(&LevelsOptions { lod, bound }, &Silent)
        .unwrap_or_else(|e| panic!("levels: {e}"));
    assert!(lv.bound_met());
    lv.levels().iter().filter(|&&l| l > 0).count()
}

fn bench(c: &mut Criterion) {
    let opts = Preset::Paper.defaults();
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("temporary folder: {e}"));
    let path = dir.path().join("paper.gml");
    let file = std::fs::File::create(&path).unwrap_or_else(|e| panic!("paper.gml: {e}"));
    let mut out = std::io::BufWriter::new(file);
    generate(&opts, &mut out).unwrap_or_else(|e| panic!("synth: {e}"));
    drop(out);
    let pois: Vec<Poi> = pois(&opts).into_iter().map(Into::into).collect();
    let mut g = c.benchmark_group("lod_paper");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    g.bench_function("raw_scan_floats (baseline)", |b| {
        b.iter(|| black_box(raw_scan_floats(&path)))
    });
    g.bench_function("lod --no-bound", |b| {
        b.iter(|| black_box(lod(&path, &pois, false)))
    });
    g.bench_function("lod (default bound)", |b| {
        b.iter(|| black_box(lod(&path, &pois, true)))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
