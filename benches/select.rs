//! Selection benchmark on the `paper` preset district (~300K polygons, generated in
//! memory by `skylod::model::synth`): the whole `lod` pipeline after loading, stage by stage.
//!
//! * `rough_model`: the rough stage over every asset;
//! * `bvh/rough` vs `bvh/full`: BVH build of the rough model against the full-detail
//!   model (baseline: what a selection on the full model would have to build);
//! * `select_10k/trace_only` (baseline: the bare `first_hit` of the 10,000 rays of the
//!   bundle, no counting, no silhouette) vs `select_10k/select` (the whole selection of
//!   one window POI).

use criterion::{criterion_group, criterion_main, Criterion};
use skylod::io::citygml::read_bytes;
use skylod::lod::poi::POI_OFFSET;
use skylod::lod::rough::{rough_model, RoughOptions};
use skylod::lod::{full_scene, rough_scene, selection_scene};
use skylod::lod::{select, SelectOptions};
use skylod::model::synth::{generate, pois, Preset};
use skylod::solar::{SkyPartition, SkyVariant};
use std::hint::black_box;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let opts = Preset::Paper.defaults();
    let mut xml = Vec::new();
    if let Err(e) = generate(&opts, &mut xml) {
        panic!("synth: {e}");
    }
    let model = read_bytes(&xml, "paper.gml").unwrap_or_else(|e| panic!("read: {e}"));
    let all_pois = pois(&opts);
    // A window POI near the middle of the list (a facade inside the district).
    let poi: skylod::lod::poi::Poi = all_pois[all_pois.len() / 2].clone().into();
    eprintln!(
        "paper preset: {} assets, {} polygons, {} POIs",
        model.assets.len(),
        model.polygon_count(),
        all_pois.len()
    );
    let ropts = RoughOptions::default();

    let mut g = c.benchmark_group("rough");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    g.bench_function("rough_model", |b| {
        b.iter(|| black_box(rough_model(&model, &ropts)))
    });
    g.finish();

    let rough = rough_model(&model, &ropts);
    let mut g = c.benchmark_group("bvh");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    g.bench_function("selection (rough, openings closed)", |b| {
        b.iter(|| black_box(selection_scene(&model, &rough)))
    });
    g.bench_function("rough (all rough assets)", |b| {
        b.iter(|| black_box(rough_scene(&rough)))
    });
    g.bench_function("full (baseline)", |b| {
        b.iter(|| black_box(full_scene(&model)))
    });
    g.finish();

    let scene = selection_scene(&model, &rough);
    eprintln!(
        "triangles: selection {}, rough {}, full {}",
        scene.len(),
        rough_scene(&rough).len(),
        full_scene(&model).len()
    );
    let sopts = SelectOptions::default();
    let part = SkyPartition::new(sopts.rays, SkyVariant::EqualSolidAngle).unwrap();
    let dirs = part.sample(sopts.seed);
    let origin = poi.ray_origin();
    let mut g = c.benchmark_group("select_10k");
    g.sample_size(20).measurement_time(Duration::from_secs(8));
    g.bench_function("trace_only (baseline)", |b| {
        b.iter(|| {
            let mut n = 0u32;
            for &d in &dirs {
                if let Some(h) = scene.first_hit(origin, d, POI_OFFSET, f64::INFINITY) {
                    n = n.wrapping_add(h.tag);
                }
            }
            black_box(n)
        })
    });
    g.bench_function("select", |b| {
        b.iter(|| {
            black_box(select(
                &model,
                &rough,
                &scene,
                std::slice::from_ref(&poi),
                &sopts,
            ))
        })
    });
    g.finish();
    let s = select(&model, &rough, &scene, &[poi], &sopts).unwrap_or_else(|e| panic!("{e}"));
    eprintln!("levels [0,1,2] = {:?}", s.level_counts());
}

criterion_group!(benches, bench);
criterion_main!(benches);
