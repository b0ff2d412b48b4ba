//! What every chunk of a document shares: its version's warning and CityGML version, its
//! template vertices, its file in the model, its reference system as a CRS name.

use super::doc::Templates;
use super::map::{real_vertices, Counts, Mapper};
use super::CityJsonError;
use crate::model::{CityGmlVersion, CityJsonFormat, Source, SourceFile};
use glam::DVec3;
use std::path::Path;

/// Warn about a version other than 1.0, 1.1, 2.0 (read as 2.0).
pub(crate) fn check_version(mapper: &mut Mapper, version: &str) {
    if !["1.0", "1.1", "2.0"].contains(&version) {
        mapper.warn(1, "", format!("CityJSON version {version:?}: read as 2.0"));
    }
}

/// The CityGML version a CityJSON version encodes: 2.0's data model is CityGML 3.0's, 1.x's
/// CityGML 2.0's.
pub(crate) fn model_version(version: &str) -> CityGmlVersion {
    if version.starts_with('1') {
        CityGmlVersion::V2_0
    } else {
        CityGmlVersion::V3_0
    }
}

/// The template vertices in real coordinates (never transformed).
pub(crate) fn template_vertices(
    templates: Option<&Templates>,
    name: &Path,
) -> Result<Vec<DVec3>, CityJsonError> {
    Ok(templates
        .map(|t| real_vertices(&t.vertices, None, name, 1))
        .transpose()?
        .unwrap_or_default())
}

/// The model's file of a CityJSON document (not CityJSONSeq) of `len` bytes.
pub(crate) fn source_file(
    name: &Path,
    version: &str,
    srs_name: Option<String>,
    gzip: bool,
    len: u64,
    counts: Counts,
) -> SourceFile {
    SourceFile {
        path: name.to_path_buf(),
        source: Source::File(name.to_path_buf()),
        version: model_version(version),
        srs_name,
        gzip,
        len,
        gml_prefix: String::new(),
        envelopes: Vec::new(),
        implicit_geometries: counts.implicit_geometries,
        library_objects: Vec::new(),
        objects_without_geometry: counts.objects_without_geometry,
        polygon_elements: counts.polygon_elements,
        features: counts.features,
        cityjson: Some(CityJsonFormat {
            version: version.to_string(),
            seq: false,
        }),
    }
}

/// `metadata.referenceSystem` as the text of a CRS name: the string as given (2.0's URL, a
/// URN), or 1.x's extended form `{"base_url": ..., "authority": "EPSG", "code": 7415}` as
/// `EPSG:7415`; `None` for anything else.
pub(crate) fn reference_system_text(v: &serde_json::Value) -> Option<String> {
    match v {
        serde_json::Value::String(s) => Some(s.clone()),
        serde_json::Value::Object(o) => {
            let code = o
                .get("code")
                .map(|c| c.to_string().trim_matches('"').to_string())?;
            let auth = o
                .get("authority")
                .and_then(|a| a.as_str())
                .unwrap_or("EPSG");
            Some(format!("{auth}:{code}"))
        }
        _ => None,
    }
}
