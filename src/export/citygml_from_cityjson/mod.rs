//! CityJSON 1.0 / 1.1 / 2.0 and CityJSONSeq → CityGML 2.0 (or 3.0 through
//! [`crate::export::transform::citygml::upgrade`]), written from the CityJSON document itself (not the model
//! [`crate::io::cityjson`] reads, which keeps only what the analysis needs).
//!
//! # Mapping
//!
//! * **City objects** by type: `Building` / `BuildingPart` (`bldg:consistsOfBuildingPart`),
//!   `BuildingInstallation` (`bldg:outerBuildingInstallation`), `Bridge` / `BridgePart` /
//!   `BridgeInstallation` / `BridgeConstructiveElement` (`brid:BridgeConstructionElement`),
//!   `Tunnel` / `TunnelPart` / `TunnelInstallation`, `CityFurniture`, `SolitaryVegetationObject`,
//!   `PlantCover`, `LandUse`, `WaterBody`, `Road` / `Railway` / `TransportSquare`
//!   (`tran:Square`), `TINRelief` (`dem:TINRelief` with a `gml:TriangulatedSurface`; a
//!   polygon of more than 3 vertices as a fan of triangles, counted), `GenericCityObject`,
//!   `CityObjectGroup` (`grp:groupMember` links to its `children`). A child is nested in its
//!   parent where the parent's feature has a property for it; otherwise it is a member of
//!   its own. `OtherConstruction`, `Waterway` and extension types (`+...`) become
//!   `GenericCityObject`s with their type in the generic attribute `cityjson_type`
//!   (counted); interior types without a CityGML 2.0 counterpart at LoD 0 to 3
//!   (`BuildingRoom`, `BuildingStorey`, `BuildingUnit`, `BuildingFurniture`,
//!   `BuildingConstructiveElement`, tunnel and bridge rooms, hollow spaces and furniture)
//!   are dropped and counted.
//! * **Geometry** by integer LoD (`"2.2"` → 2) into the first free property of the feature
//!   that can hold it, in this order: a solid into `lodXSolid` (a `MultiSolid` /
//!   `CompositeSolid` as a `gml:CompositeSolid`), `lodXMultiSolid`, `lodXGeometry`, or its
//!   polygons into `lodXMultiSurface`; a surface into `lodXMultiSurface`, `lod0FootPrint`
//!   or `lodXGeometry`; lines into `lodXMultiCurve` or `lodXGeometry`; points into
//!   `lodXGeometry`; a `GeometryInstance` into `lodXImplicitRepresentation` (a
//!   `core:ImplicitGeometry` with the template inline, its matrix and reference point). A
//!   geometry with no free property (a second LoD 2 solid, a LoD 1 installation) is dropped
//!   and counted. Rings are closed; `transform` is applied (printed with the scale's
//!   decimals).
//! * **Semantic surfaces** of LoD 2 and 3 become thematic surfaces (`boundedBy` /
//!   `RoofSurface`, `WallSurface`, ... with their own `lodXMultiSurface`; water's
//!   `lodXSurface`; roads' `trafficArea` / `auxiliaryTrafficArea`); `Window` and `Door`
//!   (LoD 3) are `opening`s of their parent surface, below LoD 3 part of it. In a solid
//!   the polygons are written once, in their thematic surface with a `gml:id`
//!   (`<object>.g<geometry>.p<polygon>`), and the solid refers to them (`xlink:href`). The
//!   semantic object's other members become generic attributes of the surface. Semantic
//!   surfaces CityGML 2.0 has no place for (LoD 0 / 1, a type the feature has no thematic
//!   surface for) leave their polygons in the object's geometry (counted).
//! * **Attributes**: those CityGML 2.0 has as properties of the feature (`class`,
//!   `function`, `usage` (arrays repeated), `yearOfConstruction`, `yearOfDemolition`,
//!   `roofType`, `measuredHeight` (`uom="m"`), `storeysAboveGround`, `storeysBelowGround`,
//!   `isMovable`, `species`, `height`, `averageHeight`, `trunkDiameter`, `crownDiameter`) in
//!   schema order when their value fits the property's type; every other attribute as a
//!   generic attribute (`gen:intAttribute`, `gen:doubleAttribute`, `gen:stringAttribute`;
//!   arrays and objects as their JSON text; `null` dropped and counted).
//! * **Ids**: each key is the feature's `gml:id` ([`gml_id`]: a key that is not an XML
//!   NCName gets `id_` in front and `_xHH_` for each character an NCName cannot hold).
//! * **CRS and extent**: `metadata.referenceSystem` → `srsName` as an OGC URN
//!   (`urn:ogc:def:crs:EPSG::7415`; a name with no EPSG code as given) on the envelopes:
//!   the model's `gml:boundedBy` (the box of every vertex of a document; a CityJSONSeq's
//!   `metadata.geographicalExtent`) and each member's (the box of its written vertices).
//! * **Not written** (counted): appearances (materials, textures: CityGML 2.0 would need
//!   the texture files and coordinates per ring), addresses.
//!
//! # Streaming
//!
//! CityJSONSeq is written feature by feature: each line is read, written as members and
//! dropped before the next, so memory follows the largest feature. A `.city.json` document
//! is one JSON value: read whole, then written member by member ([`citygml_from_cityjson`]),
//! or in chunks of whole city-object trees ([`citygml_from_cityjson_chunked`]: the same
//! bytes, memory that follows the chunk and the document's vertices).

