//! Building ray-tracing scenes from a model: the full-detail model, the rough model, or a
//! mixed-LoD model given a level per asset. Triangles are tagged with the asset index.
//!
//! # Example
//! ```
//! use glam::DVec3;
//! use skylod::model::{Asset, AssetKind, CityModel, LodGeometry, Polygon};
//! let mut m = CityModel::default();
//! let quad = Polygon::new(vec![
//!     DVec3::new(-1.0, -1.0, 5.0), DVec3::new(1.0, -1.0, 5.0),
//!     DVec3::new(1.0, 1.0, 5.0), DVec3::new(-1.0, 1.0, 5.0),
//! ]);
//! m.assets.push(Asset {
//!     kind: AssetKind::Roof, id: None, element: "RoofSurface".into(), building: None,
//!     parent: None, span: 0..0, line: 1, function: None, file: 0,
//!     geometries: vec![LodGeometry { lod: 2, polygons: vec![quad], ..Default::default() }],
//! });
//! let scene = skylod::lod::full_scene(&m);
//! let hit = scene.first_hit(DVec3::ZERO, DVec3::Z, 0.0, f64::INFINITY).unwrap();
//! assert_eq!(hit.tag, 0);
//! assert!((hit.t - 5.0).abs() < 1e-6);
//! ```

use crate::lod::rough::RoughGeometry;
use crate::model::triangulate;
use crate::model::{Asset, Bbox, CityModel};
use crate::solar::trace::{SceneBuilder, TraceScene};
use glam::DVec3;
use rayon::prelude::*;

/// Assets triangulated per parallel task, and per group added before the next group is
/// triangulated (the group's triangles are the only extra memory).
const CHUNK: usize = 256;
const GROUP: usize = 1 << 15;

/// Adds the triangles of assets `0..n`, tagged with the asset index, in asset order:
/// `triangles(i, out)` triangulates asset `i`'s polygons into `out`. Triangulation runs
/// in parallel; the scene is the same as with one thread (same triangles, same order).
fn add_assets(
    b: &mut SceneBuilder,
    n: usize,
    triangles: impl Fn(usize, &mut Vec<[DVec3; 3]>) + Sync,
) {
    add_tagged(b, n, |k| k, triangles);
}

/// [`add_assets`] of `n` assets, the `k`-th tagged `tag(k)` (increasing with `k`).
fn add_tagged(
    b: &mut SceneBuilder,
    n: usize,
    tag: impl Fn(usize) -> usize + Sync,
    triangles: impl Fn(usize, &mut Vec<[DVec3; 3]>) + Sync,
) {
    let mut start = 0;
    while start < n {
        let end = n.min(start + GROUP);
        let parts: Vec<Vec<(u32, [DVec3; 3])>> = (start..end)
            .step_by(CHUNK)
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|c| {
                let (mut out, mut scratch) = (Vec::new(), Vec::new());
                for i in c..end.min(c + CHUNK) {
                    scratch.clear();
                    triangles(i, &mut scratch);
                    let t = tag(i) as u32;
                    out.extend(scratch.iter().map(|x| (t, *x)));
                }
                out
            })
            .collect();
        for (tag, t) in parts.into_iter().flatten() {
            b.add_triangle(tag, t);
        }
        start = end;
    }
}

/// Some assets of a model, each with its index there (increasing): what the scenes of a
/// model read hollow are built from ([`full_scene_of`], [`mixed_scene_of`]).
pub type Tagged<'a> = [(usize, &'a Asset)];

/// [`full_scene`] (`frame`: `None`), or its part built in the frame `frame` for about `rays`
/// rays (`Some((frame, rays))`), of the
/// model whose assets `assets` hold every full-detail polygon: the same scene.
pub fn full_scene_of(assets: &Tagged<'_>, frame: Option<(Bbox, usize)>) -> TraceScene {
    let mut b = SceneBuilder::new();
    if let Some((f, _)) = frame {
        b = b.with_frame(f);
    }
    add_tagged(
        &mut b,
        assets.len(),
        |k| assets[k].0,
        |k, out| {
            for p in assets[k].1.detail_polygons() {
                triangulate(p, out);
            }
        },
    );
    match frame {
        Some((_, rays)) => b.for_rays(rays).build(),
        None => b.build(),
    }
}

