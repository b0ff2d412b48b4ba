//! Span-preserving CityGML writer.
//!
//! The output is the source document, streamed again from disk, with a sorted list of
//! [`Edit`]s applied by byte span: whatever no edit touches is copied byte for byte (same
//! version, namespaces, declarations, comments, ADE content). The writer adds one edit per
//! `gml:Envelope` whose owner's geometry is known, recomputing it. Output goes to a temporary
//! file beside the target, gzip-compressed when the name ends in `.gz`, then renamed into place.
//!
//! # Example
//! ```
//! use skylod::io::citygml::{Edit, WriteOptions, read_file, write_document};
//! let dir = tempfile::tempdir().unwrap();
//! let src = dir.path().join("in.gml");
//! std::fs::write(&src, br#"<CityModel xmlns="http://www.opengis.net/citygml/2.0"
//!  xmlns:gml="http://www.opengis.net/gml" xmlns:bldg="http://www.opengis.net/citygml/building/2.0">
//!  <gml:boundedBy><gml:Envelope srsName="EPSG:25832"><gml:lowerCorner>0 0 0</gml:lowerCorner>
//!  <gml:upperCorner>9 9 9</gml:upperCorner></gml:Envelope></gml:boundedBy>
//!  <cityObjectMember><bldg:Building gml:id="b"><bldg:lod1Solid><gml:Solid><gml:exterior>
//!  <gml:CompositeSurface><gml:surfaceMember><gml:Polygon><gml:exterior><gml:LinearRing>
//!  <gml:posList>0 0 0 2 0 0 2 1 3 0 0 0</gml:posList></gml:LinearRing></gml:exterior>
//!  </gml:Polygon></gml:surfaceMember></gml:CompositeSurface></gml:exterior></gml:Solid>
//!  </bldg:lod1Solid></bldg:Building></cityObjectMember></CityModel>"#).unwrap();
//! let model = read_file(&src).unwrap();
//! let out = dir.path().join("out.gml");
//! write_document(&model, 0, Vec::<Edit>::new(), &out, &WriteOptions::default()).unwrap();
//! let text = std::fs::read_to_string(&out).unwrap();
//! assert!(text.contains("<gml:upperCorner>2 1 3</gml:upperCorner>"));
//! ```

use super::error::WriteError;
use super::source;
use crate::model::{CityModel, EnvelopeSite, Polygon, SourceFile, Span};
use std::fmt::Write as _;
use std::io::{Read, Write};
use std::path::Path;

/// Replace the bytes of `span` in the source with `replacement` (empty: delete).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Edit {
    /// Byte span in the decompressed source.
    pub span: Span,
    /// New bytes.
    pub replacement: Vec<u8>,
}

/// How to write.
#[derive(Debug, Clone, Default)]
pub struct WriteOptions {
    /// Replace an existing output file.
    pub overwrite: bool,
    /// Paths that must never be written (the inputs), resolved once.
    pub protect: crate::io::files::Protected,
    /// Keep the source's envelopes instead of recomputing them.
    pub keep_envelopes: bool,
    /// The CRS of sources that name none, for outputs placed on the globe (3D Tiles).
    pub source_crs: Option<crate::model::crs::Crs>,
    /// A 3D Tiles output also gets its viewer page (`index.html` beside `tileset.json`).
    pub viewer: bool,
}

/// What was written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WriteSummary {
    /// Bytes written (before compression).
    pub bytes: u64,
    /// Edits applied (including envelopes).
    pub edits: usize,
}

/// Write file `file` of `model` to `out`, applying `edits` (any order; overlapping edits: the
/// outermost wins, edits inside it are dropped): [`write_document_to`] into a temporary file
/// renamed into place (`atomic_write`), after the target checks ([`check_target`]).
pub fn write_document(
    model: &CityModel,
    file: usize,
    edits: Vec<Edit>,
    out: &Path,
    opts: &WriteOptions,
) -> Result<WriteSummary, WriteError> {
    let src = source_file(model, file)?;
    check_target(out, opts, src.source.path())?;
    let mut n_edits = 0;
    let bytes = atomic_write(out, |w| {
        let s = write_edits(model, file, edits, w, opts.keep_envelopes, out)?;
        n_edits = s.edits;
        Ok(s.bytes)
    })?;
    Ok(WriteSummary {
        bytes,
        edits: n_edits,
    })
}

