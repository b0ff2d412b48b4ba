//! CityGML for a model read from CityJSON (`rough` and `lod` with `-o x.gml`): the mixed
//! writer copies a CityGML source's XML, which a CityJSON source has not; so the model at its
//! levels is written as CityJSON in memory ([`super::cityjson`]: attributes and semantic
//! surfaces of the source kept, rough geometry as LoD 1), then that document as CityGML 2.0
//! ([`super::citygml_from_cityjson::write_citygml`]), atomically.
//!
//! # Example
//! ```
//! use skylod::export::write_citygml_levels;
//! use skylod::export::Content;
//! let doc = br#"{"type":"CityJSON","version":"2.0",
//!   "transform":{"scale":[0.001,0.001,0.001],"translate":[0,0,0]},
//!   "CityObjects":{"b1":{"type":"Building","attributes":{"roofType":"1000"},
//!     "geometry":[{"type":"MultiSurface","lod":"2",
//!     "boundaries":[[[0,1,2,3]]],
//!     "semantics":{"surfaces":[{"type":"RoofSurface"}],"values":[0]}}]}},
//!   "vertices":[[0,0,5000],[1000,0,5000],[1000,1000,5000],[0,1000,5000]]}"#;
//! let dir = tempfile::tempdir().unwrap();
//! let src = dir.path().join("b.city.json");
//! std::fs::write(&src, doc).unwrap();
//! let model = skylod::io::citygml::read_file(&src).unwrap();
//! let out = dir.path().join("b.gml");
//! let s = write_citygml_levels(&model, 0, Content::Full, &out, &Default::default()).unwrap();
//! assert_eq!(s.polygons, 1);
//! let gml = std::fs::read_to_string(&out).unwrap();
//! assert!(gml.contains("<bldg:RoofSurface"));
//! ```

use super::citygml_from_cityjson::{write_citygml, FromCityJsonError, FromCityJsonSummary};
use super::{Content, Format};
use crate::io::citygml::error::{ReadError, WriteError};
use crate::io::citygml::write::{atomic_write, check_target, WriteOptions};
use crate::model::CityModel;
use std::io::Write;
use std::path::Path;

/// Whether file `file` of `model` was read from CityJSON.
pub fn is_cityjson_source(model: &CityModel, file: usize) -> bool {
    model.files.get(file).is_some_and(|f| f.cityjson.is_some())
}

/// A CityJSON → CityGML error as a writer's error (the commands that edit CityGML report
/// [`WriteError`]s).
impl From<FromCityJsonError> for WriteError {
    fn from(e: FromCityJsonError) -> Self {
        match e {
            FromCityJsonError::CityJson(e) => WriteError::Read(ReadError::CityJson(e)),
            FromCityJsonError::Read(e) => WriteError::Read(e),
            FromCityJsonError::Write(e) => e,
        }
    }
}

/// Write file `file` of `model` with `content` as CityGML 2.0 to `out` (see the module docs),
/// atomically, refusing to write over an input or, without `overwrite`, an existing file.
///
/// # Errors
/// [`WriteError`]: a refused target, mismatched `content`, I/O.
pub fn write_citygml_levels(
    model: &CityModel,
    file: usize,
    content: Content<'_>,
    out: &Path,
    opts: &WriteOptions,
) -> Result<FromCityJsonSummary, WriteError> {
    let src = crate::io::citygml::write::source_file(model, file)?;
    check_target(out, opts, src.source.path())?;
    let mut summary = FromCityJsonSummary::default();
    let bytes = atomic_write(out, |w| {
        summary = write_citygml_levels_to(model, file, content, w)?;
        Ok(summary.bytes_out)
    })?;
    summary.bytes_out = bytes;
    Ok(summary)
}

/// [`write_citygml_levels`] into any writer `w` (uncompressed, no target checks).
///
/// # Errors
/// As [`write_citygml_levels`].
pub fn write_citygml_levels_to(
    model: &CityModel,
    file: usize,
    content: Content<'_>,
    w: &mut dyn Write,
) -> Result<FromCityJsonSummary, WriteError> {
    let src = crate::io::citygml::write::source_file(model, file)?;
    let mut json = Vec::new();
    let chunks = super::Chunks::model(model, file, content);
    super::write_to(Format::CityJson, &chunks, &mut json)?;
    Ok(write_citygml(std::io::Cursor::new(json), &src.path, w)?)
}
