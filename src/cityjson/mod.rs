//! CityJSON 1.0 / 1.1 / 2.0 (`.city.json`, or any name: recognised by content) and
//! CityJSONSeq (`.city.jsonl`: a `CityJSON` header line, then `CityJSONFeature` lines) read
//! into the same [`CityModel`] as CityGML ([`map`] has the mapping).
//!
//! Vertices get the document's `transform`; `metadata.referenceSystem` (any form the CRS
//! parser knows: `https://www.opengis.net/def/crs/EPSG/0/7415`, `urn:ogc:def:crs:EPSG::7415`,
//! `EPSG:7415`) becomes the model's `srsName`. A CityJSON source has no XML: its spans are
//! empty, [`SourceFile::cityjson`] says what it is, and the writers that copy CityGML from
//! their source refuse it.
//!
//! The document is read value by value ([`serde_json::StreamDeserializer`]): CityJSONSeq one
//! feature line at a time, each line's objects mapped and dropped before the next; gzip is
//! decompressed as it is read. Errors name the file, line:column where the JSON parser knows
//! them, and the city object's id.
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
//! let model = skylod::cityjson::read_slice(doc, "b.city.json".as_ref()).unwrap();
//! assert_eq!(model.assets[0].kind, skylod::model::AssetKind::Roof);
//! assert_eq!(model.assets[0].geometries[0].lod, 2);
//! assert_eq!(model.assets[0].detail_polygons()[0].exterior()[1].x, 1001.0);
//! ```

mod doc;
pub mod map;
mod seq;

pub use map::Origin;
pub use seq::{read_reader, read_slice, read_slice_with_origins};

use crate::model::CityModel;
use std::fmt;
use std::path::{Path, PathBuf};

/// Why a CityJSON document could not be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub struct Error {
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

impl fmt::Display for Error {
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

impl Error {
    pub(crate) fn at(file: &Path, line: u64, id: Option<&str>, message: String) -> Error {
        Error {
            file: file.to_path_buf(),
            line,
            column: 0,
            id: id.map(str::to_string),
            message,
        }
    }

    /// A JSON parser's error, with its line and column.
    pub(crate) fn json(file: &Path, e: &serde_json::Error) -> Error {
        let text = e.to_string();
        let message = match text.rsplit_once(" at line ") {
            Some((m, _)) => m.to_string(),
            None => text,
        };
        Error {
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
/// use skylod::cityjson::{sniff, Sniffed};
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

/// True when `model`'s file `file` was read from CityJSON.
pub fn is_cityjson(model: &CityModel, file: usize) -> bool {
    model.files.get(file).is_some_and(|f| f.cityjson.is_some())
}