/// [`write_document`] into any writer `w` (uncompressed, no target checks): the source's bytes
/// (from its file, or from memory for a model read from bytes or standard input) with `edits`
/// applied. Only `opts.keep_envelopes` matters here.
pub fn write_document_to(
    model: &CityModel,
    file: usize,
    edits: Vec<Edit>,
    w: &mut dyn Write,
    opts: &WriteOptions,
) -> Result<WriteSummary, WriteError> {
    let name = Path::new(crate::io::files::WRITER_NAME);
    write_edits(model, file, edits, w, opts.keep_envelopes, name)
}

/// The source file `file` of `model`; [`WriteError::Invalid`] when it has none (every
/// writer's first check).
pub(crate) fn source_file(model: &CityModel, file: usize) -> Result<&SourceFile, WriteError> {
    model
        .files
        .get(file)
        .ok_or_else(|| WriteError::Invalid(format!("no source file {file}")))
}

/// The work of [`write_document_to`]; `out` names the output in errors.
fn write_edits(
    model: &CityModel,
    file: usize,
    mut edits: Vec<Edit>,
    w: &mut dyn Write,
    keep_envelopes: bool,
    out: &Path,
) -> Result<WriteSummary, WriteError> {
    let src = source_file(model, file)?;
    if !keep_envelopes {
        for env in &src.envelopes {
            if let Some(text) = envelope_xml(env) {
                edits.push(Edit {
                    span: env.span.clone(),
                    replacement: text.into_bytes(),
                });
            }
        }
    }
    let edits = normalise(edits);
    let n_edits = edits.len();
    let mut reader = edit_source(&src.source, &src.path)?;
    let mut cursor = 0u64;
    let names = (src.len, src.path.as_path(), out);
    let mut written = apply_edits(&mut *reader, w, &edits, &mut cursor, names)?;
    written += copy_rest(&mut *reader, w, cursor, names)?;
    Ok(WriteSummary {
        bytes: written,
        edits: n_edits,
    })
}

/// What [`write_document_streamed`] wrote.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub(crate) struct StreamedDocument {
    /// Bytes and edits, as [`write_document`] counts them.
    pub summary: WriteSummary,
    /// The stream's summary of the document (warnings, version, CRS).
    pub stream: crate::io::citygml::read::StreamSummary,
    /// Asset polygons of the document ([`CityModel::polygon_count`] of the whole read).
    pub polygons: usize,
}

