//! The rewrite of a large document in passes ([`RewriteSource`]): memory follows the largest
//! city object and the envelopes, not the file.
//!
//! [`rewrite_edits`](super::rewrite_edits) holds every replacement text until the end, because
//! an envelope comes before what it bounds and may bound geometry that an `xlink:href` names
//! further on. A document of [`STREAM_BYTES`] or more is read four times instead, keeping
//! nothing of its coordinates:
//!
//! 1. the reader, chunk by chunk ([`stream`]): a broken input fails with the reader's error,
//!    and the document's `srsName` is the one the whole read finds;
//! 2. the ids some `xlink:href="#id"` names, as 8-byte hashes ([`href_targets`]);
//! 3. every point transformed, the box of every envelope owner and of every named id (only
//!    those), and the envelopes' texts (a few hundred bytes each);
//! 4. every point transformed again and written, the edits handed to the writer whenever no
//!    edit can still come before them (outside an envelope, a GML 2 `coord` and an implicit
//!    geometry, whose matrix is written after its reference point is read), merged with the
//!    envelopes of pass 3.
//!
//! The bytes are those of the whole rewrite (a test compares both on every shared file). A
//! document the chunked reader declines (see [`stream`]) is read whole and rewritten as a
//! small one.

use super::{rewrite_edits, scan, Mode, PointsFn, RewriteSummary, Scanner};
use crate::io::citygml::error::{ReadError, WriteError};
use crate::io::citygml::read::{
    read_file, stream_citygml as stream, ReadOptions, Streamed, CHUNK_BYTES,
};
use crate::io::citygml::source;
use crate::io::citygml::write::{
    apply_edits, atomic_write, check_target, copy_rest, normalise, write_document, Edit,
    WriteOptions,
};
use crate::model::CityModel;
use foldhash::{HashSet, HashSetExt};
use quick_xml::events::Event;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Documents of this many bytes (on disk) or more are rewritten in passes (module docs).
pub const STREAM_BYTES: u64 = 64 << 20;

/// Edits held by the writing pass before they are written, when it may write them.
pub(super) const FLUSH_EDITS: usize = 4096;

/// The hash an id is known by in [`href_targets`].
pub(super) fn id_hash(id: &str) -> u64 {
    use std::hash::BuildHasher;
    foldhash::fast::FixedState::with_seed(0x736b_796c_6f64).hash_one(id)
}

/// The hashes ([`id_hash`]) of the ids some `xlink:href="#id"` of the document at `path`
/// names (any prefix of `href`, the id trimmed, as the rewrite reads them).
fn href_targets(path: &Path) -> Result<HashSet<u64>, WriteError> {
    let (reader, _) = source::open(path)?;
    let mut reader = quick_xml::Reader::from_reader(reader);
    reader.config_mut().trim_text(false);
    let mut out = HashSet::new();
    let mut buf = Vec::with_capacity(64 * 1024);
    loop {
        let ev = match reader.read_event_into(&mut buf) {
            Ok(ev) => ev,
            Err(e) => {
                return Err(WriteError::xml_at_byte(
                    path,
                    reader.error_position(),
                    e.to_string(),
                ))
            }
        };
        match ev {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let raw: &[u8] = e;
                if memchr::memmem::find(raw, b"href").is_some() {
                    for (name, span) in super::attribute_spans(raw) {
                        let local = name.rsplit(|&c| c == b':').next().unwrap_or(name);
                        if local != b"href" || !name.contains(&b':') {
                            continue;
                        }
                        if let Some(r) = raw[span].strip_prefix(b"#") {
                            out.insert(id_hash(String::from_utf8_lossy(r).trim()));
                        }
                    }
                }
            }
            Event::Eof => break,
            _ => {}
        }
        buf.clear();
    }
    Ok(out)
}

/// A document to rewrite, read first so that a broken input fails with the reader's error:
/// whole below `stream_from` bytes (`STREAM_BYTES` by default), else chunk by chunk
/// (module docs), keeping only its `srsName`.
///
/// ```
/// use glam::DVec3;
/// use skylod::export::transform::RewriteSource;
/// use skylod::io::citygml::WriteOptions;
/// use skylod::io::citygml::WriteError;
/// let dir = tempfile::tempdir().unwrap();
/// let src = dir.path().join("in.gml");
/// std::fs::write(&src, br#"<CityModel xmlns="http://www.opengis.net/citygml/2.0"
///  xmlns:gml="http://www.opengis.net/gml" xmlns:gen="http://www.opengis.net/citygml/generics/2.0">
///  <cityObjectMember><gen:GenericCityObject gml:id="g"><gen:lod1Geometry>
///  <gml:Point srsName="EPSG:25832"><gml:pos>1 2 3</gml:pos></gml:Point>
///  </gen:lod1Geometry></gen:GenericCityObject></cityObjectMember></CityModel>"#).unwrap();
/// // 0: in passes whatever the size (the default streams from 64 MiB on).
/// let doc = RewriteSource::read_with(&src, 0).unwrap();
/// assert_eq!(doc.srs_name(), Some("EPSG:25832"));
/// let up = |p: &mut [DVec3]| -> Result<(), String> {
///     p.iter_mut().for_each(|q| q.z += 10.0);
///     Ok(())
/// };
/// let out = dir.path().join("out.gml");
/// let s = doc
///     .rewrite(&out, &up, "EPSG:9999", &WriteOptions::default(), |_| Ok::<(), WriteError>(()))
///     .unwrap();
/// assert_eq!(s.points, 1);
/// assert!(std::fs::read_to_string(&out).unwrap().contains("<gml:pos>1 2 13</gml:pos>"));
/// ```
#[derive(Debug)]
pub struct RewriteSource {
    path: PathBuf,
    srs_name: Option<String>,
    /// The whole read of a small document (its bytes are written from it).
    whole: Option<CityModel>,
}

