//! A BVH over axis-aligned boxes that lists every box a ray crosses, nearest first: the
//! cheap first pass of `lod`'s error bound, which builds the full-detail scene only from
//! the assets whose box some ray can reach (`crate::lod::bound`).

use crate::model::Bbox;
use glam::{DVec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::bvh2::Bvh2;
use obvhs::ploc::PlocBuilder;
use obvhs::ray::{Ray, RayHit};
use obvhs::BvhBuildParams;

/// Boxes in model coordinates, each grown by [`BoxIndex::margin`], and their BVH.
#[derive(Clone)]
pub struct BoxIndex {
    origin: DVec3,
    margin: f64,
    /// The boxes as given (model coordinates).
    boxes: Vec<Bbox>,
    /// Slot -> box index, `None` without a box.
    bvh: Option<(Bvh2, Vec<u32>)>,
}

impl std::fmt::Debug for BoxIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BoxIndex")
            .field("boxes", &self.boxes.len())
            .field("margin", &self.margin)
            .finish()
    }
}

impl BoxIndex {
    /// Index `boxes` (empty boxes are never crossed), each grown by `margin` on every
    /// side (in metres, at least zero).
    pub fn new(boxes: Vec<Bbox>, margin: f64) -> BoxIndex {
        let margin = if margin.is_finite() {
            margin.max(0.0)
        } else {
            0.0
        };
        let mut all = Bbox::EMPTY;
        for b in &boxes {
            if b.min.is_finite() && b.max.is_finite() {
                all.union(b);
            }
        }
        let origin = if all.is_empty() {
            DVec3::ZERO
        } else {
            all.center()
        };
        // f32 node boxes grown a little more than the f64 boxes, so that the (non-robust)
        // f32 slab test never drops a box the exact f64 test crosses.
        let far = (all.max - origin).abs().max((all.min - origin).abs());
        let pad = (far.max_element().max(1.0) * (1.0 / 32768.0)) as f32 + margin as f32;
        let mut aabbs = Vec::new();
        let mut ids = Vec::new();
        for (i, b) in boxes.iter().enumerate() {
            if b.is_empty() || !b.min.is_finite() || !b.max.is_finite() {
                continue;
            }
            let lo = Vec3A::from((b.min - origin).as_vec3()) - Vec3A::splat(pad);
            let hi = Vec3A::from((b.max - origin).as_vec3()) + Vec3A::splat(pad);
            aabbs.push(Aabb::new(lo, hi));
            ids.push(i as u32);
        }
        let bvh = (!aabbs.is_empty()).then(|| {
            let p = BvhBuildParams::fast_build();
            let mut bvh = PlocBuilder::with_capacity(aabbs.len()).build(
                p.ploc_search_distance,
                &aabbs,
                (0..aabbs.len() as u32).collect(),
                p.sort_precision,
                p.search_depth_threshold,
            );
            ReinsertionOptimizer::default().run(&mut bvh, p.reinsertion_batch_ratio, None);
            (bvh, ids)
        });
        BoxIndex {
            origin,
            margin,
            boxes,
            bvh,
        }
    }

    /// How far every box is grown on each side.
    pub fn margin(&self) -> f64 {
        self.margin
    }

    /// A box (grown by the margin) that the ray `origin + t dir` (`t >= 0`) crosses first, or
    /// one crossed nearly as soon (the search prunes in f32); `None` when it crosses none.
    pub fn nearest(&self, origin: DVec3, dir: DVec3) -> Option<u32> {
        let mut best: Option<(f64, u32)> = None;
        self.traverse(origin, dir, f64::INFINITY, |t0, i| {
            if best.is_none_or(|(bt, _)| t0 < bt) {
                best = Some((t0, i));
                t0
            } else {
                f64::INFINITY
            }
        });
        best.map(|(_, i)| i)
    }

    /// The first `k` entries of [`BoxIndex::crossed`] with an infinite `tmax` (every box
    /// when the ray crosses fewer), appended to `out`: (entry distance, box index),
    /// nearest first, ties by box index. One traversal that prunes beyond the `k`-th entry
    /// found so far, so it costs about what [`BoxIndex::nearest`] does.
    pub fn nearest_k(&self, origin: DVec3, dir: DVec3, k: usize, out: &mut Vec<(f64, u32)>) {
        if k == 0 {
            return;
        }
        let start = out.len();
        self.traverse(origin, dir, f64::INFINITY, |t0, i| {
            let list = &mut out[start..];
            let at = list.partition_point(|x| x.0 < t0 || (x.0 == t0 && x.1 < i));
            if list.len() == k {
                if at == k {
                    return f64::INFINITY;
                }
                out.pop();
            }
            out.insert(start + at, (t0, i));
            out[start..].get(k - 1).map_or(f64::INFINITY, |&(tk, _)| tk)
        });
    }