/// [`write_document`] of the whole document at `input` (no other edits than the envelopes)
/// from two streamed reads ([`crate::io::citygml::read::Passes`], chunks of whole top-level
/// members): memory follows the chunk, not the file, and the bytes are
/// [`write_document`]'s of the whole read. The root's `gml:boundedBy` comes first in the
/// document but bounds everything, so a first pass computes its box (the union of every
/// chunk's assets and building geometry, the whole read's root envelope), and a second
/// writes the document chunk by chunk, each chunk's envelopes recomputed from the chunk (an
/// envelope's owner is within one top-level member). Pass 0: the root's box, 1: the
/// writing. `Ok(None)`, nothing written, where the stream declines: read the whole file and
/// [`write_document`] it then.
///
/// # Errors
/// As [`write_document`].
pub(crate) fn write_document_streamed(
    input: &Path,
    passes: &crate::io::citygml::read::Passes<'_>,
    out: &Path,
    opts: &WriteOptions,
) -> Result<Option<StreamedDocument>, WriteError> {
    use crate::io::citygml::read::Chunk;
    use crate::model::Bbox;
    check_target(out, opts, std::iter::once(input))?;
    // Pass 0: the root envelope's box.
    let mut root = Bbox::EMPTY;
    let first = passes.pass_citygml(input, 0, |c: Chunk| {
        root.union(&crate::model::content_bbox(
            &c.model.assets,
            &c.model.buildings,
        ));
        Ok::<(), WriteError>(())
    })?;
    if first.is_none() {
        return Ok(None);
    }
    // Pass 1: the document, chunk by chunk.
    let keep = opts.keep_envelopes;
    let mut done: Option<StreamedDocument> = None;
    let r = atomic_write(out, |w| {
        let src = crate::model::Source::File(input.to_path_buf());
        let (mut reader, _) = source::open_source(&src, input)?;
        let (mut cursor, mut written, mut n_edits, mut polygons, mut len) = (0, 0, 0, 0, 0);
        let second = passes.pass_citygml(input, 1, |c: Chunk| {
            polygons += c.model.polygon_count();
            let Some(f) = c.model.files.first() else {
                return Ok::<(), WriteError>(());
            };
            len = f.len;
            let mut edits = Vec::new();
            for (i, env) in f.envelopes.iter().enumerate().filter(|_| !keep) {
                let text = if c.root_envelopes.contains(&i) {
                    // the root's, bounding the whole document (one of no dimension is none)
                    let whole = EnvelopeSite {
                        bbox: root,
                        ..env.clone()
                    };
                    envelope_xml(&whole)
                } else {
                    envelope_xml(env)
                };
                if let Some(text) = text {
                    edits.push(Edit {
                        span: env.span.clone(),
                        replacement: text.into_bytes(),
                    });
                }
            }
            let edits = normalise(edits);
            n_edits += edits.len();
            written += apply_edits(&mut reader, w, &edits, &mut cursor, (len, input, out))?;
            Ok(())
        })?;
        let Some(sum) = second else {
            // nothing is kept of a declined stream's output
            return Err(WriteError::Invalid("declined".into()));
        };
        written += copy_rest(&mut reader, w, cursor, (len, input, out))?;
        done = Some(StreamedDocument {
            summary: WriteSummary {
                bytes: written,
                edits: n_edits,
            },
            stream: sum,
            polygons,
        });
        Ok(written)
    });
    match (r, done) {
        (Ok(bytes), Some(mut d)) => {
            d.summary.bytes = bytes;
            Ok(Some(d))
        }
        (Err(WriteError::Invalid(_)), None) | (Ok(_), None) => Ok(None),
        (Err(e), _) => Err(e),
    }
}

/// A source the edits are applied from, read in order: what no edit touches is read and
/// copied, the spans the edits replace are passed over.
pub(crate) trait EditSource: Read {
    /// Pass over the next `n` bytes; the bytes passed (fewer where the source ends before).
    fn pass(&mut self, n: u64) -> std::io::Result<u64> {
        std::io::copy(&mut self.take(n), &mut std::io::sink())
    }
}

impl EditSource for Box<dyn std::io::BufRead + Send> {}

/// An uncompressed source file, read unbuffered where it is copied (the output is buffered)
/// and passed over by seeking: a model that keeps a small part of its source reads only that
/// part again (the paper district: 0.8 of 125 MB), not the whole file.
struct PlainSource {
    file: std::fs::File,
    /// The file's length when opened.
    len: u64,
    pos: u64,
}

impl Read for PlainSource {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.file.read(buf)?;
        self.pos += n as u64;
        Ok(n)
    }
}

impl EditSource for PlainSource {
    fn pass(&mut self, n: u64) -> std::io::Result<u64> {
        use std::io::{Seek, SeekFrom};
        let to = self.pos.saturating_add(n).min(self.len.max(self.pos));
        self.file.seek(SeekFrom::Start(to))?;
        let passed = to - self.pos;
        self.pos = to;
        Ok(passed)
    }
}

/// The source of `src` opened for [`apply_edits`]: an uncompressed file as a
/// [`PlainSource`], anything else (gzip, memory, standard input) streamed
/// ([`source::open_source`]).
fn edit_source(src: &crate::model::Source, name: &Path) -> Result<Box<dyn EditSource>, WriteError> {
    let io = |source| WriteError::Io {
        file: name.to_path_buf(),
        source,
    };
    if let source::Stream::Plain(reader) = source::open_stream(src, name)? {
        let file = reader.into_inner();
        let len = file.metadata().map_err(io)?.len();
        let mut plain = PlainSource { file, len, pos: 0 };
        // the buffered reader that told it from gzip has read ahead
        std::io::Seek::rewind(&mut plain.file).map_err(io)?;
        return Ok(Box::new(plain));
    }
    let (reader, _) = source::open_source(src, name)?;
    Ok(Box::new(reader))
}

