//! Trace benchmark: BVH build and hemisphere rays on a synthetic city.
//!
//! City: a 100 x 100 grid of 20 m cells at UTM-sized coordinates, each with one
//! rotated building box (8-16 m footprint, 5-40 m tall, 12 triangles) and 1-2 small
//! roof boxes (chimneys, dormers; 12 triangles each): 10,000 buildings, ~300K
//! triangles. `build/*_600k` doubles the district (200 x 100 cells) for the product
//! target (BVH over ~600K triangles <= 0.5 s).
//!
//! Rays: 10,000 seeded uniform directions on the upper hemisphere from a point 1.5 m
//! above a street near the centre, `first_hit` and `occluded`, single thread and
//! rayon `par_iter`.
//!
//! Baseline (same run): the f64 brute-force loop (`trace::ray::ray_triangle`) over the
//! first 1,000 triangles of the scene for the same 10,000 rays; multiply by the
//! scene size / 1,000 for what brute force over the whole scene would cost.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::{DQuat, DVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use skylod::model::Polygon;
use skylod::solar::trace::ray_triangle;
use skylod::solar::trace::{BuildQuality, BvhLayout, SceneBuilder, TraceScene};
use std::hint::black_box;
use std::time::Duration;

const UTM: DVec3 = DVec3::new(430_000.0, 4_581_000.0, 0.0);
const CELL: f64 = 20.0;

fn add_box(tris: &mut Vec<[DVec3; 3]>, c: DVec3, half: DVec3, yaw: f64) {
    let r = DQuat::from_rotation_z(yaw);
    let corner = |i: usize| {
        let s = DVec3::new(
            if i & 1 == 0 { -1.0 } else { 1.0 },
            if i & 2 == 0 { -1.0 } else { 1.0 },
            if i & 4 == 0 { -1.0 } else { 1.0 },
        );
        c + r * (s * half)
    };
    for q in [
        [0, 4, 6, 2],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 2, 3, 1],
        [4, 5, 7, 6],
    ] {
        let p = q.map(corner);
        tris.push([p[0], p[1], p[2]]);
        tris.push([p[0], p[2], p[3]]);
    }
}

/// Triangles (tag = building index) of an `nx` x `ny` city.
fn city(nx: usize, ny: usize, seed: u64) -> Vec<(u32, [DVec3; 3])> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    let mut tris = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            tris.clear();
            let centre = UTM + DVec3::new((i as f64 + 0.5) * CELL, (j as f64 + 0.5) * CELL, 0.0);
            let hw = rng.random_range(4.0..7.0);
            let hd = rng.random_range(4.0..7.0);
            let h = rng.random_range(5.0..40.0);
            let yaw = rng.random_range(-0.3..0.3);
            add_box(
                &mut tris,
                centre + DVec3::Z * (h / 2.0),
                DVec3::new(hw, hd, h / 2.0),
                yaw,
            );
            for _ in 0..rng.random_range(1..=2) {
                let off = DVec3::new(
                    rng.random_range(-3.0..3.0),
                    rng.random_range(-3.0..3.0),
                    0.0,
                );
                let s = rng.random_range(0.3..1.2);
                add_box(
                    &mut tris,
                    centre + off + DVec3::Z * (h + s),
                    DVec3::splat(s),
                    yaw,
                );
            }
            let tag = (j * nx + i) as u32;
            out.extend(tris.iter().map(|t| (tag, *t)));
        }
    }
    out
}

/// The default (CWBVH, fast build) and the fastest-building alternative.
const CONFIGS: [(BvhLayout, BuildQuality); 2] = [
    (BvhLayout::Cwbvh, BuildQuality::Fast),
    (BvhLayout::Bvh2, BuildQuality::Fastest),
];

