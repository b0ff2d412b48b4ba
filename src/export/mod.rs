//! Interchange with the tools that come next (DESIGN.md "Interchange"): the model, the rough
//! model or the mixed-LoD model written as OBJ ([`obj`]) for daylight tools, or as CityJSON 2.0
//! and CityJSONSeq ([`cityjson`]) for the CityJSON tools. The format follows the output's name
//! ([`mod@format`]). CityGML itself is written by [`crate::io::citygml::write`] and
//! [`crate::lod::mixed`].
//!
//! What each asset contributes is decided once: [`Content::Full`] (`convert`) writes every asset
//! at full detail; [`Content::Levels`] (`rough`, `lod`) writes level 2 at full detail, level 1
//! with its rough geometry and drops level 0, as the traced LoD scene
//! ([`crate::lod::scene::mixed_scene`], for OBJ) and the mixed CityGML writer
//! ([`crate::lod::level::properties`], for CityJSON's per-LoD geometry) do.
//!
//! # Example
//! ```
//! use skylod::export::{write, Content, Format};
//! use skylod::model::synth::{generate, Preset};
//! let dir = tempfile::tempdir().unwrap();
//! let gml = dir.path().join("small.gml");
//! let mut xml = Vec::new();
//! generate(&Preset::Small.defaults(), &mut xml).unwrap();
//! std::fs::write(&gml, &xml).unwrap();
//! let model = skylod::io::citygml::read_file(&gml).unwrap();
//! let out = dir.path().join("small.obj");
//! let s = write(Format::Obj, &model, 0, Content::Full, &out, &Default::default()).unwrap();
//! let text = std::fs::read_to_string(&out).unwrap();
//! assert!(text.starts_with("# origin "));
//! assert_eq!(s.objects, model.assets.len());
//! ```

pub mod citygml_from_cityjson;
pub mod citygml_via_cityjson;
pub mod cityjson;
pub mod cityjson_edit;
pub(crate) use crate::io::citygml::json::source as cityjson_source;
mod cityjson_stream;
pub mod format;
pub mod merged;
pub mod obj;
// What the commands report (typed JSON with schemas): the `lod` report, model counts.
#[allow(clippy::module_inception)] // `report::report` is the `lod` report
pub mod report;

pub use format::{Format, UnknownFormat};

use crate::io::citygml::read::{Passes, StreamSummary};
use crate::io::citygml::write::WriteOptions;
use crate::io::citygml::WriteError;
use crate::lod::rough::RoughGeometry;
use crate::model::{Asset, CityModel};
use std::path::Path;

/// What the export holds per asset.
#[derive(Debug, Clone, Copy)]
pub enum Content<'a> {
    /// Every asset with all its geometry (`convert`); no `skylod_level`.
    Full,
    /// Every asset at its level (`rough`: all 1; `lod`: the selection): 2 full detail, 1 rough
    /// geometry, 0 absent; `rough[i]` and `levels[i]` belong to asset `i`.
    Levels {
        /// Rough geometry per asset.
        rough: &'a [RoughGeometry],
        /// Level per asset (above 2 counts as 2).
        levels: &'a [u8],
    },
}

impl<'a> Content<'a> {
    /// Level of asset `i`: 2 for [`Content::Full`].
    pub fn level(&self, i: usize) -> u8 {
        match self {
            Content::Full => 2,
            Content::Levels { levels, .. } => levels.get(i).copied().unwrap_or(0).min(2),
        }
    }

    /// Rough geometry of asset `i`, if any.
    pub fn rough(&self, i: usize) -> Option<&'a RoughGeometry> {
        match self {
            Content::Full => None,
            Content::Levels { rough, .. } => rough.get(i),
        }
    }

    /// True when levels are written as `skylod_level`.
    pub fn has_levels(&self) -> bool {
        matches!(self, Content::Levels { .. })
    }

    fn check(&self, model: &CityModel) -> Result<(), WriteError> {
        match self {
            Content::Levels { rough, levels } => {
                crate::lod::mixed::check_per_asset(model, rough, levels)
            }
            Content::Full => Ok(()),
        }
    }
}

