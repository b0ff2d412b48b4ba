//! CityJSON 1.0 / 1.1 / 2.0 (`.city.json`, or any name: recognised by content) and
//! CityJSONSeq (`.city.jsonl`: a `CityJSON` header line, then `CityJSONFeature` lines) read
//! into the same [`CityModel`] as CityGML (`map` has the mapping).
//!
//! Vertices get the document's `transform`; `metadata.referenceSystem` (any form the CRS
//! parser knows: `https://www.opengis.net/def/crs/EPSG/0/7415`, `urn:ogc:def:crs:EPSG::7415`,
//! `EPSG:7415`) becomes the model's `srsName`. A CityJSON source has no XML: its spans are
//! empty, [`crate::model::SourceFile::cityjson`] says what it is, and the writers that copy CityGML from
//! their source refuse it.
//!
//! One reader, in chunks (`chunks`): a document's small members, vertices and the links of
//! its city objects in a first pass, then its city objects one at a time, cut into chunks
//! of whole city-object trees; CityJSONSeq in chunks of whole lines (`seq`). The whole
//! read ([`read_slice`], `crate::io::citygml::read::read_file`) is the chunks collected,
//! as one chunk. `stream` reads a document in passes for the edits, `source` finds what
//! a CityJSON output copies from a CityJSON source. Gzip is decompressed as it is read.
//! Errors name the file, line:column where the JSON parser knows them, and the city
//! object's id.
//!
//! # Example
//! ```
//! let doc = br#"{"type":"CityJSON","version":"2.0",
//!   "transform":{"scale":[0.001,0.001,0.001],"translate":[1000,2000,0]},
//!   "metadata":{"referenceSystem":"https://www.opengis.net/def/crs/EPSG/0/7415"},
//!   "CityObjects":{"b1":{"type":"Building","geometry":[{"type":"MultiSurface","lod":"2.2",
//!     "boundaries":[[[0,1,2,3]]],
//!     "semantics":{"surfaces":[{"type":"RoofSurface"}],"values":[0]}}]}},
//!   "vertices":[[0,0,5000],[1000,0,5000],[1000,1000,5000],[0,1000,5000]]}"#;
//! let model = skylod::io::cityjson::read_slice(doc, "b.city.json".as_ref()).unwrap();
//! assert_eq!(model.assets[0].kind, skylod::model::AssetKind::Roof);
//! assert_eq!(model.assets[0].geometries[0].lod, 2);
//! assert_eq!(model.assets[0].detail_polygons()[0].exterior()[1].x, 1001.0);
//! ```

pub(crate) mod chunks;
pub(crate) mod doc;
mod head;
pub(crate) mod map;
mod seq;
pub(crate) mod source;
pub(crate) mod stream;
pub(crate) use head::reference_system_text;

pub use map::Origin;

/// Read a CityJSON or CityJSONSeq document held in memory (`name` names it in the model,
/// errors and warnings): its chunks collected, as one chunk.
///
/// # Errors
/// [`CityJsonError`]: not JSON, not CityJSON, a vertex index out of range, a non-finite coordinate...
pub fn read_slice(bytes: &[u8], name: &Path) -> Result<CityModel, CityJsonError> {
    chunks::whole_model(chunks::Input::Bytes(bytes), name)
}

use crate::model::CityModel;
use std::fmt;
use std::io::BufRead;
use std::path::{Path, PathBuf};

/// Why a CityJSON document could not be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub struct CityJsonError {
    /// The file.
    pub file: PathBuf,
    /// 1-based line, 0 when unknown.
    pub line: u64,
    /// 1-based column, 0 when unknown.
    pub column: u64,
    /// The city object concerned, when known.
    pub id: Option<String>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for CityJsonError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", crate::model::shown(&self.file))?;
        if self.line > 0 {
            write!(f, ":{}:{}", self.line, self.column.max(1))?;
        }
        if let Some(id) = &self.id {
            write!(f, " [city object {id}]")?;
        }
        write!(f, ": invalid CityJSON: {}", self.message)
    }
}

impl CityJsonError {
    pub(crate) fn at(file: &Path, line: u64, id: Option<&str>, message: String) -> CityJsonError {
        CityJsonError {
            file: file.to_path_buf(),
            line,
            column: 0,
            id: id.map(str::to_string),
            message,
        }
    }

    /// A JSON parser's error, with its line and column.
    pub(crate) fn json(file: &Path, e: &serde_json::Error) -> CityJsonError {
        let text = e.to_string();
        let message = match text.rsplit_once(" at line ") {
            Some((m, _)) => m.to_string(),
            None => text,
        };
        CityJsonError {
            file: file.to_path_buf(),
            line: e.line() as u64,
            column: e.column() as u64,
            id: None,
            message,
        }
    }
}

/// What a document's first bytes show it to be.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sniffed {
    /// JSON: a CityJSON document or CityJSONSeq (told apart while reading: more than one
    /// JSON value is CityJSONSeq).
    Json,
    /// Anything else (XML for the CityGML reader).
    Other,
}