fn build(tris: &[(u32, [DVec3; 3])], (layout, quality): (BvhLayout, BuildQuality)) -> TraceScene {
    let mut b = SceneBuilder::new()
        .with_layout(layout)
        .with_quality(quality);
    for (tag, t) in tris {
        b.add_triangle(*tag, *t);
    }
    b.build()
}

fn hemisphere(n: usize, seed: u64) -> Vec<DVec3> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let z: f64 = rng.random_range(0.0..1.0);
            let phi = rng.random_range(0.0..std::f64::consts::TAU);
            let r = (1.0 - z * z).sqrt();
            DVec3::new(r * phi.sin(), r * phi.cos(), z)
        })
        .collect()
}

fn bench_trace(c: &mut Criterion) {
    let tris300 = city(100, 100, 1);
    let tris600 = city(200, 100, 1);
    // A street crossing near the centre, 1.5 m above ground.
    let poi = UTM + DVec3::new(50.0 * CELL, 50.5 * CELL, 1.5);
    let dirs = hemisphere(10_000, 7);

    let mut g = c.benchmark_group("build");
    g.sample_size(10);
    for (name, tris) in [("300k", &tris300), ("600k", &tris600)] {
        for config in CONFIGS {
            g.bench_function(
                BenchmarkId::new(
                    format!("{:?}_{:?}", config.0, config.1),
                    format!("{name}_{}", tris.len()),
                ),
                |b| b.iter(|| black_box(build(tris, config)).len()),
            );
        }
    }
    g.finish();

    let mut g = c.benchmark_group("rays10k");
    g.sample_size(10);
    g.throughput(Throughput::Elements(dirs.len() as u64));
    for config in CONFIGS {
        let scene = build(&tris300, config);
        let hits = dirs
            .iter()
            .filter(|d| scene.occluded(poi, **d, 0.0, f64::INFINITY))
            .count();
        let name = format!("{:?}_{:?}_300k_blocked_{hits}", config.0, config.1);
        g.bench_function(BenchmarkId::new("first_hit", &name), |b| {
            b.iter(|| {
                dirs.iter()
                    .filter_map(|d| scene.first_hit(poi, *d, 0.0, f64::INFINITY))
                    .count()
            })
        });
        g.bench_function(BenchmarkId::new("occluded", &name), |b| {
            b.iter(|| {
                dirs.iter()
                    .filter(|d| scene.occluded(poi, **d, 0.0, f64::INFINITY))
                    .count()
            })
        });
        g.bench_function(BenchmarkId::new("first_hit_par", &name), |b| {
            b.iter(|| {
                dirs.par_iter()
                    .filter_map(|d| scene.first_hit(poi, *d, 0.0, f64::INFINITY))
                    .count()
            })
        });
        g.bench_function(BenchmarkId::new("occluded_par", &name), |b| {
            b.iter(|| {
                dirs.par_iter()
                    .filter(|d| scene.occluded(poi, **d, 0.0, f64::INFINITY))
                    .count()
            })
        });
    }
    // Baseline: f64 brute force over 1,000 triangles (x300 for the whole scene).
    let subset: Vec<[DVec3; 3]> = tris300.iter().take(1000).map(|t| t.1).collect();
    g.bench_function("baseline_brute_force_1k_tris", |b| {
        b.iter(|| {
            dirs.iter()
                .filter(|d| {
                    subset
                        .iter()
                        .any(|t| ray_triangle(poi, **d, t, 0.0, f64::INFINITY).is_some())
                })
                .count()
        })
    });
    g.finish();
    // Keep the polygon path compiled into the bench too (add_polygon on a roof).
    let mut b = SceneBuilder::new();
    b.add_polygon(0, &Polygon::new(vec![UTM, UTM + DVec3::X, UTM + DVec3::Y]));
    black_box(b.build());
}

criterion_group! {
    name = benches;
    config = Criterion::default().measurement_time(Duration::from_secs(3)).warm_up_time(Duration::from_secs(1));
    targets = bench_trace
}
criterion_main!(benches);
