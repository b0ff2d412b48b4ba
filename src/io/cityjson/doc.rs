//! The CityJSON document as serde reads it: only what the model needs (every other member,
//! such as `appearance` or `extensions`, is passed over).

use serde::de::{Deserializer, MapAccess, Visitor};
use serde::Deserialize;
use serde_json::Value;
use std::fmt;

/// A CityJSON document, the header line of CityJSONSeq, or one `CityJSONFeature` line.
#[derive(Debug, Deserialize)]
pub(super) struct Doc {
    /// `"CityJSON"` or `"CityJSONFeature"`.
    #[serde(rename = "type")]
    pub ty: String,
    /// `"1.0"`, `"1.1"`, `"2.0"` (the header only).
    #[serde(default)]
    pub version: Option<String>,
    /// A feature's id (its main city object).
    #[serde(default)]
    pub id: Option<String>,
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
}

/// `transform`: real = integer × scale + translate.
#[derive(Debug, Deserialize)]
pub(super) struct Transform {
    pub scale: [f64; 3],
    pub translate: [f64; 3],
}

/// `metadata`: the reference system only.
#[derive(Debug, Deserialize)]
pub(super) struct Metadata {
    #[serde(rename = "referenceSystem", default)]
    pub reference_system: Option<Value>,
}

/// `geometry-templates`.
#[derive(Debug, Deserialize)]
pub(super) struct Templates {
    #[serde(default)]
    pub templates: Vec<Geometry>,
    /// Real coordinates (never compressed by `transform`).
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
    pub attributes: Option<Attributes>,
}

/// The attributes the model keeps (the others are copied from the source by the writer).
#[derive(Debug, Deserialize)]
pub(super) struct Attributes {
    #[serde(default)]
    pub function: Option<Value>,
    /// The CityGML type of a `GenericCityObject` written by skylod's own export.
    #[serde(default)]
    pub citygml_type: Option<Value>,
}

/// One geometry; `boundaries` are read by type ([`super::map`]).
#[derive(Debug, Deserialize)]
pub(super) struct Geometry {
    #[serde(rename = "type")]
    pub ty: String,
    #[serde(default)]
    pub lod: Option<Lod>,
    #[serde(default)]
    pub boundaries: Value,
    #[serde(default)]
    pub semantics: Option<Semantics>,
    /// `GeometryInstance`: index into the templates.
    #[serde(default)]
    pub template: Option<usize>,
    /// `GeometryInstance`: 4×4, row by row.
    #[serde(rename = "transformationMatrix", default)]
    pub matrix: Option<Vec<f64>>,
}

/// `lod`: a string (`"2.2"`) since CityJSON 1.1, a number in 1.0.
#[derive(Debug, Deserialize, Clone)]
#[serde(untagged)]
pub(super) enum Lod {
    Text(String),
    Number(f64),
}

impl Lod {
    /// The LoD as a number (`"2.2"` → 2.2), `None` when it is not one.
    pub fn value(&self) -> Option<f64> {
        let v = match self {
            Lod::Text(s) => s.trim().parse::<f64>().ok()?,
            Lod::Number(n) => *n,
        };
        (v.is_finite() && (0.0..4.0).contains(&v)).then_some(v)
    }
}

/// `semantics`.
#[derive(Debug, Deserialize)]
pub(super) struct Semantics {
    #[serde(default)]
    pub surfaces: Vec<Surface>,
    #[serde(default)]
    pub values: Value,
}

/// A semantic surface object.
#[derive(Debug, Deserialize)]
pub(super) struct Surface {
    #[serde(rename = "type")]
    pub ty: String,
    #[serde(default)]
    pub parent: Option<usize>,
    #[serde(default)]
    pub id: Option<Value>,
}
