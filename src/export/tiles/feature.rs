//! One city object as a feature of a tileset: its triangles in the model's east-north-up
//! frame, as the leaves show it (its level's geometry) and as the parents show it (its rough
//! form), with the deviation of each from its full detail.
//!
//! The deviation is measured, not guessed: the largest distance from a vertex of the full
//! detail to the triangles shown instead (a box's faces, a plane's polygon). A feature that a
//! tile leaves out deviates by its extent (the diagonal of its box); an opening, which the
//! parents leave out because its wall's rough plane covers it, by the distance of its
//! vertices from that plane.
//!
//! Features go to a spill file between the pass that makes them and the one that writes
//! the tiles ([`Feature::encode`], [`Feature::decode`]): memory follows the chunk.

use super::georef::{Georef, AFFINE_EXTENT};
use crate::export::Content;
use crate::io::citygml::WriteError;
use crate::lod::level::traced;
use crate::lod::rough::{rough_asset, RoughOptions};
use crate::model::{newell, triangulate, AssetKind, Bbox, CityModel, Polygon};
use foldhash::HashMap;
use glam::{DVec3, Vec3};
use std::borrow::Cow;

/// Triangles with a normal per vertex, positions in the model's east-north-up frame.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct Mesh {
    pub positions: Vec<DVec3>,
    pub normals: Vec<Vec3>,
    pub indices: Vec<u32>,
}

impl Mesh {
    /// True when the mesh has no triangle.
    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    /// The box of the positions.
    pub fn bbox(&self) -> Bbox {
        Bbox::of_points(&self.positions)
    }

    /// Append `polys`' triangles (polygon normals, vertices shared within a polygon); the
    /// number of polygons that gave no triangle.
    fn add_polygons(&mut self, polys: &[Polygon], tris: &mut Vec<[DVec3; 3]>) -> usize {
        let mut degenerate = 0;
        let mut index: HashMap<[u64; 3], u32> = HashMap::default();
        for p in polys {
            tris.clear();
            let n = newell(p.exterior()).normalize_or_zero();
            if triangulate(p, tris) == 0 || n == DVec3::ZERO {
                degenerate += 1;
                continue;
            }
            index.clear();
            for t in tris.iter() {
                for v in t {
                    let key = [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
                    let next = self.positions.len() as u32;
                    let k = *index.entry(key).or_insert(next);
                    if k == next {
                        self.positions.push(*v);
                        self.normals.push(n.as_vec3());
                    }
                    self.indices.push(k);
                }
            }
        }
        degenerate
    }

    /// The triangles as points.
    fn triangle_points(&self) -> impl Iterator<Item = [DVec3; 3]> + '_ {
        self.indices
            .chunks_exact(3)
            .map(|t| [0, 1, 2].map(|k| self.positions[t[k] as usize]))
    }
}

/// A city object as a tileset shows it (see the module docs).
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct Feature {
    /// Its name: gml:id, or the name exports give an id-less object.
    pub name: String,
    /// Its top-level building's gml:id (empty outside buildings or without id).
    pub building: String,
    /// The CityGML class (element name): `RoofSurface`, `Window`, `Building`, ...
    pub class: String,
    /// What it is (its material).
    pub kind: Option<AssetKind>,
    /// Level shown in the leaves: 2 full detail, 1 rough, 0 absent.
    pub level: u8,
    /// LoD of the geometry the leaves show.
    pub lod: u8,
    /// LoD of the geometry its rough form was made from.
    pub rough_lod: u8,
    /// Deviation of the leaves' geometry from the full detail (m).
    pub leaf_error: f64,
    /// Deviation of the parents' geometry (its rough form, or none) from the full detail.
    pub rough_error: f64,
    /// Diagonal of its full detail's box (m): its deviation where it is left out.
    pub extent: f64,
    /// What the leaves show.
    pub leaf: Mesh,
    /// What the parents show: its rough form (empty for openings).
    pub rough: Mesh,
    /// Polygons that gave no triangle (skipped).
    pub degenerate: usize,
    /// Annual irradiation (kWh/m²) where the caller gives it (the cadastre's surfaces).
    pub irradiance: Option<f32>,
    /// An opening's full-detail vertices, until its deviation from its wall is known (not
    /// spilled).
    pub opening_points: Vec<DVec3>,
}

