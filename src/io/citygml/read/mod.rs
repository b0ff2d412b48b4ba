//! Streaming CityGML reader: XML events -> [`CityModel`] of buildings and assets.
//!
//! Namespace-aware ([`quick_xml::NsReader`]): elements are matched by namespace URI, so any
//! prefix and default namespaces work, for CityGML 1.0, 2.0 and 3.0. An uncompressed file is
//! read whole into one buffer and parsed in place (events borrow from it, line numbers are
//! counted only where a location needs one); a gzip-compressed one, or any [`read_from`]
//! reader, is streamed: each event is handled and dropped, memory grows with the model only.
//!
//! Geometry is collected into a per-document arena of *parts* (polygons, `xlink:href`
//! references, implicit-geometry headers); every geometry element with a `gml:id` records its
//! range of parts, so references (forward ones too) are resolved after the last event.
//!
//! One concern per file: `events` (the event loop), `element` (start and end of an element),
//! `classify` (what an element is), `attrs` (namespaces and attributes), `coords` (coordinates
//! and other captured text), `geometry` (rings and polygons), `ids` (gml:id uniqueness),
//! `xlink` (references), `assemble` (the model after the last event), `position` (lines, columns, locations), `state` (the
//! parser's state and stack queries).
//!
//! # Example
//! ```
//! let xml = br#"<CityModel xmlns="http://www.opengis.net/citygml/2.0"
//!   xmlns:bldg="http://www.opengis.net/citygml/building/2.0" xmlns:gml="http://www.opengis.net/gml">
//!  <cityObjectMember><bldg:Building gml:id="b1"><bldg:boundedBy><bldg:RoofSurface gml:id="r1">
//!   <bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember><gml:Polygon><gml:exterior>
//!    <gml:LinearRing><gml:posList>0 0 5 1 0 5 1 1 5 0 0 5</gml:posList></gml:LinearRing>
//!   </gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface>
//!  </bldg:RoofSurface></bldg:boundedBy></bldg:Building></cityObjectMember></CityModel>"#;
//! let model = skylod::io::citygml::read_bytes(xml, "inline.gml").unwrap();
//! assert_eq!(model.buildings.len(), 1);
//! assert_eq!(model.assets[0].kind, skylod::model::AssetKind::Roof);
//! assert_eq!(model.assets[0].detail_polygons()[0].exterior().len(), 3);
//! ```

mod ahead;
mod assemble;
mod attrs;
mod classify;
mod collect;
pub(crate) mod coords;
mod element;
mod events;
mod geometry;
mod head;
mod ids;
mod position;
mod seen;
mod state;
mod stream;
mod xlink;

pub(crate) use collect::Collected;
pub use events::read_from;
pub(crate) use seen::SeenIds;
pub(crate) use stream::{member_chunks, MemberChunks};
pub use stream::{
    stream, stream_citygml, Chunk, ChunkStart, Passes, Reread, StreamSummary, Streamed, CHUNK_BYTES,
};

use crate::io::citygml::error::ReadError;
use crate::io::citygml::source;
use crate::model::{CityModel, Source};
use std::path::Path;

/// Limits that protect against hostile input.
#[derive(Debug, Clone)]
pub struct ReadOptions {
    /// Maximum element nesting depth.
    pub max_depth: usize,
    /// Maximum size of one XML event (a tag with its attributes, or one text node), bytes.
    pub max_event_bytes: usize,
    /// Maximum depth of chained `xlink:href` geometry references.
    pub max_href_depth: usize,
    /// Maximum number of steps (polygons and references visited) spent resolving
    /// `xlink:href` geometry references, on top of five per polygon element of the document;
    /// protects against exponential reference trees ("billion laughs" built from xlinks).
    pub max_href_work: usize,
    /// Bytes of whole top-level members (`cityObjectMember`s) the read of an uncompressed
    /// document parses at a time: the chunks of [`stream`], parsed ahead on rayon's threads
    /// ([`ReadOptions::stream_ahead`]) and collected into one model, the same whatever the
    /// chunks. 0 (default): an eighth of the document, at least `MIN_CHUNK_BYTES` and at
    /// most [`CHUNK_BYTES`], so that a city tile of a few MB is read by every core;
    /// `u64::MAX`: the document as one chunk, by one core.
    pub chunk_bytes: u64,
    /// Chunks of a streamed read ([`stream`]) parsed ahead on other threads while the one
    /// before them is handled, at most one per thread of rayon's current pool (none when it
    /// has one thread); 0: one thread parses every chunk. The chunks are the same either
    /// way; each chunk parsed ahead holds about its bytes again (default 2: two cores parse,
    /// ~40 MB more for 16 MiB chunks of LoD3, within the stream's memory goal).
    pub stream_ahead: usize,
    /// Keep each polygon's `gml:id` ([`crate::model::Polygon::id`]; default true). Without
    /// them every polygon has none; the ids are still checked and resolved (duplicates,
    /// `xlink:href` targets), only not stored. `lod`'s hollow read, which drops most polygons
    /// once it has their rough forms, reads without them: ids longer than fit inline take an
    /// allocation each, made on a reading thread and freed on another, for ids nothing reads.
    pub polygon_ids: bool,
}

