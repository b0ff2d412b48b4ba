//! One document read a chunk of whole top-level members at a time ([`stream`]): memory follows
//! the chunk, not the file.
//!
//! The bytes after the root's start tag are cut at the ends of top-level `cityObjectMember`
//! elements (any prefix, CityGML 1.0 to 3.0) about every
//! `chunk_bytes`; each chunk is parsed by its own [`Parser`] seeded with the root's start tag
//! and with the document-wide state the serial read would have reached there (version, CRS,
//! `gml:` prefix, relief LoD, the foreign namespaces and unknown prefixes already warned
//! about, how many invalid gml:ids were listed, the line the chunk starts on), assembled
//! into a [`CityModel`] of its own, handed over and dropped.
//!
//! What one chunk cannot know, the stream checks, and declines ([`Streamed::Declined`]: the
//! caller reads the whole document instead, which reports errors as always) where a chunk
//! could differ from the serial read's:
//!
//! * an `xlink:href` whose target is in another chunk: the chunk's resolution fails (as any
//!   read error, and any chunk that does not end between two children of the root, declines);
//! * an `xlink:href` to a gml:id that is also in an earlier chunk (the serial read resolves it
//!   to the first);
//! * a DOCTYPE (entities), a root that is no `CityModel`.
//!
//! A gzip-compressed file is decompressed once into an unnamed temporary file and streamed
//! from there (see [`stream`]).
//!
//! The chunks after the one handed over are parsed ahead on other threads
//! ([`super::ahead`], [`ReadOptions::stream_ahead`]), each from the state the serial read
//! stands in at its start, or parsed again where that state was not known yet.
//!
//! A gml:id repeated in a later chunk is warned about there, as the serial read does: the
//! hashes of the ids read so far are kept, sorted, bucketed by their top bits, behind a
//! filter (`SeenIds`: 7 to 7.75 bytes an id, the one part of memory that grows with the
//! document: 27 to 30 MB for the 3.9 million ids of 1 GB of LoD3).
//!
//! A chunk's model is the serial read's restricted to its members, with two differences its
//! user must know: a building's body asset (a building without thematic surfaces, made after
//! the last event) comes after the chunk's other assets, where the serial read puts every
//! body after all the document's other assets ([`Chunk`] counts both kinds); and the root's
//! envelope is computed over the chunk. The summary of invalid gml:ids ("N more ...") is the
//! stream's: [`StreamSummary::patch_warnings`].

use super::ahead::{Ahead, ChunkSource};
use super::events::{configured, finish, parse_events, start_root};
use super::ids::{is_listed_invalid_id, INVALID_IDS_LISTED};
use super::seen::SeenIds;
use super::state::{EnvOwner, LineMark, Parser, NO_REC};
use super::ReadOptions;
use crate::io::citygml::source;
use crate::model::{AssetKind, CityGmlVersion, CityModel, Warning};
use std::path::Path;

/// Default bytes of document per chunk of [`stream`]: 16 MiB (a chunk's model of LoD3 is
/// about its size again).
pub const CHUNK_BYTES: u64 = 16 << 20;

/// The most bytes of a stream's first chunk (whole members: it ends after the member that
/// crosses this).
const FIRST_CHUNK_BYTES: usize = 256 << 10;

/// One chunk of a streamed document: its model and what came before it.
#[derive(Debug)]
pub struct Chunk {
    /// The chunk's members as a model of one file (path and CRS of the document).
    pub model: CityModel,
    /// Position of the chunk in the document (0 for the first).
    pub index: usize,
    /// Buildings (and parts) in earlier chunks: the index of this chunk's building `b` in
    /// the whole document's model is `buildings_before + b`.
    pub buildings_before: usize,
    /// Assets other than bodies in earlier chunks: this chunk's non-body asset `i` is asset
    /// `assets_before + i` of the whole document's model (its bodies come after all the
    /// document's other assets there).
    pub assets_before: usize,
    /// Body assets in earlier chunks.
    pub bodies_before: usize,
    /// Warnings in earlier chunks.
    pub warnings_before: usize,
    /// First and last byte (exclusive) of the chunk in the document (a CityJSON document's:
    /// in proportion to its city objects).
    pub bytes: (u64, u64),
    /// A CityJSON document's: the attributes of the chunk's city objects and the members of
    /// their semantic surface objects, which its CityJSON output copies.
    pub(crate) source: Option<crate::io::cityjson::source::FromSource>,
    /// A CityGML document's: where the chunk starts, to parse it or some of its members
    /// again ([`Reread`]).
    pub start: Option<ChunkStart>,
    /// The root's envelopes among the model's file's envelopes (indices), each with the box
    /// of the chunk's content, where the whole document's puts the box of all of it.
    pub(crate) root_envelopes: Vec<usize>,
}

