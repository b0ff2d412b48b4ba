//! The element index of the mixed-LoD writer: one streaming pass over a source document that
//! records, per element, its span, parent, name, `gml:id` and reference (`xlink:href`,
//! appearance target), which the rules ([`super::plan`]) decide on.
//!
//! **Cost follows what is kept.** The pass is given the spans of the elements the writer
//! drops whole (level-0 assets that hold no kept asset, see [`super::plan::skip_spans`]). Such
//! an element is indexed as one node without children: its content is not parsed, only
//! scanned for the one thing the rules need from dropped content, the `gml:id`s it holds (a
//! kept `xlink:href` or appearance target pointing at one of them is pruned, and a fresh id
//! must not meet one). References inside dropped content are never looked at (they are dead
//! before the first pruning round), so they need not be found. The scan
//! ([`super::content_ids`]) is exact for well-formed XML and gives up on content holding a
//! comment, CDATA section, processing instruction or namespace declaration (the namespace
//! scope of its ids could change), larger than half the token limit or not ending with the
//! element's own end tag: such content is parsed as usual instead.
//!
//! In a plain document holding 1 MiB or more of such content, the other cores scan it ahead
//! of the pass ([`Prescan`]), and the pass jumps over it (a seek, no read); in a gzip stream,
//! or for a span the prescan could not judge, the pass reads the content and scans it as it
//! comes. Ids go to an arena table ([`IdTable`](super::id_table::IdTable)): no allocation per id; an id that repeats
//! maps to its first element, as in a full parse.
//!
//! The pass shares the reader's set-up: namespace classification ([`crate::io::citygml::ns`]),
//! the byte-order-mark handling and the per-token size limit and nesting depth of
//! [`ReadOptions`].

use super::content_ids::{gml_ids, is_end_tag, Prescan, Taken, CHUNK_BYTES};
use super::doc::{Doc, Name, Node, NsKind, RefKind, NONE};
use super::push_back::{PushBack, Source};
use crate::io::citygml::error::WriteError;
use crate::io::citygml::ns::{self, Module, Ns};
use crate::io::citygml::read::ReadOptions;
use crate::io::citygml::source::{self, Limited, SkipAhead, Stream};
use crate::model::{Source as DocSource, Span};
use foldhash::{HashMap, HashMapExt};
use quick_xml::events::{BytesStart, Event};
use quick_xml::name::{QName, ResolveResult};
use quick_xml::NsReader;
use std::io::{BufRead, Read};
use std::path::Path;

fn ns_kind(uri: Option<&[u8]>) -> NsKind {
    match uri.map(ns::classify) {
        Some(Ns::Gml) => NsKind::Gml,
        Some(Ns::CityGml(Module::Core, _)) => NsKind::Core,
        Some(Ns::CityGml(Module::Appearance, _)) => NsKind::App,
        Some(Ns::CityGml(Module::Generics, _)) => NsKind::Gen,
        Some(Ns::CityGml(..)) => NsKind::OtherCityGml,
        _ => NsKind::Other,
    }
}

#[derive(Clone, Copy, PartialEq)]
enum TextCapture {
    None,
    Target(u32),
    Label(u32),
}
/// Skipped bytes from which their ids are found on every core before the pass
/// ([`Prescan`]); below it the pass scans them as they come (one core).
const PRESCAN_MIN_BYTES: u64 = 1 << 20;

/// One streaming pass over the source: the element index. `skip` are the spans of elements
/// whose content is dropped with them (sorted by start; nested spans allowed).
pub(super) fn scan(
    src: &DocSource,
    path: &Path,
    skip: &[Span],
    opts: &ReadOptions,
) -> Result<Doc, WriteError> {
    scan_with(src, path, skip, opts, PRESCAN_MIN_BYTES, CHUNK_BYTES)
}

/// [`scan`], with the ids of skipped content found ahead of the pass on the other cores
/// ([`Prescan`], `chunk_bytes` at a time) when the document is plain and the spans hold
/// `prescan_min` bytes or more.
fn scan_with(
    src: &DocSource,
    path: &Path,
    skip: &[Span],
    opts: &ReadOptions,
    prescan_min: u64,
    chunk_bytes: u64,
) -> Result<Doc, WriteError> {
    let size = match src {
        DocSource::File(p) => std::fs::metadata(p).map_or(0, |m| m.len()),
        DocSource::Memory(b) => b.len() as u64,
    };
    let skipped: u64 = skip.iter().map(|s| s.end.saturating_sub(s.start)).sum();
    let mut doc = match source::open_stream(src, path)? {
        Stream::Plain(reader) if cfg!(unix) && skipped >= prescan_min => {
            let file = reader
                .get_ref()
                .try_clone()
                .map_err(|e| io_error(path, e))?;
            let pass = (size, path, skip, opts);
            prescanned(reader, file, pass, chunk_bytes, 0)?
        }
        Stream::Plain(reader) => scan_stream(reader, size, path, skip, opts, None, 0)?.0,
        Stream::Memory(reader) => scan_stream(reader, size, path, skip, opts, None, 0)?.0,
        Stream::Gzip(reader) => scan_stream(reader, size, path, skip, opts, None, 0)?.0,
    };
    doc.seal();
    Ok(doc)
}

