//! Generalisation of shell surfaces to their planes (LoD3 -> LoD2-like, paper 4.3).
//!
//! The polygons of one asset are grouped by plane, largest first: a polygon joins the
//! first group whose seed plane it parallels (normals within `angle_deg`, same side) with
//! every vertex within `thickness_m` of that plane. Otherwise, a polygon that is not
//! facing the opposite way and whose vertices all lie within `thickness_m` of a group's
//! plane is *absorbed* by that group (window reveals, sills, frames: their projection is
//! thin or degenerate and disappears in the union). Anything else seeds a new group.
//!
//! Each group is projected onto its plane (area-weighted normal of its parallel members,
//! through the centroid of its largest polygon), the exterior rings of its members are
//! united with `geo`'s boolean operations, every hole is filled (openings closed), parts
//! lying inside another part's filled outline are dropped, collinear vertices are removed,
//! and the result is lifted back to 3D. Filling holes before or after the union gives the
//! same region, so only exterior rings enter the union.
//!
//! Degenerate input (fewer than 3 finite points, zero area) is skipped; if the union comes
//! out smaller than the group's largest member (which a correct union cannot), the group
//! falls back to the convex hull of its projected points. Nothing here panics on input.

use crate::model::{newell, Polygon};
use geo::{unary_union, Area, ConvexHull, Coord, LineString, MultiPoint, Polygon as GeoPolygon};
use glam::{DVec2, DVec3};

/// Polygons smaller than this (m²) are ignored.
const AREA_EPS: f64 = 1e-8;
/// A vertex closer than this (m) to the line through its neighbours is removed.
const COLLINEAR_EPS: f64 = 1e-4;

/// Generalise polygons to their planes; see the module documentation.
///
/// `angle_deg` is the largest angle between normals of one plane, `thickness_m` the
/// largest distance of a member's vertex from the group plane. Output rings are open,
/// without holes, counter-clockwise seen from the side their group's normal points to,
/// and without ids.
///
/// # Example
/// ```rust
/// use glam::DVec3;
/// use skylod::model::Polygon;
/// use skylod::lod::rough::generalize;
/// // Two halves of a 10 x 4 wall (y = 0, facing -y) and a recessed pane 0.1 m behind.
/// let quad = |x0: f64, x1: f64, z0: f64, z1: f64, y: f64| Polygon::new(vec![
///     DVec3::new(x0, y, z0), DVec3::new(x1, y, z0), DVec3::new(x1, y, z1), DVec3::new(x0, y, z1),
/// ]);
/// let polys = [quad(0.0, 5.0, 0.0, 4.0, 0.0), quad(5.0, 10.0, 0.0, 4.0, 0.0), quad(2.0, 3.0, 1.0, 2.0, 0.1)];
/// let out = generalize(&polys, 5.0, 0.3);
/// assert_eq!(out.len(), 1);
/// assert_eq!(out[0].exterior().len(), 4);
/// assert!((out[0].area() - 40.0).abs() < 1e-9);
/// ```
pub fn generalize<'a>(
    polygons: impl IntoIterator<Item = &'a Polygon>,
    angle_deg: f64,
    thickness_m: f64,
) -> Vec<Polygon> {
    generalize_with(polygons, angle_deg, thickness_m, false)
}

/// [`generalize`] that keeps the holes: the members' interior rings enter the union and
/// the union's holes stay (a courtyard stays open), nothing is dropped as enclosed, and a
/// group whose union comes out smaller than its largest member keeps its members as
/// they are (projected). The generalised polygons cover the same ground as the input's:
/// the rough form of a whole-building asset (see [`crate::lod::rough`]).
///
/// # Example
/// ```rust
/// use glam::DVec3;
/// use skylod::model::Polygon;
/// use skylod::lod::rough::generalize_keeping_holes;
/// let sq = |a: f64, b: f64| vec![
///     DVec3::new(a, a, 15.0), DVec3::new(b, a, 15.0), DVec3::new(b, b, 15.0), DVec3::new(a, b, 15.0),
/// ];
/// let mut hole = sq(15.0, 45.0);
/// hole.reverse();
/// let roof = Polygon::from_rings(None, &sq(0.0, 60.0), &[hole]);
/// let out = generalize_keeping_holes([&roof], 5.0, 0.3);
/// assert_eq!((out.len(), out[0].interior_count()), (1, 1));
/// assert!((out[0].area() - (3600.0 - 900.0)).abs() < 1e-6);
/// ```
pub fn generalize_keeping_holes<'a>(
    polygons: impl IntoIterator<Item = &'a Polygon>,
    angle_deg: f64,
    thickness_m: f64,
) -> Vec<Polygon> {
    generalize_with(polygons, angle_deg, thickness_m, true)
}