impl Chunk {
    /// Assets of the chunk other than bodies (they come first in the chunk's model).
    pub fn non_body_assets(&self) -> usize {
        self.model
            .assets
            .iter()
            .filter(|a| a.kind != AssetKind::Body)
            .count()
    }
}

/// What the whole document held, after the last chunk.
#[derive(Debug, Clone, Default)]
pub struct StreamSummary {
    /// Chunks handed over.
    pub chunks: usize,
    /// CityGML version, as the serial read finds it.
    pub version: Option<CityGmlVersion>,
    /// `srsName` of the model, as the serial read finds it.
    pub srs_name: Option<String>,
    /// Buildings and parts.
    pub buildings: usize,
    /// Assets other than bodies.
    pub assets: usize,
    /// Body assets.
    pub bodies: usize,
    /// Warnings.
    pub warnings: usize,
    /// The serial read appends "N more gml:ids ..." to the last invalid gml:id it lists: its
    /// index among all the chunks' warnings, and the text.
    pub invalid_note: Option<(usize, String)>,
    /// Warnings the serial read gives after the last event ("CityModel has no
    /// gml:boundedBy envelope"), counted in [`StreamSummary::warnings`].
    pub trailing: Vec<Warning>,
}

impl StreamSummary {
    /// Make `warnings` (every chunk's, in order) the serial read's: the invalid-id note, the
    /// trailing warnings.
    pub fn patch_warnings(&self, warnings: &mut Vec<Warning>) {
        if let Some((i, note)) = &self.invalid_note {
            if let Some(w) = warnings.get_mut(*i) {
                w.message.push_str(note);
            }
        }
        warnings.extend(self.trailing.iter().cloned());
    }
}

/// How a streamed read ended.
#[derive(Debug)]
pub enum Streamed {
    /// Every chunk was handed over; the document as a whole.
    Done(StreamSummary),
    /// The stream could differ from the serial read (see the module docs), or the document
    /// failed to read: read it whole ([`super::read_file_with`]) instead, which also reports
    /// any error. Chunks may have been handed over before: their results are to be dropped.
    Declined(String),
}

impl Streamed {
    /// The document's summary; `None` where the stream declined.
    pub fn done(self) -> Option<StreamSummary> {
        match self {
            Streamed::Done(s) => Some(s),
            Streamed::Declined(_) => None,
        }
    }
}

/// The settings of a writer that reads one document in several streamed passes: the options
/// of every read, the chunk size, and the progress of each pass (`passed(k, n)`: `n` more
/// bytes read in pass `k`, the writer telling what its passes are).
///
/// A CityJSON document's first pass (its small members, vertices and links:
/// `io::cityjson::chunks`) is made once and kept for the later passes over the
/// same file: the document is read once a pass of the writer, not twice, for as long as the
/// passes live at the cost of its vertices (24 bytes each) held between the passes.
#[derive(Clone)]
pub struct Passes<'a> {
    /// Options of every read.
    pub read: &'a ReadOptions,
    /// Bytes of whole top-level members a chunk holds, about ([`stream`]).
    pub chunk_bytes: u64,
    /// Progress: `passed(k, n)`, `n` more bytes read in pass `k`.
    pub passed: &'a dyn Fn(usize, u64),
    /// A CityJSON document's first pass, kept.
    kept: std::sync::Arc<crate::io::cityjson::chunks::Kept>,
}

impl<'a> Passes<'a> {
    /// Passes reading with `read` in chunks of `chunk_bytes`, telling `passed`.
    pub fn new(read: &'a ReadOptions, chunk_bytes: u64, passed: &'a dyn Fn(usize, u64)) -> Self {
        Passes {
            read,
            chunk_bytes,
            passed,
            kept: Default::default(),
        }
    }