/// The index of one chunk of whole top-level members of a plain document held in `bytes`
/// (`chunks.ranges[k]`, see [`crate::io::citygml::read::member_chunks`]): the pass reads the
/// prolog, then the chunk, then (but for the last chunk) the root's end tag, the positions
/// those of the document. The index holds the root and the chunk's elements; the ids of
/// skipped content are found ahead by the other cores as in [`scan`] (`file`: the document,
/// opened). Its memory follows the chunk, not the document.
pub(super) fn scan_chunk(
    bytes: &[u8],
    file: &std::fs::File,
    path: &Path,
    chunks: &crate::io::citygml::read::MemberChunks,
    k: usize,
    skip: &[Span],
    opts: &ReadOptions,
) -> Result<Doc, WriteError> {
    let (from, to) = chunks.ranges[k];
    let last = k + 1 == chunks.ranges.len();
    let mut tail = Vec::new();
    if !last {
        tail.extend_from_slice(b"</");
        tail.extend_from_slice(&chunks.root_qname);
        tail.push(b'>');
    }
    let (Some(head), Some(body)) = (bytes.get(..chunks.head_end), bytes.get(from..to)) else {
        return Err(WriteError::SourceChanged(path.to_path_buf()));
    };
    let reader = Pieces {
        parts: [head, body, &tail],
        at: 0,
    };
    let gap = (from - chunks.head_end) as u64;
    let skipped: u64 = skip.iter().map(|s| s.end.saturating_sub(s.start)).sum();
    let mut doc = if cfg!(unix) && skipped >= PRESCAN_MIN_BYTES {
        let file = file.try_clone().map_err(|e| io_error(path, e))?;
        let pass = ((to - from) as u64, path, skip, opts);
        prescanned(reader, file, pass, CHUNK_BYTES, gap)?
    } else {
        scan_stream(reader, (to - from) as u64, path, skip, opts, None, gap)?.0
    };
    doc.seal();
    Ok(doc)
}

/// [`scan_stream`] of `reader` with `pass` (its size, path, skip spans and options), the
/// ids of skipped content found ahead by the other cores ([`Prescan`] of `file`, the
/// document, `chunk_bytes` at a time).
fn prescanned<R: BufRead + SkipAhead>(
    reader: R,
    file: std::fs::File,
    (size, path, skip, opts): (u64, &Path, &[Span], &ReadOptions),
    chunk_bytes: u64,
    gap: u64,
) -> Result<Doc, WriteError> {
    let max_content = (opts.max_event_bytes / 2) as u64;
    let pre = Prescan::new(file, skip, max_content, chunk_bytes);
    let workers = rayon::current_num_threads().saturating_sub(1);
    let (mut doc, taken) = pre.alongside(workers, |pre| {
        scan_stream(reader, size, path, skip, opts, Some(pre), gap)
    })?;
    pre.into_table(&taken, &mut doc.ids);
    Ok(doc)
}

/// An I/O error reading `path`.
fn io_error(path: &Path, source: std::io::Error) -> WriteError {
    WriteError::Io {
        file: path.to_path_buf(),
        source,
    }
}

/// Byte slices read one after the other ([`scan_chunk`]'s prolog, chunk and end tag).
struct Pieces<'b> {
    parts: [&'b [u8]; 3],
    at: usize,
}

impl Read for Pieces<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        crate::io::files::read_through_buf(self, buf)
    }
}

impl BufRead for Pieces<'_> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        while self.at < self.parts.len() && self.parts[self.at].is_empty() {
            self.at += 1;
        }
        Ok(self.parts.get(self.at).copied().unwrap_or_default())
    }

    fn consume(&mut self, amt: usize) {
        if let Some(p) = self.parts.get_mut(self.at) {
            *p = p.get(amt..).unwrap_or_default();
        }
    }
}

impl SkipAhead for Pieces<'_> {}

/// The index being built: one call per start tag, end tag and text of the pass.
struct Indexer<'p> {
    path: &'p Path,
    opts: &'p ReadOptions,
    skip: &'p [Span],
    next_skip: usize,
    doc: Doc,
    name_ids: HashMap<Box<[u8]>, Vec<(NsKind, u32)>>,
    stack: Vec<u32>,
    capture: TextCapture,
    text: Vec<u8>,
}