/// What an export wrote.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ExportSummary {
    /// Bytes written (before compression).
    pub bytes: u64,
    /// OBJ objects (`o`), or CityJSON city objects.
    pub objects: usize,
    /// Polygons written (OBJ: polygons triangulated; CityJSON: surfaces).
    pub polygons: usize,
    /// Triangles (OBJ only).
    pub triangles: usize,
    /// Vertices written.
    pub vertices: usize,
    /// CityJSONSeq features (lines after the header).
    pub features: usize,
}

impl ExportSummary {
    /// One line saying what was written from `input` to `out` in `format`:
    /// `a.gml -> a.obj (obj): 3 objects, 40 polygons as 80 triangles, 60 vertices, 2048 bytes`.
    pub fn describe(&self, format: Format, input: &Path, out: &Path) -> String {
        let what = match format {
            Format::Obj => format!(
                "{} objects, {} polygons as {} triangles, {} vertices",
                self.objects, self.polygons, self.triangles, self.vertices
            ),
            Format::CityJsonSeq => format!(
                "{} city objects in {} features, {} surfaces, {} vertices",
                self.objects, self.features, self.polygons, self.vertices
            ),
            _ => format!(
                "{} city objects, {} surfaces, {} vertices",
                self.objects, self.polygons, self.vertices
            ),
        };
        format!(
            "{} -> {} ({format}): {what}, {} bytes",
            crate::model::shown(input),
            out.display(),
            self.bytes
        )
    }
}

/// Write file `file` of `model` to `out` in `format` (OBJ, CityJSON or CityJSONSeq), atomically
/// (temporary file + rename), refusing to write over an input or, without `overwrite`, over an
/// existing file.
///
/// # Errors
/// [`WriteError`] for a refused target, I/O errors, mismatched `content` lengths, or
/// [`Format::CityGml`] (written by [`crate::io::citygml::write`] and [`crate::lod::mixed`]).
pub fn write(
    format: Format,
    model: &CityModel,
    file: usize,
    content: Content<'_>,
    out: &Path,
    opts: &WriteOptions,
) -> Result<ExportSummary, WriteError> {
    content.check(model)?;
    let src = crate::io::citygml::write::source_file(model, file)?;
    crate::io::citygml::write::check_target(out, opts, src.source.path())?;
    let mut summary = ExportSummary::default();
    let bytes = crate::io::citygml::write::atomic_write(out, |w| {
        summary = write_to(format, model, file, content, w)?;
        Ok(summary.bytes)
    })?;
    summary.bytes = bytes;
    Ok(summary)
}

/// [`write()`] into any writer `w` (uncompressed, no target checks); the summary counts the
/// bytes written.
///
/// # Errors
/// As [`write()`].
pub fn write_to(
    format: Format,
    model: &CityModel,
    file: usize,
    content: Content<'_>,
    w: &mut dyn std::io::Write,
) -> Result<ExportSummary, WriteError> {
    content.check(model)?;
    crate::io::citygml::write::source_file(model, file)?;
    let io = |e| WriteError::Io {
        file: crate::io::files::WRITER_NAME.into(),
        source: e,
    };
    let mut cw = crate::io::files::CountingWriter::new(w);
    let mut summary = match format {
        Format::Obj => obj::write_obj(model, file, content, &mut cw).map_err(io)?,
        Format::CityJson => cityjson::write_cityjson(model, file, content, &mut cw).map_err(io)?,
        Format::CityJsonSeq => {
            cityjson::write_cityjsonseq(model, file, content, &mut cw).map_err(io)?
        }
        Format::CityGml => {
            return Err(WriteError::Invalid(
                "CityGML is written by citygml::write / lod::mixed".into(),
            ))
        }
    };
    summary.bytes = cw.count();
    Ok(summary)
}