    /// Pass `k` over `path`: [`stream`] handing each chunk to `each`, its bytes told as pass
    /// `k`'s. The document's summary, or `None` where the stream declines
    /// ([`Streamed::Declined`]: what the pass did is to be dropped).
    ///
    /// # Errors
    /// Errors of `each`, as [`stream`].
    pub fn pass<E>(
        &self,
        path: &Path,
        k: usize,
        each: impl FnMut(Chunk) -> Result<(), E>,
    ) -> Result<Option<StreamSummary>, E> {
        self.run(path, k, false, each)
    }

    /// [`Passes::pass`] over a CityGML document only (`stream_citygml`: a CityJSON one
    /// declines), for the writers that copy the document's XML.
    ///
    /// # Errors
    /// As [`Passes::pass`].
    pub fn pass_citygml<E>(
        &self,
        path: &Path,
        k: usize,
        each: impl FnMut(Chunk) -> Result<(), E>,
    ) -> Result<Option<StreamSummary>, E> {
        self.run(path, k, true, each)
    }

    /// Pass `k` over `path`, of a CityGML document only where `citygml_only`.
    fn run<E>(
        &self,
        path: &Path,
        k: usize,
        citygml_only: bool,
        each: impl FnMut(Chunk) -> Result<(), E>,
    ) -> Result<Option<StreamSummary>, E> {
        let passed = self.passed;
        let passed = &|n| passed(k, n);
        let r = if citygml_only {
            stream_citygml(path, self.read, self.chunk_bytes, passed, each)?
        } else if crate::io::cityjson::is_json_file(path) {
            stream_json(path, self.chunk_bytes, Some(&self.kept), passed, each)?
        } else {
            stream(path, self.read, self.chunk_bytes, passed, each)?
        };
        Ok(r.done())
    }
}

impl std::fmt::Debug for Passes<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Passes")
            .field("read", self.read)
            .field("chunk_bytes", &self.chunk_bytes)
            .finish_non_exhaustive()
    }
}

/// Read `path` one chunk of about `chunk_bytes` bytes of whole top-level members at a time
/// (see the module docs), handing each to `each` in document order and dropping it after;
/// `passed(n)` is called as bytes of the document have been read (they add up to the
/// file's size when the stream is done: for a gzip-compressed file, its compressed bytes in
/// proportion to the document's read).
///
/// A gzip-compressed file is first decompressed into an unnamed temporary file (in the
/// system's temporary directory, `TMPDIR`: it needs the document's size on disk, never in
/// memory; nothing is left behind) and streamed from there as a plain file is.
///
/// # Errors
/// Errors of `each` (the stream stops at the first). A document that cannot be read is
/// [`Streamed::Declined`]: the whole read reports its error as always.
pub fn stream<E>(
    path: &Path,
    opts: &ReadOptions,
    chunk_bytes: u64,
    passed: &dyn Fn(u64),
    each: impl FnMut(Chunk) -> Result<(), E>,
) -> Result<Streamed, E> {
    if crate::io::cityjson::is_json_file(path) {
        return stream_json(path, chunk_bytes, None, passed, each);
    }
    stream_citygml(path, opts, chunk_bytes, passed, each)
}

/// [`stream`] of a CityJSON document or CityJSONSeq ([`crate::io::cityjson`] reads its
/// chunks), its first pass kept in `kept` where given.
fn stream_json<E>(
    path: &Path,
    chunk_bytes: u64,
    kept: Option<&crate::io::cityjson::chunks::Kept>,
    passed: &dyn Fn(u64),
    mut each: impl FnMut(Chunk) -> Result<(), E>,
) -> Result<Streamed, E> {
    use crate::io::cityjson::chunks::{stream, Input, Part, Stop};
    let mut sum = StreamSummary::default();
    let r = stream(
        Input::File(path),
        path,
        chunk_bytes,
        kept,
        passed,
        |p: Part| {
            let bodies = p.model.assets.iter().filter(|a| a.kind == AssetKind::Body);
            let bodies = bodies.count();
            let chunk = Chunk {
                index: sum.chunks,
                buildings_before: sum.buildings,
                assets_before: sum.assets,
                bodies_before: sum.bodies,
                warnings_before: sum.warnings,
                bytes: p.bytes,
                source: Some(p.source),
                start: None,
                root_envelopes: Vec::new(),
                model: p.model,
            };
            sum.chunks += 1;
            sum.buildings += chunk.model.buildings.len();
            sum.assets += chunk.model.assets.len() - bodies;
            sum.bodies += bodies;
            sum.warnings += chunk.model.warnings.len();
            each(chunk)
        },
    );
    match r {
        Ok(shared) => Ok(Streamed::Done(StreamSummary {
            version: shared.version,
            srs_name: shared.srs_name,
            ..sum
        })),
        Err(Stop::Each(e)) => Err(e),
        Err(Stop::Declined(why)) => Ok(Streamed::Declined(why)),
        Err(Stop::Read(e)) => Ok(Streamed::Declined(e.to_string())),
    }
}

