//! Geometry of one perimeter building on a [`Lot`]: walls with recessed windows and doors
//! (a hole in the wall polygon, four reveal polygons and a pane per opening), balconies,
//! a flat roof with parapet or a gabled roof, the ground surface, and the roof installations
//! packed onto the roof (stair tower, water tanks, solar panels, chimneys, antennas).
//!
//! Everything lands in one reusable [`Mesh`] arena; [`BuildingGeom`] keeps polygon ranges per
//! thematic surface, opening and installation in the order the writer emits them.
//!
//! # Example
//!
//! ```rust
//! use skylod::model::synth::{BuildingGeom, SurfaceKind, build};
//! use skylod::model::synth::block_lots;
//! use skylod::model::synth::Preset;
//!
//! let mut lots = Vec::new();
//! block_lots(7, 0, 0, &mut lots);
//! let mut g = BuildingGeom::default();
//! build(&lots[1], &Preset::Paper.defaults(), &mut g);
//! let walls = g.surfaces.iter().filter(|s| s.kind == SurfaceKind::Wall).count();
//! assert_eq!(walls, 4);
//! assert!(!g.openings.is_empty());
//! // every window pane lies behind its wall's outer plane
//! assert!(g.openings.iter().all(|o| o.normal.z == 0.0));
//! ```

use super::layout::{mix, Lot, GROUND_Z};
use super::mesh::Mesh;
use super::{InstallationKind, SynthOptions};
use glam::{DVec2, DVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::ops::Range;

/// Storey height, metres.
pub const STOREY: f64 = 3.1;
/// Parapet thickness on flat roofs, metres.
pub const PARAPET_T: f64 = 0.3;
/// Recess of window panes behind the wall plane, metres.
pub const WINDOW_RECESS: f64 = 0.15;
/// Recess of door leaves behind the wall plane, metres.
pub const DOOR_RECESS: f64 = 0.2;
/// Pitch of gabled roofs, degrees.
pub const ROOF_PITCH_DEG: f64 = 25.0;

/// Thematic boundary surface kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SurfaceKind {
    /// `bldg:WallSurface`.
    Wall,
    /// `bldg:RoofSurface`.
    Roof,
    /// `bldg:GroundSurface`.
    Ground,
}

/// Opening kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OpeningKind {
    /// `bldg:Window`.
    Window,
    /// `bldg:Door`.
    Door,
}

/// One thematic surface: polygon ranges into the mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct Surface {
    /// Kind.
    pub kind: SurfaceKind,
    /// Polygons of `lod2MultiSurface` (empty when not written).
    pub lod2: Range<u32>,
    /// Polygons of `lod3MultiSurface` (empty at LoD 2).
    pub lod3: Range<u32>,
    /// Openings (indices into [`BuildingGeom::openings`]).
    pub openings: Range<u32>,
}

/// One window or door.
#[derive(Debug, Clone, PartialEq)]
pub struct Opening {
    /// Window or door.
    pub kind: OpeningKind,
    /// Pane/leaf polygons (`lod3MultiSurface` of the opening).
    pub polys: Range<u32>,
    /// Centre of the pane (recessed behind the wall plane).
    pub centre: DVec3,
    /// Outward unit normal of the wall.
    pub normal: DVec3,
    /// Recess of the pane behind the wall plane.
    pub recess: f64,
    /// Wall polygon holding the matching hole.
    pub wall_poly: u32,
    /// The hole's ring index.
    pub hole_ring: u32,
    /// Storey (0 = ground floor).
    pub floor: u32,
    /// On the street facade (else the courtyard facade).
    pub street: bool,
    /// A balcony stands in front of it.
    pub balcony: bool,
}

/// One outer building installation.
#[derive(Debug, Clone, PartialEq)]
pub struct Installation {
    /// Function.
    pub kind: InstallationKind,
    /// Polygons of its `lod3Geometry`.
    pub polys: Range<u32>,
}