fn generalize_with<'a>(
    polygons: impl IntoIterator<Item = &'a Polygon>,
    angle_deg: f64,
    thickness_m: f64,
    keep_holes: bool,
) -> Vec<Polygon> {
    let cos_a = angle_deg.to_radians().cos();
    let thick = if thickness_m.is_finite() {
        thickness_m.max(0.0)
    } else {
        0.0
    };

    let (items, origin) = prepare(polygons, keep_holes);
    let mut order: Vec<usize> = (0..items.len()).collect();
    order.sort_by(|&a, &b| items[b].area.total_cmp(&items[a].area).then(a.cmp(&b)));

    let mut groups: Vec<Group> = Vec::new();
    for &i in &order {
        let it = &items[i];
        let within = |g: &Group| {
            it.pts
                .iter()
                .all(|p| (*p - g.point).dot(g.seed_normal).abs() <= thick)
        };
        if let Some(g) = groups
            .iter_mut()
            .find(|g| it.normal.dot(g.seed_normal) >= cos_a && within(g))
        {
            g.normal_sum += it.normal * it.area;
            g.members.push(i);
        } else if let Some(g) = groups
            .iter_mut()
            .find(|g| it.normal.dot(g.seed_normal) > -cos_a && within(g))
        {
            g.members.push(i);
        } else {
            groups.push(Group {
                seed_normal: it.normal,
                point: it.centroid,
                normal_sum: it.normal * it.area,
                members: vec![i],
            });
        }
    }

    let mut out = Vec::new();
    for g in &groups {
        if keep_holes {
            flatten_group_keeping_holes(g, &items, origin, &mut out);
        } else {
            flatten_group(g, &items, origin, &mut out);
        }
    }
    out
}

/// A usable input polygon in local coordinates.
struct Item {
    /// Exterior ring, local coordinates, finite points only.
    pts: Vec<DVec3>,
    /// Interior rings, local coordinates, finite points only (empty unless holes are kept).
    holes: Vec<Vec<DVec3>>,
    /// Unit normal.
    normal: DVec3,
    /// Area of the exterior ring.
    area: f64,
    /// Mean of the ring's points.
    centroid: DVec3,
}

struct Group {
    seed_normal: DVec3,
    /// Point on the plane (centroid of the seed polygon), local coordinates.
    point: DVec3,
    /// Sum of area-weighted normals of the parallel members.
    normal_sum: DVec3,
    members: Vec<usize>,
}

/// Usable polygons relative to a local origin (the first finite point met), and the origin.
fn prepare<'a>(
    polygons: impl IntoIterator<Item = &'a Polygon>,
    keep_holes: bool,
) -> (Vec<Item>, DVec3) {
    let mut origin: Option<DVec3> = None;
    let mut items = Vec::new();
    for p in polygons {
        let Some(o) = origin.or_else(|| p.exterior().iter().find(|q| q.is_finite()).copied())
        else {
            continue;
        };
        origin = Some(o);
        let pts: Vec<DVec3> = p
            .exterior()
            .iter()
            .filter(|q| q.is_finite())
            .map(|q| *q - o)
            .collect();
        if pts.len() < 3 {
            continue;
        }
        let n = newell(&pts);
        let area = n.length() * 0.5;
        if area <= AREA_EPS || !area.is_finite() {
            continue;
        }
        let centroid = pts.iter().sum::<DVec3>() / pts.len() as f64;
        let holes = if keep_holes {
            p.interiors()
                .map(|r| {
                    r.iter()
                        .filter(|q| q.is_finite())
                        .map(|q| *q - o)
                        .collect::<Vec<_>>()
                })
                .filter(|r| r.len() >= 3)
                .collect()
        } else {
            Vec::new()
        };
        items.push(Item {
            holes,
            normal: n / (2.0 * area),
            area,
            centroid,
            pts,
        });
    }
    (items, origin.unwrap_or(DVec3::ZERO))
}