/// Every asset at full detail (its highest LoD).
pub fn full_scene(model: &CityModel) -> TraceScene {
    let tagged: Vec<(usize, &Asset)> = model.assets.iter().enumerate().collect();
    full_scene_of(&tagged, None)
}

/// Per asset, the bounding box of the finite points of its full-detail polygons (empty
/// when none), which holds every triangle [`full_scene`] makes of it; and the box of all
/// of [`full_scene`]'s triangles ([`TraceScene::bbox`], its frame), found exactly while
/// triangulating only the assets that reach the edges.
pub fn detail_boxes(model: &CityModel) -> (Vec<Bbox>, Bbox) {
    let boxes: Vec<Bbox> = model
        .assets
        .par_iter()
        .with_min_len(CHUNK)
        .map(|a| {
            let mut b = Bbox::EMPTY;
            for p in a.detail_polygons() {
                p.points().filter(|q| q.is_finite()).for_each(|&q| b.add(q));
            }
            b
        })
        .collect();
    let frame = triangles_box(model, &boxes);
    (boxes, frame)
}

/// A 128-bit key of what [`full_scene`] makes of `asset`: its full-detail polygons' rings,
/// their lengths and their points bit for bit (xxh3-128). Two assets with the same key
/// give the same triangles (`crate::lod::hollow::Hollow::twin`: the error bound's
/// reference traces such twins once); `None` for an asset without full-detail polygons.
///
/// ```
/// use glam::DVec3;
/// use skylod::model::{Asset, AssetKind, LodGeometry, Polygon};
/// let triangle = |z: f64| Polygon::new(vec![
///     DVec3::new(0.0, 0.0, z), DVec3::new(1.0, 0.0, z), DVec3::new(1.0, 1.0, z),
/// ]);
/// let roof = |polygons: Vec<Polygon>, id: &str| Asset {
///     kind: AssetKind::Roof, id: Some(id.into()), element: "RoofSurface".into(),
///     building: None, parent: None, span: 0..0, line: 1, function: None, file: 0,
///     geometries: vec![LodGeometry { lod: 3, polygons, ..Default::default() }],
/// };
/// let key = skylod::lod::detail_key;
/// assert_eq!(key(&roof(vec![triangle(5.0)], "a")), key(&roof(vec![triangle(5.0)], "b")));
/// assert_ne!(key(&roof(vec![triangle(5.0)], "a")), key(&roof(vec![triangle(6.0)], "a")));
/// assert_eq!(key(&roof(vec![], "a")), None);
/// ```
pub fn detail_key(asset: &Asset) -> Option<u128> {
    let polygons = asset.detail_polygons();
    if polygons.is_empty() {
        return None;
    }
    let mut h = xxhash_rust::xxh3::Xxh3Default::new();
    let ring = |h: &mut xxhash_rust::xxh3::Xxh3Default, r: &[DVec3]| {
        h.update(&(r.len() as u64).to_le_bytes());
        h.update(bytemuck::cast_slice(r));
    };
    for p in polygons {
        h.update(&(p.interior_count() as u64).to_le_bytes());
        ring(&mut h, p.exterior());
        p.interiors().for_each(|r| ring(&mut h, r));
    }
    Some(h.digest128())
}