impl Default for ReadOptions {
    fn default() -> Self {
        ReadOptions {
            max_depth: 4096,
            max_event_bytes: 64 << 20,
            max_href_depth: 64,
            max_href_work: 2_000_000,
            chunk_bytes: 0,
            stream_ahead: 2,
            polygon_ids: true,
        }
    }
}

/// Read one CityGML file (`.gml`, `.xml`, gzip-compressed or not); `-` reads standard input
/// (whole, into memory: [`crate::io::files::stdin_bytes`]).
pub fn read_file(path: &Path) -> Result<CityModel, ReadError> {
    read_file_with(path, &ReadOptions::default())
}

/// [`read_file`] with explicit limits ([`read_source`]).
pub fn read_file_with(path: &Path, opts: &ReadOptions) -> Result<CityModel, ReadError> {
    read_source(source::resolve(path)?, path, opts, &|_| {})
}

/// The least bytes of a chunk of the whole read by default ([`ReadOptions::chunk_bytes`]).
pub const MIN_CHUNK_BYTES: u64 = 1 << 20;

/// The chunks the whole read of a document of `len` bytes parses, about
/// ([`ReadOptions::chunk_bytes`]).
fn chunk_bytes(opts: &ReadOptions, len: u64) -> u64 {
    match opts.chunk_bytes {
        0 => (len / 8).clamp(MIN_CHUNK_BYTES, CHUNK_BYTES),
        n => n,
    }
}

/// The whole model of the uncompressed document `doc` (named `name`) read in chunks
/// ([`ReadOptions::chunk_bytes`]), `passed(n)` told as bytes are read; `None` where it is one
/// chunk or the stream declines (the caller reads it as one chunk).
fn read_in_chunks(
    doc: &source::Bytes,
    name: &Path,
    opts: &ReadOptions,
    passed: &dyn Fn(u64),
) -> Option<CityModel> {
    let len = doc.len() as u64;
    let chunk = chunk_bytes(opts, len);
    (chunk < len)
        .then(|| collect::read_collected(doc, name, opts, chunk, passed))
        .flatten()
}

/// Read a document from where it is ([`Source`]: a file, or bytes in memory; for a path,
/// [`source::resolve`]), naming it `name` in the model ([`crate::model::SourceFile::path`]),
/// errors and warnings. An uncompressed document is parsed in chunks on every core (events
/// borrow from its bytes); a gzip-compressed one is decompressed as it is parsed. A model read
/// from memory keeps the bytes ([`crate::model::SourceFile::source`]), so that every writer
/// can copy from them as from a file.
///
/// `passed(n)` is called, from any of the reading threads, each time `n` more bytes of an
/// uncompressed document have been parsed (every few MiB), so that progress moves while one
/// large file is read. The calls add up to at most the document's size, also where the
/// chunked read declines and the document is read as one chunk; a gzip-compressed document
/// is not reported (`passed` is never called).
pub fn read_source(
    src: Source,
    name: &Path,
    opts: &ReadOptions,
    passed: &(dyn Fn(u64) + Sync),
) -> Result<CityModel, ReadError> {
    // CityJSON and CityJSONSeq, recognised by content
    let mut model = match json_or_xml(source::load_source(&src, name)?, &src, name)? {
        Ok(model) => model,
        Err(source::Loaded::Plain(doc)) => {
            let told = Told::new(doc.len() as u64, passed);
            match read_in_chunks(&doc, name, opts, &|n| told.more(n)) {
                Some(model) => model,
                None => {
                    // one chunk: the serial read, which also reports any error
                    let at = std::sync::atomic::AtomicU64::new(0);
                    events::read_slice(&doc, name, false, opts, &|upto| {
                        let upto = upto as u64;
                        let from = at.fetch_max(upto, std::sync::atomic::Ordering::Relaxed);
                        told.more(upto.saturating_sub(from));
                        doc.release_before(upto as usize);
                    })?
                }
            }
        }
        Err(source::Loaded::Gzip(reader, compressed)) => {
            // gzip-compressed CityGML is typically 8-12 times smaller than the document
            let hint = compressed.saturating_mul(8);
            events::read_sized(reader, name, true, opts, hint)?
        }
    };
    if let Source::Memory(_) = src {
        for f in &mut model.files {
            f.source = src.clone();
        }
    }
    Ok(model)
}

