//! Geometry encoding of the mixed-LoD writer: rough polygons as GML text in the schema type of
//! the LoD property they replace, with fresh, unique `gml:id`s.
//!
//! `lodNSolid` gets a `gml:Solid` whose exterior is a `gml:CompositeSurface` (GML 3.1.1) or a
//! `gml:Shell` (GML 3.2); `lodNMultiSurface`, `lodNGeometry`, `lod0FootPrint`, `lod0RoofEdge`
//! a `gml:MultiSurface`; other `lodNSurface` properties a `gml:CompositeSurface`; everything
//! else (implicit geometry, curves, terrain intersections, reliefs) is kept verbatim.

use super::id_table::IdTable;
use crate::io::citygml::ns;
use crate::io::citygml::write::{escape_attr, GmlWriter};
use crate::model::{CityGmlVersion, Polygon};
use foldhash::{HashSet, HashSetExt};
use std::fmt::Write as _;

/// How rough geometry is written into a LoD property.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Enc {
    MultiSurface,
    CompositeSurface,
    Solid,
    Keep,
}

/// Schema encoding of rough geometry for a LoD property (by local name).
pub(super) fn encoding(prop: &str) -> Enc {
    if prop.contains("Implicit") || prop.contains("Curve") || prop.contains("TerrainIntersection") {
        Enc::Keep
    } else if prop.ends_with("Solid") {
        Enc::Solid
    } else if prop.ends_with("MultiSurface")
        || prop.ends_with("Geometry")
        || prop == "lod0FootPrint"
        || prop == "lod0RoofEdge"
    {
        Enc::MultiSurface
    } else if prop.starts_with("lod") && prop.ends_with("Surface") {
        Enc::CompositeSurface
    } else {
        Enc::Keep
    }
}

/// Writes geometry in the document's GML prefix.
pub(super) struct Encoder {
    version: CityGmlVersion,
    /// GML prefix with its colon (`gml:`).
    gml: String,
    /// Namespace declaration to put on each new geometry when the document declares no GML
    /// prefix (empty otherwise).
    gml_decl: String,
}

impl Encoder {
    /// `gml_prefix` as the reader recorded it (empty: the document has none).
    pub(super) fn new(version: CityGmlVersion, gml_prefix: &str) -> Self {
        let gml_uri = if version == CityGmlVersion::V3_0 {
            ns::GML_32
        } else {
            ns::GML_311
        };
        let (gml, gml_decl) = if gml_prefix.is_empty() {
            (
                "gml:".to_string(),
                format!(" xmlns:gml=\"{}\"", String::from_utf8_lossy(gml_uri)),
            )
        } else {
            (gml_prefix.to_string(), String::new())
        };
        Encoder {
            version,
            gml,
            gml_decl,
        }
    }

    /// `polys` as the geometry element of encoding `enc`, ids `id`, `id_s` (shell) and
    /// `id_<n>` (polygons).
    pub(super) fn geometry(&self, enc: Enc, id: &str, polys: &[Polygon]) -> String {
        let w = GmlWriter {
            gml: self.gml.clone(),
            ids: true,
        };
        let g = &self.gml;
        let decl = &self.gml_decl;
        let id = escape_attr(id);
        let mut s = String::with_capacity(256 + polys.len() * 256);
        let members = |s: &mut String| {
            for (n, p) in polys.iter().enumerate() {
                let _ = write!(s, "<{g}surfaceMember>");
                w.polygon(s, &format!("{id}_{n}"), p);
                let _ = write!(s, "</{g}surfaceMember>");
            }
        };
        match enc {
            Enc::MultiSurface | Enc::Keep => {
                let _ = write!(s, "<{g}MultiSurface{decl} {g}id=\"{id}\">");
                members(&mut s);
                let _ = write!(s, "</{g}MultiSurface>");
            }
            Enc::CompositeSurface => {
                let _ = write!(s, "<{g}CompositeSurface{decl} {g}id=\"{id}\">");
                members(&mut s);
                let _ = write!(s, "</{g}CompositeSurface>");
            }
            Enc::Solid => {
                let shell = if self.version == CityGmlVersion::V3_0 {
                    "Shell"
                } else {
                    "CompositeSurface"
                };
                let _ = write!(
                    s,
                    "<{g}Solid{decl} {g}id=\"{id}\"><{g}exterior><{g}{shell} {g}id=\"{id}_s\">"
                );
                members(&mut s);
                let _ = write!(s, "</{g}{shell}></{g}exterior></{g}Solid>");
            }
        }
        s
    }
}