impl<'p> Indexer<'p> {
    fn new(path: &'p Path, skip: &'p [Span], opts: &'p ReadOptions) -> Self {
        Indexer {
            path,
            opts,
            skip,
            next_skip: 0,
            doc: Doc::default(),
            name_ids: HashMap::new(),
            stack: Vec::with_capacity(64),
            capture: TextCapture::None,
            text: Vec::new(),
        }
    }

    /// A start (or empty) tag at `pos`, its content at `content_start`. Returns the node and
    /// the span when its content is to be skipped.
    fn start<R>(
        &mut self,
        reader: &NsReader<R>,
        e: &BytesStart,
        empty: bool,
        pos: u64,
        content_start: u64,
    ) -> Result<Option<(u32, usize, Span)>, WriteError> {
        let doc = &mut self.doc;
        let (res, _) = reader.resolve_element(e.name());
        let uri = match res {
            ResolveResult::Bound(n) => Some(n.0),
            _ => None,
        };
        let kind = ns_kind(uri);
        let qname = e.name();
        let known = self
            .name_ids
            .get(qname.as_ref())
            .and_then(|v| v.iter().find(|(k, _)| *k == kind).map(|&(_, i)| i));
        let name = match known {
            Some(i) => i,
            None => {
                let i = doc.names.len() as u32;
                let local = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
                doc.names.push(Name {
                    qname: String::from_utf8_lossy(qname.as_ref()).into_owned(),
                    upper: local.starts_with(|c: char| c.is_ascii_uppercase()),
                    local,
                    ns: kind,
                });
                self.name_ids
                    .entry(qname.as_ref().into())
                    .or_default()
                    .push((kind, i));
                i
            }
        };
        let idx = doc.nodes.len() as u32;
        let Ok(tag_len) = u32::try_from(content_start.saturating_sub(pos)) else {
            return Err(WriteError::xml_at_byte(
                self.path,
                pos,
                "a start tag of 4 GiB or more".into(),
            ));
        };
        doc.nodes.push(Node {
            start: pos,
            end: if empty { content_start } else { 0 },
            tag_len,
            parent: self.stack.last().copied().unwrap_or(NONE),
            last_desc: idx,
            name,
        });
        scan_attrs(reader, e, idx, kind, self.stack.is_empty(), doc, self.path)?;
        if empty {
            return Ok(None);
        }
        let local = doc.names[name as usize].local.as_str();
        let capture_here = match (kind, local) {
            (NsKind::App, "target") => Some(TextCapture::Target(idx)),
            (NsKind::Gen, "name") => Some(TextCapture::Label(idx)),
            _ => None,
        };
        self.stack.push(idx);
        if self.stack.len() > self.opts.max_depth {
            return Err(WriteError::xml_at_byte(
                self.path,
                pos,
                format!("elements nested deeper than {}", self.opts.max_depth),
            ));
        }
        if let Some(c) = capture_here {
            if !(c == TextCapture::Target(idx) && doc.refs.last().is_some_and(|r| r.0 == idx)) {
                self.capture = c;
                self.text.clear();
            }
        }
        while self.skip.get(self.next_skip).is_some_and(|s| s.start < pos) {
            self.next_skip += 1;
        }
        Ok(self
            .skip
            .get(self.next_skip)
            .filter(|s| s.start == pos)
            .map(|s| (idx, self.next_skip, s.clone())))
    }

    /// The content of the element just opened was skipped: `n` bytes, up to its end tag;
    /// `end` is the end of its span (skip spans inside it are passed).
    fn skipped(&mut self, n: u64, end: u64) {
        self.doc.skipped.0 += 1;
        self.doc.skipped.1 += n;
        while self.skip.get(self.next_skip).is_some_and(|x| x.start < end) {
            self.next_skip += 1;
        }
    }

    /// An end tag ending at `end`.
    fn end(&mut self, end: u64) {
        let Some(idx) = self.stack.pop() else {
            return;
        };
        let doc = &mut self.doc;
        let last = doc.nodes.len() as u32 - 1;
        let n = &mut doc.nodes[idx as usize];
        n.end = end;
        n.last_desc = last;
        match self.capture {
            TextCapture::Target(t) if t == idx => {
                let s = String::from_utf8_lossy(&self.text).trim().to_string();
                if !s.is_empty() {
                    doc.refs.push((idx, RefKind::AppTarget, s.into()));
                }
                self.capture = TextCapture::None;
            }
            TextCapture::Label(t) if t == idx => {
                let s = String::from_utf8_lossy(&self.text).trim().to_string();
                doc.labels.insert(idx, s.into());
                self.capture = TextCapture::None;
            }
            _ => {}
        }
    }