/// The box of [`full_scene`]'s triangles, `boxes` from [`detail_boxes`]: on each side, the
/// assets in the order of their box's reach, triangulated until the next cannot reach
/// farther than the triangles found so far.
fn triangles_box(model: &CityModel, boxes: &[Bbox]) -> Bbox {
    let mut exact: Vec<Option<Bbox>> = vec![None; boxes.len()];
    let mut scratch = Vec::new();
    let mut tri_box = |i: usize, exact: &mut Vec<Option<Bbox>>| -> Bbox {
        if let Some(b) = exact[i] {
            return b;
        }
        scratch.clear();
        for p in model.assets[i].detail_polygons() {
            triangulate(p, &mut scratch);
        }
        let mut b = Bbox::EMPTY;
        for t in scratch.iter().filter(|t| SceneBuilder::accepts(t)) {
            t.iter().for_each(|&p| b.add(p));
        }
        exact[i] = Some(b);
        b
    };
    let mut order: Vec<usize> = (0..boxes.len()).filter(|&i| !boxes[i].is_empty()).collect();
    let mut out = Bbox::EMPTY;
    for axis in 0..3 {
        for high in [false, true] {
            // reach of a box on this side, larger is farther out
            let reach = |b: &Bbox| if high { b.max[axis] } else { -b.min[axis] };
            let farther = |a: &usize, b: &usize| reach(&boxes[*b]).total_cmp(&reach(&boxes[*a]));
            // the walk nearly always stops within the first few boxes: the farthest
            // `TOP` sorted first, the whole order only when the walk gets past them
            // (the box found is the same in any order: every side's reach is exact)
            let mut best = f64::NEG_INFINITY;
            let mut sorted = 0;
            let mut at = 0;
            while at < order.len() {
                if at == sorted {
                    sorted = if sorted == 0 && order.len() > TOP {
                        order.select_nth_unstable_by(TOP - 1, farther);
                        order[..TOP].sort_unstable_by(farther);
                        TOP
                    } else {
                        order[sorted..].sort_unstable_by(farther);
                        order.len()
                    };
                }
                let i = order[at];
                if reach(&boxes[i]) <= best {
                    break;
                }
                let b = tri_box(i, &mut exact);
                if !b.is_empty() {
                    best = best.max(reach(&b));
                    out.union(&b);
                }
                at += 1;
            }
        }
    }
    out
}

/// Boxes sorted first on each side in [`triangles_box`].
const TOP: usize = 64;

/// Every asset as its rough geometry (`rough[i]` belongs to asset `i`).
pub fn rough_scene(rough: &[RoughGeometry]) -> TraceScene {
    let mut b = SceneBuilder::new();
    add_assets(&mut b, rough.len(), |i, out| {
        for p in rough[i].polygons().iter() {
            triangulate(p, out);
        }
    });
    b.build()
}

/// The scene the selection traces: the rough model without the openings that their
/// surface's rough plane closes (`crate::lod::level::selection_traced`).
pub fn selection_scene(model: &CityModel, rough: &[RoughGeometry]) -> TraceScene {
    selection_builder(model, rough).build()
}

/// [`selection_scene`] built for about `rays` rays ([`SceneBuilder::for_rays`]): the same
/// answers, a quicker build when few rays are traced.
pub fn selection_scene_for_rays(
    model: &CityModel,
    rough: &[RoughGeometry],
    rays: usize,
) -> TraceScene {
    selection_builder(model, rough).for_rays(rays).build()
}

fn selection_builder(model: &CityModel, rough: &[RoughGeometry]) -> SceneBuilder {
    let traced = crate::lod::level::selection_traced(model);
    let mut b = SceneBuilder::new();
    add_assets(&mut b, rough.len().min(traced.len()), |i, out| {
        if traced[i] {
            for p in rough[i].polygons().iter() {
                triangulate(p, out);
            }
        }
    });
    b
}

/// The mixed-LoD model as `lod` writes it: each asset's [`crate::lod::level::traced`] polygons
/// at its level (level 0 absent).
pub fn mixed_scene(model: &CityModel, rough: &[RoughGeometry], levels: &[u8]) -> TraceScene {
    let mut b = SceneBuilder::new();
    add_assets(&mut b, model.assets.len(), |i, out| {
        mixed_triangles(&model.assets[i], i, rough, levels, out);
    });
    b.build()
}

/// [`mixed_scene`] of the model whose assets `assets` hold every asset above level 0: the
/// same scene.
pub fn mixed_scene_of(assets: &Tagged<'_>, rough: &[RoughGeometry], levels: &[u8]) -> TraceScene {
    let mut b = SceneBuilder::new();
    add_tagged(
        &mut b,
        assets.len(),
        |k| assets[k].0,
        |k, out| {
            mixed_triangles(assets[k].1, assets[k].0, rough, levels, out);
        },
    );
    b.build()
}

/// The triangles of asset `i` in [`mixed_scene`].
fn mixed_triangles(
    a: &Asset,
    i: usize,
    rough: &[RoughGeometry],
    levels: &[u8],
    out: &mut Vec<[DVec3; 3]>,
) {
    let level = levels.get(i).copied().unwrap_or(0);
    for p in crate::lod::level::traced(a, rough.get(i), level).iter() {
        triangulate(p, out);
    }
}