mod document;
mod geometry;
mod object;
mod types;
mod values;

pub use values::gml_id;

use crate::export::transform::citygml::upgrade::{upgrade, UpgradeOptions};
use crate::io::citygml::error::{ReadError, WriteError};
use crate::io::citygml::write::{check_target, WriteOptions};
use crate::io::cityjson::doc::{self, Doc};
use geometry::Verts;
use object::{write_object, Tally, Unit};
use std::collections::BTreeMap;
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};
use values::{esc, Coords};

/// The CityGML version written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TargetVersion {
    /// CityGML 2.0.
    #[default]
    V2_0,
    /// CityGML 3.0 (2.0 upgraded member by member: `crate::export::transform::citygml::upgrade`).
    V3_0,
}

impl std::str::FromStr for TargetVersion {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            "2.0" | "2" => Ok(TargetVersion::V2_0),
            "3.0" | "3" => Ok(TargetVersion::V3_0),
            o => Err(format!("CityGML version {o:?}: 2.0 or 3.0")),
        }
    }
}

/// Why a CityJSON document could not be written as CityGML.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FromCityJsonError {
    /// The source is not valid CityJSON (file, line, city object).
    #[error(transparent)]
    CityJson(#[from] crate::io::cityjson::CityJsonError),
    /// The source cannot be read.
    #[error(transparent)]
    Read(#[from] ReadError),
    /// The output cannot be written (or is refused).
    #[error(transparent)]
    Write(#[from] WriteError),
}

impl From<crate::io::files::FileError> for FromCityJsonError {
    fn from(e: crate::io::files::FileError) -> Self {
        FromCityJsonError::Write(e.into())
    }
}

/// What a conversion wrote and left out.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
#[non_exhaustive]
pub struct FromCityJsonSummary {
    /// The source's CityJSON version.
    pub cityjson_version: String,
    /// Whether the source was CityJSONSeq.
    pub seq: bool,
    /// The CityGML version written (`2.0`, `3.0`).
    pub citygml_version: String,
    /// Top-level members written.
    pub members: usize,
    /// Features written by CityGML element (nested ones and thematic surfaces too).
    pub objects: BTreeMap<String, usize>,
    /// Polygons written (triangles of a TIN).
    pub polygons: usize,
    /// `gml:id`s made from keys that are not XML names.
    pub ids_made: usize,
    /// What was left out or written otherwise (as a generic object, a fan of triangles),
    /// by kind, with how many.
    pub dropped: BTreeMap<String, usize>,
    /// Bytes written (before compression).
    pub bytes_out: u64,
}

impl FromCityJsonSummary {
    /// `a.city.json -> a.gml: CityJSON 2.0 -> CityGML 2.0, 3 member(s), ...`.
    pub fn describe(&self, input: &Path, out: &Path) -> String {
        let objects: Vec<String> = self
            .objects
            .iter()
            .map(|(k, n)| format!("{k} {n}"))
            .collect();
        let mut s = format!(
            "CityJSON{} {} -> CityGML {}, {} member(s) ({}), {} polygon(s), {} gml:id(s) made",
            if self.seq { "Seq" } else { "" },
            self.cityjson_version,
            self.citygml_version,
            self.members,
            objects.join(", "),
            self.polygons,
            self.ids_made,
        );
        if !self.dropped.is_empty() {
            let d: Vec<String> = self
                .dropped
                .iter()
                .map(|(k, n)| format!("{n} × {k}"))
                .collect();
            s += &format!(", left out or changed: {}", d.join("; "));
        }
        s += &format!(", {} bytes", self.bytes_out);
        crate::model::made_line(input, out, &s)
    }
}

/// Write the CityJSON / CityJSONSeq document `input` (gzip recognised by content) as CityGML
/// `version` to `out` (`.gz` compressed, `-` standard output), atomically.
///
/// # Errors
/// The target is refused ([`check_target`]), the source is not CityJSON or cannot be read,
/// the output cannot be written.
pub fn citygml_from_cityjson(
    input: &Path,
    out: &Path,
    version: TargetVersion,
    opts: &WriteOptions,
) -> Result<FromCityJsonSummary, FromCityJsonError> {
    convert(input, out, version, opts, None)
}

/// [`citygml_from_cityjson`] of a `.city.json` document in chunks of whole city-object
/// trees of about `chunk_bytes` of document (`io::cityjson::chunks`): the same
/// bytes, memory that follows the chunk and the document's vertices (24 bytes each), not the
/// document. The document is read twice (its vertices and links, then its objects).
/// CityJSONSeq, and a document the chunked read declines (an id given twice, one that does
/// not read), is converted as [`citygml_from_cityjson`] does.
///
/// # Errors
/// As [`citygml_from_cityjson`].
pub fn citygml_from_cityjson_chunked(
    input: &Path,
    out: &Path,
    version: TargetVersion,
    opts: &WriteOptions,
    chunk_bytes: u64,
) -> Result<FromCityJsonSummary, FromCityJsonError> {
    convert(input, out, version, opts, Some(chunk_bytes))
}

/// [`citygml_from_cityjson`], in chunks where `chunk` says so.
fn convert(
    input: &Path,
    out: &Path,
    version: TargetVersion,
    opts: &WriteOptions,
    chunk: Option<u64>,
) -> Result<FromCityJsonSummary, FromCityJsonError> {
    use crate::io::cityjson::chunks::{prepare, Input};
    check_target(out, opts, std::iter::once(input))?;
    // pass 1 of the chunked read; what it declines is read whole (and its errors said so)
    let mut prepared = chunk
        .and_then(|c| prepare::<()>(Input::File(input), input, c).ok())
        .flatten();
    let mut write = |w: &mut dyn Write| match prepared.take() {
        Some(p) => document::write_chunked(input, p, w),
        None => write_citygml(open(input)?, input, w),
    };
    if version == TargetVersion::V2_0 {
        let mut summary = FromCityJsonSummary::default();
        let bytes = crate::io::files::atomic_write(out, |w| {
            summary = write(w)?;
            Ok::<_, FromCityJsonError>(summary.bytes_out)
        })?;
        summary.bytes_out = bytes;
        return Ok(summary);
    }
    // 3.0: the 2.0 document in a temporary file beside the output, upgraded member by member.
    let dir = match out.parent().filter(|d| !d.as_os_str().is_empty()) {
        Some(d) if !crate::io::files::is_stdout(out) && d.is_dir() => d.to_path_buf(),
        _ => std::env::temp_dir(),
    };
    let io = |source| WriteError::Io {
        file: dir.clone(),
        source,
    };
    let tmp = tempfile::Builder::new()
        .prefix(".skylod-cityjson-")
        .suffix(".gml")
        .tempfile_in(&dir)
        .map_err(io)?;
    let mut w = std::io::BufWriter::new(tmp.as_file());
    let mut summary = write(&mut w)?;
    w.flush().map_err(io)?;
    drop(w);
    let options = UpgradeOptions::new(false, true, true);
    let up = upgrade(tmp.path(), out, &options, opts)?;
    summary.citygml_version = "3.0".into();
    for d in up.dropped {
        *summary
            .dropped
            .entry(format!("{d} (upgrade to 3.0)"))
            .or_default() += 1;
    }
    summary.bytes_out = up.bytes_out;
    Ok(summary)
}

pub use crate::io::cityjson::is_json_file;

/// Open a (possibly gzip-compressed) file, or standard input for `-`.
fn open(input: &Path) -> Result<Box<dyn BufRead + Send>, ReadError> {
    let (r, _) = crate::io::files::open_decoded(input).map_err(|source| ReadError::Io {
        file: input.to_path_buf(),
        source,
    })?;
    Ok(r)
}

/// Write the CityJSON / CityJSONSeq read from `r` (named `name` in errors) as CityGML 2.0
/// to `w`, value by value.
///
/// # Errors
/// The source is not CityJSON (a vertex index out of range, a non-finite coordinate, ...);
/// `w` fails.
pub fn write_citygml<R: BufRead>(
    mut r: R,
    name: &Path,
    w: &mut dyn Write,
) -> Result<FromCityJsonSummary, FromCityJsonError> {
    let cj = |line: u64, id: Option<&str>, m: String| {
        crate::io::cityjson::CityJsonError::at(name, line, id, m)
    };
    if r.fill_buf().is_ok_and(|h| h.starts_with(b"\xEF\xBB\xBF")) {
        r.consume(3);
    }
    let mut values = serde_json::Deserializer::from_reader(r).into_iter::<Doc>();
    let head = match values.next() {
        None => return Err(cj(0, None, "empty document".into()).into()),
        Some(Err(e)) => return Err(crate::io::cityjson::CityJsonError::json(name, &e).into()),
        Some(Ok(d)) => d,
    };
    if head.ty != "CityJSON" {
        let m = format!(
            "the first object is of type {:?}, not \"CityJSON\"",
            head.ty
        );
        return Err(cj(1, None, m).into());
    }
    let meta = head.metadata.as_ref();
    let transform = head.transform;
    let list = real(&head.vertices, transform.as_ref(), name, 0)?;
    let mut out = Out::new(w, name, meta, transform.as_ref());
    out.root(bbox(&list).or_else(|| meta?.extent()))?;
    if head.appearance.is_some() {
        out.tally.drop("appearance (materials, textures)".into());
    }
    let templates = head.templates.as_ref();
    out.unit(&head.objects.0, templates, &list, 0)?;
    drop(list);
    let (mut seq, mut appearances) = (false, 0);
    for (k, v) in values.enumerate() {
        let line = k as u64 + 2;
        let f = v.map_err(|e| crate::io::cityjson::CityJsonError::json(name, &e))?;
        if f.ty != "CityJSONFeature" {
            let m = format!("a value of type {:?} after the CityJSON header (CityJSONSeq holds CityJSONFeature lines)", f.ty);
            return Err(cj(line, None, m).into());
        }
        seq = true;
        appearances += usize::from(f.appearance.is_some());
        let list = real(&f.vertices, transform.as_ref(), name, line)?;
        out.unit(&f.objects.0, templates, &list, line)?;
    }
    out.finish(head.version.unwrap_or_default(), seq, appearances)
}

/// The CityGML being written ([`write_citygml`], [`document::write_chunked`]): the output and
/// what it holds so far.
struct Out<'a> {
    w: &'a mut dyn Write,
    name: &'a Path,
    /// Bytes written.
    n: u64,
    tally: Tally,
    members: usize,
    srs: Option<String>,
    coords: Coords,
}

impl<'a> Out<'a> {
    fn new(
        w: &'a mut dyn Write,
        name: &'a Path,
        meta: Option<&doc::Metadata>,
        transform: Option<&doc::Transform>,
    ) -> Self {
        Out {
            w,
            name,
            n: 0,
            tally: Tally::default(),
            members: 0,
            srs: meta
                .and_then(|m| m.reference_system.as_ref())
                .and_then(srs_name),
            coords: Coords::new(transform.map(|t| t.scale)),
        }
    }

    fn put(&mut self, s: &str) -> Result<(), FromCityJsonError> {
        self.w
            .write_all(s.as_bytes())
            .map_err(|source| WriteError::Io {
                file: PathBuf::from("<output>"),
                source,
            })?;
        self.n += s.len() as u64;
        Ok(())
    }

    /// The XML declaration, the root element and its envelope (`extent`).
    fn root(&mut self, extent: Option<[f64; 6]>) -> Result<(), FromCityJsonError> {
        let mut root = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<core:CityModel");
        root += types::ROOT_NAMESPACES;
        root += ">\n";
        if let Some(e) = extent {
            root += &format!(
                "<gml:boundedBy>{}</gml:boundedBy>\n",
                envelope(&e, self.srs.as_deref(), self.coords)
            );
        }
        self.put(&root)
    }

    /// The members of `objects` (whole trees, with the real coordinates `list`; `line` of a
    /// CityJSONSeq feature for errors, else 0), each with its envelope.
    fn unit(
        &mut self,
        objects: &[(String, doc::CityObject)],
        templates: Option<&doc::Templates>,
        list: &[[f64; 3]],
        line: u64,
    ) -> Result<(), FromCityJsonError> {
        let u = Unit::new(objects, templates);
        let mut verts = Verts {
            list,
            coords: self.coords,
            bbox: [0.0; 6],
        };
        for k in 0..objects.len() {
            if u.nested[k] {
                continue;
            }
            verts.reset_box();
            let x = write_object(&u, k, &mut verts, &mut self.tally, 0).map_err(|(id, m)| {
                crate::io::cityjson::CityJsonError::at(self.name, line, Some(&id), m)
            })?;
            let Some(mut x) = x else { continue };
            if verts.bbox[0] <= verts.bbox[3] {
                let env = format!(
                    "<gml:boundedBy>{}</gml:boundedBy>",
                    envelope(&verts.bbox, self.srs.as_deref(), self.coords)
                );
                if let Some(i) = x.find('>') {
                    x.insert_str(i + 1, &env);
                }
            }
            self.members += 1;
            self.put(&format!(
                "<core:cityObjectMember>{x}</core:cityObjectMember>\n"
            ))?;
        }
        Ok(())
    }

    /// The end of the root element; the summary (`appearances` of CityJSONSeq features
    /// counted as left out).
    fn finish(
        mut self,
        version: String,
        seq: bool,
        appearances: usize,
    ) -> Result<FromCityJsonSummary, FromCityJsonError> {
        self.put("</core:CityModel>\n")?;
        for _ in 0..appearances {
            self.tally.drop("appearance (materials, textures)".into());
        }
        Ok(FromCityJsonSummary {
            cityjson_version: version,
            seq,
            citygml_version: "2.0".into(),
            members: self.members,
            objects: self.tally.objects,
            polygons: self.tally.polygons,
            ids_made: self.tally.ids_made,
            dropped: self.tally.dropped,
            bytes_out: self.n,
        })
    }
}

/// `metadata.referenceSystem` as an OGC URN (as given when it names no EPSG code).
fn srs_name(v: &serde_json::Value) -> Option<String> {
    let text = crate::io::cityjson::reference_system_text(v)?;
    match crate::model::crs::CrsName::parse(&text) {
        Some(c) => Some(c.urn()),
        None => Some(text).filter(|t| !t.trim().is_empty()),
    }
}

/// Real coordinates (the `transform` applied), each finite and at most 1e12.
fn real(
    raw: &[[f64; 3]],
    t: Option<&doc::Transform>,
    name: &Path,
    line: u64,
) -> Result<Vec<[f64; 3]>, crate::io::cityjson::CityJsonError> {
    let list = crate::io::cityjson::map::real_vertices(raw, t, name, line)?;
    Ok(list.into_iter().map(|p| p.to_array()).collect())
}

fn bbox(list: &[[f64; 3]]) -> Option<[f64; 6]> {
    let first = list.first()?;
    let mut b = [first[0], first[1], first[2], first[0], first[1], first[2]];
    for p in list {
        for (a, v) in p.iter().enumerate() {
            b[a] = b[a].min(*v);
            b[a + 3] = b[a + 3].max(*v);
        }
    }
    Some(b)
}

fn envelope(b: &[f64; 6], srs: Option<&str>, coords: Coords) -> String {
    let mut s = String::from("<gml:Envelope");
    if let Some(srs) = srs {
        s += &format!(" srsName=\"{}\"", esc(srs));
    }
    s += " srsDimension=\"3\"><gml:lowerCorner>";
    coords.push(&mut s, [b[0], b[1], b[2]]);
    s += "</gml:lowerCorner><gml:upperCorner>";
    coords.push(&mut s, [b[3], b[4], b[5]]);
    s += "</gml:upperCorner></gml:Envelope>";
    s
}

#[cfg(test)]
mod tests;