/// [`write()`] of the whole file at `input` in `format` (OBJ, CityJSON or CityJSONSeq) from
/// streamed reads ([`Passes`]: chunks of `passes.chunk_bytes`, memory follows the chunk, the
/// same bytes as [`write()`] of the whole model with [`Content::Full`]), atomically. OBJ:
/// [`obj::write_obj_streamed`], its comment line naming `label` instead of `input` when given
/// (a merge's staged document is named by the inputs it holds: [`merged`]); CityJSON and
/// CityJSONSeq read the file in several passes, and CityJSON numbers its shared vertices in
/// temporary files (in `TMPDIR`: about 32 bytes a vertex use; see the module
/// `cityjson_stream`'s docs in the source). The passes (`passes.passed(k, n)`): OBJ: 0 the
/// origin, 1 and 2 the objects; CityJSON: 0 the plan, 3 and 4 the vertex uses, 1 and 2 the
/// objects written; CityJSONSeq: 0 the plan, 1 and 2 the objects; a pass 2 or 4 only for a
/// file with such objects. `Ok(None)`, nothing written, where the stream declines: read the
/// whole file and [`write()`] it then.
///
/// # Errors
/// As [`write()`]; [`WriteError::Invalid`] for [`Format::CityGml`].
pub fn write_streamed(
    format: Format,
    input: &Path,
    label: Option<&str>,
    passes: &Passes<'_>,
    out: &Path,
    opts: &WriteOptions,
) -> Result<Option<(ExportSummary, StreamSummary)>, WriteError> {
    let kind = match format {
        Format::Obj => None,
        Format::CityJson => Some(cityjson_stream::Kind::CityJson),
        Format::CityJsonSeq => Some(cityjson_stream::Kind::Seq),
        Format::CityGml => {
            return Err(WriteError::Invalid(
                "CityGML is written by citygml::write / lod::mixed".into(),
            ))
        }
    };
    crate::io::citygml::write::check_target(out, opts, std::iter::once(input))?;
    let io = |e| WriteError::Io {
        file: out.to_path_buf(),
        source: e,
    };
    let mut done = None;
    let r = crate::io::citygml::write::atomic_write(out, |w| {
        let mut cw = crate::io::files::CountingWriter::new(w);
        let r = match kind {
            None => obj::write_obj_streamed(input, label, passes, &mut cw),
            Some(k) => cityjson_stream::write_streamed(k, input, passes, &mut cw),
        };
        match r.map_err(io)? {
            Some(d) => done = Some(d),
            // nothing is kept of a declined stream's output
            None => return Err(WriteError::Invalid("declined".into())),
        }
        Ok(cw.count())
    });
    match (r, done) {
        (Ok(bytes), Some((mut s, sum))) => {
            s.bytes = bytes;
            Ok(Some((s, sum)))
        }
        (Err(WriteError::Invalid(_)), None) => Ok(None),
        (Err(e), _) => Err(e),
        (Ok(_), None) => Ok(None),
    }
}

/// Name of asset `i` in an export: its `gml:id`, else its building's id and its index among
/// the building's assets (`B1_3`), else `asset_<i>`.
pub fn asset_name(model: &CityModel, i: usize) -> String {
    asset_name_as(model, i, i)
}

/// [`asset_name`] of asset `i` of `model` that is asset `global` of the whole document (a
/// chunk of a streamed read): `asset_<global>` when it has no name.
pub fn asset_name_as(model: &CityModel, i: usize, global: usize) -> String {
    let Some(a) = model.assets.get(i) else {
        return format!("asset_{global}");
    };
    if let Some(id) = &a.id {
        return id.to_string();
    }
    if let Some(b) = a.building.and_then(|b| model.buildings.get(b)) {
        if let Some(bid) = &b.id {
            let k = b.assets.iter().position(|&x| x == i).unwrap_or(global);
            return format!("{bid}_{k}");
        }
    }
    format!("asset_{global}")
}

/// Assets of file `file`, with their indices.
fn assets_of(model: &CityModel, file: usize) -> impl Iterator<Item = (usize, &Asset)> {
    model
        .assets
        .iter()
        .enumerate()
        .filter(move |(_, a)| a.file == file)
}