/// Geometry of one building, reused between buildings.
#[derive(Debug, Clone, Default)]
pub struct BuildingGeom {
    /// The lot.
    pub lot: Option<Lot>,
    /// All polygons.
    pub mesh: Mesh,
    /// Thematic surfaces in writing order.
    pub surfaces: Vec<Surface>,
    /// Openings.
    pub openings: Vec<Opening>,
    /// Outer installations in writing order.
    pub installations: Vec<Installation>,
    /// Storeys above ground.
    pub storeys: u32,
    /// Gabled (else flat with parapet).
    pub pitched: bool,
    /// Flat roof slab height, or eave height of a gabled roof.
    pub roof_z: f64,
    /// Highest point of the shell (parapet top or ridge).
    pub top_z: f64,
    rects: Vec<Rect>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Rect {
    u0: f64,
    u1: f64,
    v0: f64,
    v1: f64,
    kind: OpeningKind,
    floor: u32,
    balcony: bool,
}

/// Per-building style drawn from the building's own random stream.
struct Style {
    bay: f64,
    balconies: u8,
    door_bay: usize,
    parapet: f64,
}

fn v3(p: DVec2, z: f64) -> DVec3 {
    DVec3::new(p.x, p.y, z)
}

/// Generate building `lot` into `g` as `opts` asks (LoD 3 = full detail, 2 = shells only;
/// `with_lod2` adds LoD2 shell surfaces to a LoD3 building; the preset caps the storeys).
pub fn build(lot: &Lot, opts: &SynthOptions, g: &mut BuildingGeom) {
    let (seed, lod, with_lod2) = (opts.seed, opts.lod, opts.with_lod2);
    g.mesh.clear();
    g.surfaces.clear();
    g.openings.clear();
    g.installations.clear();
    g.lot = Some(*lot);
    let lod3 = lod >= 3;
    let lod2 = with_lod2 || !lod3;
    let mut rng = ChaCha8Rng::seed_from_u64(mix(
        seed,
        &[2, lot.bx as u64, lot.by as u64, lot.index as u64],
    ));
    let corner = matches!(lot.edge, super::layout::LotEdge::Chamfer(_));
    g.storeys = if corner {
        rng.random_range(6..=9)
    } else {
        rng.random_range(4..=9)
    };
    g.storeys = g.storeys.min(opts.preset.max_storeys());
    g.pitched = rng.random_bool(0.12);
    let style = Style {
        bay: rng.random_range(3.4..4.4),
        balconies: match rng.random_range(0..10) {
            0..=3 => 0,
            4..=7 => 1,
            _ => 2,
        },
        door_bay: rng.random_range(0..64),
        parapet: rng.random_range(0.9..1.2),
    };
    let z0 = GROUND_Z;
    let zr = z0 + g.storeys as f64 * STOREY;
    g.roof_z = zr;
    let rise = lot.depth * 0.5 * ROOF_PITCH_DEG.to_radians().tan();
    g.top_z = if g.pitched {
        zr + rise
    } else {
        zr + style.parapet
    };
    let f = lot.footprint();

    // walls: street (0), party (1), courtyard (2), party (3)
    for e in 0..4 {
        let (p, q) = (f[e], f[(e + 1) % 4]);
        let facade = e % 2 == 0;
        let apex = (g.pitched && !facade).then(|| v3((p + q) * 0.5, zr + rise));
        let top = if g.pitched { zr } else { g.top_z };
        wall(g, &style, p, q, z0, top, apex, e, lod2, lod3);
    }

    // ground
    let ground: [DVec3; 4] = f.map(|p| v3(p, z0));
    let start = g.mesh.poly_count();
    if lod2 {
        g.mesh.poly(&ground, -DVec3::Z);
    }
    let mid = g.mesh.poly_count();
    if lod3 {
        g.mesh.poly(&ground, -DVec3::Z);
    }
    push_surface(g, SurfaceKind::Ground, (start, mid), 0..0);

    roof(g, lot, &style, rise, lod2, lod3);
    if lod3 {
        roof_installations(g, lot, &mut rng, rise);
    }
}

/// One wall from `p` to `q` (outward normal on the right), from `z0` to `top`, with an
/// optional gable apex; facades (`e` even) get openings at LoD3.
#[allow(clippy::too_many_arguments)]
fn wall(
    g: &mut BuildingGeom,
    style: &Style,
    p: DVec2,
    q: DVec2,
    z0: f64,
    top: f64,
    apex: Option<DVec3>,
    e: usize,
    lod2: bool,
    lod3: bool,
) {
    let len = (q - p).length();
    let d2 = (q - p) / len;
    let d = DVec3::new(d2.x, d2.y, 0.0);
    let n = DVec3::new(d2.y, -d2.x, 0.0);
    let mut ring = [DVec3::ZERO; 5];
    ring[0] = v3(p, z0);
    ring[1] = v3(q, z0);
    ring[2] = v3(q, top);
    let k = if let Some(a) = apex {
        ring[3] = a;
        ring[4] = v3(p, top);
        5
    } else {
        ring[3] = v3(p, top);
        4
    };
    let ring = ring.get(..k).unwrap_or(&[]);
    let l2s = g.mesh.poly_count();
    if lod2 {
        g.mesh.poly(ring, n);
    }
    let l3s = g.mesh.poly_count();
    let o_start = g.openings.len() as u32;
    if !lod3 {
        push_surface(g, SurfaceKind::Wall, (l2s, l3s), o_start..o_start);
        return;
    }
    g.rects.clear();
    if e % 2 == 0 {
        facade_rects(&mut g.rects, style, len, g.storeys, e == 0);
    }
    let wall_poly = g.mesh.poly(ring, n);
    let at = |u: f64, v: f64| v3(p, z0 + v) + d * u;
    let mut holes = [0u32; 128];
    for (r, h) in g.rects.iter().zip(holes.iter_mut()) {
        let pts = [
            at(r.u0, r.v0),
            at(r.u1, r.v0),
            at(r.u1, r.v1),
            at(r.u0, r.v1),
        ];
        *h = g.mesh.hole(&pts, n);
    }
    // reveals
    for r in &g.rects {
        let depth = if r.kind == OpeningKind::Door {
            DOOR_RECESS
        } else {
            WINDOW_RECESS
        };
        let back = -n * depth;
        let (a, b, c, dd) = (
            at(r.u0, r.v0),
            at(r.u1, r.v0),
            at(r.u1, r.v1),
            at(r.u0, r.v1),
        );
        g.mesh.poly(&[a, dd, dd + back, a + back], d);
        g.mesh.poly(&[b, c, c + back, b + back], -d);
        g.mesh.poly(&[a, b, b + back, a + back], DVec3::Z);
        g.mesh.poly(&[dd, c, c + back, dd + back], -DVec3::Z);
    }
    let l3e = g.mesh.poly_count();
    // panes and leaves
    for (i, r) in g.rects.iter().enumerate() {
        let depth = if r.kind == OpeningKind::Door {
            DOOR_RECESS
        } else {
            WINDOW_RECESS
        };
        let back = -n * depth;
        let s = g.mesh.poly_count();
        let pts = [
            at(r.u0, r.v0) + back,
            at(r.u1, r.v0) + back,
            at(r.u1, r.v1) + back,
            at(r.u0, r.v1) + back,
        ];
        g.mesh.poly(&pts, n);
        g.openings.push(Opening {
            kind: r.kind,
            polys: s..s + 1,
            centre: at((r.u0 + r.u1) * 0.5, (r.v0 + r.v1) * 0.5) + back,
            normal: n,
            recess: depth,
            wall_poly,
            hole_ring: holes.get(i).copied().unwrap_or(0),
            floor: r.floor,
            street: e == 0,
            balcony: r.balcony,
        });
    }
    g.surfaces.push(Surface {
        kind: SurfaceKind::Wall,
        lod2: l2s..l3s,
        lod3: l3s..l3e,
        openings: o_start..g.openings.len() as u32,
    });
    // balconies in front of the flagged windows
    for i in 0..g.rects.len() {
        let Some(r) = g.rects.get(i).copied() else {
            continue;
        };
        if !r.balcony {
            continue;
        }
        let bays = bays(len, style.bay);
        let bay_w = len / bays.max(1) as f64;
        let uc = (r.u0 + r.u1) * 0.5;
        let bw = (r.u1 - r.u0 + 0.8).min(bay_w - 0.3);
        let fz = r.floor as f64 * STOREY;
        let s = g.mesh.poly_count();
        let o = at(uc - bw * 0.5, fz - 0.15);
        g.mesh.cuboid(o, d * bw, n * 0.8, DVec3::Z * 0.15);
        let f0 = at(uc - bw * 0.5, fz) + n * 0.8;
        let up = DVec3::Z * 1.0;
        g.mesh
            .poly(&[f0, f0 + d * bw, f0 + d * bw + up, f0 + up], n);
        let l0 = at(uc - bw * 0.5, fz);
        g.mesh
            .poly(&[l0, l0 + n * 0.8, l0 + n * 0.8 + up, l0 + up], -d);
        let r0 = l0 + d * bw;
        g.mesh
            .poly(&[r0, r0 + n * 0.8, r0 + n * 0.8 + up, r0 + up], d);
        g.installations.push(Installation {
            kind: InstallationKind::Balcony,
            polys: s..g.mesh.poly_count(),
        });
    }
}

fn bays(len: f64, bay: f64) -> usize {
    ((len - 0.6) / bay).floor().max(0.0) as usize
}

/// Opening rectangles of a facade in (u along the wall, v above ground) coordinates.
fn facade_rects(out: &mut Vec<Rect>, style: &Style, len: f64, storeys: u32, street: bool) {
    let bay = if street { style.bay } else { style.bay * 1.1 };
    let nb = bays(len, bay);
    if nb == 0 {
        return;
    }
    let bw = len / nb as f64;
    let ww = if street { 1.3f64 } else { 1.0 }.min(bw - 0.8);
    if ww < 0.6 {
        return;
    }
    let door_bay = style.door_bay % nb;
    for fl in 0..storeys {
        let fz = fl as f64 * STOREY;
        for j in 0..nb {
            if out.len() >= 127 {
                return;
            }
            let c = (j as f64 + 0.5) * bw;
            let (w, v0, v1, kind) = match (street, fl) {
                (true, 0) if j == door_bay => (1.4f64.min(bw - 0.6), 0.15, 2.6, OpeningKind::Door),
                (true, 0) => ((ww * 1.4).min(bw - 0.6), 0.6, 2.6, OpeningKind::Window),
                (true, _) => (ww, 0.5, 2.5, OpeningKind::Window),
                (false, _) => (ww, 0.9, 2.3, OpeningKind::Window),
            };
            let balcony = street
                && fl >= 1
                && match style.balconies {
                    1 => fl == 1,
                    2 => true,
                    _ => false,
                };
            out.push(Rect {
                u0: c - w * 0.5,
                u1: c + w * 0.5,
                v0: fz + v0,
                v1: fz + v1,
                kind,
                floor: fl,
                balcony,
            });
        }
    }
}

/// Inset of a convex counter-clockwise quad by `s`.
fn inset(f: &[DVec2; 4], s: f64) -> [DVec2; 4] {
    let mut out = [DVec2::ZERO; 4];
    for (k, o) in out.iter_mut().enumerate() {
        let prev = (f[k] - f[(k + 3) % 4]).normalize();
        let next = (f[(k + 1) % 4] - f[k]).normalize();
        let (m1, m2) = (prev.perp(), next.perp());
        *o = f[k] + (m1 + m2) * (s / (1.0 + m1.dot(m2)));
    }
    out
}

fn roof(g: &mut BuildingGeom, lot: &Lot, style: &Style, rise: f64, lod2: bool, lod3: bool) {
    let f = lot.footprint();
    let zr = g.roof_z;
    let l2s = g.mesh.poly_count();
    let ns = {
        let d = (lot.o1 - lot.o0).normalize();
        DVec3::new(d.y, -d.x, 1.0)
    };
    let nc = {
        let d = (lot.i0 - lot.i1).normalize();
        DVec3::new(d.y, -d.x, 1.0)
    };
    let m0 = v3((lot.o0 + lot.i0) * 0.5, zr + rise);
    let m1 = v3((lot.o1 + lot.i1) * 0.5, zr + rise);
    let gable = |g: &mut BuildingGeom| {
        g.mesh.poly(&[v3(lot.o0, zr), v3(lot.o1, zr), m1, m0], ns);
        g.mesh.poly(&[v3(lot.i1, zr), v3(lot.i0, zr), m0, m1], nc);
    };
    if lod2 {
        if g.pitched {
            gable(g);
        } else {
            let top = f.map(|p| v3(p, g.top_z));
            g.mesh.poly(&top, DVec3::Z);
        }
    }
    let l3s = g.mesh.poly_count();
    if lod3 {
        if g.pitched {
            gable(g);
        } else {
            let gi = inset(&f, PARAPET_T);
            let slab = gi.map(|p| v3(p, zr));
            g.mesh.poly(&slab, DVec3::Z);
            let centre = (gi[0] + gi[1] + gi[2] + gi[3]) * 0.25;
            for k in 0..4 {
                let (a, b) = (gi[k], gi[(k + 1) % 4]);
                let inw = centre - (a + b) * 0.5;
                g.mesh.poly(
                    &[
                        v3(a, zr),
                        v3(b, zr),
                        v3(b, zr + style.parapet),
                        v3(a, zr + style.parapet),
                    ],
                    DVec3::new(inw.x, inw.y, 0.0),
                );
            }
            let top = f.map(|p| v3(p, g.top_z));
            g.mesh.poly(&top, DVec3::Z);
            let hole = gi.map(|p| v3(p, g.top_z));
            g.mesh.hole(&hole, DVec3::Z);
        }
    }
    push_surface(g, SurfaceKind::Roof, (l2s, l3s), 0..0);
}

/// A surface of `kind` whose LoD 2 polygons start at `lod2_start` and whose LoD 3 polygons
/// run from `lod3_start` to the last polygon made.
fn push_surface(
    g: &mut BuildingGeom,
    kind: SurfaceKind,
    (lod2_start, lod3_start): (u32, u32),
    openings: Range<u32>,
) {
    let end = g.mesh.poly_count();
    g.surfaces.push(Surface {
        kind,
        lod2: lod2_start..lod3_start,
        lod3: lod3_start..end,
        openings,
    });
}

/// Local frame of a lot: u along the street facade, t inward (towards the courtyard).
struct Frame {
    o: DVec2,
    u: DVec2,
    t: DVec2,
}

impl Frame {
    fn world(&self, u: f64, t: f64, z: f64) -> DVec3 {
        v3(self.o + self.u * u + self.t * t, z)
    }
    fn local(&self, p: DVec2) -> DVec2 {
        DVec2::new((p - self.o).dot(self.u), (p - self.o).dot(self.t))
    }
}

/// u-range of a trapezoid with edges `l0 -> l1` (left) and `r0 -> r1` (right) in local
/// coordinates, at depth `t`.
fn span(l0: DVec2, l1: DVec2, r0: DVec2, r1: DVec2, t: f64) -> (f64, f64) {
    let lerp = |a: DVec2, b: DVec2| {
        let s = if (b.y - a.y).abs() < 1e-12 {
            0.0
        } else {
            (t - a.y) / (b.y - a.y)
        };
        a.x + (b.x - a.x) * s
    };
    (lerp(l0, l1), lerp(r0, r1))
}

fn roof_installations(g: &mut BuildingGeom, lot: &Lot, rng: &mut ChaCha8Rng, rise: f64) {
    let u = (lot.o1 - lot.o0).normalize();
    let fr = Frame {
        o: lot.o0,
        u,
        t: u.perp(),
    };
    let zr = g.roof_z;
    if g.pitched {
        let half = lot.depth * 0.5;
        let (l0, l1, r0, r1) = (
            fr.local(lot.o0),
            fr.local(lot.i0),
            fr.local(lot.o1),
            fr.local(lot.i1),
        );
        let n: u32 = rng.random_range(1..=2);
        for _ in 0..n {
            let t = rng.random_range(1.0..(half - 1.6));
            let (a0, b0) = span(l0, l1, r0, r1, t);
            let (a1, b1) = span(l0, l1, r0, r1, t + 0.5);
            let (lo, hi) = (a0.max(a1) + 0.5, b0.min(b1) - 1.0);
            if hi <= lo {
                continue;
            }
            let uu = rng.random_range(lo..hi);
            let zb = zr + rise * t / half;
            let h = zr + rise + 0.8 - zb;
            let s = g.mesh.poly_count();
            g.mesh.cuboid(
                fr.world(uu, t, zb),
                v3(fr.u * 0.5, 0.0),
                v3(fr.t * 0.5, 0.0),
                DVec3::Z * h,
            );
            g.installations.push(Installation {
                kind: InstallationKind::Chimney,
                polys: s..g.mesh.poly_count(),
            });
        }
        return;
    }
    let gi = inset(&lot.footprint(), PARAPET_T);
    let (l0, l1, r0, r1) = (
        fr.local(gi[0]),
        fr.local(gi[3]),
        fr.local(gi[1]),
        fr.local(gi[2]),
    );
    // items: (kind, su, st, variant)
    let mut items: [(InstallationKind, f64, f64, u8); 24] =
        [(InstallationKind::Chimney, 0.0, 0.0, 0); 24];
    let mut ni = 0usize;
    let mut add = |it: (InstallationKind, f64, f64, u8)| {
        if let Some(slot) = items.get_mut(ni) {
            *slot = it;
            ni += 1;
        }
    };
    if rng.random_bool(0.85) {
        add((
            InstallationKind::StairTower,
            rng.random_range(2.4..3.0),
            rng.random_range(3.0..3.8),
            0,
        ));
    }
    for _ in 0..rng.random_range(0..=2) {
        let cyl = rng.random_bool(0.5);
        add((InstallationKind::WaterTank, 1.5, 1.5, cyl as u8));
    }
    // solar panels face the local axis closest to south
    let south = DVec2::new(0.0, -1.0);
    let facing = [fr.u, -fr.u, fr.t, -fr.t];
    let mut best = 0u8;
    for (k, f) in facing.iter().enumerate() {
        if f.dot(south) > facing[best as usize].dot(south) {
            best = k as u8;
        }
    }
    if rng.random_bool(0.4) {
        for _ in 0..rng.random_range(3..=8) {
            let (su, st) = if best < 2 { (1.5, 1.0) } else { (1.0, 1.5) };
            add((InstallationKind::SolarPanel, su, st, best));
        }
    }
    for _ in 0..rng.random_range(0..=3) {
        add((InstallationKind::Chimney, 0.5, 0.5, 0));
    }
    for _ in 0..rng.random_range(0..=2) {
        add((InstallationKind::Antenna, 0.1, 0.1, 0));
    }
    // shelf packing inside the parapet
    let margin = 0.4;
    let tmax = lot.depth - PARAPET_T - margin;
    let mut shelf_t = PARAPET_T + margin;
    let mut shelf_h = 0.0f64;
    let mut cursor = f64::NEG_INFINITY;
    for &(kind, su, st, var) in items.iter().take(ni) {
        let placed = loop {
            if shelf_t + st > tmax {
                break None;
            }
            let (a0, b0) = span(l0, l1, r0, r1, shelf_t);
            let (a1, b1) = span(l0, l1, r0, r1, shelf_t + st);
            let (lo, hi) = (a0.max(a1) + margin, b0.min(b1) - margin);
            let uu = cursor.max(lo);
            if uu + su <= hi {
                cursor = uu + su + rng.random_range(0.6..1.6);
                shelf_h = shelf_h.max(st);
                break Some((uu, shelf_t));
            }
            if shelf_h == 0.0 {
                break None;
            }
            shelf_t += shelf_h + 0.8;
            shelf_h = 0.0;
            cursor = f64::NEG_INFINITY;
        };
        let Some((uu, tt)) = placed else {
            continue;
        };
        let s = g.mesh.poly_count();
        let (au, at) = (v3(fr.u * su, 0.0), v3(fr.t * st, 0.0));
        let o = fr.world(uu, tt, zr);
        match kind {
            InstallationKind::StairTower => {
                g.mesh
                    .cuboid(o, au, at, DVec3::Z * rng.random_range(2.6..3.0));
            }
            InstallationKind::WaterTank if var == 1 => {
                let c = fr.world(uu + su * 0.5, tt + st * 0.5, zr);
                let mut base = [DVec3::ZERO; 12];
                for (k, b) in base.iter_mut().enumerate() {
                    let a = k as f64 * std::f64::consts::TAU / 12.0;
                    *b = c + DVec3::new(a.cos(), a.sin(), 0.0) * 0.7;
                }
                g.mesh.prism(&base, 1.6);
            }
            InstallationKind::WaterTank => {
                g.mesh.cuboid(o, au, at, DVec3::Z * 1.8);
            }
            InstallationKind::SolarPanel => {
                let f = facing.get(var as usize).copied().unwrap_or(fr.t);
                let f3 = v3(f, 0.0);
                let s3 = v3(f.perp(), 0.0);
                let c = fr.world(uu + su * 0.5, tt + st * 0.5, zr);
                let tilt = 30f64.to_radians();
                let (len, w) = (1.7, 1.0);
                let low0 = c + f3 * (0.75 - 0.02) - s3 * (w * 0.5);
                let high = -f3 * (len * tilt.cos()) + DVec3::Z * (len * tilt.sin());
                let pn = (f3 * tilt.sin() + DVec3::Z * tilt.cos()) * 0.04;
                g.mesh.cuboid(low0, s3 * w, high, pn);
            }
            InstallationKind::Chimney => {
                g.mesh
                    .cuboid(o, au, at, DVec3::Z * rng.random_range(1.2..2.0));
            }
            InstallationKind::Antenna => {
                g.mesh
                    .cuboid(o, au, at, DVec3::Z * rng.random_range(3.0..7.0));
            }
            InstallationKind::Balcony => {}
        }
        g.installations.push(Installation {
            kind,
            polys: s..g.mesh.poly_count(),
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::newell;
    use crate::model::synth::layout::block_lots;
    use crate::model::synth::Preset;

    /// Every building of a 2x2 Paper district, with its geometry.
    fn each_building(seed: u64, mut f: impl FnMut(&BuildingGeom)) {
        let mut opts = Preset::Paper.defaults();
        opts.seed = seed;
        opts.with_lod2 = true;
        let mut lots = Vec::new();
        let mut g = BuildingGeom::default();
        for by in 0..2 {
            for bx in 0..2 {
                block_lots(seed, bx, by, &mut lots);
                for lot in &lots {
                    build(lot, &opts, &mut g);
                    f(&g);
                }
            }
        }
    }

    fn point_in_ring_xy(p: DVec2, ring: &[DVec3]) -> bool {
        let mut inside = false;
        let n = ring.len();
        for i in 0..n {
            let (a, b) = (ring[i], ring[(i + n - 1) % n]);
            if (a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x {
                inside = !inside;
            }
        }
        inside
    }

    /// Height of the roof at `p` (lowest roof polygon above it), if any.
    fn roof_height(g: &BuildingGeom, p: DVec2) -> Option<f64> {
        let roof = g.surfaces.iter().find(|s| s.kind == SurfaceKind::Roof)?;
        let mut best: Option<f64> = None;
        for poly in roof.lod3.clone() {
            let rings = g.mesh.rings_of(poly);
            let ext = g.mesh.ring(rings.start);
            let n = newell(ext).normalize();
            if n.z < 0.1 || !point_in_ring_xy(p, ext) {
                continue;
            }
            if rings
                .clone()
                .skip(1)
                .any(|h| point_in_ring_xy(p, g.mesh.ring(h)))
            {
                continue;
            }
            let z = ext[0].z - (n.x * (p.x - ext[0].x) + n.y * (p.y - ext[0].y)) / n.z;
            best = Some(best.map_or(z, |b: f64| b.min(z)));
        }
        best
    }

    #[test]
    fn roof_installations_stand_on_the_roof() {
        let mut checked = 0;
        let mut kinds = std::collections::BTreeSet::new();
        each_building(11, |g| {
            for inst in g.installations.iter().filter(|i| i.kind.on_roof()) {
                let pts: Vec<DVec3> = inst
                    .polys
                    .clone()
                    .flat_map(|p| g.mesh.rings_of(p))
                    .flat_map(|r| g.mesh.ring(r).iter().copied())
                    .collect();
                let zmin = pts.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
                let mut roof_min = f64::INFINITY;
                for p in &pts {
                    let h = roof_height(g, p.truncate());
                    let h = h.unwrap_or_else(|| panic!("{:?} outside the roof at {p}", inst.kind));
                    if (p.z - zmin).abs() < 1e-9 {
                        roof_min = roof_min.min(h);
                    }
                }
                assert!(
                    (zmin - roof_min).abs() < 0.01,
                    "{:?}: lowest z {zmin} vs roof {roof_min}",
                    inst.kind
                );
                checked += 1;
                kinds.insert(inst.kind);
            }
        });
        assert!(checked > 300, "{checked}");
        assert_eq!(kinds.len(), 5, "{kinds:?}");
    }

    #[test]
    fn windows_lie_in_their_walls_with_matching_holes() {
        let mut windows = 0;
        each_building(5, |g| {
            for s in g.surfaces.iter().filter(|s| s.kind == SurfaceKind::Wall) {
                for oi in s.openings.clone() {
                    let o = &g.openings[oi as usize];
                    assert!(s.lod3.contains(&o.wall_poly));
                    let rings = g.mesh.rings_of(o.wall_poly);
                    assert!(rings.contains(&o.hole_ring));
                    let ext = g.mesh.ring(rings.start);
                    let n = newell(ext).normalize();
                    assert!((n - o.normal).length() < 1e-9);
                    let pane = g.mesh.ring(g.mesh.rings_of(o.polys.start).start);
                    assert!(newell(pane).dot(n) > 0.0, "pane faces out");
                    let u = n.cross(DVec3::Z).normalize();
                    let (umin, umax, zmin, zmax) = ext.iter().fold(
                        (
                            f64::INFINITY,
                            f64::NEG_INFINITY,
                            f64::INFINITY,
                            f64::NEG_INFINITY,
                        ),
                        |(a, b, c, d), p| {
                            let pu = p.dot(u);
                            (a.min(pu), b.max(pu), c.min(p.z), d.max(p.z))
                        },
                    );
                    for p in pane {
                        // behind the wall plane by the recess
                        let dist = (*p - ext[0]).dot(n);
                        assert!((dist + o.recess).abs() < 1e-9, "{dist}");
                        let pu = p.dot(u);
                        assert!(pu > umin && pu < umax && p.z > zmin && p.z < zmax);
                    }
                    // the hole is the pane pushed back onto the wall plane
                    let hole = g.mesh.ring(o.hole_ring);
                    assert_eq!(hole.len(), pane.len());
                    for p in pane {
                        let q = *p + n * o.recess;
                        assert!(hole.iter().any(|h| (*h - q).length() < 1e-9));
                    }
                    assert!(newell(hole).dot(n) < 0.0, "hole is clockwise from outside");
                    windows += 1;
                }
            }
        });
        assert!(windows > 1000, "{windows}");
    }

    #[test]
    fn polygons_are_planar_and_shells_face_outward() {
        each_building(3, |g| {
            for p in 0..g.mesh.poly_count() {
                let rings = g.mesh.rings_of(p);
                let ext = g.mesh.ring(rings.start);
                assert!(ext.len() >= 3);
                let n = newell(ext);
                assert!(n.length() > 1e-6, "degenerate polygon");
                let n = n.normalize();
                for r in rings {
                    for q in g.mesh.ring(r) {
                        assert!((*q - ext[0]).dot(n).abs() < 1e-6, "non-planar");
                    }
                }
            }
            let lot = g.lot.as_ref().unwrap();
            let c = (lot.o0 + lot.o1 + lot.i0 + lot.i1) * 0.25;
            for s in &g.surfaces {
                for p in s.lod2.clone() {
                    let ring = g.mesh.ring(g.mesh.rings_of(p).start);
                    let n = newell(ring);
                    let mid = ring.iter().copied().sum::<DVec3>() / ring.len() as f64;
                    match s.kind {
                        SurfaceKind::Ground => assert!(n.z < 0.0),
                        SurfaceKind::Roof => assert!(n.z > 0.0),
                        SurfaceKind::Wall => {
                            assert!(n.truncate().dot(mid.truncate() - c) > 0.0)
                        }
                    }
                }
            }
            // a LoD2 shell is closed: its vector area sums to zero
            let mut sum = DVec3::ZERO;
            for s in &g.surfaces {
                for p in s.lod2.clone() {
                    sum += newell(g.mesh.ring(g.mesh.rings_of(p).start));
                }
            }
            assert!(sum.length() < 1e-6, "open shell {sum}");
        });
    }

    #[test]
    fn lod2_only_has_no_detail() {
        let mut opts = Preset::Paper.defaults();
        opts.lod = 2;
        let mut lots = Vec::new();
        block_lots(1, 0, 0, &mut lots);
        let mut g = BuildingGeom::default();
        build(&lots[0], &opts, &mut g);
        assert!(g.openings.is_empty() && g.installations.is_empty());
        assert!(g
            .surfaces
            .iter()
            .all(|s| s.lod3.is_empty() && !s.lod2.is_empty()));
        let lod2: usize = g.surfaces.iter().map(|s| s.lod2.len()).sum();
        assert_eq!(g.mesh.poly_count() as usize, lod2);
        assert_eq!(g.surfaces.len(), 6);
    }
}
