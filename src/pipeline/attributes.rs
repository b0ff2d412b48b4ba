//! Per-surface results written back into the city model (`irradiance --output-attributes`):
//! the thematic surface that holds each POI ([`holding_surfaces`]), the mean of a value over
//! the POIs of each surface ([`surface_means`]), and a copy of the CityGML document with a
//! generic attribute added to each such surface by span edits ([`write_attributes`]):
//! everything else is copied byte for byte; or, for CityJSON, an attribute of each surface's
//! semantic object ([`write_surface_means`] picks by the output's name).
//!
//! # Example
//! ```
//! use skylod::pipeline::insertion_point;
//! let xml = br#"<bldg:WallSurface gml:id="w"><gml:name>a > b</gml:name><bldg:lod2MultiSurface/></bldg:WallSurface>"#;
//! let at = insertion_point(xml).unwrap();
//! assert!(xml[at..].starts_with(b"<bldg:lod2MultiSurface"));
//! ```

use super::Framed;
use crate::export::cityjson::{write as write_cityjson, Kind};
use crate::export::{Chunks, Content, Format};
use crate::io::citygml::ns::CORE_LEADING;
use crate::io::citygml::write::{escape_attr, write_document, Edit, WriteOptions};
use crate::io::citygml::WriteError;
use crate::io::files::{atomic_write, check_target, FileError, TargetError};
use crate::lod::scene::full_scene;
use crate::model::{CityGmlVersion, CityModel};
use glam::DVec3;
use quick_xml::events::Event;
use serde_json::{Map, Value};
use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};

/// How far behind a POI (along its normal reversed; down when it has none) its surface may
/// lie, in metres: facade POIs sit 5 cm out.
pub const HOLD_DISTANCE_M: f64 = 0.25;

pub use crate::export::IRRADIATION_ATTRIBUTE;

/// Per POI of `framed`, the thematic surface (an asset that is a shell surface: wall, roof,
/// ground, …) that holds it: the surface hit from the POI backwards along its normal (down
/// without one) within [`HOLD_DISTANCE_M`]. Five rays, from the POI and 1 cm to each side in
/// its plane, so that a POI on the edge between a wall and a roof (where the two tie) goes to
/// the surface whose plane is the POI's: among the surfaces hit, those with a polygon within
/// 25° of the POI's plane first, then the most rays, then the centre ray's. `None` when none
/// is hit (a POI in the open, on an opening or an installation).
pub fn holding_surfaces(framed: &Framed<'_>) -> Vec<Option<usize>> {
    let scene = full_scene(&framed.model);
    let model = &framed.model;
    let aligned = |i: usize, n: DVec3| {
        model.assets[i].detail_polygons().iter().any(|p| {
            p.newell_normal()
                .try_normalize()
                .is_some_and(|m| m.dot(n).abs() > 0.9)
        })
    };
    framed
        .local_pois
        .iter()
        .map(|p| {
            let n = p.normal.and_then(|n| n.try_normalize()).unwrap_or(DVec3::Z);
            let u = n.cross(DVec3::Z).try_normalize().unwrap_or(DVec3::X);
            let v = n.cross(u);
            let mut votes: Vec<(usize, usize, bool)> = Vec::new();
            for (k, d) in [DVec3::ZERO, u, -u, v, -v].into_iter().enumerate() {
                let o = p.position + 0.01 * d;
                let Some(hit) = scene.first_hit(o, -n, 0.0, HOLD_DISTANCE_M) else {
                    continue;
                };
                let i = hit.tag as usize;
                if !model
                    .assets
                    .get(i)
                    .is_some_and(|a| a.kind.is_shell_surface())
                {
                    continue;
                }
                match votes.iter_mut().find(|x| x.0 == i) {
                    Some(x) => x.1 += 1,
                    None => votes.push((i, 1, k == 0)),
                }
            }
            votes
                .into_iter()
                .max_by_key(|&(i, rays, centre)| (aligned(i, n), rays, centre))
                .map(|x| x.0)
        })
        .collect()
}

/// The mean of `values[k]` over the POIs `k` of each surface (`holders` from
/// [`holding_surfaces`]), with the number of POIs, by asset index.
pub fn surface_means(holders: &[Option<usize>], values: &[f64]) -> BTreeMap<usize, (f64, usize)> {
    let mut sums: BTreeMap<usize, (f64, usize)> = BTreeMap::new();
    for (h, v) in holders.iter().zip(values) {
        if let Some(i) = h {
            let e = sums.entry(*i).or_insert((0.0, 0));
            e.0 += v;
            e.1 += 1;
        }
    }
    for e in sums.values_mut() {
        e.0 /= e.1 as f64;
    }
    sums
}