/// [`stream`] of a CityGML document only (a CityJSON one declines): for the writers that
/// copy the document's XML.
///
/// # Errors
/// As [`stream`].
pub fn stream_citygml<E>(
    path: &Path,
    opts: &ReadOptions,
    chunk_bytes: u64,
    passed: &dyn Fn(u64),
    each: impl FnMut(Chunk) -> Result<(), E>,
) -> Result<Streamed, E> {
    let decline = |why: &str| Ok(Streamed::Declined(why.to_string()));
    let (doc, on_disk) = match source::load(path) {
        Ok(source::Loaded::Plain(doc)) => (doc, None),
        // decompressed once into an unnamed temporary file, then streamed from its map
        Ok(source::Loaded::Gzip(mut reader, len)) => match source::spill(&mut reader) {
            Ok(doc) => (doc, Some(len)),
            Err(e) => return decline(&format!("decompressing: {e}")),
        },
        Err(e) => return decline(&e.to_string()),
    };
    stream_document(&doc, on_disk, path, opts, chunk_bytes, passed, each)
}

/// [`stream_citygml`] of the uncompressed document `doc` at hand, named `path`; `on_disk`:
/// the compressed size of the file it was decompressed from, whose bytes `passed` tells in
/// proportion.
///
/// # Errors
/// As [`stream`].
pub(super) fn stream_document<E>(
    doc: &source::Bytes,
    on_disk: Option<u64>,
    path: &Path,
    opts: &ReadOptions,
    chunk_bytes: u64,
    passed: &dyn Fn(u64),
    mut each: impl FnMut(Chunk) -> Result<(), E>,
) -> Result<Streamed, E> {
    let decline = |why: &str| Ok(Streamed::Declined(why.to_string()));
    // the bytes reported: the document's, or for a compressed file its compressed bytes in
    // proportion (they add up to the size on disk)
    let doc_len = doc.len() as u64;
    let reported = std::cell::Cell::new(0u64);
    let passed = |to: u64| {
        let at = match on_disk {
            Some(len) if doc_len > 0 => {
                u64::try_from(u128::from(to) * u128::from(len) / u128::from(doc_len)).unwrap_or(len)
            }
            _ => to,
        };
        let n = at.saturating_sub(reported.replace(at.max(reported.get())));
        if n > 0 {
            passed(n);
        }
    };
    let (bom, body, root_end) = match super::head::parse_head(doc, path, opts) {
        Ok(h) => (h.bom, h.body, h.root_end),
        Err(why) => return decline(why),
    };
    let prolog = &body[..root_end];
    let mut state = DocState {
        line: LineMark {
            line: 1,
            line_start: 0,
            counted_to: 0,
        },
        ..DocState::default()
    };
    let mut ids = SeenIds::default();
    let mut sum = StreamSummary::default();
    let mut from = 0usize; // body offset of the chunk (0: from the prolog on)
    let step = usize::try_from(chunk_bytes.max(1)).unwrap_or(usize::MAX);
    let src = ChunkSource {
        doc,
        bom,
        prolog,
        path,
        opts,
    };
    let threads = rayon::current_num_threads();
    let depth = if threads > 1 {
        opts.stream_ahead.min(threads)
    } else {
        0
    };
    std::thread::scope(|scope| {
        let mut ahead = Ahead::new(depth, src);
        let mut index = 0;
        loop {
            let first = index == 0;
            let start = if first { root_end } else { from };
            // the first chunk is parsed before any other can start (the others are seeded with
            // the state after it): kept short, so that the other threads start early
            let to = chunk_end(
                body,
                start,
                if first {
                    step.min(FIRST_CHUNK_BYTES)
                } else {
                    step
                },
            );
            let last = to == body.len();
            let before = (!first).then(|| std::sync::Arc::new(state.clone()));
            let ready = (!first).then(|| ahead.take((from, to), &state)).flatten();
            let p = ready
                .or_else(|| parse_chunk(doc, bom, prolog, from, to, first, &state, path, opts));
            let Some(p) = p else {
                return decline("a chunk that does not read alone");
            };
            if p.stack.len() != usize::from(!last) {
                return decline("a chunk that does not end between members");
            }
            state.absorb(&p);
            // the first chunk's members are read again after the root's start tag, as the
            // others, with the state after it (what they read of it is the root's)
            let start_at = ChunkStart {
                from: start,
                to,
                state: before.unwrap_or_else(|| std::sync::Arc::new(state.clone())),
            };
            if first && p.root_is_model && !p.env_owners.iter().any(|o| matches!(o, EnvOwner::Root))
            {
                sum.trailing.push(Warning {
                    file: p.shared_path.clone(),
                    line: 1,
                    column: 1,
                    gml_id: None,
                    message: "CityModel has no gml:boundedBy envelope".into(),
                });
            }
            let mut p = p;
            let (before, repeated) = ids.check_and_add(&p);
            p.dup_within = Some(repeated);
            if !before.is_empty() {
                // a reference to such an id means its first occurrence, in another chunk
                if p.href_targets().iter().any(|t| before.contains(t)) {
                    return decline("a reference to a gml:id of two chunks");
                }
                p.dup_before = before;
            }
            let listed = p.invalid_listed.clone();
            let invalid = p.invalid_ids;
            let end = (to + bom) as u64;
            p.stack.clear();
            p.event_pos = end;
            state.line = {
                let (line, line_start) = p.line_mark();
                LineMark {
                    line,
                    line_start,
                    counted_to: end,
                }
            };
            // the chunks after this one parse on other threads while this one is handled
            ahead.fill(scope, (start, to), &state, |s| chunk_end(body, s, step));
            // an envelope without srsDimension is written empty, whoever owns it
            let root_envelopes = (p.env_owners.iter().zip(&p.envelopes).enumerate())
                .filter(|(_, (o, e))| matches!(o, EnvOwner::Root) && e.dimension != 0)
                .map(|(i, _)| i)
                .collect();
            let model = match finish(p, doc.len() as u64, true, false) {
                Ok(m) => m,
                Err(e) => return decline(&e.to_string()),
            };
            doc.release_range(from + bom, to + bom);
            // invalid gml:ids: listed up to INVALID_IDS_LISTED per document; the last one this
            // chunk lists is found among its warnings as written, the duplicate-id warnings
            // (made after the last event) placed among them
            if listed.iter().any(|&w| w != usize::MAX) {
                let last = model.warnings.iter().rposition(is_listed_invalid_id);
                state.invalid_last = last.map(|k| sum.warnings + k).or(state.invalid_last);
            }
            state.invalid_ids += invalid;
            let bodies = model
                .assets
                .iter()
                .filter(|a| a.kind == AssetKind::Body)
                .count();
            let chunk = Chunk {
                index,
                buildings_before: sum.buildings,
                assets_before: sum.assets,
                bodies_before: sum.bodies,
                warnings_before: sum.warnings,
                bytes: (if first { 0 } else { (from + bom) as u64 }, end),
                model,
                source: None,
                start: Some(start_at),
                root_envelopes,
            };
            sum.buildings += chunk.model.buildings.len();
            sum.assets += chunk.model.assets.len() - bodies;
            sum.bodies += bodies;
            sum.warnings += chunk.model.warnings.len();
            passed(chunk.bytes.1);
            each(chunk)?;
            index += 1;
            from = to;
            if last {
                break;
            }
        }
        sum.chunks = index;
        sum.warnings += sum.trailing.len();
        sum.version = state.version;
        sum.srs_name = state.srs_name;
        let listed = state.invalid_listed as u64;
        let more = state.invalid_ids.saturating_sub(listed);
        if let (true, Some(i)) = (more > 0, state.invalid_last) {
            sum.invalid_note = Some((
                i,
                format!(
                    "; {more} more gml:ids after it are not valid xs:IDs either (not listed one by one)"
                ),
            ));
        }
        Ok(Streamed::Done(sum))
    })
}

