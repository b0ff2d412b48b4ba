//! One input of `stats` and of `convert`: read whole, or a chunk of whole top-level members
//! at a time where the file is large ([`chunk_for`], [`crate::io::citygml::read::stream`]:
//! the same output as from the whole model, memory that follows the chunk). Where the
//! stream declines, the file is read whole and the caller is told why (`note`). Nothing is
//! printed: the bytes read go to a [`Progress`] ([`Stage::Read`]).

use super::outputs::{create_parent, PlanError};
use super::run::{size_note, Done};
use crate::export::citygml_from_cityjson::{
    citygml_from_cityjson, citygml_from_cityjson_chunked, is_json_file, FromCityJsonError,
    TargetVersion,
};
use crate::export::report::stats::Stats;
use crate::export::{Chunks, Content, Format};
use crate::io::citygml::read::{read_source, stream, Passes, ReadOptions, Streamed};
use crate::io::citygml::source::resolve;
use crate::io::citygml::write::{write_document, write_document_streamed, WriteOptions};
use crate::io::citygml::{ReadError, WriteError};
use crate::model::crs::Crs;
use crate::model::runtime::progress::{Progress, Stage};
use crate::model::{shown, CityModel, Warning};
use std::path::Path;

/// The chunk size to stream `path` with (`chunk` bytes), or `None` to read it whole: small
/// files (under four chunks), standard input, and every file when `chunk` is 0. A
/// gzip-compressed file counts as ten times its size (CityGML compresses 10 to 20 times): it
/// is streamed from a temporary file. A CityJSON document is streamed in chunks of city
/// objects, CityJSONSeq in chunks of lines ([`crate::io::citygml::read::stream`]).
pub fn chunk_for(path: &Path, chunk: u64) -> Option<u64> {
    len_and_chunk(path, chunk).1
}

/// The file's size in bytes (0 where its metadata cannot be read) and [`chunk_for`] of it:
/// the metadata read once for a caller that needs both.
pub(crate) fn len_and_chunk(path: &Path, chunk: u64) -> (u64, Option<u64>) {
    let Ok(meta) = std::fs::metadata(path) else {
        return (0, None);
    };
    let len = meta.len();
    let gzip = crate::io::files::is_gzip_file(path);
    let counted = if gzip { len.saturating_mul(10) } else { len };
    (
        len,
        (chunk > 0 && counted >= chunk.saturating_mul(4)).then_some(chunk),
    )
}

/// The line that says a file meant to be streamed was read whole, and why.
fn read_whole(input: &Path, why: &str) -> String {
    format!("{}: read whole ({why})", shown(input))
}

/// The statistics of one file ([`file_stats`]).
#[derive(Debug)]
pub struct StatsRead {
    /// Its counts (the `srsName` replaced by the source CRS when one is given).
    pub stats: Stats,
    /// Its warnings (streamed: only when asked for, else only counted).
    pub warnings: Vec<Warning>,
}

/// The statistics of the file at `path` ([`Stats::of`] its model, with `source_crs` as the
/// `srsName` of every file when given): streamed a `chunk` at a time when given (the same
/// counts as the whole read; `warnings`: keep the warnings, else count them only), else read
/// whole (`note`: the line that says why a file meant to be streamed was, said before it
/// is). The bytes read advance [`Stage::Read`] of `progress`. `leak`: the process ends soon, so the model read
/// whole is not handed back to the allocator piece by piece (a large share of a small
/// file's run) but left to the end of the process.
///
/// # Errors
/// The file could not be read ([`ReadError`]; a stream that fails is retried whole).
pub fn file_stats(
    path: &Path,
    source_crs: Option<&Crs>,
    (chunk, warnings): (Option<u64>, bool),
    progress: &dyn Progress,
    note: &(dyn Fn(String) + Sync),
    leak: bool,
) -> Result<StatsRead, ReadError> {
    let passed = |n| progress.advance(Stage::Read, 0, n, None);
    if let Some(chunk) = chunk {
        match streamed_stats(path, source_crs, warnings, chunk, &passed) {
            Some(Ok(s)) => return Ok(s),
            Some(Err(why)) => note(read_whole(path, &why)),
            None => {}
        }
    }
    let mut m = read_source(resolve(path)?, path, &ReadOptions::default(), &passed)?;
    if let Some(c) = source_crs {
        for f in &mut m.files {
            f.srs_name = Some(c.name.clone());
        }
    }
    let stats = Stats::of(&m);
    let warnings = std::mem::take(&mut m.warnings);
    if leak {
        std::mem::forget(m);
    }
    Ok(StatsRead { stats, warnings })
}