/// Where a generic attribute goes inside the element that starts at `xml[0]`: after its start
/// tag and after the children that must come first (GML's `name`, `description`,
/// `boundedBy`, …, core's `creationDate` … `relativeToWater`, `relatedTo`, appearances and
/// generic attributes already there); `None` for an empty or malformed element.
pub fn insertion_point(xml: &[u8]) -> Option<usize> {
    const GML_LEADING: &[&str] = &[
        "metaDataProperty",
        "description",
        "descriptionReference",
        "identifier",
        "name",
        "boundedBy",
        "location",
    ];
    const GENERIC_ATTRIBUTES: &[&str] = &[
        "stringAttribute",
        "intAttribute",
        "doubleAttribute",
        "dateAttribute",
        "uriAttribute",
        "measureAttribute",
        "genericAttributeSet",
    ];
    let leading = |local: &[u8]| {
        let local = std::str::from_utf8(local).unwrap_or_default();
        [GML_LEADING, CORE_LEADING, GENERIC_ATTRIBUTES]
            .iter()
            .any(|names| names.contains(&local))
    };
    // The XML reader every other scan uses: quotes, comments, CDATA and nesting are its.
    let mut reader = quick_xml::Reader::from_reader(xml);
    let at = |r: &quick_xml::Reader<&[u8]>| usize::try_from(r.buffer_position()).ok();
    let Ok(Event::Start(_)) = reader.read_event() else {
        return None;
    };
    let mut after = at(&reader)?;
    loop {
        match reader.read_event().ok()? {
            Event::Text(t) if t.iter().all(u8::is_ascii_whitespace) => {}
            Event::Comment(_) => after = at(&reader)?,
            Event::Start(e) if leading(e.local_name().as_ref()) => {
                reader.read_to_end(e.name()).ok()?;
                after = at(&reader)?;
            }
            Event::Empty(e) if leading(e.local_name().as_ref()) => after = at(&reader)?,
            _ => return Some(after),
        }
    }
}

/// A generic attribute `name` = `value` for a document of `version`, with its namespace
/// declared on itself (whatever the document binds).
fn attribute_xml(version: CityGmlVersion, name: &str, value: f64) -> String {
    let name = escape_attr(name);
    match version {
        CityGmlVersion::V3_0 => format!(
            "<gen:genericAttribute xmlns:gen=\"http://www.opengis.net/citygml/generics/3.0\"><gen:DoubleAttribute><gen:name>{name}</gen:name><gen:value>{value}</gen:value></gen:DoubleAttribute></gen:genericAttribute>"
        ),
        v => {
            let ns = if v == CityGmlVersion::V1_0 { "1.0" } else { "2.0" };
            format!(
                "<gen:doubleAttribute xmlns:gen=\"http://www.opengis.net/citygml/generics/{ns}\" name=\"{name}\"><gen:value>{value}</gen:value></gen:doubleAttribute>"
            )
        }
    }
}

/// Write file `file` of `model` (as read, the CRS of its source) to `out` with the generic
/// double attribute `name` added to each asset of `values` (asset index → value) in that
/// file; the rest is copied byte for byte ([`write_document`], envelopes kept). The number
/// of surfaces that received it.
///
/// # Errors
/// [`WriteError`] when the source cannot be read again or the output cannot be written.
pub fn write_attributes(
    model: &CityModel,
    file: usize,
    name: &str,
    values: &BTreeMap<usize, f64>,
    out: &Path,
    opts: &WriteOptions,
) -> Result<usize, WriteError> {
    let src = crate::io::citygml::write::source_file(model, file)?;
    let io = |source| WriteError::Io {
        file: src.path.clone(),
        source,
    };
    let (mut reader, _) = crate::io::citygml::source::open(&src.path)
        .map_err(|e| WriteError::Invalid(format!("{}: {e}", src.path.display())))?;
    let mut xml = Vec::new();
    reader.read_to_end(&mut xml).map_err(io)?;
    let mut edits = Vec::new();
    for (&i, &v) in values {
        let Some(a) = model.assets.get(i).filter(|a| a.file == file) else {
            continue;
        };
        let (s, e) = (a.span.start as usize, a.span.end as usize);
        let Some(at) = xml.get(s..e).and_then(insertion_point) else {
            continue;
        };
        let at = (s + at) as u64;
        edits.push(Edit {
            span: at..at,
            replacement: attribute_xml(src.version, name, v).into_bytes(),
        });
    }
    let n = edits.len();
    let opts = WriteOptions {
        keep_envelopes: true,
        ..opts.clone()
    };
    write_document(model, file, edits, out, &opts)?;
    Ok(n)
}