/// The source from `cursor` to the last of `edits` (sorted, not nested) copied to `w` with
/// them applied; `cursor` moves past it. `(len, src, out)`: the source's length and the
/// names of the source and the output. The bytes written.
pub(crate) fn apply_edits(
    reader: &mut dyn EditSource,
    w: &mut dyn Write,
    edits: &[Edit],
    cursor: &mut u64,
    (len, src, out): (u64, &Path, &Path),
) -> Result<u64, WriteError> {
    let mut written = 0;
    for e in edits {
        if e.span.start < *cursor || e.span.end > len {
            continue;
        }
        written += copy(reader, w, e.span.start - *cursor, src, out)?;
        w.write_all(&e.replacement)
            .map_err(|source| WriteError::Io {
                file: out.to_path_buf(),
                source,
            })?;
        written += e.replacement.len() as u64;
        let skip = e.span.end - e.span.start;
        let skipped = reader.pass(skip).map_err(|source| WriteError::Io {
            file: src.to_path_buf(),
            source,
        })?;
        if skipped != skip {
            return Err(WriteError::SourceChanged(src.to_path_buf()));
        }
        *cursor = e.span.end;
    }
    Ok(written)
}

/// The source after `cursor` copied to `w`, up to its end at `len`; an error if it holds more
/// (it changed since it was read). `(len, src, out)` as for [`apply_edits`]. The bytes
/// copied.
pub(crate) fn copy_rest(
    reader: &mut dyn EditSource,
    w: &mut dyn Write,
    cursor: u64,
    (len, src, out): (u64, &Path, &Path),
) -> Result<u64, WriteError> {
    let written = copy(reader, w, len.saturating_sub(cursor), src, out)?;
    let mut rest = [0u8; 1];
    let extra = reader.read(&mut rest).map_err(|source| WriteError::Io {
        file: src.to_path_buf(),
        source,
    })?;
    if extra != 0 {
        return Err(WriteError::SourceChanged(src.to_path_buf()));
    }
    Ok(written)
}

pub(crate) fn copy<R: Read + ?Sized>(
    reader: &mut R,
    w: &mut dyn Write,
    len: u64,
    src: &Path,
    out: &Path,
) -> Result<u64, WriteError> {
    source::copy_exact(reader, w, len).map_err(|e| {
        if e.kind() == std::io::ErrorKind::UnexpectedEof {
            WriteError::SourceChanged(src.to_path_buf())
        } else {
            WriteError::Io {
                file: out.to_path_buf(),
                source: e,
            }
        }
    })
}

/// Sort edits and drop those nested in an earlier one. Zero-length edits (insertions) at the
/// start or at the end of another edit are kept: an insertion sorts before an edit that starts
/// at the same offset; insertions at the same offset keep their order.
pub(crate) fn normalise(mut edits: Vec<Edit>) -> Vec<Edit> {
    edits.sort_by(|a, b| {
        a.span
            .start
            .cmp(&b.span.start)
            .then((!a.span.is_empty()).cmp(&!b.span.is_empty()))
            .then(b.span.end.cmp(&a.span.end))
    });
    let mut out: Vec<Edit> = Vec::with_capacity(edits.len());
    for e in edits {
        if let Some(last) = out.last() {
            if e.span.start < last.span.end {
                continue;
            }
        }
        out.push(e);
    }
    out
}

pub use crate::io::files::is_stdout;

/// Refuse to write over an input (or over `opts.protect`), or over an existing file without
/// `overwrite` ([`crate::io::files::check_target`]). Standard output (`-`) is always a valid target.
pub fn check_target<'a>(
    out: &Path,
    opts: &WriteOptions,
    inputs: impl IntoIterator<Item = &'a Path>,
) -> Result<(), WriteError> {
    let (set, overwrite) = (&opts.protect, opts.overwrite);
    Ok(crate::io::files::check_target_in(
        out, set, inputs, overwrite,
    )?)
}

/// [`crate::io::files::atomic_write`] with the writer's error: a temporary file beside `out`
/// (gzip when `out` ends in `.gz`) renamed into place, or standard output for `-`.
pub fn atomic_write<F>(out: &Path, f: F) -> Result<u64, WriteError>
where
    F: FnOnce(&mut dyn Write) -> Result<u64, WriteError>,
{
    crate::io::files::atomic_write(out, f)
}