/// The asset `i` of `model` (asset `global` of the whole document) as a feature, shown as
/// `content` says; `None` when it has no geometry at all.
///
/// # Errors
/// A point the CRS conversion does not cover ([`WriteError::Crs`]).
pub(super) fn feature(
    model: &CityModel,
    (i, global): (usize, usize),
    content: &Content<'_>,
    georef: &Georef,
) -> Result<Option<Feature>, WriteError> {
    let Some(a) = model.assets.get(i) else {
        return Ok(None);
    };
    let at = |e| georef.error(model, a, e);
    let b = a.bbox();
    if b.is_empty() {
        return Ok(None);
    }
    // small objects through the affine fit at their centre, large ones point by point
    let affine = georef.affine(b.center()).map_err(at)?;
    let fits = (affine.apply(b.max) - affine.apply(b.min)).length() <= AFFINE_EXTENT;
    let enu = |polys: &[Polygon]| -> Result<Vec<Polygon>, WriteError> {
        polys
            .iter()
            .map(|p| match fits {
                true => Ok(affine.polygon(p)),
                false => georef.polygon(p).map_err(at),
            })
            .collect()
    };
    let mut local = a.clone();
    for g in &mut local.geometries {
        g.polygons = enu(&g.polygons)?;
    }
    let full = traced(&local, None, 2).into_owned();
    if full.is_empty() {
        return Ok(None);
    }
    let mut tris = Vec::new();
    let mut f = Feature {
        name: model.asset_name(i, global),
        building: a
            .building
            .map(|b| model.root_building(b))
            .and_then(|b| model.buildings.get(b))
            .and_then(|b| b.id.clone())
            .unwrap_or_default(),
        class: a.element.to_string(),
        kind: Some(a.kind),
        level: content.level(i),
        lod: a.max_lod().unwrap_or(0),
        ..Feature::default()
    };
    let mut detail = Mesh::default();
    f.degenerate = detail.add_polygons(&full, &mut tris);
    let points: Vec<DVec3> = full.iter().flat_map(|p| p.points().copied()).collect();
    let b = Bbox::of_points(&points);
    f.extent = (b.max - b.min).length();
    // the rough form: the one given with the levels, or made here in the metric frame
    let rough: Cow<'_, [Polygon]> = match content.rough(i) {
        Some(r) => {
            f.rough_lod = r.lod;
            Cow::Owned(enu(&r.polygons())?)
        }
        None => {
            let r = rough_asset(&local, &RoughOptions::default());
            f.rough_lod = r.lod;
            Cow::Owned(r.polygons().into_owned())
        }
    };
    if a.kind.is_opening() {
        f.opening_points.clone_from(&points);
    } else {
        f.rough.add_polygons(&rough, &mut tris);
    }
    f.rough_error = if f.rough.is_empty() {
        f.extent
    } else {
        deviation(&points, &f.rough)
    };
    match f.level {
        2 => {
            f.leaf = detail;
            f.leaf_error = 0.0;
        }
        1 => {
            f.leaf = f.rough.clone();
            f.lod = f.rough_lod;
            f.leaf_error = f.rough_error;
        }
        _ => f.leaf_error = f.extent,
    }
    Ok(Some(f))
}

/// An opening's deviation where the parents show its wall's rough form instead: the
/// largest distance of its vertices from `wall`'s triangles (its extent when the wall shows
/// none).
pub(super) fn opening_error(opening: &Feature, wall: &Mesh) -> f64 {
    if wall.is_empty() || opening.opening_points.is_empty() {
        return opening.extent;
    }
    deviation(&opening.opening_points, wall)
}