/// A CityJSON document read ([`crate::io::cityjson`]), or the document handed back for the
/// CityGML reader.
fn json_or_xml(
    doc: source::Loaded,
    src: &Source,
    name: &Path,
) -> Result<Result<CityModel, source::Loaded>, ReadError> {
    use crate::io::cityjson::chunks::{whole_model, Input};
    // the chunks of the chunked read collected (memory follows the model, not a value of
    // the whole document)
    Ok(Ok(match doc {
        source::Loaded::Plain(doc) if source::is_json(&doc) => {
            whole_model(Input::Bytes(&doc), name)?
        }
        source::Loaded::Gzip(mut reader, n) => {
            if !source::is_json(source::peek(&mut reader)) {
                return Ok(Err(source::Loaded::Gzip(reader, n)));
            }
            match src {
                Source::File(p) => whole_model(Input::File(p), name)?,
                Source::Memory(b) => whole_model(Input::Gzip(b), name)?,
            }
        }
        doc => return Ok(Err(doc)),
    }))
}

/// The bytes [`read_source`] has told, capped at the document's length (a read that
/// starts over after the chunked read declined tells no byte twice).
struct Told<'a> {
    total: std::sync::atomic::AtomicU64,
    len: u64,
    passed: &'a (dyn Fn(u64) + Sync),
}

impl<'a> Told<'a> {
    fn new(len: u64, passed: &'a (dyn Fn(u64) + Sync)) -> Self {
        Told {
            total: std::sync::atomic::AtomicU64::new(0),
            len,
            passed,
        }
    }

    /// `n` more bytes read.
    fn more(&self, n: u64) {
        use std::sync::atomic::Ordering;
        let before = self.total.fetch_add(n, Ordering::Relaxed);
        let n = n.min(self.len.saturating_sub(before));
        if n > 0 {
            (self.passed)(n);
        }
    }
}

/// The chunked read of [`read_file_with`] alone ([`ReadOptions::chunk_bytes`]): `Ok(None)`
/// where `read_file_with` reads the document as one chunk instead (gzip, a document of one
/// chunk, a document the stream declines, and every input that fails to read). For tests
/// and benchmarks.
///
/// # Errors
/// The file cannot be opened.
pub fn read_file_chunked(path: &Path, opts: &ReadOptions) -> Result<Option<CityModel>, ReadError> {
    match source::load(path)? {
        source::Loaded::Plain(doc) => Ok(read_in_chunks(&doc, path, opts, &|_| {})),
        source::Loaded::Gzip(..) => Ok(None),
    }
}

/// Read a document held in memory, plain or gzip-compressed. `name` names it in the model,
/// errors and warnings. The bytes are copied once and kept with the model, so that it can be
/// written as a model read from a file can ([`read_source`] keeps shared bytes without
/// the copy).
pub fn read_bytes(bytes: &[u8], name: impl AsRef<Path>) -> Result<CityModel, ReadError> {
    let src = Source::Memory(bytes.into());
    read_source(src, name.as_ref(), &ReadOptions::default(), &|_| {})
}

/// Largest accepted coordinate magnitude: far beyond any real CRS (geocentric coordinates are
/// about 6.4e6 m) yet small enough that areas and cross products of coordinates stay finite.
pub const MAX_COORDINATE: f64 = 1e12;