/// Why [`write_surface_means`] failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AttributesError {
    /// The target is refused (an input, or an existing file without `overwrite`).
    #[error(transparent)]
    Target(#[from] TargetError),
    /// The CityJSON output could not be written.
    #[error("writing {}", .out.display())]
    CityJson {
        /// The output.
        out: PathBuf,
        /// Cause.
        source: FileError,
    },
    /// The CityGML output could not be written.
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// Write the model of `framed` (file 0: its one input) to `out` with the mean of `values`
/// (one per POI) over the POIs of each surface that holds POIs (`holding_surfaces`,
/// `surface_means`) as `IRRADIATION_ATTRIBUTE`: CityJSON for a `.city.json` name (an
/// attribute of the surface's semantic object), a 3D Tiles tileset for `DIR/tileset.json`
/// (each surface's `irradiance`; with `viewer`, its CesiumJS page), else CityGML by span
/// edits (`write_attributes`). Never over an input, nor over an existing file without
/// `overwrite`. The number of surfaces given it.
///
/// # Errors
/// [`AttributesError`].
pub fn write_surface_means(
    framed: &Framed<'_>,
    values: &[f64],
    out: &Path,
    (overwrite, viewer): (bool, bool),
) -> Result<usize, AttributesError> {
    let model = framed.source;
    let means = surface_means(&holding_surfaces(framed), values);
    let means: BTreeMap<usize, f64> = means.into_iter().map(|(i, (m, _))| (i, m)).collect();
    let inputs = model.files.iter().map(|f| f.path.as_path());
    check_target(out, inputs, overwrite)?;
    let format = Format::from_path(out);
    if matches!(format, Some(Format::CityJson | Format::Tiles)) {
        let attrs: BTreeMap<usize, Map<String, Value>> = (means.iter())
            .map(|(&i, &m)| {
                (
                    i,
                    Map::from_iter([(IRRADIATION_ATTRIBUTE.to_string(), m.into())]),
                )
            })
            .collect();
        let chunks = Chunks::Model {
            model,
            file: 0,
            content: Content::Full,
            surface_attributes: Some(&attrs),
        };
        if format == Some(Format::Tiles) {
            let opts = WriteOptions {
                overwrite,
                viewer,
                ..Default::default()
            };
            crate::export::write(Format::Tiles, &chunks, out, &opts)?;
            return Ok(means.len());
        }
        atomic_write(out, |w| {
            let written = write_cityjson(Kind::CityJson, &chunks, w);
            written.map(|_| 0).map_err(|e| FileError::new(out, e))
        })
        .map_err(|source| AttributesError::CityJson {
            out: out.to_path_buf(),
            source,
        })?;
        return Ok(means.len());
    }
    let opts = WriteOptions {
        overwrite,
        ..Default::default()
    };
    Ok(write_attributes(
        model,
        0,
        IRRADIATION_ATTRIBUTE,
        &means,
        out,
        &opts,
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn insertion_after_the_leading_children() {
        let x = br#"<W a="x>y"><!-- c --><gml:name>n</gml:name>
  <gml:boundedBy><gml:Envelope><gml:lowerCorner>0 0</gml:lowerCorner></gml:Envelope></gml:boundedBy>
  <gen:stringAttribute name="k"><gen:value>v</gen:value></gen:stringAttribute>
  <bldg:lod3MultiSurface/></W>"#;
        let at = insertion_point(x).unwrap();
        assert!(x[at..]
            .trim_ascii_start()
            .starts_with(b"<bldg:lod3MultiSurface"));
        let y = br#"<W><bldg:opening><x/></bldg:opening></W>"#;
        assert_eq!(insertion_point(y), Some(3));
        assert_eq!(insertion_point(b"<W/>"), None);
        assert_eq!(insertion_point(b"<W><gml:name>"), None);
    }

    #[test]
    fn means_per_surface() {
        let m = surface_means(&[Some(3), None, Some(3), Some(1)], &[1.0, 9.0, 3.0, 5.0]);
        assert_eq!(
            m.into_iter().collect::<Vec<_>>(),
            vec![(1, (5.0, 1)), (3, (2.0, 2))]
        );
    }
}