/// JSON when the first byte after a UTF-8 byte-order mark and white space is `{`.
///
/// ```
/// use skylod::io::cityjson::{sniff, Sniffed};
/// assert_eq!(sniff(b" \n{\"type\":\"CityJSON\"}"), Sniffed::Json);
/// assert_eq!(sniff(b"<?xml version=\"1.0\"?>"), Sniffed::Other);
/// ```
pub fn sniff(head: &[u8]) -> Sniffed {
    let head = head.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(head);
    match head.iter().find(|b| !b.is_ascii_whitespace()) {
        Some(b'{') => Sniffed::Json,
        _ => Sniffed::Other,
    }
}

/// Whether the file at `path` holds JSON (CityJSON, CityJSONSeq; gzip-compressed or not), by
/// its first bytes ([`sniff`]); false when it cannot be read.
pub fn is_json_file(path: &Path) -> bool {
    crate::io::files::open_decoded(path)
        .is_ok_and(|(mut r, _)| r.fill_buf().is_ok_and(|h| sniff(h) == Sniffed::Json))
}

/// True when `model`'s file `file` was read from CityJSON.
pub fn is_cityjson(model: &CityModel, file: usize) -> bool {
    model.files.get(file).is_some_and(|f| f.cityjson.is_some())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{AssetKind, CityJsonFormat};

    const HEAD: &str = r#""type":"CityJSON","version":"2.0","transform":{"scale":[0.01,0.01,0.01],"translate":[100,200,0]}"#;
    const SQUARE: &str =
        "[[0,0,0],[100,0,0],[100,100,0],[0,100,0],[0,0,300],[100,0,300],[100,100,300],[0,100,300]]";

    fn read(doc: &str) -> CityModel {
        read_slice(doc.as_bytes(), Path::new("t.city.json")).unwrap()
    }

    #[test]
    fn surfaces_openings_parts_and_installations() {
        let doc = format!(
            r#"{{{HEAD},"metadata":{{"referenceSystem":"https://www.opengis.net/def/crs/EPSG/0/7415"}},
            "CityObjects":{{
              "b":{{"type":"Building","children":["p"]}},
              "p":{{"type":"BuildingPart","parents":["b"],"geometry":[
                {{"type":"Solid","lod":"1.2","boundaries":[[[[0,1,2,3]],[[4,5,6,7]]]]}},
                {{"type":"Solid","lod":"2.2","boundaries":[[[[0,1,2,3]],[[4,5,6,7]],[[0,1,5,4]],[[1,2,6,5]]]],
                  "semantics":{{"surfaces":[{{"type":"GroundSurface"}},{{"type":"RoofSurface","slope":0}},
                    {{"type":"WallSurface","children":[3]}},{{"type":"Window","parent":2}}],
                    "values":[[0,1,3,null]]}}}}]}},
              "i":{{"type":"BuildingInstallation","parents":["p"],"attributes":{{"function":"chimney"}},
                "geometry":[{{"type":"MultiSurface","lod":"2","boundaries":[[[4,5,6]]]}}]}},
              "r":{{"type":"BuildingRoom","parents":["p"],"geometry":[{{"type":"MultiSurface","lod":"3","boundaries":[[[0,1,2]]]}}]}}
            }},"vertices":{SQUARE}}}"#
        );
        let m = read(&doc);
        let f = &m.files[0];
        assert_eq!(
            f.srs_name.as_deref(),
            Some("https://www.opengis.net/def/crs/EPSG/0/7415")
        );
        assert_eq!(
            f.cityjson,
            Some(CityJsonFormat {
                version: "2.0".into(),
                seq: false
            })
        );
        assert_eq!(m.buildings.len(), 2);
        assert_eq!(m.buildings[1].parent, Some(0));
        let kinds: Vec<AssetKind> = m.assets.iter().map(|a| a.kind).collect();
        use AssetKind::*;
        assert_eq!(kinds, [Ground, Roof, Wall, Window, Installation]);
        // the wall holds only its window; the window's parent is the wall
        assert_eq!(m.assets[2].polygon_count(), 0);
        assert_eq!(m.assets[3].parent, Some(2));
        assert_eq!(m.assets[4].building, Some(1));
        assert_eq!(m.assets[4].function.as_deref(), Some("chimney"));
        // LoD 1.2 and the unclassified polygon of LoD 2.2 are the part's own geometry
        let own: Vec<u8> = m.buildings[1].geometries.iter().map(|g| g.lod).collect();
        assert_eq!(own, [1, 2]);
        assert_eq!(m.warnings.len(), 1, "{:?}", m.warnings);
        // transform applied
        let roof = &m.assets[1].detail_polygons()[0];
        assert_eq!(roof.exterior()[2], glam::DVec3::new(101.0, 201.0, 3.0));
        assert_eq!(m.assets[1].geometries[0].property.as_ref(), "lod2Solid");
        assert_eq!(f.features.get("BuildingRoom"), Some(&1));
    }

    #[test]
    fn body_templates_and_seq() {
        let doc = format!(
            r#"{{{HEAD},"metadata":{{"referenceSystem":{{"authority":"EPSG","code":7415}}}},
            "geometry-templates":{{"templates":[{{"type":"MultiSurface","lod":"2","boundaries":[[[0,1,2]]]}}],
              "vertices-templates":[[0,0,0],[1,0,0],[0,1,0]]}},"CityObjects":{{}},"vertices":[]}}
{{"type":"CityJSONFeature","id":"b","CityObjects":{{"b":{{"type":"Building","geometry":[
  {{"type":"MultiSurface","lod":"1","boundaries":[[[0,1,2]]]}}]}}}},"vertices":[[0,0,0],[100,0,0],[0,100,0]]}}
{{"type":"CityJSONFeature","id":"t","CityObjects":{{"t":{{"type":"SolitaryVegetationObject","geometry":[
  {{"type":"GeometryInstance","template":0,"boundaries":[0],
    "transformationMatrix":[2,0,0,0, 0,2,0,0, 0,0,2,0, 0,0,0,1]}}]}}}},"vertices":[[1000,0,0]]}}