/// Fresh `gml:id`s: never one of the document's, never one handed out before.
#[derive(Debug, Default)]
pub(super) struct IdPool {
    used: HashSet<String>,
    /// With [`IdPool::logging`]: the hashes ([`IdTable::hash`]) of the ids handed out (with
    /// their `_s` and `_<n>` forms) since [`IdPool::take_log`].
    log: Option<Vec<u64>>,
}

impl IdPool {
    pub(super) fn new() -> Self {
        IdPool {
            used: HashSet::new(),
            log: None,
        }
    }

    /// A pool that logs the hashes of what it hands out (the chunked plan checks them against
    /// the ids of the chunks after).
    pub(super) fn logging() -> Self {
        IdPool {
            log: Some(Vec::new()),
            ..IdPool::new()
        }
    }

    /// The hashes logged since the last call.
    pub(super) fn take_log(&mut self) -> Vec<u64> {
        self.log.as_mut().map(std::mem::take).unwrap_or_default()
    }

    fn take(&mut self, id: String) {
        if let Some(log) = &mut self.log {
            log.push(IdTable::hash(id.as_bytes()));
        }
        self.used.insert(id);
    }

    /// A base id for geometry with `polygons` polygons: `base` with characters an `xs:ID`
    /// cannot hold replaced by `_`, and `_<k>` appended until neither it nor `<id>_s` nor any
    /// `<id>_<n>` is taken (`in_doc`) or handed out before.
    pub(super) fn fresh(
        &mut self,
        base: &str,
        polygons: usize,
        in_doc: impl Fn(&str) -> bool,
    ) -> String {
        let clean: String = base
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        let mut k = 0usize;
        loop {
            let cand = if k == 0 {
                clean.clone()
            } else {
                format!("{clean}_{k}")
            };
            let taken = |s: &str| in_doc(s) || self.used.contains(s);
            let clash = taken(&cand)
                || taken(&format!("{cand}_s"))
                || (0..polygons).any(|i| taken(&format!("{cand}_{i}")));
            if !clash {
                self.take(cand.clone());
                self.take(format!("{cand}_s"));
                for i in 0..polygons {
                    self.take(format!("{cand}_{i}"));
                }
                return cand;
            }
            k += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn encodings() {
        assert_eq!(encoding("lod2Solid"), Enc::Solid);
        assert_eq!(encoding("lod3MultiSurface"), Enc::MultiSurface);
        assert_eq!(encoding("lod3Geometry"), Enc::MultiSurface);
        assert_eq!(encoding("lod0FootPrint"), Enc::MultiSurface);
        assert_eq!(encoding("lod2Surface"), Enc::CompositeSurface);
        assert_eq!(encoding("lod2ImplicitRepresentation"), Enc::Keep);
        assert_eq!(encoding("lod2MultiCurve"), Enc::Keep);
        assert_eq!(encoding("lod2TerrainIntersection"), Enc::Keep);
        assert_eq!(encoding("tin"), Enc::Keep);
    }

    #[test]
    fn fresh_ids_avoid_the_document_and_each_other() {
        let mut pool = IdPool::new();
        let doc = |s: &str| s == "skylod_a_g0" || s == "skylod_a_g0_1_1";
        assert_eq!(pool.fresh("skylod_a_g0", 2, doc), "skylod_a_g0_2");
        // handed out before: the next candidate
        assert_eq!(pool.fresh("skylod_a_g0", 2, doc), "skylod_a_g0_3");
        // characters an xs:ID cannot hold
        assert_eq!(pool.fresh("skylod_x y#z", 0, |_| false), "skylod_x_y_z");
    }

    #[test]
    fn solid_in_gml32_has_a_shell() {
        let square = Polygon::new(vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(0.0, 0.0, 0.0),
        ]);
        let e3 = Encoder::new(CityGmlVersion::V3_0, "gml:");
        let s = e3.geometry(Enc::Solid, "i", std::slice::from_ref(&square));
        assert!(
            s.starts_with("<gml:Solid gml:id=\"i\"><gml:exterior><gml:Shell gml:id=\"i_s\">"),
            "{s}"
        );
        assert!(s.contains("gml:id=\"i_0\""));
        let e2 = Encoder::new(CityGmlVersion::V2_0, "");
        let s = e2.geometry(Enc::MultiSurface, "i", &[square]);
        assert!(
            s.starts_with(
                "<gml:MultiSurface xmlns:gml=\"http://www.opengis.net/gml\" gml:id=\"i\">"
            ),
            "{s}"
        );
    }
}