    /// The traversal of the three searches: `visit(t0, i)` for each box `i` (grown by the
    /// margin) that the ray `origin + t dir` crosses with `0 <= t <= tmax` (decided in f64,
    /// [`crate::solar::trace::ray::ray_aabb`]; `t0` the entry distance), in the order the tree
    /// gives. `visit` returns the distance beyond which no box is wanted any more
    /// (`f64::INFINITY`: every box); nodes entered a little beyond it are pruned (f32 node
    /// entries are rounded).
    fn traverse(
        &self,
        origin: DVec3,
        dir: DVec3,
        tmax: f64,
        mut visit: impl FnMut(f64, u32) -> f64,
    ) {
        let Some((bvh, ids)) = &self.bvh else {
            return;
        };
        let Some(ray) = self.local_ray(origin, dir, tmax) else {
            return;
        };
        let g = DVec3::splat(self.margin);
        let mut hit = RayHit::none();
        bvh.ray_traverse(ray, &mut hit, |_, slot| {
            let Some((i, b)) = self.slot_box(bvh, ids, slot) else {
                return f32::INFINITY;
            };
            match super::ray::ray_aabb(origin, dir, b.min - g, b.max + g, 0.0, tmax) {
                Some((t0, _)) => (visit(t0, i) * (1.0 + 1e-6) + 1e-3) as f32,
                None => f32::INFINITY,
            }
        });
    }

    fn slot_box<'a>(&'a self, bvh: &Bvh2, ids: &[u32], slot: usize) -> Option<(u32, &'a Bbox)> {
        let k = *bvh.primitive_indices.get(slot)?;
        let i = *ids.get(k as usize)?;
        Some((i, self.boxes.get(i as usize)?))
    }

    /// The f32 ray of a traversal up to about `tmax`, `None` for an invalid ray.
    fn local_ray(&self, origin: DVec3, dir: DVec3, tmax: f64) -> Option<Ray> {
        let o = (origin - self.origin).as_vec3();
        let d = dir.as_vec3();
        if !o.is_finite() || !d.is_finite() || d.length_squared() == 0.0 || tmax.is_nan() {
            return None;
        }
        let tmax32 = (tmax * (1.0 + 1e-6) + 1e-3) as f32;
        Some(Ray::new(
            Vec3A::from(o),
            Vec3A::from(d) + Vec3A::ZERO,
            0.0,
            tmax32,
        ))
    }

    /// Every box (grown by the margin) that the ray `origin + t dir` crosses with
    /// `0 <= t <= tmax`, as (entry distance, box index) appended to `out`, nearest first
    /// (ties by box index). The entry distance is 0 for a box around the origin. The
    /// crossing is decided in f64 ([`crate::solar::trace::ray::ray_aabb`]).
    pub fn crossed(&self, origin: DVec3, dir: DVec3, tmax: f64, out: &mut Vec<(f64, u32)>) {
        let start = out.len();
        self.traverse(origin, dir, tmax, |t0, i| {
            out.push((t0, i));
            // never a hit: every node the ray crosses is visited
            f64::INFINITY
        });
        out[start..].sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn lists_the_same_boxes_as_brute_force() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let o = DVec3::new(430_000.0, 4_581_000.0, 0.0);
        let boxes: Vec<Bbox> = (0..2000)
            .map(|i| {
                if i % 97 == 0 {
                    return Bbox::EMPTY;
                }
                let c = o + DVec3::new(
                    rng.random_range(-500.0..500.0),
                    rng.random_range(-500.0..500.0),
                    rng.random_range(0.0..40.0),
                );
                let h = DVec3::new(
                    rng.random_range(0.0..10.0),
                    rng.random_range(0.0..10.0),
                    rng.random_range(0.0..10.0),
                );
                Bbox {
                    min: c - h,
                    max: c + h,
                }
            })
            .collect();
        let index = BoxIndex::new(boxes.clone(), 0.01);
        let mut seen = 0;
        for r in 0..400 {
            let p = o + DVec3::new(
                rng.random_range(-300.0..300.0),
                rng.random_range(-300.0..300.0),
                1.5,
            );
            let mut d = DVec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(0.0..0.3),
            );
            if r % 10 == 0 {
                d.y = 0.0; // axis-parallel component
            }
            let d = d.normalize();
            let tmax = if r % 3 == 0 { 200.0 } else { f64::INFINITY };
            let mut got = Vec::new();
            index.crossed(p, d, tmax, &mut got);
            let g = DVec3::splat(0.01);
            let mut want: Vec<(f64, u32)> = boxes
                .iter()
                .enumerate()
                .filter(|(_, b)| !b.is_empty())
                .filter_map(|(i, b)| {
                    super::super::ray::ray_aabb(p, d, b.min - g, b.max + g, 0.0, tmax)
                        .map(|(t0, _)| (t0, i as u32))
                })
                .collect();
            want.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            assert_eq!(got, want, "ray {r}");
            assert!(got.windows(2).all(|w| w[0].0 <= w[1].0));
            if tmax.is_infinite() {
                for k in [1, 3, 8] {
                    let mut first = Vec::new();
                    index.nearest_k(p, d, k, &mut first);
                    assert_eq!(first, got[..k.min(got.len())], "ray {r}, k {k}");
                }
            }
            let near = index.nearest(p, d);
            if tmax.is_infinite() {
                assert_eq!(near.is_some(), !got.is_empty(), "ray {r}");
                if let (Some(n), Some(first)) = (near, got.first()) {
                    let e = got.iter().find(|x| x.1 == n).map(|x| x.0);
                    assert!(e.is_some_and(|e| e <= first.0 + 1e-2), "ray {r}");
                }
            }
            seen += got.len();
        }
        assert!(seen > 400, "{seen} crossings");
    }
}
