//! The CityJSON document as serde reads it, for the model reader ([`super::map`]) and the
//! CityGML writer (`crate::export::citygml_from_cityjson`): one set of types. What the model
//! needs is typed; what only the writer uses is kept as it is (attributes, `children`, the
//! semantic objects' other members, `metadata.geographicalExtent`) or only noted as present
//! (appearances, materials, textures, addresses: the writer counts what it does not write).
//! Any other member, such as `extensions`, is passed over.

use serde::de::{Deserializer, IgnoredAny, MapAccess, Visitor};
use serde::Deserialize;
use serde_json::value::RawValue;
use serde_json::{Map, Value};
use std::fmt;

/// A CityJSON document, the header line of CityJSONSeq, or one `CityJSONFeature` line.
#[derive(Debug, Deserialize)]
pub(crate) struct Doc {
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
    /// Materials and textures: present or not (never read).
    #[serde(default)]
    pub appearance: Option<IgnoredAny>,
}

/// `transform`: real = integer × scale + translate.
#[derive(Debug, Deserialize, Clone, Copy)]
pub(crate) struct Transform {
    pub scale: [f64; 3],
    pub translate: [f64; 3],
}

/// `metadata`: the reference system and the extent.
#[derive(Debug, Deserialize)]
pub(crate) struct Metadata {
    #[serde(rename = "referenceSystem", default)]
    pub reference_system: Option<Value>,
    /// `geographicalExtent` as written ([`Metadata::extent`]).
    #[serde(rename = "geographicalExtent", default)]
    pub extent: Option<Value>,
}

impl Metadata {
    /// `referenceSystem` as the text of a CRS name ([`super::reference_system_text`]).
    pub fn srs_name(&self) -> Option<String> {
        self.reference_system
            .as_ref()
            .and_then(super::reference_system_text)
    }

    /// `geographicalExtent` (min x, y, z, max x, y, z), `None` unless it is six numbers.
    pub fn extent(&self) -> Option<[f64; 6]> {
        let e = self.extent.as_ref()?.as_array()?;
        let mut out = [0.0; 6];
        if e.len() != out.len() {
            return None;
        }
        for (o, v) in out.iter_mut().zip(e) {
            *o = v.as_f64()?;
        }
        Some(out)
    }
}

/// `geometry-templates`.
#[derive(Debug, Deserialize)]
pub(crate) struct Templates {
    #[serde(default)]
    pub templates: Vec<Geometry>,
    /// Real coordinates (never compressed by `transform`).
    #[serde(rename = "vertices-templates", default)]
    pub vertices: Vec<[f64; 3]>,
}

/// `CityObjects` in document order.
#[derive(Debug, Default)]
pub(crate) struct Objects(pub Vec<(String, CityObject)>);

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
pub(crate) struct CityObject {
    #[serde(rename = "type")]
    pub ty: String,
    #[serde(default)]
    pub geometry: Vec<Geometry>,
    #[serde(default)]
    pub parents: Vec<String>,
    #[serde(default)]
    pub children: Vec<String>,
    /// All attributes; the model reads `function` and `citygml_type` (the CityGML type of a
    /// `GenericCityObject` written by skylod's own export), the writer all of them.
    #[serde(default)]
    pub attributes: Option<Map<String, Value>>,
    /// CityJSON 1.1+/2.0 `address`: present or not (never read).
    #[serde(default)]
    pub address: Option<IgnoredAny>,
}

impl CityObject {
    /// Attribute `name`, if the object has it.
    pub fn attribute(&self, name: &str) -> Option<&Value> {
        self.attributes.as_ref()?.get(name)
    }
}

