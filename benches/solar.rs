//! Benchmarks of the solar analysis: year sun table, sun hours, SVF bundles.
use criterion::{criterion_group, criterion_main, Criterion};
use glam::DVec3;
use skylod::sky::{SkyPartition, SkyVariant};
use skylod::solar::{sky_view, sun_hours, Site, SkyBundles, SunTable};
use std::hint::black_box;

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

criterion_group!(benches, sun, svf);
criterion_main!(benches);