/// [`file_stats`] from a streamed read: `None` when the stream fails, `Some(Err(why))` when
/// it declines.
fn streamed_stats(
    path: &Path,
    source_crs: Option<&Crs>,
    keep: bool,
    chunk: u64,
    passed: &(dyn Fn(u64) + Sync),
) -> Option<Result<StatsRead, String>> {
    let mut total = Stats::default();
    let mut warnings = Vec::new();
    let end = stream(path, &ReadOptions::default(), chunk, passed, |mut c| {
        total.add(&Stats::of(&c.model));
        if keep {
            warnings.append(&mut c.model.warnings);
        }
        Ok::<(), ()>(())
    })
    .ok()?;
    let sum = match end {
        Streamed::Done(sum) => sum,
        Streamed::Declined(why) => return Some(Err(why)),
    };
    sum.patch_warnings(&mut warnings);
    total.warnings += sum.trailing.len();
    total.citygml_version = sum.version.map(|v| v.to_string());
    total.srs_name = match source_crs {
        Some(c) => Some(c.name.clone()),
        None => sum.srs_name,
    };
    Some(Ok(StatsRead {
        stats: total,
        warnings,
    }))
}

/// Why one input of [`convert_file`] failed (each in the library's terms; the outputs are
/// named).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ConvertError {
    /// The input could not be read.
    #[error(transparent)]
    Read(#[from] ReadError),
    /// The output could not be written (a refused target, I/O).
    #[error(transparent)]
    Write(#[from] WriteError),
    /// The output's directory could not be made.
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// A CityJSON input could not be converted to CityGML.
    #[error(transparent)]
    FromCityJson(#[from] FromCityJsonError),
    /// A streamed OBJ or CityJSON output could not be written (`error` is said in the
    /// message, not kept as a cause).
    #[error("writing {}: {error}", out.display())]
    Streamed {
        /// The output.
        out: std::path::PathBuf,
        /// What went wrong.
        error: WriteError,
    },
    /// The caller asked to stop before the input was read.
    #[error("{}: cancelled before reading", shown(input))]
    Cancelled {
        /// The input.
        input: std::path::PathBuf,
    },
}

/// What [`convert_file`] did with one input.
#[derive(Debug, Default)]
pub struct Converted {
    /// Its result in the batch ([`super::run::Batch::finish`] says its line in input order).
    pub done: Done,
    /// The line of an OBJ or CityJSON output, to say as soon as it is written.
    pub written: Option<String>,
}

/// How [`convert_file`] writes.
#[derive(Debug, Clone, Copy)]
pub struct ConvertOptions<'a> {
    /// The format written.
    pub format: Format,
    /// The CityGML version written for a CityJSON input (CityGML inputs keep theirs).
    pub version: TargetVersion,
    /// The target checks, envelopes.
    pub write: &'a WriteOptions,
    /// Whether the output's directory is made first (`-o DIR`).
    pub mirror: bool,
    /// The chunk to stream the input with ([`chunk_for`]), `None` to read it whole.
    pub chunk: Option<u64>,
}

/// Read `input` and write it to `out` (`convert`): CityGML written back with its envelopes
/// recomputed, CityJSON converted to CityGML feature by feature, or OBJ, CityJSON,
/// CityJSONSeq; streamed when [`ConvertOptions::chunk`] says so (the same bytes).
/// The bytes of `input` read advance [`Stage::Read`] of `progress` (each pass of a streamed
/// output for its share, so the total is the file's size); a file meant to be streamed but
/// read whole is said to `note` first, and is not read once `progress` is cancelled. A
/// failed write leaves no output or temporary file behind.
///
/// # Errors
/// [`ConvertError`].
pub fn convert_file(
    input: &Path,
    out: &Path,
    o: &ConvertOptions<'_>,
    progress: &dyn Progress,
    note: &(dyn Fn(String) + Sync),
) -> Result<Converted, ConvertError> {
    let passed = |n| progress.advance(Stage::Read, 0, n, None);
    // CityJSON → CityGML goes from the document itself (below: in chunks of city objects
    // where `chunk` says so)
    let cityjson_to_citygml = o.format == Format::CityGml && is_json_file(input);
    if let Some(chunk) = o.chunk.filter(|_| !cityjson_to_citygml) {
        // the bar's share of each pass: a tileset's one pass all; OBJ origin 1/2, objects 1/2; CityJSONSeq plan 1/2,
        // buildings 1/2; CityJSON plan, vertex uses and objects 1/3 each (the passes over
        // the objects outside buildings, when a file has them, are not counted)
        let thirds = o.format == Format::CityJson;
        let once = o.format == Format::Tiles;
        let pass = |pass, n: u64| {
            let share = match (thirds, pass) {
                _ if once => n,
                (false, 0) => n.div_ceil(2),
                (false, 1) => n / 2,
                (true, 0) => n.div_ceil(3),
                (true, 1 | 3) => n / 3,
                _ => 0,
            };
            if share > 0 {
                passed(share);
            }
        };
        let ropts = ReadOptions::default();
        let passes = Passes::new(&ropts, chunk, &pass);
        let label = None;
        let stream = Chunks::Stream {
            path: input,
            label,
            passes: &passes,
        };
        match write_out(input, out, o, &stream)? {
            Some(c) => return Ok(c),
            None => note(read_whole(input, "the stream declined")),
        }
    }
    if progress.is_cancelled() {
        return Err(ConvertError::Cancelled {
            input: input.to_path_buf(),
        });
    }
    if cityjson_to_citygml {
        if o.mirror {
            create_parent(out)?;
        }
        let s = match o.chunk {
            Some(c) => citygml_from_cityjson_chunked(input, out, o.version, o.write, c)?,
            None => citygml_from_cityjson(input, out, o.version, o.write)?,
        };
        let line = s.describe(input, out).replace(
            &format!(", {} bytes", s.bytes_out),
            &format!(", {}", size_note(out, s.bytes_out)),
        );
        let warnings = s.dropped.values().sum();
        let polygons = (s.polygons, s.polygons);
        return Ok(converted(Some(line), warnings, polygons, None));
    }
    let model = read_source(resolve(input)?, input, &ReadOptions::default(), &passed)?;
    write_out(input, out, o, &Chunks::model(&model, 0, Content::Full))?
        .ok_or_else(|| WriteError::Declined(input.to_path_buf()).into())
}

/// A CityGML output's line: its size, envelopes recomputed, warnings.
fn document_line(input: &Path, out: &Path, bytes: u64, edits: usize, warnings: usize) -> String {
    format!(
        "{} -> {}: {}, {edits} envelope(s) recomputed, {warnings} warning(s)",
        shown(input),
        out.display(),
        size_note(out, bytes),
    )
}

/// [`convert_file`] of `input` from `chunks` (its streamed passes, or its model read whole),
/// but for CityJSON → CityGML; `None` where the stream declines.
fn write_out(
    input: &Path,
    out: &Path,
    o: &ConvertOptions<'_>,
    chunks: &Chunks<'_>,
) -> Result<Option<Converted>, ConvertError> {
    if o.mirror {
        create_parent(out)?;
    }
    let model = match *chunks {
        Chunks::Model { model, .. } => Some(model),
        Chunks::Stream { .. } => None,
    };
    if o.format == Format::CityGml {
        let (s, warnings, polygons) = match *chunks {
            Chunks::Model { model: m, .. } => {
                let s = write_document(m, 0, Vec::new(), out, o.write)?;
                (s, m.warnings.len(), m.polygon_count())
            }
            Chunks::Stream { passes, .. } => {
                let Some(d) = write_document_streamed(input, passes, out, o.write)? else {
                    return Ok(None);
                };
                (d.summary, d.stream.warnings, d.polygons)
            }
        };
        let line = document_line(input, out, s.bytes, s.edits, warnings);
        let polygons = (polygons, polygons);
        return Ok(Some(converted(Some(line), warnings, polygons, None)));
    }
    let (s, sum) = match crate::export::write(o.format, chunks, out, o.write) {
        Ok(w) => w,
        Err(WriteError::Declined(_)) => return Ok(None),
        // a stream's errors are said naming the output
        Err(error) if model.is_none() => {
            let out = out.to_path_buf();
            return Err(ConvertError::Streamed { out, error });
        }
        Err(e) => return Err(e.into()),
    };
    // a stream counts no polygons; the model read whole is named as it names itself
    let polygons = model.map_or(0, CityModel::polygon_count);
    let shown_input = model
        .and_then(|m| m.files.first())
        .map_or(input, |f| &f.path);
    let written = Some(s.describe(o.format, shown_input, out));
    let polygons = (polygons, polygons);
    Ok(Some(converted(None, sum.warnings, polygons, written)))
}

/// What [`convert_file`] says of one input.
fn converted(
    line: Option<String>,
    warnings: usize,
    polygons: (usize, usize),
    written: Option<String>,
) -> Converted {
    let done = Done {
        line,
        warnings,
        polygons,
    };
    Converted { done, written }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::runtime::progress::Silent;
    use std::path::PathBuf;

    /// A streamed read that declines would say so: these fixtures stream.
    fn no_note(n: String) {
        panic!("read whole: {n}");
    }

    /// A CityGML file of three buildings, 300 KB.
    fn big_fixture() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/synth-small.gml")
    }

    #[test]
    fn chunks_only_for_large_citygml() {
        let f = big_fixture();
        let len = f.metadata().unwrap().len();
        assert_eq!(chunk_for(&f, len / 4), Some(len / 4));
        assert_eq!(chunk_for(&f, len / 4 + 1), None, "under four chunks");
        assert_eq!(chunk_for(&f, 0), None, "0: always whole");
        assert_eq!(chunk_for(Path::new("/nonexistent.gml"), 1), None);
        // the size as it is on disk, streamed or not; a gzip file counts ten times it
        assert_eq!(len_and_chunk(&f, len / 4 + 1), (len, None));
        assert_eq!(len_and_chunk(Path::new("/nonexistent.gml"), 1), (0, None));
        let dir = tempfile::tempdir().unwrap();
        let gz = crate::pipeline::test_support::gzip_copy(&f, dir.path());
        let gz_len = gz.metadata().unwrap().len();
        assert_eq!(
            len_and_chunk(&gz, gz_len * 10 / 4),
            (gz_len, Some(gz_len * 10 / 4))
        );
        assert_eq!(len_and_chunk(&gz, gz_len * 10 / 4 + 1), (gz_len, None));
        let json = dir.path().join("a.city.json");
        std::fs::write(
            &json,
            format!("{{\"type\": \"CityJSON\"{}}}", " ".repeat(4000)),
        )
        .unwrap();
        assert_eq!(
            chunk_for(&json, 10),
            Some(10),
            "a CityJSON document streams"
        );
        let seq = dir.path().join("a.city.jsonl");
        std::fs::copy(&json, &seq).unwrap();
        assert_eq!(
            chunk_for(&seq, 10),
            Some(10),
            "CityJSONSeq streams in chunks of lines"
        );
    }

    #[test]
    fn streamed_stats_are_the_whole_read_s() {
        let f = big_fixture();
        let len = f.metadata().unwrap().len();
        let whole = file_stats(&f, None, (None, true), &Silent, &no_note, false).unwrap();
        assert!(whole.stats.buildings > 0);
        let crs = Crs::parse_named("EPSG:25832").unwrap();
        let chunk = (Some(len / 8), true);
        let s = file_stats(&f, Some(&crs), chunk, &Silent, &no_note, false).unwrap();
        assert_eq!(s.stats.buildings, whole.stats.buildings);
        assert_eq!(s.stats.polygons, whole.stats.polygons);
        assert_eq!(s.warnings.len(), whole.warnings.len());
        assert_eq!(s.stats.srs_name.as_deref(), Some(crs.name.as_str()));
        let nowhere = Path::new("/nonexistent.gml");
        assert!(file_stats(nowhere, None, (None, false), &Silent, &no_note, false).is_err());
    }

    #[test]
    fn convert_writes_citygml_and_obj_the_same_streamed_or_whole() {
        let f = big_fixture();
        let len = f.metadata().unwrap().len();
        let dir = tempfile::tempdir().unwrap();
        let wopts = WriteOptions::default();
        // CityJSON: its vertex buckets resolved three records at a time in unit tests
        for format in [Format::CityGml, Format::Obj, Format::CityJson] {
            let ext = match format {
                Format::Obj => "obj",
                Format::CityJson => "city.json",
                _ => "gml",
            };
            let mut outs = Vec::new();
            for chunk in [None, Some(len / 8)] {
                let out = dir.path().join(format!("sub/{}.{ext}", chunk.is_some()));
                let o = ConvertOptions {
                    format,
                    version: TargetVersion::V2_0,
                    write: &wopts,
                    mirror: true,
                    chunk,
                };
                let c = convert_file(&f, &out, &o, &Silent, &no_note).unwrap();
                match format {
                    Format::CityGml => {
                        let line = c.done.line.unwrap();
                        assert!(line.contains("envelope(s) recomputed"), "{line}");
                        assert!(c.written.is_none());
                    }
                    _ => assert!(c.written.unwrap().contains(&out.display().to_string())),
                }
                outs.push(std::fs::read(&out).unwrap());
            }
            assert_eq!(outs[0], outs[1], "{format:?}: streamed = whole");
        }
        // A target that exists is refused, named by the output.
        let out = dir.path().join("sub/false.gml");
        let o = ConvertOptions {
            format: Format::CityGml,
            version: TargetVersion::V2_0,
            write: &wopts,
            mirror: false,
            chunk: None,
        };
        let e = convert_file(&f, &out, &o, &Silent, &no_note).unwrap_err();
        assert!(
            matches!(e, ConvertError::Write(WriteError::Exists(_))),
            "{e}"
        );
        let o = ConvertOptions {
            chunk: Some(len / 8),
            format: Format::Obj,
            ..o
        };
        let out = dir.path().join("sub/false.obj");
        let e = convert_file(&f, &out, &o, &Silent, &no_note).unwrap_err();
        assert!(
            e.to_string()
                .starts_with(&format!("writing {}: ", out.display())),
            "{e}"
        );
    }
}