/// One geometry; `boundaries` are read by type ([`super::map`]).
#[derive(Debug, Deserialize)]
pub(crate) struct Geometry {
    #[serde(rename = "type")]
    pub ty: String,
    #[serde(default)]
    pub lod: Option<Lod>,
    /// `boundaries` kept as their JSON text until they are read ([`Geometry::boundaries`]):
    /// as values, nested arrays of indices take about eight times the bytes of their text,
    /// and a document holds every geometry's at once.
    #[serde(default, rename = "boundaries")]
    pub boundaries_text: Option<Box<RawValue>>,
    #[serde(default)]
    pub semantics: Option<Semantics>,
    /// `GeometryInstance`: index into the templates.
    #[serde(default)]
    pub template: Option<usize>,
    /// `GeometryInstance`: 4×4, row by row.
    #[serde(rename = "transformationMatrix", default)]
    pub matrix: Option<Vec<f64>>,
    /// Material and texture references: present or not (never read).
    #[serde(default)]
    pub material: Option<IgnoredAny>,
    #[serde(default)]
    pub texture: Option<IgnoredAny>,
}

impl Geometry {
    /// `boundaries` as a value (`Null` when absent), parsed from the text kept: each
    /// geometry's only while it is read.
    pub fn boundaries(&self) -> Value {
        self.boundaries_text
            .as_ref()
            .and_then(|t| serde_json::from_str(t.get()).ok())
            .unwrap_or(Value::Null)
    }

    /// The whole LoD (`"2.2"` → 2, `1` → 1), `None` when there is none in 0..=3.
    pub fn whole_lod(&self) -> Option<u8> {
        let v = self.lod.as_ref()?.value()?;
        Some(v.floor() as u8)
    }
}

/// `lod`: a string (`"2.2"`) since CityJSON 1.1, a number in 1.0.
#[derive(Debug, Deserialize, Clone)]
#[serde(untagged)]
pub(crate) enum Lod {
    Text(String),
    Number(f64),
}

impl Lod {
    /// The LoD as a number (`"2.2"` → 2.2), `None` when it is not one in `0..4`.
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
pub(crate) struct Semantics {
    #[serde(default)]
    pub surfaces: Vec<Surface>,
    #[serde(default)]
    pub values: Value,
}

/// A semantic surface object.
#[derive(Debug)]
pub(crate) struct Surface {
    pub ty: String,
    pub parent: Option<usize>,
    /// Its other members in document order (`children`, `id` and its own attributes).
    pub others: Map<String, Value>,
    /// Where `type` and `parent` stood among the members.
    at: [Option<usize>; 2],
}

impl<'de> Deserialize<'de> for Surface {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Surface;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a semantic surface object")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut m: A) -> Result<Surface, A::Error> {
                let (mut ty, mut parent) = (None, None);
                let mut others = Map::new();
                let mut at = [None; 2];
                let mut k = 0;
                while let Some(key) = m.next_key::<String>()? {
                    match key.as_str() {
                        "type" => (ty, at[0]) = (Some(m.next_value::<String>()?), Some(k)),
                        "parent" => (parent, at[1]) = (m.next_value()?, Some(k)),
                        _ => drop(others.insert(key, m.next_value()?)),
                    }
                    k += 1;
                }
                let ty = ty.ok_or_else(|| serde::de::Error::missing_field("type"))?;
                Ok(Surface {
                    ty,
                    parent,
                    others,
                    at,
                })
            }
        }
        d.deserialize_map(V)
    }
}

impl Surface {
    /// `id` as a string.
    pub fn id(&self) -> Option<String> {
        match self.others.get("id")? {
            Value::String(t) => Some(t.clone()),
            Value::Number(n) => Some(n.to_string()),
            _ => None,
        }
    }