/// Where a chunk of [`stream_citygml`] starts ([`Chunk::start`]): its bytes and the state
/// the serial read stands in there, to parse the chunk, or some of its members, again.
#[derive(Clone)]
pub struct ChunkStart {
    /// Body offsets of the chunk (the first chunk's from the root's start tag on).
    from: usize,
    to: usize,
    state: std::sync::Arc<DocState>,
}

impl std::fmt::Debug for ChunkStart {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ChunkStart")
            .field("from", &self.from)
            .field("to", &self.to)
            .finish_non_exhaustive()
    }
}

/// A plain CityGML document held (memory-mapped) to parse chunks of a stream of it, or some
/// of their top-level members, again ([`Reread::parse`]): a member parsed alone gives the
/// chunk's model of it (the same assets, polygons and spans), since a chunk's parser is
/// seeded with the state the serial read stands in at the chunk's start and a member's
/// geometry depends on nothing read between the chunk's start and the member.
pub struct Reread {
    doc: source::Bytes,
    bom: usize,
    root_end: usize,
    path: std::path::PathBuf,
    opts: ReadOptions,
}

impl std::fmt::Debug for Reread {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Reread")
            .field("path", &self.path)
            .finish_non_exhaustive()
    }
}

impl Reread {
    /// The plain document at `path` read with `opts` (as its stream was); `None` for a
    /// compressed document or one whose head does not read.
    pub fn open(path: &Path, opts: &ReadOptions) -> Option<Reread> {
        let source::Loaded::Plain(doc) = source::load(path).ok()? else {
            return None;
        };
        let (bom, root_end) = {
            let h = super::head::parse_head(&doc, path, opts).ok()?;
            (h.bom, h.root_end)
        };
        Some(Reread {
            doc,
            bom,
            root_end,
            path: path.to_path_buf(),
            opts: opts.clone(),
        })
    }