/// `atomic_write` of bytes already made (a report, a picture, a table): their length.
pub fn atomic_write_bytes(out: &Path, bytes: &[u8]) -> Result<u64, WriteError> {
    atomic_write(out, |w| {
        w.write_all(bytes).map_err(|source| WriteError::Io {
            file: out.to_path_buf(),
            source,
        })?;
        Ok(bytes.len() as u64)
    })
}

/// The recomputed envelope element, or `None` when its owner has no known geometry.
pub fn envelope_xml(env: &EnvelopeSite) -> Option<String> {
    let b = env.bbox.to_array()?;
    let p = &env.prefix;
    let mut s = String::with_capacity(200);
    let _ = write!(s, "<{p}Envelope");
    if let Some(srs) = &env.srs_name {
        let _ = write!(s, " srsName=\"{}\"", escape_attr(srs));
    }
    let dims = if env.dimension == 2 { 2 } else { 3 };
    let _ = write!(s, " srsDimension=\"{dims}\">");
    let _ = write!(s, "<{p}lowerCorner>");
    push_coords(&mut s, &b[0..dims]);
    let _ = write!(s, "</{p}lowerCorner><{p}upperCorner>");
    push_coords(&mut s, &b[3..3 + dims]);
    let _ = write!(s, "</{p}upperCorner></{p}Envelope>");
    Some(s)
}

fn push_coords(s: &mut String, v: &[f64]) {
    for (i, x) in v.iter().enumerate() {
        if i > 0 {
            s.push(' ');
        }
        push_num(s, *x);
    }
}

/// Shortest round-trip decimal of `x` (`-0` written as `0`).
pub fn push_num(s: &mut String, x: f64) {
    let x = if x == 0.0 { 0.0 } else { x };
    let _ = write!(s, "{x}");
}

/// Escape `&`, `<`, `"` for an attribute value.
pub fn escape_attr(v: &str) -> String {
    v.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('"', "&quot;")
}

/// Writes GML geometry with deterministic ids.
///
/// ```
/// use skylod::io::citygml::GmlWriter;
/// use skylod::model::Polygon;
/// use glam::DVec3;
/// let w = GmlWriter { gml: "gml:".into(), ids: true };
/// let p = Polygon::new(vec![DVec3::ZERO, DVec3::X, DVec3::Y]);
/// let mut s = String::new();
/// w.multi_surface(&mut s, "m1", std::slice::from_ref(&p));
/// assert!(s.starts_with("<gml:MultiSurface gml:id=\"m1\">"));
/// assert!(s.contains("<gml:posList srsDimension=\"3\">0 0 0 1 0 0 0 1 0 0 0 0</gml:posList>"));
/// ```
#[derive(Debug, Clone)]
pub struct GmlWriter {
    /// GML prefix with colon.
    pub gml: String,
    /// Write `gml:id` on geometries (required by GML 3.2).
    pub ids: bool,
}

impl GmlWriter {
    /// `<gml:MultiSurface gml:id="{id}">` with one `surfaceMember` per polygon; polygon ids are
    /// `{id}_{n}`.
    pub fn multi_surface(&self, s: &mut String, id: &str, polys: &[Polygon]) {
        let g = &self.gml;
        if self.ids {
            let _ = write!(s, "<{g}MultiSurface {g}id=\"{}\">", escape_attr(id));
        } else {
            let _ = write!(s, "<{g}MultiSurface>");
        }
        for (n, p) in polys.iter().enumerate() {
            let _ = write!(s, "<{g}surfaceMember>");
            self.polygon(s, &format!("{id}_{n}"), p);
            let _ = write!(s, "</{g}surfaceMember>");
        }
        let _ = write!(s, "</{g}MultiSurface>");
    }

    /// One `gml:Polygon` with closed rings.
    pub fn polygon(&self, s: &mut String, id: &str, p: &Polygon) {
        let g = &self.gml;
        if self.ids {
            let _ = write!(s, "<{g}Polygon {g}id=\"{}\">", escape_attr(id));
        } else {
            let _ = write!(s, "<{g}Polygon>");
        }
        let _ = write!(s, "<{g}exterior>");
        self.ring(s, p.exterior());
        let _ = write!(s, "</{g}exterior>");
        for r in p.interiors() {
            let _ = write!(s, "<{g}interior>");
            self.ring(s, r);
            let _ = write!(s, "</{g}interior>");
        }
        let _ = write!(s, "</{g}Polygon>");
    }