/// The largest distance from `points` to the nearest triangle of `mesh` (infinite for an
/// empty mesh).
pub(super) fn deviation(points: &[DVec3], mesh: &Mesh) -> f64 {
    let tris: Vec<[DVec3; 3]> = mesh.triangle_points().collect();
    if tris.is_empty() {
        return f64::INFINITY;
    }
    let mut worst = 0.0f64;
    for p in points {
        let mut best = f64::INFINITY;
        for t in &tris {
            let d = (closest_on_triangle(*p, t) - *p).length_squared();
            if d < best {
                best = d;
                if best <= worst {
                    break;
                }
            }
        }
        worst = worst.max(best);
    }
    worst.sqrt()
}

/// The point of triangle `t` nearest to `p` (Ericson, Real-Time Collision Detection, 5.1.5).
fn closest_on_triangle(p: DVec3, [a, b, c]: &[DVec3; 3]) -> DVec3 {
    let (ab, ac, ap) = (*b - *a, *c - *a, p - *a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return *a;
    }
    let bp = p - *b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return *b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return *a + ab * (d1 / (d1 - d3));
    }
    let cp = p - *c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return *c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return *a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return *b + (*c - *b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom.abs() < f64::MIN_POSITIVE {
        return *a;
    }
    *a + ab * (vb / denom) + ac * (vc / denom)
}

/// Reads a spilled feature back.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let s = self.bytes.get(self.at..self.at.checked_add(n)?)?;
        self.at += n;
        Some(s)
    }
    fn u8(&mut self) -> Option<u8> {
        Some(self.take(1)?[0])
    }
    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
    fn f64(&mut self) -> Option<f64> {
        Some(f64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }
    fn string(&mut self) -> Option<String> {
        let n = self.u32()? as usize;
        String::from_utf8(self.take(n)?.to_vec()).ok()
    }
    fn mesh(&mut self, keep: bool) -> Option<Mesh> {
        let nv = self.u32()? as usize;
        let positions = self.take(nv.checked_mul(24)?)?;
        let normals = self.take(nv.checked_mul(12)?)?;
        let ni = self.u32()? as usize;
        let indices = self.take(ni.checked_mul(4)?)?;
        if !keep {
            return Some(Mesh::default());
        }
        Some(Mesh {
            positions: bytemuck::pod_collect_to_vec(positions),
            normals: bytemuck::pod_collect_to_vec(normals),
            indices: bytemuck::pod_collect_to_vec(indices),
        })
    }
}

fn put_str(out: &mut Vec<u8>, s: &str) {
    out.extend_from_slice(&(s.len() as u32).to_le_bytes());
    out.extend_from_slice(s.as_bytes());
}

fn put_mesh(out: &mut Vec<u8>, m: &Mesh) {
    out.extend_from_slice(&(m.positions.len() as u32).to_le_bytes());
    out.extend_from_slice(bytemuck::cast_slice(&m.positions));
    out.extend_from_slice(bytemuck::cast_slice(&m.normals));
    out.extend_from_slice(&(m.indices.len() as u32).to_le_bytes());
    out.extend_from_slice(bytemuck::cast_slice(&m.indices));
}

impl Feature {
    /// Append the feature to a spill buffer (all but `opening_points`).
    pub fn encode(&self, out: &mut Vec<u8>) {
        put_str(out, &self.name);
        put_str(out, &self.building);
        put_str(out, &self.class);
        let kind = self
            .kind
            .and_then(|k| AssetKind::ALL.iter().position(|x| *x == k))
            .map_or(u8::MAX, |k| k as u8);
        out.extend_from_slice(&[kind, self.level, self.lod, self.rough_lod]);
        for x in [self.leaf_error, self.rough_error, self.extent] {
            out.extend_from_slice(&x.to_le_bytes());
        }
        out.extend_from_slice(&(self.degenerate as u32).to_le_bytes());
        out.extend_from_slice(&self.irradiance.unwrap_or(f32::NAN).to_le_bytes());
        put_mesh(out, &self.leaf);
        put_mesh(out, &self.rough);
    }