    /// Its members but `type`, `parent` and `children`, in the order the source's object
    /// gives them after each is taken out by [`Map::remove`] (the last member moved into its
    /// place), as a CityJSON output copies them.
    pub fn copied(&self) -> Map<String, Value> {
        let mut all = Map::new();
        let mut others = self.others.iter();
        for k in 0..self.others.len() + self.at.iter().flatten().count() {
            match self.at.iter().position(|&a| a == Some(k)) {
                Some(0) => drop(all.insert("type".into(), Value::Null)),
                Some(_) => drop(all.insert("parent".into(), Value::Null)),
                None => {
                    if let Some((key, v)) = others.next() {
                        all.insert(key.clone(), v.clone());
                    }
                }
            }
        }
        for key in ["type", "parent", "children"] {
            all.remove(key);
        }
        all
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_document_type_for_the_reader_and_the_writer() {
        let d: Doc = serde_json::from_str(
            r#"{"type":"CityJSON","version":"2.0","transform":{"scale":[1,1,1],"translate":[0,0,0]},
            "metadata":{"geographicalExtent":[0,1,2,3,4,5.5]},"appearance":{"materials":[]},
            "CityObjects":{"b":{"type":"Building","children":["p"],"address":[{"x":1}],
              "attributes":{"function":"1000","n":2},
              "geometry":[{"type":"MultiSurface","lod":"2.2","boundaries":[[[0,1,2]]],"material":{},
                "semantics":{"surfaces":[{"type":"RoofSurface","slope":3,"id":"r1"},
                  {"type":"Window","parent":0,"children":[]}],"values":[0]}}]},
              "p":{"type":"BuildingPart","parents":["b"],"geometry":[{"type":"Solid","lod":1,"boundaries":[]}]}},
            "vertices":[[0,0,0],[1,0,0],[0,1,0]]}"#,
        )
        .unwrap();
        assert!(d.appearance.is_some() && d.id.is_none());
        let meta = d.metadata.as_ref().unwrap();
        assert_eq!(meta.extent(), Some([0.0, 1.0, 2.0, 3.0, 4.0, 5.5]));
        let (id, b) = &d.objects.0[0];
        assert_eq!(
            (id.as_str(), &b.children[..]),
            ("b", &["p".to_string()][..])
        );
        assert!(b.address.is_some());
        assert_eq!(b.attribute("function"), Some(&Value::from("1000")));
        assert_eq!(b.attribute("citygml_type"), None);
        let g = &b.geometry[0];
        assert_eq!(
            (g.whole_lod(), g.lod.as_ref().and_then(Lod::value)),
            (Some(2), Some(2.2))
        );
        assert!(g.material.is_some() && g.texture.is_none());
        let s = &g.semantics.as_ref().unwrap().surfaces;
        assert_eq!(
            (s[0].ty.as_str(), s[0].parent, s[1].parent),
            ("RoofSurface", None, Some(0))
        );
        assert_eq!(s[0].id().as_deref(), Some("r1"));
        let others: Vec<&str> = s[0].others.keys().map(String::as_str).collect();
        assert_eq!(
            (others, s[1].others.contains_key("children")),
            (vec!["slope", "id"], true)
        );
        // a copy's members as the source's object gives them, `type` taken out
        let copied: Vec<String> = s[0].copied().keys().cloned().collect();
        assert_eq!(copied, ["id", "slope"]);
        assert_eq!(g.boundaries_text.as_ref().unwrap().get(), "[[[0,1,2]]]");
        assert_eq!(g.boundaries(), serde_json::json!([[[0, 1, 2]]]));
        let p = &d.objects.0[1].1;
        assert_eq!((p.parents.len(), p.geometry[0].whole_lod()), (1, Some(1)));
        assert_eq!(p.geometry[0].boundaries(), serde_json::json!([]));
        let none: Geometry = serde_json::from_str(r#"{"type":"MultiSurface"}"#).unwrap();
        assert_eq!(none.boundaries(), Value::Null);
        let bad = |e: &str| Metadata {
            reference_system: None,
            extent: serde_json::from_str(e).ok(),
        };
        assert_eq!(bad("[0,1,2]").extent(), None);
        assert_eq!(bad(r#"[0,1,2,3,4,"5"]"#).extent(), None);
        assert_eq!(bad("{}").extent(), None);
    }
}