/// An orthonormal basis (u, v) of the plane with normal `n`, u x v = n; u horizontal
/// unless the plane is horizontal.
fn plane_basis(n: DVec3) -> (DVec3, DVec3) {
    let h = n.cross(DVec3::Z);
    let u = if h.length_squared() > 1e-12 {
        h.normalize()
    } else {
        DVec3::X
    };
    let u = (u - n * u.dot(n)).normalize();
    (u, n.cross(u))
}

/// The group's plane basis `(u, v)`: from its summed normal, or its seed's when they cancel.
fn group_basis(g: &Group) -> (DVec3, DVec3) {
    let n = g.normal_sum.normalize_or_zero();
    plane_basis(if n == DVec3::ZERO { g.seed_normal } else { n })
}

/// The group's members projected into its plane (basis `u`, `v`, origin `g.point`), exterior
/// rings counter-clockwise, members seen edge-on left out; with `keep_holes` their holes come
/// along, clockwise. Also the largest member area (of the exterior alone without holes, as
/// [`flatten_group`] compares it; of the polygon with its holes otherwise).
fn projected_parts(
    g: &Group,
    items: &[Item],
    (u, v): (DVec3, DVec3),
    keep_holes: bool,
) -> (Vec<GeoPolygon<f64>>, f64) {
    let to2 = |p: &DVec3| {
        let d = *p - g.point;
        Coord {
            x: d.dot(u),
            y: d.dot(v),
        }
    };
    let mut parts: Vec<GeoPolygon<f64>> = Vec::with_capacity(g.members.len());
    let mut max_area = 0.0f64;
    for &i in &g.members {
        let Some(it) = items.get(i) else { continue };
        let mut ring: Vec<Coord<f64>> = it.pts.iter().map(to2).collect();
        let signed = signed_area(&ring);
        if signed.abs() <= AREA_EPS {
            continue; // degenerate projection: a reveal seen edge-on
        }
        if signed < 0.0 {
            ring.reverse();
        }
        if !keep_holes {
            max_area = max_area.max(signed.abs());
            parts.push(GeoPolygon::new(LineString::new(ring), Vec::new()));
            continue;
        }
        let holes: Vec<LineString<f64>> = it
            .holes
            .iter()
            .map(|h| {
                let mut r: Vec<Coord<f64>> = h.iter().map(to2).collect();
                if signed_area(&r) > 0.0 {
                    r.reverse();
                }
                LineString::new(r)
            })
            .collect();
        let part = GeoPolygon::new(LineString::new(ring), holes);
        max_area = max_area.max(part.unsigned_area());
        parts.push(part);
    }
    (parts, max_area)
}

fn flatten_group(g: &Group, items: &[Item], origin: DVec3, out: &mut Vec<Polygon>) {
    let (u, v) = group_basis(g);
    let (parts, max_area) = projected_parts(g, items, (u, v), false);
    if parts.is_empty() {
        return;
    }

    let mut rings: Vec<Vec<DVec2>> = if parts.len() == 1 {
        parts
            .iter()
            .map(|p| {
                p.exterior()
                    .coords()
                    .map(|c| DVec2::new(c.x, c.y))
                    .collect()
            })
            .collect()
    } else {
        let merged = unary_union(&parts);
        let exteriors: Vec<GeoPolygon<f64>> = merged
            .0
            .iter()
            .map(|p| GeoPolygon::new(p.exterior().clone(), Vec::new()))
            .collect();
        let filled_area: f64 = exteriors.iter().map(|p| p.unsigned_area()).sum();
        if filled_area.is_finite() && filled_area >= max_area * (1.0 - 1e-6) {
            drop_enclosed(&exteriors)
        } else {
            let all: MultiPoint<f64> = parts
                .iter()
                .flat_map(|p| p.exterior().coords().copied())
                .collect();
            let hull = all.convex_hull();
            vec![hull
                .exterior()
                .coords()
                .map(|c| DVec2::new(c.x, c.y))
                .collect()]
        }
    };

    for ring in &mut rings {
        simplify_ring(ring);
        if ring.len() < 3 {
            continue;
        }
        let mut pts: Vec<DVec2> = std::mem::take(ring);
        if signed_area_v(&pts) < 0.0 {
            pts.reverse();
        }
        let base = origin + g.point;
        out.push(Polygon::new(
            pts.iter().map(|q| base + u * q.x + v * q.y).collect(),
        ));
    }
}