    /// The document's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The document's bytes after the byte-order mark.
    fn body(&self) -> &[u8] {
        self.doc.get(self.bom..).unwrap_or(&[])
    }

    /// The bytes (document offsets) of the top-level members of chunk `start` that hold the
    /// document bytes `span` (an element inside the chunk): from the end of the last member
    /// before it (or the chunk's start) to the end of the member that ends it.
    pub fn members(&self, start: &ChunkStart, span: std::ops::Range<u64>) -> std::ops::Range<u64> {
        const NAME: &[u8] = b"cityObjectMember>";
        let body = self.body();
        let lo = start.from;
        let hi = start.to.min(body.len());
        let at = |x: u64| {
            usize::try_from(x)
                .unwrap_or(usize::MAX)
                .saturating_sub(self.bom)
        };
        let (s, e) = (at(span.start).clamp(lo, hi), at(span.end).clamp(lo, hi));
        let finder = memchr::memmem::FinderRev::new(NAME);
        let mut from = lo;
        let mut upto = s;
        while let Some(m) = body.get(lo..upto).and_then(|b| finder.rfind(b)) {
            let m = lo + m;
            if super::head::is_end_tag(body, m) {
                from = m + NAME.len();
                break;
            }
            upto = m;
        }
        let to = next_cut(body, e).map_or(hi, |c| c.min(hi));
        let doc = |x: usize| (x + self.bom) as u64;
        doc(from)..doc(to.max(from))
    }

