//! A tile's content: glTF 2.0 binary (`.glb`) with one feature per city object.
//!
//! * One mesh, one primitive per material; the materials are the classes (roof, wall,
//!   ground, other shell surfaces, installation, window, door, building body, other), so a
//!   plain glTF viewer shows the structure. Double-sided: CityGML's ring orientation is not
//!   reliable enough to cull by.
//! * Positions in the tile's east-north-up frame turned y-up as glTF asks (east, up,
//!   −north), as `f32` relative to the tile's centre; flat normals per polygon.
//! * `EXT_mesh_features`: the vertex attribute `_FEATURE_ID_0` (float, exact to 2^24 features)
//!   numbers each vertex's feature, the row of the tile's property table.
//! * `EXT_structural_metadata`: the class `cityObject` with `gml_id`, `building`, `class`
//!   (strings), `lod` and `level` (`UINT8`), and `irradiance` (`FLOAT32`, kWh/m², −1 where
//!   not computed) in a tile where some object has it; one property table per tile; every
//!   buffer view starts at a multiple of 8 bytes.

use super::feature::{Feature, Mesh};
use crate::model::AssetKind;
use glam::{DMat4, DVec3, Vec3};
use serde_json::{json, Value};

/// A feature as one tile shows it.
pub(super) struct Shown<'a> {
    /// The feature.
    pub feature: &'a Feature,
    /// What the tile shows of it (its leaf or its rough mesh).
    pub mesh: &'a Mesh,
    /// Level shown (2 full detail, 1 rough).
    pub level: u8,
    /// LoD of the geometry shown.
    pub lod: u8,
}

/// A tile's content and what it holds.
pub(super) struct Glb {
    /// The file.
    pub bytes: Vec<u8>,
    /// The box of the positions in the tile's frame (z up).
    pub min: DVec3,
    pub max: DVec3,
    /// Triangles and features written.
    pub triangles: usize,
    pub features: usize,
}

/// Materials: name and base colour (linear RGB), by [`material_of`].
const MATERIALS: [(&str, [f32; 3]); 9] = [
    ("roof", [0.55, 0.12, 0.08]),
    ("wall", [0.80, 0.78, 0.74]),
    ("ground", [0.25, 0.25, 0.25]),
    ("shell", [0.55, 0.55, 0.55]),
    ("installation", [0.85, 0.40, 0.08]),
    ("window", [0.35, 0.60, 0.90]),
    ("door", [0.30, 0.18, 0.10]),
    ("building", [0.85, 0.78, 0.60]),
    ("other", [0.35, 0.55, 0.30]),
];

/// The material of a kind of object ([`MATERIALS`]).
fn material_of(kind: Option<AssetKind>) -> usize {
    match kind {
        Some(AssetKind::Roof) => 0,
        Some(AssetKind::Wall) => 1,
        Some(AssetKind::Ground) => 2,
        Some(AssetKind::Closure | AssetKind::OuterCeiling | AssetKind::OuterFloor) => 3,
        Some(AssetKind::Installation) => 4,
        Some(AssetKind::Window) => 5,
        Some(AssetKind::Door) => 6,
        Some(AssetKind::Body) => 7,
        _ => 8,
    }
}

/// The binary chunk being built and the JSON that describes it.
#[derive(Default)]
struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    /// A buffer view of `bytes` at a multiple of 8, with `target` when given; its index.
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while self.bin.len() % 8 != 0 {
            self.bin.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()});
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    /// An accessor of `count` elements of `kind` (`VEC3`, `SCALAR`) and `component` type
    /// over a new view of `bytes`; its index.
    fn accessor(&mut self, bytes: &[u8], target: u32, acc: Value) -> usize {
        let view = self.view(bytes, Some(target));
        let mut a = acc;
        a["bufferView"] = json!(view);
        self.accessors.push(a);
        self.accessors.len() - 1
    }
}