/// [`flatten_group`] keeping the holes (see [`generalize_keeping_holes`]).
fn flatten_group_keeping_holes(g: &Group, items: &[Item], origin: DVec3, out: &mut Vec<Polygon>) {
    let (u, v) = group_basis(g);
    let (parts, max_area) = projected_parts(g, items, (u, v), true);
    if parts.is_empty() {
        return;
    }
    let merged: Vec<GeoPolygon<f64>> = if parts.len() == 1 {
        parts
    } else {
        let m = unary_union(&parts);
        let area = m.unsigned_area();
        if area.is_finite() && area >= max_area * (1.0 - 1e-6) {
            m.0
        } else {
            // a union that lost area: keep the members as they are
            parts
        }
    };
    let base = origin + g.point;
    let lift = |q: &DVec2| base + u * q.x + v * q.y;
    for p in &merged {
        let mut ext: Vec<DVec2> = p
            .exterior()
            .coords()
            .map(|c| DVec2::new(c.x, c.y))
            .collect();
        simplify_ring(&mut ext);
        if ext.len() < 3 {
            continue;
        }
        if signed_area_v(&ext) < 0.0 {
            ext.reverse();
        }
        let holes: Vec<Vec<DVec3>> = p
            .interiors()
            .iter()
            .filter_map(|h| {
                let mut r: Vec<DVec2> = h.coords().map(|c| DVec2::new(c.x, c.y)).collect();
                simplify_ring(&mut r);
                if r.len() < 3 || signed_area_v(&r).abs() <= AREA_EPS {
                    return None;
                }
                if signed_area_v(&r) > 0.0 {
                    r.reverse();
                }
                Some(r.iter().map(lift).collect())
            })
            .collect();
        let ext3: Vec<DVec3> = ext.iter().map(lift).collect();
        out.push(Polygon::from_rings(None, &ext3, &holes));
    }
}

/// Exterior rings of `polys` that are not inside another one's outline.
fn drop_enclosed(polys: &[GeoPolygon<f64>]) -> Vec<Vec<DVec2>> {
    use geo::{Contains, InteriorPoint};
    polys
        .iter()
        .enumerate()
        .filter(|(i, p)| {
            let Some(inside) = p.interior_point() else {
                return false;
            };
            !polys.iter().enumerate().any(|(j, q)| {
                j != *i && q.unsigned_area() > p.unsigned_area() && q.contains(&inside)
            })
        })
        .map(|(_, p)| {
            p.exterior()
                .coords()
                .map(|c| DVec2::new(c.x, c.y))
                .collect()
        })
        .collect()
}

fn signed_area(ring: &[Coord<f64>]) -> f64 {
    let len = ring.len();
    let mut s = 0.0;
    for i in 0..len {
        let a = ring[i];
        let b = ring[(i + 1) % len];
        s += a.x * b.y - b.x * a.y;
    }
    s * 0.5
}

fn signed_area_v(ring: &[DVec2]) -> f64 {
    let len = ring.len();
    (0..len)
        .map(|i| ring[i].perp_dot(ring[(i + 1) % len]))
        .sum::<f64>()
        * 0.5
}