    /// Chunk `start` parsed again, or only its members in `range` (document offsets from
    /// [`Reread::members`]): the model a stream makes of them, but for warnings and lines.
    /// `None` where they do not read alone (e.g. a reference to another member of the
    /// chunk). The pages of the document read are given back after.
    pub fn parse(
        &self,
        start: &ChunkStart,
        range: Option<std::ops::Range<u64>>,
    ) -> Option<CityModel> {
        let body = self.body();
        let at = |x: u64| {
            usize::try_from(x)
                .unwrap_or(usize::MAX)
                .saturating_sub(self.bom)
        };
        let (from, to) = match range {
            None => (start.from, start.to),
            Some(r) => (at(r.start), at(r.end)),
        };
        if from > to || to > body.len() {
            return None;
        }
        let prolog = body.get(..self.root_end)?;
        let (doc, bom) = (&self.doc[..], self.bom);
        // lines counted from the members on, not from the chunk's start: a member's lines
        // are not the serial read's, its geometry is
        let at_from = (from + bom) as u64;
        let state = DocState {
            line: LineMark {
                line: 1,
                line_start: at_from,
                counted_to: at_from,
            },
            ..(*start.state).clone()
        };
        let (path, opts) = (&self.path, &self.opts);
        let p = parse_chunk(doc, bom, prolog, from, to, false, &state, path, opts);
        // whole pages around the members (their neighbours' are read again if needed): the
        // map keeps no page of what is read back
        const PAGE: usize = 64 << 10;
        let around = ((from + bom) / PAGE * PAGE, (to + bom).div_ceil(PAGE) * PAGE);
        self.doc.release_range(around.0, around.1);
        let mut p = p?;
        if p.stack.len() != usize::from(to != body.len()) {
            return None;
        }
        p.stack.clear();
        p.event_pos = (to + bom) as u64;
        finish(p, doc.len() as u64, true, false).ok()
    }
}

/// The end (body offset) of the chunk of [`stream_citygml`] whose members start at `start`:
/// the first top-level member end after `step` bytes, or the body's end.
fn chunk_end(body: &[u8], start: usize, step: usize) -> usize {
    let at = start.saturating_add(step);
    if at >= body.len() {
        body.len()
    } else {
        next_cut(body, at).unwrap_or(body.len())
    }
}

/// Where [`stream_citygml`] cuts a document into chunks of whole top-level members
/// ([`member_chunks`]), in document offsets (byte-order mark included).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct MemberChunks {
    /// End of the root's start tag: `doc[..head_end]` is the prolog.
    pub(crate) head_end: usize,
    /// The chunks: the first starts at `head_end`, each starts where the one before ends, the
    /// last ends at the document's end.
    pub(crate) ranges: Vec<(usize, usize)>,
    /// The root's qualified name, as written in its start tag.
    pub(crate) root_qname: Vec<u8>,
}

/// The chunks [`stream_citygml`] reads `doc` (a whole uncompressed document) in, about
/// `chunk_bytes` each; `Err` with why the document is not read in chunks (see
/// [`super::head::parse_head`]). For the writers that go through a document a chunk at a
/// time without reading it into a model (`lod::mixed`).
pub(crate) fn member_chunks(
    doc: &[u8],
    path: &Path,
    opts: &ReadOptions,
    chunk_bytes: u64,
) -> Result<MemberChunks, &'static str> {
    let h = super::head::parse_head(doc, path, opts)?;
    let (bom, body, root_end) = (h.bom, h.body, h.root_end);
    // the root's start tag ends the prolog; no `<` can stand in its attribute values
    let tag = memchr::memrchr(b'<', &body[..root_end]).ok_or("no CityModel root")?;
    let root_qname: Vec<u8> = body[tag + 1..root_end]
        .iter()
        .copied()
        .take_while(|c| !c.is_ascii_whitespace() && *c != b'>' && *c != b'/')
        .collect();
    let step = usize::try_from(chunk_bytes.max(1)).unwrap_or(usize::MAX);
    let mut ranges = Vec::new();
    let mut from = root_end;
    loop {
        let to = chunk_end(body, from, step);
        ranges.push((from + bom, to + bom));
        if to >= body.len() {
            break;
        }
        from = to;
    }
    Ok(MemberChunks {
        head_end: root_end + bom,
        ranges,
        root_qname,
    })
}

/// The end (after `>`) of the first top-level member end tag at or after `at`; `None` at the
/// document's end.
fn next_cut(body: &[u8], at: usize) -> Option<usize> {
    const NAME: &[u8] = b"cityObjectMember>";
    let finder = memchr::memmem::Finder::new(NAME);
    let mut at = at;
    while let Some(hit) = body.get(at..).and_then(|b| finder.find(b)) {
        let m = at + hit;
        at = m + 1;
        if super::head::is_end_tag(body, m) {
            let cut = m + NAME.len();
            return (cut < body.len()).then_some(cut);
        }
    }
    None
}