    /// Text or CDATA (kept only where captured).
    fn text(&mut self, t: &[u8]) {
        if self.capture != TextCapture::None {
            self.text.extend_from_slice(t);
        }
    }

    /// The document ended at `at` (the index is sealed by the caller: [`Doc::seal`]).
    fn finish(self, at: u64) -> Result<Doc, WriteError> {
        if !self.stack.is_empty() || self.doc.nodes.is_empty() {
            return Err(WriteError::xml_at_byte(
                self.path,
                at,
                "unexpected end of document".into(),
            ));
        }
        Ok(self.doc)
    }

    fn token_limit(&self, pos: u64) -> WriteError {
        WriteError::xml_at_byte(
            self.path,
            pos,
            format!(
                "one XML token (tag, attribute value, text, comment or DOCTYPE) exceeds the limit of {} bytes",
                self.opts.max_event_bytes
            ),
        )
    }
}

/// The pass over `reader` (`size`: the file's size, a hint): skipped content found by
/// `pre` is jumped over ([`jump`]), any other is read and scanned as it comes
/// ([`skip_content`]). `gap`: bytes of the document left out of `reader` right after the
/// root's start tag ([`scan_chunk`]; counted in the positions).
fn scan_stream<R: BufRead + SkipAhead>(
    reader: R,
    size: u64,
    path: &Path,
    skip: &[Span],
    opts: &ReadOptions,
    pre: Option<&Prescan>,
    gap: u64,
) -> Result<(Doc, Taken), WriteError> {
    let mut taken: Taken = if pre.is_some() {
        vec![None; skip.len()]
    } else {
        Vec::new()
    };
    let mut reader = reader;
    let base = source::skip_bom(&mut reader, path)?;
    let mut reader =
        NsReader::from_reader(PushBack::new(Limited::new(reader, opts.max_event_bytes)));
    reader.config_mut().trim_text(false);
    reader.config_mut().check_end_names = true;
    let mut ix = Indexer::new(path, skip, opts);
    ix.doc.ids.expect_bytes(size);
    let mut buf = Vec::with_capacity(64 * 1024);
    let mut skipped = 0u64;
    let mut content = Vec::new();
    loop {
        let pos = reader.buffer_position() + base + skipped;
        reader.get_mut().inner.reset();
        let ev = match reader.read_event_into(&mut buf) {
            Ok(ev) => ev,
            Err(e) => {
                let at = reader.error_position() + base + skipped;
                if reader.get_mut().inner.exceeded() {
                    return Err(ix.token_limit(pos));
                }
                return Err(WriteError::xml_at_byte(path, at, e.to_string()));
            }
        };
        match ev {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let empty = matches!(ev, Event::Empty(_));
                let content_start = reader.buffer_position() + base + skipped;
                let root = ix.stack.is_empty() && ix.doc.nodes.is_empty();
                let hit = ix.start(&reader, e, empty, pos, content_start)?;
                if root {
                    skipped += gap;
                }
                if let Some((idx, si, s)) = hit {
                    let io = |source| WriteError::Io {
                        file: path.to_path_buf(),
                        source,
                    };
                    let len = s.end.saturating_sub(content_start);
                    let jumped = match pre {
                        Some(p) => jump(&mut reader, p, si, content_start).map_err(io)?,
                        None => None,
                    };
                    let n = match jumped {
                        Some((n, gml)) => {
                            taken[si] = Some((idx, gml));
                            n
                        }
                        None => {
                            skip_content(&mut reader, idx, len, opts, &mut content, &mut ix.doc)
                                .map_err(io)?
                        }
                    };
                    if n > 0 {
                        skipped += n;
                        ix.skipped(n, s.end);
                    }
                }
            }
            Event::End(_) => ix.end(reader.buffer_position() + base + skipped),
            Event::Text(t) => ix.text(&t),
            Event::CData(t) => ix.text(&t),
            Event::Eof => break,
            _ => {}
        }
        buf.clear();
    }
    let doc = ix.finish(reader.buffer_position() + base + skipped)?;
    Ok((doc, taken))
}

/// Jump over the content of the element just opened, skip span `span`, when the prescan
/// found it starting at `content_start` and its ids valid where GML prefixes are bound
/// here: the bytes up to its end tag are passed without being read. Returns the bytes
/// passed and the prefixes bound to GML (bits of [`Prescan::prefixes_of`]); `None` when
/// [`skip_content`] must read it.
fn jump<R: BufRead + SkipAhead>(
    reader: &mut NsReader<Source<R>>,
    pre: &Prescan,
    span: usize,
    content_start: u64,
) -> std::io::Result<Option<(u64, u64)>> {
    let Some(f) = pre.found(span).filter(|f| f.content_start == content_start) else {
        return Ok(None);
    };
    let mut cache = PrefixCache::default();
    let mut gml = 0u64;
    for (bit, prefix) in pre.prefixes_of(&f) {
        if cache.is_gml(reader, prefix) {
            gml |= 1 << bit;
        }
    }
    if f.bad & gml != 0 {
        return Ok(None);
    }
    let n = f.end_tag - content_start;
    reader.get_mut().skip_ahead(n)?;
    Ok(Some((n, gml)))
}