/// Open the ring (drop a closing point) and remove repeated and collinear vertices.
fn simplify_ring(ring: &mut Vec<DVec2>) {
    loop {
        let before = ring.len();
        ring.dedup_by(|a, b| a.distance(*b) <= COLLINEAR_EPS);
        while ring.len() > 1
            && ring
                .first()
                .zip(ring.last())
                .is_some_and(|(a, b)| a.distance(*b) <= COLLINEAR_EPS)
        {
            ring.pop();
        }
        let len = ring.len();
        if len < 3 {
            return;
        }
        let mut keep: Vec<DVec2> = Vec::with_capacity(len);
        for i in 0..len {
            let prev = keep.last().copied().unwrap_or(ring[(i + len - 1) % len]);
            let cur = ring[i];
            let next = ring[(i + 1) % len];
            let base = next - prev;
            let bl = base.length();
            // Collinear (or a zero-width spike, whose neighbours coincide): drop.
            let degenerate =
                bl <= COLLINEAR_EPS || base.perp_dot(cur - prev).abs() / bl <= COLLINEAR_EPS;
            if !degenerate {
                keep.push(cur);
            }
        }
        *ring = keep;
        if ring.len() == before {
            return;
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A frame on a vertical wall plane: `o` origin, `u` along the wall (horizontal),
    /// outward normal `n = u x z`, so rings counter-clockwise in (u, z) face outward.
    pub(crate) struct WallFrame {
        pub o: DVec3,
        pub u: DVec3,
    }

    impl WallFrame {
        pub fn new(o: DVec3, angle_deg: f64) -> Self {
            let (s, c) = angle_deg.to_radians().sin_cos();
            WallFrame {
                o,
                u: DVec3::new(c, s, 0.0),
            }
        }
        /// Outward normal.
        pub fn n(&self) -> DVec3 {
            self.u.cross(DVec3::Z)
        }
        /// Point at wall coordinate (a along the wall, h up, d in front of the wall).
        pub fn p(&self, a: f64, h: f64, d: f64) -> DVec3 {
            self.o + self.u * a + DVec3::Z * h + self.n() * d
        }
        /// Quad in a plane parallel to the wall at depth d, counter-clockwise from outside.
        pub fn quad(&self, a0: f64, a1: f64, h0: f64, h1: f64, d: f64) -> Vec<DVec3> {
            vec![
                self.p(a0, h0, d),
                self.p(a1, h0, d),
                self.p(a1, h1, d),
                self.p(a0, h1, d),
            ]
        }
    }

    /// A 20 x 15 m LoD3 wall with a 4 x 5 grid of 1.2 x 1.5 m windows, each with four
    /// 0.2 m deep reveal quads and a recessed pane: 101 polygons.
    pub(crate) fn lod3_wall(f: &WallFrame) -> Vec<Polygon> {
        let mut wall = Polygon::new(f.quad(0.0, 20.0, 0.0, 15.0, 0.0));
        let mut out = Vec::new();
        for row in 0..4 {
            for col in 0..5 {
                let a0 = 1.4 + 4.0 * col as f64;
                let h0 = 1.0 + 3.5 * row as f64;
                let (a1, h1) = (a0 + 1.2, h0 + 1.5);
                let mut hole = f.quad(a0, a1, h0, h1, 0.0);
                hole.reverse();
                wall.push_interior(&hole);
                // Reveals: from the wall plane (d = 0) to the pane (d = -0.2), facing in.
                let d = -0.2;
                out.push(Polygon::new(vec![
                    f.p(a0, h0, 0.0),
                    f.p(a1, h0, 0.0),
                    f.p(a1, h0, d),
                    f.p(a0, h0, d),
                ]));
                out.push(Polygon::new(vec![
                    f.p(a0, h1, 0.0),
                    f.p(a0, h1, d),
                    f.p(a1, h1, d),
                    f.p(a1, h1, 0.0),
                ]));
                out.push(Polygon::new(vec![
                    f.p(a0, h0, 0.0),
                    f.p(a0, h0, d),
                    f.p(a0, h1, d),
                    f.p(a0, h1, 0.0),
                ]));
                out.push(Polygon::new(vec![
                    f.p(a1, h0, 0.0),
                    f.p(a1, h1, 0.0),
                    f.p(a1, h1, d),
                    f.p(a1, h0, d),
                ]));
                out.push(Polygon::new(f.quad(a0, a1, h0, h1, d)));
            }
        }
        out.insert(0, wall);
        out
    }

    #[test]
    fn lod3_wall_becomes_one_rectangle() {
        let f = WallFrame::new(DVec3::new(691_234.5, 5_334_567.25, 372.0), 30.0);
        let polys = lod3_wall(&f);
        assert_eq!(polys.len(), 101);
        let out = generalize(&polys, 5.0, 0.3);
        assert_eq!(out.len(), 1, "{out:?}");
        let r = &out[0];
        assert!(
            r.exterior().len() <= 8 && r.exterior().len() >= 4,
            "{}",
            r.exterior().len()
        );
        assert!(r.interior_count() == 0);
        assert!((r.area() - 300.0).abs() < 1e-6, "{}", r.area());
        for p in r.exterior() {
            assert!((*p - f.o).dot(f.n()).abs() < 1e-6, "off the wall plane");
        }
        // Facing outward like the wall.
        assert!(r.newell_normal().normalize().dot(f.n()) > 1.0 - 1e-9);
    }

    #[test]
    fn wall_split_into_strips_with_protruding_sills_unions() {
        // The same wall without holes: strips between and around the windows, plus
        // sills 0.1 m in front (top faces horizontal, front faces parallel).
        let f = WallFrame::new(DVec3::new(500.0, 200.0, 0.0), -72.0);
        let mut polys = vec![
            Polygon::new(f.quad(0.0, 20.0, 0.0, 1.0, 0.0)),
            Polygon::new(f.quad(0.0, 20.0, 2.5, 15.0, 0.0)),
            Polygon::new(f.quad(0.0, 1.4, 1.0, 2.5, 0.0)),
        ];
        for col in 0..5 {
            let a0 = 1.4 + 4.0 * col as f64;
            polys.push(Polygon::new(f.quad(
                a0 + 1.2,
                (a0 + 4.0).min(20.0),
                1.0,
                2.5,
                0.0,
            )));
            polys.push(Polygon::new(f.quad(a0, a0 + 1.2, 1.0, 2.5, -0.15)));
            // Sill front (parallel) and top (horizontal, absorbed).
            polys.push(Polygon::new(f.quad(a0 - 0.1, a0 + 1.3, 0.95, 1.0, 0.1)));
            polys.push(Polygon::new(vec![
                f.p(a0 - 0.1, 1.0, 0.1),
                f.p(a0 - 0.1, 1.0, 0.0),
                f.p(a0 + 1.3, 1.0, 0.0),
                f.p(a0 + 1.3, 1.0, 0.1),
            ]));
        }
        let out = generalize(&polys, 5.0, 0.3);
        assert_eq!(out.len(), 1, "{out:?}");
        assert!((out[0].area() - 300.0).abs() < 1e-6, "{}", out[0].area());
        assert!(out[0].exterior().len() <= 8);
    }

    #[test]
    fn l_shaped_roof_unions_to_one_polygon() {
        // Two coplanar pieces of a roof sloping 20 degrees towards -y.
        let t = 20f64.to_radians().tan();
        let p = |x: f64, y: f64| DVec3::new(x, y, 10.0 + y * t);
        let a = Polygon::new(vec![p(0.0, 0.0), p(10.0, 0.0), p(10.0, 4.0), p(0.0, 4.0)]);
        let b = Polygon::new(vec![p(0.0, 4.0), p(4.0, 4.0), p(4.0, 10.0), p(0.0, 10.0)]);
        let (aa, ab) = (a.area(), b.area());
        let out = generalize(&[a, b], 5.0, 0.3);
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].exterior().len(), 6, "{:?}", out[0].exterior());
        assert!((out[0].area() - (aa + ab)).abs() < 1e-6);
        assert!(out[0].newell_normal().z > 0.0);
    }

    #[test]
    fn pitched_roof_keeps_two_planes() {
        let t = 35f64.to_radians().tan();
        let p = |x: f64, y: f64| DVec3::new(x, y, 8.0 + (5.0 - (y - 5.0).abs()) * t);
        let south = Polygon::new(vec![p(0.0, 0.0), p(12.0, 0.0), p(12.0, 5.0), p(0.0, 5.0)]);
        let north = Polygon::new(vec![p(0.0, 5.0), p(12.0, 5.0), p(12.0, 10.0), p(0.0, 10.0)]);
        let area = south.area();
        let out = generalize(&[south, north], 5.0, 0.3);
        assert_eq!(out.len(), 2);
        for r in &out {
            assert_eq!(r.exterior().len(), 4);
            assert!((r.area() - area).abs() < 1e-6);
        }
        assert!(out[0].newell_normal().y * out[1].newell_normal().y < 0.0);
    }

    #[test]
    fn opposite_faces_are_not_merged() {
        // Both sides of a 0.2 m parapet: antiparallel, within the thickness.
        let f = WallFrame::new(DVec3::ZERO, 0.0);
        let front = Polygon::new(f.quad(0.0, 5.0, 0.0, 1.0, 0.0));
        let mut back = f.quad(0.0, 5.0, 0.0, 1.0, -0.2);
        back.reverse();
        let out = generalize(&[front, Polygon::new(back)], 5.0, 0.3);
        assert_eq!(out.len(), 2);
    }

    #[test]
    fn island_inside_a_hole_is_dropped_and_degenerates_skipped() {
        // A wall ring (outer square minus inner square as two U-shapes would be complex);
        // use a frame made of four strips around a hole and a small pane floating in
        // the hole with a gap: the filled outline swallows the pane.
        let f = WallFrame::new(DVec3::new(10.0, 10.0, 0.0), 10.0);
        let polys = vec![
            Polygon::new(f.quad(0.0, 6.0, 0.0, 1.0, 0.0)),
            Polygon::new(f.quad(0.0, 6.0, 5.0, 6.0, 0.0)),
            Polygon::new(f.quad(0.0, 1.0, 1.0, 5.0, 0.0)),
            Polygon::new(f.quad(5.0, 6.0, 1.0, 5.0, 0.0)),
            Polygon::new(f.quad(2.0, 4.0, 2.0, 4.0, -0.1)),
            // Degenerate: zero area, too few points, NaN.
            Polygon::new(vec![
                f.p(0.0, 0.0, 0.0),
                f.p(1.0, 0.0, 0.0),
                f.p(2.0, 0.0, 0.0),
            ]),
            Polygon::new(vec![f.p(0.0, 0.0, 0.0), f.p(1.0, 0.0, 0.0)]),
            Polygon::new(vec![DVec3::NAN, DVec3::NAN, DVec3::NAN]),
        ];
        let out = generalize(&polys, 5.0, 0.3);
        assert_eq!(out.len(), 1, "{out:?}");
        assert!((out[0].area() - 36.0).abs() < 1e-6);
        assert_eq!(out[0].exterior().len(), 4);
        assert!(generalize(&[], 5.0, 0.3).is_empty());
    }

    #[test]
    fn simplify_removes_collinear_and_duplicates() {
        let mut r = vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(2.0, 0.0),
            DVec2::new(2.0, 1.0),
            DVec2::new(0.0, 1.0),
            DVec2::new(0.0, 0.5),
            DVec2::new(0.0, 0.0),
        ];
        simplify_ring(&mut r);
        assert_eq!(r.len(), 4, "{r:?}");
        assert!((signed_area_v(&r) - 2.0).abs() < 1e-12);
    }

    proptest::proptest! {
        #[test]
        fn random_coplanar_rectangles_stay_in_plane_and_cover(
            rects in proptest::collection::vec((0.0f64..30.0, 0.0f64..20.0, 0.2f64..10.0, 0.2f64..8.0, -0.25f64..0.25), 1..25),
            angle in 0.0f64..360.0,
            ox in 3e5f64..8e5, oy in 5.0e6f64..6.0e6,
        ) {
            let f = WallFrame::new(DVec3::new(ox, oy, 300.0), angle);
            let polys: Vec<Polygon> = rects
                .iter()
                .map(|&(a, h, w, t, d)| Polygon::new(f.quad(a, a + w, h, h + t, d)))
                .collect();
            let out = generalize(&polys, 5.0, 0.3);
            proptest::prop_assert!(!out.is_empty() && out.len() <= polys.len());
            let largest = polys.iter().map(Polygon::area).fold(0.0, f64::max);
            let total_in: f64 = polys.iter().map(Polygon::area).sum();
            let covered: f64 = out.iter().map(Polygon::area).sum();
            proptest::prop_assert!(covered >= largest - 1e-6);
            // Holes filled can add area, but never beyond the rectangles' bounding box: per
            // plane (rectangles up to 0.5 m apart in depth, beyond the 0.3 m thickness, make
            // planes of their own whose outlines overlap seen from the front).
            let (a0, a1) = rects.iter().fold((f64::MAX, f64::MIN), |m, r| (m.0.min(r.0), m.1.max(r.0 + r.2)));
            let (h0, h1) = rects.iter().fold((f64::MAX, f64::MIN), |m, r| (m.0.min(r.1), m.1.max(r.1 + r.3)));
            for p in &out {
                proptest::prop_assert!(p.area() <= (a1 - a0) * (h1 - h0) + 1e-6);
            }
            proptest::prop_assert!(covered <= total_in + (a1 - a0) * (h1 - h0));
            // All output lies on one plane parallel to the wall, within the depth range.
            for p in &out {
                proptest::prop_assert!(p.newell_normal().normalize().dot(f.n()) > 1.0 - 1e-9);
                for q in p.exterior() {
                    proptest::prop_assert!((*q - f.o).dot(f.n()).abs() <= 0.25 + 1e-6);
                }
            }
        }
    }
}
