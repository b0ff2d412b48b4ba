//! Rough stage on a synthetic LoD3 wall (20 x 15 m, 4 x 5 windows with reveals and
//! recessed panes: 101 polygons): plane generalisation against the oriented box of the
//! same polygons (the baseline), and `rough_asset` on the wall asset.

use criterion::{criterion_group, criterion_main, Criterion};
use glam::DVec3;
use skylod::lod::rough::generalize;
use skylod::lod::rough::Obb;
use skylod::lod::rough::{rough_asset, RoughOptions};
use skylod::model::{Asset, AssetKind, LodGeometry, Polygon};
use std::hint::black_box;

/// The wall of the unit tests, placed at UTM-sized coordinates and rotated 30 degrees.
fn lod3_wall() -> Vec<Polygon> {
    let o = DVec3::new(691_234.5, 5_334_567.25, 372.0);
    let (s, c) = 30f64.to_radians().sin_cos();
    let u = DVec3::new(c, s, 0.0);
    let n = u.cross(DVec3::Z);
    let p = |a: f64, h: f64, d: f64| o + u * a + DVec3::Z * h + n * d;
    let quad = |a0: f64, a1: f64, h0: f64, h1: f64, d: f64| {
        vec![p(a0, h0, d), p(a1, h0, d), p(a1, h1, d), p(a0, h1, d)]
    };
    let mut wall = Polygon::new(quad(0.0, 20.0, 0.0, 15.0, 0.0));
    let mut out = Vec::new();
    for row in 0..4 {
        for col in 0..5 {
            let (a0, h0) = (1.4 + 4.0 * col as f64, 1.0 + 3.5 * row as f64);
            let (a1, h1, d) = (a0 + 1.2, h0 + 1.5, -0.2);
            let mut hole = quad(a0, a1, h0, h1, 0.0);
            hole.reverse();
            wall.push_interior(&hole);
            out.push(Polygon::new(vec![
                p(a0, h0, 0.0),
                p(a1, h0, 0.0),
                p(a1, h0, d),
                p(a0, h0, d),
            ]));
            out.push(Polygon::new(vec![
                p(a0, h1, 0.0),
                p(a0, h1, d),
                p(a1, h1, d),
                p(a1, h1, 0.0),
            ]));
            out.push(Polygon::new(vec![
                p(a0, h0, 0.0),
                p(a0, h0, d),
                p(a0, h1, d),
                p(a0, h1, 0.0),
            ]));
            out.push(Polygon::new(vec![
                p(a1, h0, 0.0),
                p(a1, h1, 0.0),
                p(a1, h1, d),
                p(a1, h0, d),
            ]));
            out.push(Polygon::new(quad(a0, a1, h0, h1, d)));
        }
    }
    out.insert(0, wall);
    out
}

fn bench(c: &mut Criterion) {
    let polys = lod3_wall();
    let out = generalize(&polys, 5.0, 0.3);
    assert_eq!((polys.len(), out.len()), (101, 1));
    let asset = Asset {
        kind: AssetKind::Wall,
        id: None,
        element: "WallSurface".into(),
        building: None,
        parent: None,
        span: 0..0,
        line: 1,
        function: None,
        geometries: vec![LodGeometry {
            lod: 3,
            property: "lod3MultiSurface".into(),
            span: 0..0,
            content: 0..0,
            polygons: polys.clone(),
        }],
        file: 0,
    };
    let opts = RoughOptions::default();
    let mut g = c.benchmark_group("lod3_wall_101_polygons");
    g.bench_function("obb_baseline", |b| {
        b.iter(|| Obb::of_polygons(black_box(&polys)))
    });
    g.bench_function("plane_generalize", |b| {
        b.iter(|| generalize(black_box(&polys), 5.0, 0.3))
    });
    g.bench_function("rough_asset", |b| {
        b.iter(|| rough_asset(black_box(&asset), &opts))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