"#
        );
        let m = read(&doc);
        assert_eq!(m.files[0].srs_name.as_deref(), Some("EPSG:7415"));
        assert!(m.files[0].cityjson.as_ref().is_some_and(|c| c.seq));
        // bodies come last, as in the CityGML reader
        assert_eq!(m.assets[1].kind, AssetKind::Body);
        assert_eq!(m.assets[1].building, Some(0));
        assert_eq!(m.assets[1].line, 2);
        assert!(m.buildings[0].geometries.is_empty());
        let tree = &m.assets[0];
        assert_eq!(
            (tree.kind, tree.element.as_ref()),
            (AssetKind::Other, "SolitaryVegetationObject")
        );
        assert_eq!(
            tree.geometries[0].property.as_ref(),
            "lod2ImplicitRepresentation"
        );
        // template scaled by 2, then moved to the reference point (110, 200, 0)
        assert_eq!(
            tree.detail_polygons()[0].exterior()[1],
            glam::DVec3::new(112.0, 200.0, 0.0)
        );
        assert_eq!(m.files[0].implicit_geometries, 1);
        // seq lines are numbered: an error on line 3 says so
        let bad = doc.replace("\"template\":0", "\"template\":3");
        let e = read_slice(bad.as_bytes(), Path::new("t.city.jsonl")).unwrap_err();
        assert_eq!((e.line, e.id.as_deref()), (3, Some("t")));
    }

    #[test]
    fn no_panic_on_odd_input() {
        for doc in [
            "",
            "{",
            "{}",
            "[1,2]",
            r#"{"type":"CityJSON","CityObjects":{"a":{"type":"Building","geometry":[{"type":"Solid","lod":"2","boundaries":[[[[0]]]]}]}},"vertices":[[0,0,0]]}"#,
            r#"{"type":"CityJSON","CityObjects":{"a":{"type":"Building","geometry":[{"type":"MultiSurface","lod":"9","boundaries":[]}]}},"vertices":[]}"#,
            r#"{"type":"CityJSON","CityObjects":{"a":{"type":"Building","geometry":[{"type":"MultiSurface","lod":"2","boundaries":[[[0,1,2]]],"semantics":{"surfaces":[],"values":[7]}}]}},"vertices":[[0,0,0],[1,0,0],[0,1,0]]}"#,
            r#"{"type":"CityJSON","transform":{"scale":[1e300,1,1],"translate":[0,0,0]},"CityObjects":{},"vertices":[[1e300,0,0]]}"#,
        ] {
            let _ = read_slice(doc.as_bytes(), Path::new("odd.json"));
        }
        // a semantic index beyond the surfaces is a warning, not an error
        let m = read(
            r#"{"type":"CityJSON","version":"2.0","CityObjects":{"a":{"type":"Building","geometry":[{"type":"MultiSurface","lod":"2","boundaries":[[[0,1,2]]],"semantics":{"surfaces":[],"values":[7]}}]}},"vertices":[[0,0,0],[1,0,0],[0,1,0]]}"#,
        );
        assert_eq!(m.assets[0].kind, AssetKind::Body);
        assert_eq!(m.warnings.len(), 1);
    }

    #[test]
    fn gzip_reads_the_same() {
        use std::io::Write;
        let doc = format!(
            r#"{{{HEAD},"CityObjects":{{"b":{{"type":"Building","geometry":[{{"type":"MultiSurface","lod":"2","boundaries":[[[0,1,2]]]}}]}}}},"vertices":{SQUARE}}}"#
        );
        let mut e = flate2::write::GzEncoder::new(Vec::new(), Default::default());
        e.write_all(doc.as_bytes()).unwrap();
        let gz = e.finish().unwrap();
        let a = chunks::whole_model(chunks::Input::Gzip(&gz), Path::new("t.city.json.gz")).unwrap();
        let b = read(&doc);
        assert_eq!(a.assets, b.assets);
        assert!(a.files[0].gzip);
        assert_eq!(a.files[0].len, doc.len() as u64);
    }
}