/// Skip the content of the element `idx` just opened, `len` bytes up to the end of its end
/// tag: read them, record the `gml:id`s of the content, and give the end tag back to the
/// reader. Returns the bytes skipped; 0 when the content is given back whole to be parsed
/// (see the module docs).
fn skip_content<R: BufRead>(
    reader: &mut NsReader<Source<R>>,
    idx: u32,
    len: u64,
    opts: &ReadOptions,
    content: &mut Vec<u8>,
    doc: &mut Doc,
) -> std::io::Result<u64> {
    if len == 0 || len > (opts.max_event_bytes / 2) as u64 {
        return Ok(0);
    }
    content.clear();
    let src = reader.get_mut();
    src.inner.reset();
    src.by_ref().take(len).read_to_end(content)?;
    // the element's own end tag, `</qname` then space or `>`
    let qname = doc.names[doc.nodes[idx as usize].name as usize]
        .qname
        .as_bytes();
    let end_tag = memchr::memrchr(b'<', content).filter(|&k| is_end_tag(&content[k..], qname));
    let table = &mut doc.ids;
    let skipped = match end_tag {
        Some(k) if content.len() as u64 == len => {
            let mut gml = PrefixCache::default();
            gml_ids(
                &content[..k],
                |p| gml.is_gml(reader, p),
                |id| table.push(id, idx),
            )
            .then_some(k)
        }
        _ => None,
    };
    let Some(k) = skipped else {
        reader.get_mut().push_back(content);
        return Ok(0);
    };
    reader.get_mut().push_back(&content[k..]);
    Ok(k as u64)
}

/// Which attribute prefixes are bound to a GML namespace where the skipped content starts.
#[derive(Default)]
struct PrefixCache {
    known: Vec<(Vec<u8>, bool)>,
}

impl PrefixCache {
    fn is_gml<R>(&mut self, reader: &NsReader<R>, prefix: &[u8]) -> bool {
        if let Some(&(_, g)) = self.known.iter().find(|(p, _)| p == prefix) {
            return g;
        }
        let mut q = prefix.to_vec();
        q.extend_from_slice(b":id");
        let g = matches!(
            reader.resolve_attribute(QName(&q)).0,
            ResolveResult::Bound(n) if ns::classify(n.0) == Ns::Gml
        );
        self.known.push((prefix.to_vec(), g));
        g
    }
}