    /// The features spilled into `bytes`, each with its leaf mesh when `leaf` and its rough
    /// mesh when `rough` (the others left empty); `None` for bytes that are not such a spill.
    pub fn decode_all(bytes: &[u8], leaf: bool, rough: bool) -> Option<Vec<Feature>> {
        let mut r = Reader { bytes, at: 0 };
        let mut all = Vec::new();
        while r.at < bytes.len() {
            let (name, building, class) = (r.string()?, r.string()?, r.string()?);
            let kind = AssetKind::ALL.get(usize::from(r.u8()?)).copied();
            let (level, lod, rough_lod) = (r.u8()?, r.u8()?, r.u8()?);
            let (leaf_error, rough_error, extent) = (r.f64()?, r.f64()?, r.f64()?);
            let degenerate = r.u32()? as usize;
            let irradiance = Some(f32::from_bits(r.u32()?)).filter(|v| !v.is_nan());
            all.push(Feature {
                name,
                building,
                class,
                kind,
                level,
                lod,
                rough_lod,
                leaf_error,
                rough_error,
                extent,
                degenerate,
                irradiance,
                leaf: r.mesh(leaf)?,
                rough: r.mesh(rough)?,
                opening_points: Vec::new(),
            });
        }
        Some(all)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(z: f64) -> Polygon {
        Polygon::new(vec![
            DVec3::new(0.0, 0.0, z),
            DVec3::new(4.0, 0.0, z),
            DVec3::new(4.0, 3.0, z),
            DVec3::new(0.0, 3.0, z),
        ])
    }

    #[test]
    fn closest_points_and_deviation() {
        let mut m = Mesh::default();
        let mut tris = Vec::new();
        assert_eq!(m.add_polygons(&[square(0.0)], &mut tris), 0);
        assert_eq!((m.positions.len(), m.indices.len()), (4, 6));
        assert!(m.normals.iter().all(|n| *n == Vec3::Z));
        // above the square: the height; beside it: the distance to its edge
        let d = deviation(&[DVec3::new(1.0, 1.0, 2.0)], &m);
        assert!((d - 2.0).abs() < 1e-12);
        let d = deviation(&[DVec3::new(7.0, 7.0, 0.0)], &m);
        assert!((d - 5.0).abs() < 1e-12, "{d}");
        assert_eq!(deviation(&[DVec3::ZERO], &Mesh::default()), f64::INFINITY);
        // a degenerate polygon is counted and skipped
        let line = Polygon::new(vec![DVec3::ZERO, DVec3::X, DVec3::X * 2.0]);
        assert_eq!(m.add_polygons(&[line], &mut tris), 1);
        assert_eq!(m.indices.len(), 6);
    }

    #[test]
    fn spill_round_trip() {
        let mut tris = Vec::new();
        let mut f = Feature {
            name: "r1".into(),
            building: "b1".into(),
            class: "RoofSurface".into(),
            kind: Some(AssetKind::Roof),
            level: 2,
            lod: 3,
            rough_lod: 2,
            leaf_error: 0.0,
            rough_error: 0.25,
            extent: 5.0,
            irradiance: Some(1012.5),
            ..Feature::default()
        };
        f.leaf.add_polygons(&[square(1.0)], &mut tris);
        f.rough.add_polygons(&[square(2.0), square(3.0)], &mut tris);
        let mut bytes = Vec::new();
        f.encode(&mut bytes);
        let g = Feature {
            name: "w".into(),
            kind: None,
            ..Feature::default()
        };
        g.encode(&mut bytes);
        let back = Feature::decode_all(&bytes, true, true).unwrap();
        assert_eq!(back, vec![f.clone(), g]);
        let no_leaf = Feature::decode_all(&bytes, false, true).unwrap();
        assert!(no_leaf[0].leaf.is_empty() && no_leaf[0].rough == f.rough);
        assert!(Feature::decode_all(&bytes[..bytes.len() - 1], true, true).is_none());
    }
}
