//! Interchange with the tools that come next (DESIGN.md "Interchange"): the model, the rough
//! model or the mixed-LoD model written as OBJ (`obj`) for daylight tools, or as CityJSON 2.0
//! and CityJSONSeq (`cityjson`) for the CityJSON tools. The format follows the output's name
//! (`mod@format`). CityGML itself is written by `crate::io::citygml::write` and
//! `crate::lod::mixed`.
//!
//! What each asset contributes is decided once: [`Content::Full`] (`convert`) writes every asset
//! at full detail; [`Content::Levels`] (`rough`, `lod`) writes level 2 at full detail, level 1
//! with its rough geometry and drops level 0, as the traced LoD scene
//! ([`crate::lod::scene::mixed_scene`], for OBJ) and the mixed CityGML writer
//! ([`crate::lod::level::properties`], for CityJSON's per-LoD geometry) do.
//!
//! Each format has one writer, which goes over a [`Chunks`] a chunk at a time: a file read
//! in streamed passes (memory follows the chunk), or a model in memory as one chunk.
//!
//! # Example
//! ```
//! use skylod::export::{write, Chunks, Content, Format};
//! use skylod::model::synth::{generate, Preset};
//! let dir = tempfile::tempdir().unwrap();
//! let gml = dir.path().join("small.gml");
//! let mut xml = Vec::new();
//! generate(&Preset::Small.defaults(), &mut xml).unwrap();
//! std::fs::write(&gml, &xml).unwrap();
//! let model = skylod::io::citygml::read_file(&gml).unwrap();
//! let out = dir.path().join("small.obj");
//! let chunks = Chunks::model(&model, 0, Content::Full);
//! let (s, _) = write(Format::Obj, &chunks, &out, &Default::default()).unwrap();
//! let text = std::fs::read_to_string(&out).unwrap();
//! assert!(text.starts_with("# origin "));
//! assert_eq!(s.objects, model.assets.len());
//! ```

mod chunks;
pub(crate) mod citygml_from_cityjson;
pub(crate) mod citygml_via_cityjson;
pub(crate) mod cityjson;
pub(crate) use crate::io::cityjson::source as cityjson_source;
mod cityjson_vertices;
pub(crate) mod format;
pub(crate) mod merge;
pub(crate) mod obj;
// 3D Tiles 1.1: a folder with tileset.json and glTF binary tiles.
pub(crate) mod tiles;
// What the commands report (typed JSON with schemas): the `lod` report, model counts.
#[allow(clippy::module_inception)] // `report::report` is the `lod` report
pub mod report;
// The edits of a document, CityGML and CityJSON alike: subset, filter-lods, upgrade, reproject.
pub mod transform;
pub use citygml_from_cityjson::{gml_id, is_json_file, TargetVersion};
pub use citygml_via_cityjson::write_citygml_levels;
pub use cityjson::reference_system;
pub use merge::{merge_cityjson, merge_named, rename_ids, renamed_id};
pub use obj::write_obj;

pub use chunks::Chunks;

/// The attribute that carries a surface's annual irradiation (kWh/m²) in the outputs of
/// `irradiance --output-attributes` (a 3D Tiles feature's `irradiance`).
pub const IRRADIATION_ATTRIBUTE: &str = "skylodAnnualIrradiation";
pub use format::{Format, UnknownFormat};