fn scan_attrs<R>(
    reader: &NsReader<R>,
    e: &BytesStart,
    idx: u32,
    kind: NsKind,
    is_root: bool,
    doc: &mut Doc,
    path: &Path,
) -> Result<(), WriteError> {
    if memchr::memchr(b'=', e.attributes_raw()).is_none() {
        return Ok(());
    }
    let local = doc.names[doc.nodes[idx as usize].name as usize]
        .local
        .clone();
    for attr in e.attributes().with_checks(false) {
        let attr =
            attr.map_err(|err| WriteError::xml_at_byte(path, 0, format!("bad attribute: {err}")))?;
        let key = attr.key.as_ref();
        let value = || -> Result<String, WriteError> {
            attr.unescape_value()
                .map(|v| v.into_owned())
                .map_err(|err| {
                    WriteError::xml_at_byte(path, 0, format!("bad attribute value: {err}"))
                })
        };
        if key == b"xmlns" || key.starts_with(b"xmlns:") {
            let prefix = String::from_utf8_lossy(key.get(6..).unwrap_or_default()).into_owned();
            if is_root {
                doc.root_ns.push((prefix, value()?));
            } else {
                doc.redeclared.insert(prefix);
            }
            continue;
        }
        let lname = attr.key.local_name();
        match lname.as_ref() {
            b"id" | b"href" if attr.key.prefix().is_some() => {
                let (res, _) = reader.resolve_attribute(attr.key);
                let ResolveResult::Bound(n) = res else {
                    continue;
                };
                match (lname.as_ref(), ns::classify(n.0)) {
                    (b"id", Ns::Gml) => {
                        let v = attr.unescape_value().map_err(|err| {
                            WriteError::xml_at_byte(path, 0, format!("bad attribute value: {err}"))
                        })?;
                        doc.ids.push(v.as_bytes(), idx);
                    }
                    (b"href", Ns::Xlink) => {
                        doc.refs
                            .push((idx, RefKind::Href, value()?.trim().to_string().into()));
                    }
                    _ => {}
                }
            }
            b"uri" if attr.key.prefix().is_none() && kind == NsKind::App && local == "target" => {
                doc.refs
                    .push((idx, RefKind::AppTarget, value()?.trim().to_string().into()));
            }
            b"name" if attr.key.prefix().is_none() && kind == NsKind::Gen => {
                doc.labels.insert(idx, value()?.into());
            }
            _ => {}
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::test_support::gzip_copy;

    const DOC: &str = r##"<?xml version="1.0"?>
<CityModel xmlns="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml" xmlns:xlink="http://www.w3.org/1999/xlink">
<cityObjectMember><A gml:id="a"><b><c gml:id="c1"/><c gml:id="c2" xlink:href="#q"/></b></A></cityObjectMember>
<cityObjectMember><B gml:id="b"><!-- note --><c gml:id="c3"/></B></cityObjectMember>
<cityObjectMember><C gml:id="cc"><c xmlns:gml="urn:not-gml" gml:id="c4"/><c gml:id="c1"/></C></cityObjectMember>
</CityModel>
"##;

    fn span_of(doc: &str, tag: &str) -> Span {
        let start = doc.find(&format!("<{tag} ")).unwrap() as u64;
        let end = (doc.find(&format!("</{tag}>")).unwrap() + tag.len() + 3) as u64;
        start..end
    }

    #[test]
    fn skipping_keeps_ids_and_spans() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.gml");
        std::fs::write(&path, DOC).unwrap();
        let opts = ReadOptions::default();
        let full = scan(&DocSource::File(path.clone()), &path, &[], &opts).unwrap();
        let skip = [span_of(DOC, "A"), span_of(DOC, "B"), span_of(DOC, "C")];
        let fast = scan(&DocSource::File(path.clone()), &path, &skip, &opts).unwrap();
        // A skipped; B (comment) and C (namespace declaration) parsed
        assert_eq!(
            fast.skipped,
            (
                1,
                (DOC.find("</A>").unwrap() - DOC.find("<b>").unwrap()) as u64
            )
        );
        assert_eq!(fast.nodes.len(), full.nodes.len() - 3);
        let a = fast.node_at(skip[0].start).unwrap();
        assert_eq!(fast.nodes[a as usize].end, skip[0].end);
        assert_eq!(fast.nodes[a as usize].last_desc, a);
        for id in ["a", "c1", "c2", "b", "c3", "cc"] {
            let (f, s) = (full.id_node(id).unwrap(), fast.id_node(id).unwrap());
            assert_eq!(
                full.nodes[f as usize].start >= skip[0].end,
                fast.nodes[s as usize].start >= skip[0].end,
                "{id}"
            );
        }
        // c1 repeats: the first one (inside A) wins
        assert_eq!(fast.id_node("c1"), Some(a));
        assert!(!fast.has_id("c4") && !full.has_id("c4"));
        // the reference inside skipped content is not recorded
        assert_eq!(full.refs.len(), 1);
        assert!(fast.refs.is_empty());
        // every node after the skipped one has the same span
        let tail = |d: &Doc| {
            d.nodes
                .iter()
                .filter(|n| n.start >= skip[0].end)
                .map(|n| (n.start, n.end, n.content_start()))
                .collect::<Vec<_>>()
        };
        assert_eq!(tail(&full), tail(&fast));
        // a span that does not end with the element's own end tag is parsed, not skipped
        let wrong = skip[0].start..skip[0].end + "</cityObjectMember>".len() as u64;
        let w = scan(
            &DocSource::File(path.clone()),
            &path,
            std::slice::from_ref(&wrong),
            &opts,
        )
        .unwrap();
        assert_eq!(w.skipped, (0, 0));
        assert_eq!(w.nodes.len(), full.nodes.len());
    }

    #[test]
    fn plain_and_gzip_give_the_same_index() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b, c) = (span_of(DOC, "A"), span_of(DOC, "B"), span_of(DOC, "C"));
        for (name, text, shift) in [
            ("plain", DOC.to_string(), 0),
            ("bom", format!("\u{feff}{DOC}"), 3),
        ] {
            let path = dir.path().join(format!("{name}.gml"));
            std::fs::write(&path, &text).unwrap();
            let gz = gzip_copy(&path, dir.path());
            for skip in [vec![], vec![a.clone(), b.clone(), c.clone()]] {
                let skip: Vec<Span> = skip
                    .iter()
                    .map(|s| s.start + shift..s.end + shift)
                    .collect();
                let opts = ReadOptions::default();
                let plain = scan(&DocSource::File(path.clone()), &path, &skip, &opts).unwrap();
                assert_eq!(
                    plain,
                    scan(&DocSource::File(gz.clone()), &gz, &skip, &opts).unwrap(),
                    "{name} {skip:?}"
                );
                assert_eq!(plain.skipped.0, usize::from(!skip.is_empty()), "{name}");
            }
        }
    }

    /// A document whose members hold each case the prescan meets, `copies` times over
    /// (ids numbered per copy), and the spans the writer would skip in it.
    fn prescan_doc(copies: usize) -> (String, Vec<Span>) {
        let member = |k: usize| {
            format!(
                r##"<cityObjectMember><A gml:id="a{k}"><b><c gml:id="c{k}"/><c gml:id="x{k}" xlink:href="#q"/></b></A></cityObjectMember>
<cityObjectMember><B gml:id="b{k}"><!-- note --><c gml:id="b{k}_1"/></B></cityObjectMember>
<cityObjectMember><C gml:id="cc{k}"><c xmlns:gml="urn:not-gml" gml:id="n{k}"/><c gml:id="c{k}"/></C></cityObjectMember>
<cityObjectMember><D gml:id="d{k}" note="1 > 0"><c gml:id="d{k}_1" v='a"b'/>text = 1</D></cityObjectMember>
<cityObjectMember><E gml:id="e{k}"><c xlink:id="&amp;bogus;" gml:id="e{k}&amp;1"/></E></cityObjectMember>
<cityObjectMember><F gml:id="f{k}"><G gml:id="g{k}"><c gml:id="g{k}_1"/></G><c gml:id="f{k}_1"/></F></cityObjectMember>
<cityObjectMember><H gml:id="h{k}"/></cityObjectMember>
<cityObjectMember><I xmlns:g="http://www.opengis.net/gml" gml:id="i{k}"><c g:id="i{k}_1"/><c xlink:id="i{k}_2"/></I></cityObjectMember>
<cityObjectMember><J gml:id="j{k}"><c gml:id="j{k}_1"/></J></cityObjectMember>
<cityObjectMember><K gml:id="k{k}"><c gml:id="c{k}"/><c gml:id="k{k}_1">{pad}</c></K></cityObjectMember>
"##,
                pad = "1 2 3 ".repeat(k % 7 * 40)
            )
        };
        let mut doc = String::from(
            r#"<?xml version="1.0"?>
<CityModel xmlns="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml" xmlns:xlink="http://www.w3.org/1999/xlink">
"#,
        );
        let mut skip = Vec::new();
        for k in 0..copies {
            let at = doc.len() as u64;
            let m = member(k);
            for tag in ["A", "B", "C", "D", "E", "F", "G", "H", "I", "K"] {
                let start = m.find(&format!("<{tag} ")).unwrap() as u64;
                let end = match m.find(&format!("</{tag}>")) {
                    Some(e) => (e + tag.len() + 3) as u64,
                    None => start + m[start as usize..].find("/>").unwrap() as u64 + 2,
                };
                skip.push(at + start..at + end);
            }
            // J's span runs past its end tag: not its own, the pass parses it
            let j = m.find("<J ").unwrap() as u64;
            skip.push(
                at + j
                    ..at + m.find("</cityObjectMember>\n<cityObjectMember><K").unwrap() as u64 + 19,
            );
            doc.push_str(&m);
        }
        doc.push_str("</CityModel>\n");
        skip.sort_by_key(|s| (s.start, std::cmp::Reverse(s.end)));
        (doc, skip)
    }

    /// Everything of two indexes but the order of their id arenas; ids compared by lookup.
    fn assert_same_index(a: &Doc, b: &Doc, ids: &[String], what: &str) {
        assert_eq!(a.nodes, b.nodes, "{what}");
        assert_eq!(a.names, b.names, "{what}");
        assert_eq!(a.refs, b.refs, "{what}");
        assert_eq!(a.labels, b.labels, "{what}");
        assert_eq!(a.root_ns, b.root_ns, "{what}");
        assert_eq!(a.redeclared, b.redeclared, "{what}");
        assert_eq!(a.skipped, b.skipped, "{what}");
        for id in ids {
            assert_eq!(a.id_node(id), b.id_node(id), "{what}: {id}");
        }
    }

    #[test]
    fn prescan_gives_the_index_of_the_pass() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.gml");
        let (text, skip) = prescan_doc(60);
        std::fs::write(&path, &text).unwrap();
        let mut ids: Vec<String> = text
            .split(":id=\"")
            .skip(1)
            .filter_map(|s| s.split('"').next())
            .map(|s| s.replace("&amp;", "&"))
            .collect();
        ids.extend(["nope".to_string(), "a60".to_string()]);
        let opts = ReadOptions::default();
        let serial = scan_with(
            &DocSource::File(path.clone()),
            &path,
            &skip,
            &opts,
            u64::MAX,
            CHUNK_BYTES,
        )
        .unwrap();
        // the cases: A, D, E, F (with G inside), I, K jumped over; B, C, J parsed; H empty
        assert_eq!(serial.skipped.0, 60 * 6, "spans skipped");
        assert!(serial.has_id("i0_1") && !serial.has_id("i0_2") && !serial.has_id("n0"));
        assert!(serial.has_id("e0&1") && serial.has_id("g0_1"));
        assert_eq!(
            serial.id_node("c0"),
            serial.node_at(skip[0].start),
            "first wins"
        );
        // what the prescan finds, span by span (A..K of each copy; G nested in F)
        let pre = Prescan::new(std::fs::File::open(&path).unwrap(), &skip, 1 << 30, 4096);
        let found: String = (0..skip.len())
            .map(|i| if pre.found(i).is_some() { '+' } else { '-' })
            .collect();
        assert_eq!(found, "+--+++--+-+".repeat(60), "A B C D E F G H I J K");
        let full = scan_with(
            &DocSource::File(path.clone()),
            &path,
            &[],
            &opts,
            u64::MAX,
            CHUNK_BYTES,
        )
        .unwrap();
        // one chunk, chunks of a few spans, a chunk per span: with workers or without
        for chunk in [CHUNK_BYTES, 4096, 1] {
            for workers in [0, 1, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(workers + 1)
                    .build()
                    .unwrap();
                let pre = pool
                    .install(|| {
                        scan_with(
                            &DocSource::File(path.clone()),
                            &path,
                            &skip,
                            &opts,
                            0,
                            chunk,
                        )
                    })
                    .unwrap();
                assert_same_index(
                    &serial,
                    &pre,
                    &ids,
                    &format!("chunk {chunk}, {workers} workers"),
                );
            }
        }
        // and the full parse agrees on where every id is, skipped or not
        for id in &ids {
            let (f, s) = (full.id_node(id), serial.id_node(id));
            assert_eq!(f.is_some(), s.is_some(), "{id}");
        }
        // gzip streams: no prescan, the same index
        let gz = gzip_copy(&path, dir.path());
        let z = scan_with(&DocSource::File(gz.clone()), &gz, &skip, &opts, 0, 1).unwrap();
        assert_same_index(&serial, &z, &ids, "gzip");
    }

    #[test]
    fn node_at_finds_every_node_and_nothing_else() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.gml");
        std::fs::write(&path, DOC).unwrap();
        let doc = scan(
            &DocSource::File(path.clone()),
            &path,
            &[],
            &ReadOptions::default(),
        )
        .unwrap();
        for (i, n) in doc.nodes.iter().enumerate() {
            assert_eq!(doc.node_at(n.start), Some(i as u32));
            assert_eq!(doc.node_at(n.start + 1), None);
        }
        assert_eq!(doc.node_at(0), None);
        assert_eq!(doc.node_at(u64::MAX), None);
        assert_eq!(Doc::default().node_at(0), None);
    }

    #[test]
    fn token_limit_and_depth_apply() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.gml");
        std::fs::write(&path, DOC).unwrap();
        let big = dir.path().join("big.gml");
        let text = "1 ".repeat(1 << 20);
        std::fs::write(&big, DOC.replace("<!-- note -->", &text)).unwrap();
        let tight = ReadOptions {
            max_event_bytes: 512 << 10,
            ..ReadOptions::default()
        };
        let gz = |p: &Path| gzip_copy(p, dir.path());
        let shallow = ReadOptions {
            max_depth: 2,
            ..ReadOptions::default()
        };
        // from the memory map and streamed (gzip) alike
        for (big, path) in [(big.clone(), path.clone()), (gz(&big), gz(&path))] {
            assert!(scan(
                &DocSource::File(big.clone()),
                &big,
                &[],
                &ReadOptions::default()
            )
            .is_ok());
            let e = scan(&DocSource::File(big.clone()), &big, &[], &tight)
                .unwrap_err()
                .to_string();
            assert!(e.contains("exceeds the limit of 524288 bytes"), "{e}");
            // content larger than half the limit is not skipped but parsed, and fails alike
            let span = span_of(&DOC.replace("<!-- note -->", &text), "B");
            let e = scan(&DocSource::File(big.clone()), &big, &[span], &tight)
                .unwrap_err()
                .to_string();
            assert!(e.contains("exceeds the limit of 524288 bytes"), "{e}");
            let e = scan(&DocSource::File(path.clone()), &path, &[], &shallow)
                .unwrap_err()
                .to_string();
            assert!(e.contains("nested deeper than 2"), "{e}");
        }
    }
}
