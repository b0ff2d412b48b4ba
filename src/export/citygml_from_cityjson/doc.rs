//! The CityJSON document as this writer reads it: unlike the model reader's types
//! ([`crate::io::cityjson`]), every attribute, `children`, the semantic objects' own attributes
//! and `metadata.geographicalExtent` are kept.

use serde::de::{Deserializer, MapAccess, Visitor};
use serde::Deserialize;
use serde_json::{Map, Value};
use std::fmt;

/// A CityJSON document, the header of CityJSONSeq, or one `CityJSONFeature`.
#[derive(Debug, Deserialize)]
pub(super) struct Doc {
    #[serde(rename = "type")]
    pub ty: String,
    #[serde(default)]
    pub version: Option<String>,
    #[serde(default)]
    pub transform: Option<Transform>,
    #[serde(default)]
    pub metadata: Option<Metadata>,
    #[serde(rename = "CityObjects", default)]
    pub objects: Objects,
    #[serde(default)]
    pub vertices: Vec<[f64; 3]>,
    #[serde(rename = "geometry-templates", default)]
    pub templates: Option<Templates>,
    /// Materials and textures: not written (counted).
    #[serde(default)]
    pub appearance: Option<Value>,
}

/// `transform`.
#[derive(Debug, Deserialize, Clone, Copy)]
pub(super) struct Transform {
    pub scale: [f64; 3],
    pub translate: [f64; 3],
}

/// `metadata`: the reference system and the extent.
#[derive(Debug, Deserialize)]
pub(super) struct Metadata {
    #[serde(rename = "referenceSystem", default)]
    pub reference_system: Option<Value>,
    #[serde(rename = "geographicalExtent", default)]
    pub extent: Option<Vec<f64>>,
}

/// `geometry-templates`.
#[derive(Debug, Deserialize)]
pub(super) struct Templates {
    #[serde(default)]
    pub templates: Vec<Geometry>,
    #[serde(rename = "vertices-templates", default)]
    pub vertices: Vec<[f64; 3]>,
}

/// `CityObjects` in document order.
#[derive(Debug, Default)]
pub(super) struct Objects(pub Vec<(String, CityObject)>);

impl<'de> Deserialize<'de> for Objects {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Objects;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("an object of city objects")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut m: A) -> Result<Objects, A::Error> {
                let mut v = Vec::with_capacity(m.size_hint().unwrap_or(0));
                while let Some((k, o)) = m.next_entry::<String, CityObject>()? {
                    v.push((k, o));
                }
                Ok(Objects(v))
            }
        }
        d.deserialize_map(V)
    }
}

/// One city object.
#[derive(Debug, Deserialize)]
pub(super) struct CityObject {
    #[serde(rename = "type")]
    pub ty: String,
    #[serde(default)]
    pub geometry: Vec<Geometry>,
    #[serde(default)]
    pub parents: Vec<String>,
    #[serde(default)]
    pub children: Vec<String>,
    #[serde(default)]
    pub attributes: Option<Map<String, Value>>,
    /// CityJSON 1.1+/2.0 `address`: not written (counted).
    #[serde(default)]
    pub address: Option<Value>,
}

/// One geometry.
#[derive(Debug, Deserialize)]
pub(super) struct Geometry {
    #[serde(rename = "type")]
    pub ty: String,
    #[serde(default)]
    pub lod: Option<Value>,
    #[serde(default)]
    pub boundaries: Value,
    #[serde(default)]
    pub semantics: Option<Semantics>,
    #[serde(default)]
    pub template: Option<usize>,
    #[serde(rename = "transformationMatrix", default)]
    pub matrix: Option<Vec<f64>>,
    /// Material / texture references: not written.
    #[serde(default)]
    pub material: Option<Value>,
    #[serde(default)]
    pub texture: Option<Value>,
}

impl Geometry {
    /// The integer LoD (`"2.2"` → 2, `1` → 1), `None` when there is none in 0..=3.
    pub fn lod(&self) -> Option<u8> {
        let v = match self.lod.as_ref()? {
            Value::String(s) => s.trim().parse::<f64>().ok()?,
            Value::Number(n) => n.as_f64()?,
            _ => return None,
        };
        (v.is_finite() && (0.0..4.0).contains(&v)).then_some(v.floor() as u8)
    }
}

/// `semantics`.
#[derive(Debug, Deserialize)]
pub(super) struct Semantics {
    #[serde(default)]
    pub surfaces: Vec<Map<String, Value>>,
    #[serde(default)]
    pub values: Value,
}