/// The document-wide state the serial read has reached at a chunk's start.
#[derive(Default, Clone, PartialEq)]
pub(super) struct DocState {
    pub(super) line: LineMark,
    pub(super) version: Option<CityGmlVersion>,
    pub(super) srs_name: Option<String>,
    pub(super) root_srs_set: bool,
    pub(super) gml_prefix: Option<String>,
    pub(super) relief_lod: Option<u8>,
    pub(super) ade_namespaces: Vec<Vec<u8>>,
    pub(super) unknown_prefixes: Vec<Vec<u8>>,
    pub(super) invalid_listed: usize,
    pub(super) invalid_ids: u64,
    pub(super) invalid_last: Option<usize>,
}

impl DocState {
    /// The state after chunk `p`.
    fn absorb(&mut self, p: &Parser<'_>) {
        self.version = p.version;
        self.srs_name = p.srs_name.clone();
        self.root_srs_set = p.root_srs_set;
        self.gml_prefix = p.gml_prefix.clone();
        if p.relief_lod_set {
            self.relief_lod = Some(p.relief_lod);
        }
        for k in p.ade_namespaces.keys() {
            if !self.ade_namespaces.contains(k) {
                self.ade_namespaces.push(k.clone());
            }
        }
        for k in p.unknown_prefixes.keys() {
            if !self.unknown_prefixes.contains(k) {
                self.unknown_prefixes.push(k.clone());
            }
        }
        self.invalid_listed = p.invalid_listed.len().min(INVALID_IDS_LISTED);
    }
}

/// Parse `body[from..to]` (body offsets; the first chunk from the prolog on) with a parser
/// seeded as the serial read stands there; `None` on any error.
#[allow(clippy::too_many_arguments)]
pub(super) fn parse_chunk<'d>(
    doc: &'d [u8],
    bom: usize,
    prolog: &'d [u8],
    from: usize,
    to: usize,
    first: bool,
    state: &DocState,
    path: &Path,
    opts: &ReadOptions,
) -> Option<Parser<'d>> {
    let body = doc.get(bom..)?;
    let mut p = Parser::new(path, opts.clone(), doc);
    p.streamed = true;
    p.expect_bytes((to - from) as u64);
    let release = |_: usize| {};
    if first {
        let mut reader = configured(body.get(..to)?);
        let mut saw_root = false;
        parse_events(
            &mut p,
            &mut reader,
            bom as u64,
            &mut saw_root,
            (&release, u64::MAX / 2),
            false,
        )
        .ok()?;
        return Some(p);
    }
    let mut reader = start_root(&mut p, prolog, bom as u64, u64::MAX / 2)?;
    let mut saw_root = true;
    let root = p.stack.first().map(|f| f.rec).filter(|&r| r != NO_REC);
    let root_id = root.and_then(|r| p.id_log.get(r as usize).and_then(|r| p.id_text(r)));
    p.forget_root_start()?;
    p.root_id = root_id;
    p.stream_tail = true;
    p.lines.set(state.line);
    // lines of duplicate gml:ids are counted from here, not from the document's start
    p.marks.get_mut().push(state.line);
    p.version = state.version.or(p.version);
    p.srs_name = state.srs_name.clone();
    p.root_srs_set = state.root_srs_set;
    p.gml_prefix = state.gml_prefix.clone();
    if let Some(l) = state.relief_lod {
        p.relief_lod = l;
        p.relief_lod_set = true;
    }
    for k in &state.ade_namespaces {
        p.ade_namespaces.insert(k.clone(), usize::MAX);
    }
    for k in &state.unknown_prefixes {
        p.unknown_prefixes.insert(k.clone(), usize::MAX);
    }
    p.invalid_listed = vec![usize::MAX; state.invalid_listed];
    let from_doc = (from + bom) as u64;
    let base = from_doc.checked_sub(reader.buffer_position())?;
    *reader.get_mut() = body.get(from..to)?;
    parse_events(
        &mut p,
        &mut reader,
        base,
        &mut saw_root,
        (&release, u64::MAX / 2),
        false,
    )
    .ok()?;
    Some(p)
}
