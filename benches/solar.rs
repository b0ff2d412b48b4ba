//! Benchmarks of the solar analysis: year sun table, sun hours, SVF bundles, and both
//! per POI against a ~300K-polygon district (`skylod::model::synth` paper preset, generated
//! here) with the same rays against an empty scene as the baseline in the same run.
//!
//! Product targets: SVF with 100,000 rays <= 50 ms per POI; a year of sun hours at
//! 15-minute steps (35,040 steps) <= 20 ms per POI (single thread, one POI per
//! iteration; the `district/*` benchmarks cycle through the district's facade POIs).
use criterion::{criterion_group, criterion_main, Criterion};
use glam::DVec3;
use skylod::io::citygml::read_bytes;
use skylod::lod::full_scene;
use skylod::lod::poi::Poi;
use skylod::model::synth::{generate, Preset};
use skylod::solar::trace::SceneBuilder;
use skylod::solar::{poi_sky_view, poi_sun_hours, sky_view, sun_hours, Site, SkyBundles, SunTable};
use skylod::solar::{SkyPartition, SkyVariant};
use std::cell::Cell;
use std::hint::black_box;
use std::time::Instant;

fn sun(c: &mut Criterion) {
    let site = Site::new(41.39, 2.17)
        .with_time_zone("Europe/Madrid")
        .expect("zone");
    let mut g = c.benchmark_group("sun");
    g.sample_size(10);
    g.bench_function("sun_table_year_15min", |b| {
        b.iter(|| SunTable::year(black_box(2025), 15, &site).expect("table"))
    });
    let table = SunTable::year(2025, 15, &site).expect("table");
    g.bench_function("sun_hours_trivial_predicate", |b| {
        b.iter(|| {
            sun_hours(&table, black_box(Some(DVec3::NEG_Y)), |d| {
                black_box(d).z < 0.0
            })
        })
    });
    g.bench_function("baseline_sum_above_horizon", |b| {
        b.iter(|| {
            black_box(&table)
                .steps()
                .iter()
                .filter(|s| s.above_horizon)
                .count()
        })
    });
    g.finish();
}

fn svf(c: &mut Criterion) {
    let n = 100_000;
    let bundles = SkyBundles::new(n, 1).expect("bundles");
    let mut g = c.benchmark_group("svf");
    g.sample_size(10);
    g.bench_function("sky_view_100k_trivial_predicate", |b| {
        b.iter(|| {
            sky_view(
                black_box(DVec3::ZERO),
                Some(DVec3::new(0.2, -0.7, 0.6)),
                &bundles,
                |o, d| black_box(o).z + black_box(d).x > 0.9,
            )
        })
    });
    let sky = SkyPartition::new(n, SkyVariant::EqualProjectedArea).expect("sky");
    g.bench_function("baseline_sample_100k", |b| {
        b.iter(|| sky.sample(black_box(1)))
    });
    g.bench_function("bundles_new_100k", |b| {
        b.iter(|| SkyBundles::new(n, black_box(1)).expect("bundles"))
    });
    g.finish();
}

fn district(c: &mut Criterion) {
    let t = Instant::now();
    let opts = Preset::Paper.defaults();
    let mut gml = Vec::new();
    let summary = generate(&opts, &mut gml).expect("synth");
    let model = read_bytes(&gml, "paper.gml").expect("read");
    drop(gml);
    let scene = full_scene(&model);
    let pois: Vec<Poi> = skylod::model::synth::pois(&opts)
        .into_iter()
        .map(|p| Poi {
            id: p.id,
            position: p.position,
            normal: Some(p.normal),
        })
        .collect();
    eprintln!(
        "district: {} polygons, {} triangles, {} POIs, prepared in {:.1} s",
        summary.polygons,
        scene.len(),
        pois.len(),
        t.elapsed().as_secs_f64()
    );
    let empty = SceneBuilder::new().build();
    let bundles = SkyBundles::new(100_000, 1).expect("bundles");
    let site = Site::new(41.39, 2.17)
        .with_time_zone("Europe/Madrid")
        .expect("zone");
    let table = SunTable::year(2025, 15, &site).expect("table");
    assert_eq!(table.len(), 35_040);
    let next = Cell::new(0usize);
    let poi = || {
        let i = next.get();
        next.set(i + 1);
        &pois[i % pois.len()]
    };
    let mut g = c.benchmark_group("district");
    g.sample_size(10);
    g.bench_function("svf_100k_rays_per_poi", |b| {
        b.iter(|| poi_sky_view(&scene, black_box(poi()), &bundles))
    });
    // The cosine-weighted bundle alone (SVF without sky exposure): ~half the rays.
    g.bench_function("svf_only_100k_rays_per_poi", |b| {
        b.iter(|| {
            let p = black_box(poi());
            let o = p.ray_origin();
            let f = skylod::solar::Frame::from_normal(p.normal.unwrap_or(DVec3::Z));
            bundles
                .projected_dirs()
                .iter()
                .map(|l| f.to_world(*l))
                .filter(|d| d.z > 0.0 && !scene.occluded(o, *d, 0.01, f64::INFINITY))
                .count()
        })
    });
    g.bench_function("baseline_svf_100k_rays_empty_scene", |b| {
        b.iter(|| poi_sky_view(&empty, black_box(poi()), &bundles))
    });
    g.bench_function("sun_hours_year_15min_per_poi", |b| {
        b.iter(|| poi_sun_hours(&scene, black_box(poi()), &table))
    });
    g.bench_function("baseline_sun_hours_year_15min_empty_scene", |b| {
        b.iter(|| poi_sun_hours(&empty, black_box(poi()), &table))
    });
    g.finish();
}

criterion_group!(benches, sun, svf, district);
criterion_main!(benches);
