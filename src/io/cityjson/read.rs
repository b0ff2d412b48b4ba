//! A document value by value: the `CityJSON` object, then (CityJSONSeq) one
//! `CityJSONFeature` per line, each mapped and dropped before the next is parsed.

use super::doc::{Doc, Metadata, Templates};
use super::map::{real_vertices, Counts, Mapper, Origin, Vertices};
use super::CityJsonError;
use crate::model::{CityGmlVersion, CityJsonFormat, CityModel, Source, SourceFile};
use glam::DVec3;
use std::cell::Cell;
use std::io::{BufRead, Read};
use std::path::Path;

/// Read a CityJSON or CityJSONSeq document held in memory (`name` names it in the model,
/// errors and warnings).
///
/// # Errors
/// [`CityJsonError`]: not JSON, not CityJSON, a vertex index out of range, a non-finite coordinate...
pub fn read_slice(bytes: &[u8], name: &Path) -> Result<CityModel, CityJsonError> {
    read_slice_with_origins(bytes, name).map(|(m, _)| m)
}

/// [`read_slice`], with where each asset came from in the document ([`Origin`], one per
/// asset, in the model's order).
///
/// # Errors
/// As [`read_slice`].
pub fn read_slice_with_origins(
    bytes: &[u8],
    name: &Path,
) -> Result<(CityModel, Vec<Origin>), CityJsonError> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let de = serde_json::Deserializer::from_slice(bytes);
    let (mut model, origins) = read_values(de.into_iter::<Doc>(), name, false)?;
    if let Some(f) = model.files.first_mut() {
        f.len = bytes.len() as u64;
    }
    Ok((model, origins))
}

/// Read a CityJSON or CityJSONSeq document from a reader (a gzip stream being decompressed:
/// nothing but the current value is held); `gzip` is recorded in the model.
///
/// # Errors
/// As [`read_slice`]; I/O errors of `r` as [`CityJsonError`]s.
pub fn read_reader<R: BufRead>(
    mut r: R,
    name: &Path,
    gzip: bool,
) -> Result<CityModel, CityJsonError> {
    let head = r
        .fill_buf()
        .map_err(|e| CityJsonError::at(name, 0, None, format!("cannot read: {e}")))?;
    if head.starts_with(b"\xEF\xBB\xBF") {
        r.consume(3);
    }
    let n = Cell::new(0u64);
    let counted = Counting { inner: r, n: &n };
    let de = serde_json::Deserializer::from_reader(counted);
    let (mut model, _) = read_values(de.into_iter::<Doc>(), name, gzip)?;
    if let Some(f) = model.files.first_mut() {
        f.len = n.get();
    }
    Ok(model)
}

/// A reader that counts the bytes it hands out.
struct Counting<'a, R> {
    inner: R,
    n: &'a Cell<u64>,
}

impl<R: Read> Read for Counting<'_, R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let k = self.inner.read(buf)?;
        self.n.set(self.n.get() + k as u64);
        Ok(k)
    }
}

/// The header value, then any feature values.
fn read_values(
    mut values: impl Iterator<Item = Result<Doc, serde_json::Error>>,
    name: &Path,
    gzip: bool,
) -> Result<(CityModel, Vec<Origin>), CityJsonError> {
    let head = match values.next() {
        None => return Err(CityJsonError::at(name, 0, None, "empty document".into())),
        Some(Err(e)) => return Err(CityJsonError::json(name, &e)),
        Some(Ok(d)) => d,
    };
    if head.ty != "CityJSON" {
        return Err(CityJsonError::at(
            name,
            1,
            None,
            format!(
                "the first object is of type {:?}, not \"CityJSON\"",
                head.ty
            ),
        ));
    }
    let version = head.version.clone().unwrap_or_default();
    let mut mapper = Mapper::new(name);
    check_version(&mut mapper, &version);
    let srs_name = head.metadata.as_ref().and_then(Metadata::srs_name);
    let transform = head.transform;
    let template_list = template_vertices(head.templates.as_ref(), name)?;
    let templates = head.templates.as_ref();
    let list = real_vertices(&head.vertices, transform.as_ref(), name, 0)?;
    let verts = Vertices {
        list: &list,
        templates,
        template_list: &template_list,
    };
    mapper.add(&head.objects.0, &verts, 0)?;
    drop(list);
    let mut seq = false;
    for (k, v) in values.enumerate() {
        let line = k as u64 + 2;
        let f = v.map_err(|e| CityJsonError::json(name, &e))?;
        if f.ty != "CityJSONFeature" {
            return Err(CityJsonError::at(
                name,
                line,
                f.id.as_deref(),
                format!("a value of type {:?} after the CityJSON header (CityJSONSeq holds CityJSONFeature lines)", f.ty),
            ));
        }
        seq = true;
        let list = real_vertices(&f.vertices, transform.as_ref(), name, line)?;
        let verts = Vertices {
            list: &list,
            templates,
            template_list: &template_list,
        };
        mapper.add(&f.objects.0, &verts, line)?;
    }
    let (buildings, assets, origins, warnings, counts) = mapper.finish();
    let mut file = source_file(name, &version, srs_name, gzip, 0, counts);
    if let Some(c) = &mut file.cityjson {
        c.seq = seq;
    }
    Ok((
        CityModel {
            files: vec![file],
            buildings,
            assets,
            warnings,
        },
        origins,
    ))
}

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