    fn ring(&self, s: &mut String, r: &[glam::DVec3]) {
        let g = &self.gml;
        let _ = write!(s, "<{g}LinearRing><{g}posList srsDimension=\"3\">");
        for (i, q) in r.iter().chain(r.first()).enumerate() {
            if i > 0 {
                s.push(' ');
            }
            push_coords(s, &[q.x, q.y, q.z]);
        }
        let _ = write!(s, "</{g}posList></{g}LinearRing>");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e(a: u64, b: u64) -> Edit {
        Edit {
            span: a..b,
            replacement: vec![],
        }
    }

    /// A plain file and the same bytes streamed give the same output; the plain file is
    /// passed over where the edits replace it, and a file shorter than its length in the
    /// model is a changed source, as when it is streamed.
    #[test]
    fn plain_source_passes_over_replaced_spans() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("src.gml");
        let text: Vec<u8> = (0..200_000u32).map(|i| b'a' + (i % 26) as u8).collect();
        std::fs::write(&path, &text).unwrap();
        let len = text.len() as u64;
        let edits = normalise(vec![
            e(10, 150_000),
            Edit {
                span: 150_100..150_200,
                replacement: b"<x/>".to_vec(),
            },
            e(160_000, 199_990),
        ]);
        let run = |src: &crate::model::Source, len: u64| {
            let mut reader = edit_source(src, &path)?;
            let (mut cursor, mut out) = (0u64, Vec::new());
            let names = (len, path.as_path(), Path::new("out.gml"));
            let mut n = apply_edits(&mut *reader, &mut out, &edits, &mut cursor, names)?;
            n += copy_rest(&mut *reader, &mut out, cursor, names)?;
            assert_eq!(n, out.len() as u64);
            Ok::<_, WriteError>(out)
        };
        let file = crate::model::Source::File(path.clone());
        let memory = crate::model::Source::Memory(text.clone().into());
        let got = run(&file, len).unwrap();
        assert_eq!(got, run(&memory, len).unwrap());
        let mut want = text[..10].to_vec();
        want.extend_from_slice(&text[150_000..150_100]);
        want.extend_from_slice(b"<x/>");
        want.extend_from_slice(&text[150_200..160_000]);
        want.extend_from_slice(&text[199_990..]);
        assert_eq!(got, want);
        // the source shorter (inside a replaced span) or longer than the model says
        std::fs::write(&path, &text[..170_000]).unwrap();
        assert!(matches!(run(&file, len), Err(WriteError::SourceChanged(_))));
        std::fs::write(&path, [&text[..], b"z"].concat()).unwrap();
        assert!(matches!(run(&file, len), Err(WriteError::SourceChanged(_))));
    }

    #[test]
    fn nested_edits_dropped() {
        let n = normalise(vec![e(10, 20), e(0, 5), e(12, 15), e(10, 30)]);
        assert_eq!(
            n.iter().map(|x| x.span.clone()).collect::<Vec<_>>(),
            vec![0..5, 10..30]
        );
    }

    #[test]
    fn insertions_beside_edits_kept() {
        let ins = |a: u64, t: &str| Edit {
            span: a..a,
            replacement: t.as_bytes().to_vec(),
        };
        let n = normalise(vec![
            e(10, 20),
            ins(10, "a"),
            ins(20, "b"),
            ins(15, "x"),
            ins(10, "c"),
        ]);
        let got: Vec<(u64, u64, Vec<u8>)> = n
            .into_iter()
            .map(|x| (x.span.start, x.span.end, x.replacement))
            .collect();
        assert_eq!(
            got,
            vec![
                (10, 10, b"a".to_vec()),
                (10, 10, b"c".to_vec()),
                (10, 20, vec![]),
                (20, 20, b"b".to_vec())
            ]
        );
    }

    #[test]
    fn numbers() {
        let mut s = String::new();
        push_num(&mut s, -0.0);
        s.push(' ');
        push_num(&mut s, 678050.375);
        s.push(' ');
        push_num(&mut s, 0.1 + 0.2);
        assert_eq!(s, "0 678050.375 0.30000000000000004");
    }
}