/// The glb of the features `shown` in a tile whose frame is `to_tile` (the model's frame to
/// the tile's, z up); `None` when they hold no triangle.
pub(super) fn glb(shown: &[Shown<'_>], to_tile: &DMat4, generator: &str) -> Option<Glb> {
    let shown: Vec<&Shown<'_>> = shown.iter().filter(|s| !s.mesh.is_empty()).collect();
    if shown.is_empty() {
        return None;
    }
    let rot = glam::DMat3::from_mat4(*to_tile);
    let mut b = Builder::default();
    let (mut min, mut max) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let mut primitives = Vec::new();
    let mut triangles = 0;
    for (m, (name, _)) in MATERIALS.iter().enumerate() {
        let (mut pos, mut nor, mut ids, mut idx) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut count = 0u32;
        for (row, s) in shown.iter().enumerate() {
            if material_of(s.feature.kind) != m {
                continue;
            }
            count += 1;
            let first = (pos.len() / 3) as u32;
            for (p, n) in s.mesh.positions.iter().zip(&s.mesh.normals) {
                let q = to_tile.transform_point3(*p);
                min = min.min(q);
                max = max.max(q);
                let n = (rot * n.as_dvec3()).normalize_or_zero();
                // z up to glTF's y up: (east, up, -north)
                pos.extend([q.x as f32, q.z as f32, -q.y as f32]);
                nor.extend([n.x as f32, n.z as f32, -n.y as f32]);
                ids.push(row as f32);
            }
            idx.extend(s.mesh.indices.iter().map(|i| first + i));
        }
        if idx.is_empty() {
            continue;
        }
        triangles += idx.len() / 3;
        let n = pos.len() / 3;
        let (lo, hi) = bounds(&pos);
        let position = b.accessor(
            bytemuck::cast_slice(&pos),
            34962,
            json!({"componentType": 5126, "count": n, "type": "VEC3", "min": lo, "max": hi}),
        );
        let normal = b.accessor(
            bytemuck::cast_slice(&nor),
            34962,
            json!({"componentType": 5126, "count": n, "type": "VEC3"}),
        );
        let feature = b.accessor(
            bytemuck::cast_slice(&ids),
            34962,
            json!({"componentType": 5126, "count": n, "type": "SCALAR"}),
        );
        let indices = b.accessor(
            bytemuck::cast_slice(&idx),
            34963,
            json!({"componentType": 5125, "count": idx.len(), "type": "SCALAR"}),
        );
        primitives.push(json!({
            "attributes": {"POSITION": position, "NORMAL": normal, "_FEATURE_ID_0": feature},
            "indices": indices,
            "material": m,
            "mode": 4,
            "extensions": {"EXT_mesh_features": {"featureIds": [
                {"featureCount": count, "attribute": 0, "propertyTable": 0, "label": name}
            ]}}
        }));
    }
    let irradiance = shown.iter().any(|s| s.feature.irradiance.is_some());
    let table = property_table(&mut b, &shown, irradiance);
    let materials: Vec<Value> = MATERIALS
        .iter()
        .map(|(name, [r, g, bl])| {
            json!({
                "name": name,
                "pbrMetallicRoughness": {"baseColorFactor": [r, g, bl, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0},
                "doubleSided": true
            })
        })
        .collect();
    while b.bin.len() % 4 != 0 {
        b.bin.push(0);
    }
    let doc = json!({
        "asset": {"version": "2.0", "generator": generator},
        "extensionsUsed": ["EXT_mesh_features", "EXT_structural_metadata"],
        "extensions": {"EXT_structural_metadata": {"schema": schema(irradiance), "propertyTables": [table]}},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": primitives}],
        "materials": materials,
        "accessors": b.accessors,
        "bufferViews": b.views,
        "buffers": [{"byteLength": b.bin.len()}],
    });
    Some(Glb {
        bytes: container(&doc, &b.bin),
        min,
        max,
        triangles,
        features: shown.len(),
    })
}

/// Per-component minimum and maximum of `xyz` triples (glTF requires them on positions).
fn bounds(xyz: &[f32]) -> ([f32; 3], [f32; 3]) {
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for p in xyz.chunks_exact(3) {
        let v = Vec3::new(p[0], p[1], p[2]);
        lo = lo.min(v);
        hi = hi.max(v);
    }
    (lo.to_array(), hi.to_array())
}

/// The metadata schema: one class, `cityObject` (with `irradiance` when asked).
fn schema(irradiance: bool) -> Value {
    let mut s = json!({
        "id": "skylod",
        "classes": {"cityObject": {
            "name": "City object",
            "description": "A CityGML object: a thematic surface, installation, opening or building body.",
            "properties": {
                "gml_id": {"type": "STRING", "description": "gml:id, or the name skylod gives an object without one"},
                "building": {"type": "STRING", "description": "gml:id of its top-level building"},
                "class": {"type": "STRING", "description": "CityGML class, e.g. RoofSurface"},
                "lod": {"type": "SCALAR", "componentType": "UINT8", "description": "LoD of the geometry shown"},
                "level": {"type": "SCALAR", "componentType": "UINT8", "description": "2 full detail, 1 skylod's rough form"}
            }
        }}
    });
    if irradiance {
        s["classes"]["cityObject"]["properties"]["irradiance"] = json!({
            "type": "SCALAR", "componentType": "FLOAT32", "noData": NO_IRRADIANCE,
            "description": "annual irradiation, kWh/m² (the mean of the surface's points)"
        });
    }
    s
}

/// `irradiance` of an object without one.
const NO_IRRADIANCE: f32 = -1.0;

/// The property table of the tile's features, in row order; its JSON. A string property
/// empty in every row is left out of the table (glTF allows no empty buffer view; the
/// properties are optional).
fn property_table(b: &mut Builder, shown: &[&Shown<'_>], irradiance: bool) -> Value {
    let mut properties = serde_json::Map::new();
    type Column<'c> = &'c dyn for<'s> Fn(&'s Shown<'_>) -> &'s str;
    let columns: [(&str, Column<'_>); 3] = [
        ("gml_id", &|s| &s.feature.name),
        ("building", &|s| &s.feature.building),
        ("class", &|s| &s.feature.class),
    ];
    for (name, get) in columns {
        let (mut values, mut offsets) = (Vec::new(), vec![0u32]);
        for s in shown {
            values.extend_from_slice(get(s).as_bytes());
            offsets.push(values.len() as u32);
        }
        if values.is_empty() {
            continue;
        }
        let v = b.view(&values, None);
        let o = b.view(bytemuck::cast_slice(&offsets), None);
        let p = json!({"values": v, "stringOffsets": o, "stringOffsetType": "UINT32"});
        properties.insert(name.into(), p);
    }
    let lods: Vec<u8> = shown.iter().map(|s| s.lod).collect();
    let levels: Vec<u8> = shown.iter().map(|s| s.level).collect();
    properties.insert("lod".into(), json!({"values": b.view(&lods, None)}));
    properties.insert("level".into(), json!({"values": b.view(&levels, None)}));
    if irradiance {
        let kwh: Vec<f32> = (shown.iter())
            .map(|s| s.feature.irradiance.unwrap_or(NO_IRRADIANCE))
            .collect();
        let v = b.view(bytemuck::cast_slice(&kwh), None);
        properties.insert("irradiance".into(), json!({ "values": v }));
    }
    json!({
        "name": "city objects",
        "class": "cityObject",
        "count": shown.len(),
        "properties": properties
    })
}

/// The glb container: header, JSON chunk (padded with spaces), binary chunk.
fn container(doc: &Value, bin: &[u8]) -> Vec<u8> {
    let mut json = serde_json::to_vec(doc).unwrap_or_default();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn container_and_layout() {
        let mut f = Feature {
            name: "r1".into(),
            building: "b1".into(),
            class: "RoofSurface".into(),
            kind: Some(AssetKind::Roof),
            ..Feature::default()
        };
        f.leaf = Mesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y],
            normals: vec![Vec3::Z; 3],
            indices: vec![0, 1, 2],
        };
        let shown = [Shown {
            feature: &f,
            mesh: &f.leaf,
            level: 2,
            lod: 2,
        }];
        let g = glb(&shown, &DMat4::IDENTITY, "test").unwrap();
        assert_eq!(&g.bytes[..4], b"glTF");
        assert_eq!(g.bytes.len() % 4, 0);
        let total = u32::from_le_bytes(g.bytes[8..12].try_into().unwrap()) as usize;
        assert_eq!(total, g.bytes.len());
        let jlen = u32::from_le_bytes(g.bytes[12..16].try_into().unwrap()) as usize;
        let doc: Value = serde_json::from_slice(&g.bytes[20..20 + jlen]).unwrap();
        // y up: north (+y) becomes -z
        assert_eq!(doc["accessors"][0]["max"], json!([1.0, 0.0, 0.0]));
        assert_eq!(doc["accessors"][0]["min"], json!([0.0, 0.0, -1.0]));
        for v in doc["bufferViews"].as_array().unwrap() {
            assert_eq!(v["byteOffset"].as_u64().unwrap() % 8, 0);
        }
        let table = &doc["extensions"]["EXT_structural_metadata"]["propertyTables"][0];
        assert_eq!(table["count"], 1);
        assert!(table["properties"]["building"].is_object());
        f.building.clear();
        let shown = [Shown {
            feature: &f,
            mesh: &f.leaf,
            level: 2,
            lod: 2,
        }];
        let g = glb(&shown, &DMat4::IDENTITY, "test").unwrap();
        let jlen = u32::from_le_bytes(g.bytes[12..16].try_into().unwrap()) as usize;
        let doc: Value = serde_json::from_slice(&g.bytes[20..20 + jlen]).unwrap();
        let table = &doc["extensions"]["EXT_structural_metadata"]["propertyTables"][0];
        assert!(table["properties"]["building"].is_null());
        for v in doc["bufferViews"].as_array().unwrap() {
            assert!(v["byteLength"].as_u64().unwrap() > 0);
        }
        assert_eq!((g.triangles, g.features), (1, 1));
        let empty = Mesh::default();
        let none = [Shown {
            feature: &f,
            mesh: &empty,
            level: 1,
            lod: 2,
        }];
        assert!(glb(&none, &DMat4::IDENTITY, "test").is_none());
    }
}