use crate::io::citygml::read::StreamSummary;
use crate::io::citygml::write::WriteOptions;
use crate::io::citygml::WriteError;
use crate::lod::rough::RoughGeometry;
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
    /// 3D Tiles: tiles with content.
    pub tiles: usize,
    /// 3D Tiles: bytes of the largest tile.
    pub largest_tile: u64,
    /// 3D Tiles: degenerate polygons skipped (no area, or fewer than three points).
    pub skipped: usize,
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
            Format::Tiles => format!(
                "{} city objects in {} tiles (largest {} bytes), {} triangles at full detail{}",
                self.objects,
                self.tiles,
                self.largest_tile,
                self.triangles,
                match self.skipped {
                    0 => String::new(),
                    n => format!(", {n} degenerate polygon(s) skipped"),
                }
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

/// Write `chunks` to `out` in `format` (OBJ, CityJSON or CityJSONSeq), atomically
/// (temporary file + rename), refusing to write over its source or, without `overwrite`, over
/// an existing file. With what was written, the source's summary (a model's: its file as one
/// chunk).
///
/// Every writer goes over its source in passes, a chunk at a time: a model in memory is one
/// chunk; a stream ([`Chunks::Stream`]) reads its document once a pass, memory following the
/// chunk, and gives the bytes of the whole model with [`Content::Full`]. The passes
/// (`passes.passed(k, n)`): OBJ: 0 the origin, 1 and 2 the objects; CityJSON: 0 the plan, 3
/// and 4 the vertex uses (a stream's only: it numbers its shared vertices in temporary files
/// in `TMPDIR`, about 32 bytes a vertex use), 1 and 2 the objects written; CityJSONSeq: 0 the
/// plan, 1 and 2 the objects; a pass 2 or 4 only for a source with such objects.
///
/// # Errors
/// [`WriteError`] for a refused target, I/O errors, mismatched `content` lengths, or
/// [`Format::CityGml`] (written by `crate::io::citygml::write` and `crate::lod::mixed`);
/// [`WriteError::Declined`], nothing written, where a stream declines: read the whole file
/// and write that model then.
pub fn write(
    format: Format,
    chunks: &Chunks<'_>,
    out: &Path,
    opts: &WriteOptions,
) -> Result<(ExportSummary, StreamSummary), WriteError> {
    if format == Format::Tiles {
        return tiles::write(chunks, out, opts);
    }
    let input = chunks.check()?;
    crate::io::citygml::write::check_target(out, opts, input)?;
    let mut done: (ExportSummary, StreamSummary) = Default::default();
    let bytes = crate::io::citygml::write::atomic_write(out, |w| {
        done = export(format, chunks, w, out)?;
        Ok(done.0.bytes)
    })?;
    done.0.bytes = bytes;
    Ok(done)
}

/// [`write()`] into any writer `w` (uncompressed, no target checks); the summary counts the
/// bytes written.
///
/// # Errors
/// As [`write()`].
pub fn write_to(
    format: Format,
    chunks: &Chunks<'_>,
    w: &mut dyn std::io::Write,
) -> Result<(ExportSummary, StreamSummary), WriteError> {
    chunks.check()?;
    export(format, chunks, w, Path::new(crate::io::files::WRITER_NAME))
}

/// The writer of `format` over `chunks` into `w` (named `name` in errors).
fn export(
    format: Format,
    chunks: &Chunks<'_>,
    w: &mut dyn std::io::Write,
    name: &Path,
) -> Result<(ExportSummary, StreamSummary), WriteError> {
    let mut cw = crate::io::files::CountingWriter::new(w);
    let written = match format {
        Format::Obj => obj::write_obj(chunks, &mut cw),
        Format::CityJson => cityjson::write(cityjson::Kind::CityJson, chunks, &mut cw),
        Format::CityJsonSeq => cityjson::write(cityjson::Kind::Seq, chunks, &mut cw),
        Format::CityGml => {
            return Err(WriteError::Invalid(
                "CityGML is written by citygml::write / lod::mixed".into(),
            ))
        }
        Format::Tiles => {
            return Err(WriteError::Invalid(
                "a 3D Tiles tileset is a folder of files; write it to DIR/tileset.json".into(),
            ))
        }
    };
    let io = |source| WriteError::Io {
        file: name.to_path_buf(),
        source,
    };
    match written.map_err(io)? {
        Some((mut s, sum)) => {
            s.bytes = cw.count();
            Ok((s, sum))
        }
        None => Err(WriteError::Declined(chunks.label().into())),
    }
}