impl RewriteSource {
    /// [`RewriteSource::read_with`] from `STREAM_BYTES`.
    pub fn read(path: &Path) -> Result<RewriteSource, ReadError> {
        RewriteSource::read_with(path, STREAM_BYTES)
    }

    /// Read the document at `path`: whole when it is smaller than `stream_from` bytes on disk
    /// (or when the chunked reader declines it), else chunk by chunk.
    pub fn read_with(path: &Path, stream_from: u64) -> Result<RewriteSource, ReadError> {
        let size = std::fs::metadata(path).map_or(0, |m| m.len());
        if size >= stream_from {
            let done = stream(path, &ReadOptions::default(), CHUNK_BYTES, &|_| {}, |_| {
                Ok::<(), ReadError>(())
            })?;
            if let Streamed::Done(sum) = done {
                return Ok(RewriteSource {
                    path: path.to_path_buf(),
                    srs_name: sum.srs_name,
                    whole: None,
                });
            }
        }
        let model = read_file(path)?;
        Ok(RewriteSource {
            path: path.to_path_buf(),
            srs_name: model.files.first().and_then(|f| f.srs_name.clone()),
            whole: Some(model),
        })
    }

    /// The document's `srsName`, as the reader finds it.
    pub fn srs_name(&self) -> Option<&str> {
        self.srs_name.as_deref()
    }

    /// Whether the document is rewritten in passes (not read whole).
    pub fn in_passes(&self) -> bool {
        self.whole.is_none()
    }

    /// Write the document to `out` with every coordinate passed through `transform` and every
    /// `srsName` set to `target_srs` (`super`'s module docs); `check` sees the summary
    /// before anything is written (it may add warnings, or refuse: nothing is written then).
    pub fn rewrite<E: From<WriteError>>(
        self,
        out: &Path,
        transform: &PointsFn<'_>,
        target_srs: &str,
        opts: &WriteOptions,
        check: impl FnOnce(&mut RewriteSummary) -> Result<(), E>,
    ) -> Result<RewriteSummary, E> {
        let wopts = WriteOptions {
            keep_envelopes: true,
            ..opts.clone()
        };
        if let Some(model) = &self.whole {
            let (edits, mut summary) = rewrite_edits(&self.path, transform, target_srs)?;
            check(&mut summary)?;
            summary.bytes = write_document(model, 0, edits, out, &wopts)?.bytes;
            return Ok(summary);
        }
        let path = self.path.as_path();
        let mut boxes = Scanner::new(path, transform, target_srs, Mode::Boxes);
        boxes.wanted = Some(href_targets(path)?);
        let len = scan(&mut boxes, &mut |_, _| Ok(()))?;
        let envelopes = boxes.envelope_edits();
        let mut summary = std::mem::take(&mut boxes.summary);
        drop(boxes);
        check(&mut summary)?;
        check_target(out, &wopts, std::iter::once(path))?;
        summary.bytes = atomic_write(out, |w| {
            write_pass(path, transform, target_srs, envelopes, len, w, out)
        })?;
        Ok(summary)
    }
}

/// Pass 4 (module docs): the document at `path` (`len` bytes, decompressed) written to `w`
/// with its points transformed and `envelopes` (pass 3's, in document order) in place.
fn write_pass(
    path: &Path,
    transform: &PointsFn<'_>,
    target_srs: &str,
    envelopes: Vec<Edit>,
    len: u64,
    w: &mut dyn Write,
    out: &Path,
) -> Result<u64, WriteError> {
    let (mut reader, _) = source::open(path)?;
    let mut envelopes = envelopes.into_iter().peekable();
    let (mut cursor, mut written) = (0u64, 0u64);
    // the edits so far and the envelopes that end by `at`, written
    let mut flush = |edits: Vec<Edit>, at: u64| -> Result<(), WriteError> {
        let mut batch = edits;
        while let Some(e) = envelopes.next_if(|e| e.span.end <= at) {
            batch.push(e);
        }
        written += apply_edits(
            &mut reader,
            w,
            &normalise(batch),
            &mut cursor,
            (len, path, out),
        )?;
        Ok(())
    };
    let mut sc = Scanner::new(path, transform, target_srs, Mode::Write);
    scan(&mut sc, &mut |sc, at| {
        let pending = sc.env_open.is_some()
            || sc.coord.is_some()
            || sc.implicit.is_some()
            || sc.capture.is_some();
        if pending || (sc.edits.len() < FLUSH_EDITS && sc.stack.len() > 1) {
            return Ok(());
        }
        flush(std::mem::take(&mut sc.edits), at)
    })?;
    flush(std::mem::take(&mut sc.edits), u64::MAX)?;
    written += copy_rest(&mut reader, w, cursor, (len, path, out))?;
    Ok(written)
}
