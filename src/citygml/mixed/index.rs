//! The element index of the mixed-LoD writer: one streaming pass over a source document that
//! records, per element, its span, parent, name, `gml:id` and reference (`xlink:href`,
//! appearance target), which the rules ([`super::plan`]) decide on.
//!
//! **Cost follows what is kept.** The pass is given the spans of the elements the writer
//! drops whole (level-0 assets that hold no kept asset, see [`super::plan::skip_spans`]). Such
//! an element is indexed as one node without children: its content is not parsed but read
//! as bytes and scanned for the one thing the rules need from dropped content, the
//! `gml:id`s it holds (a kept `xlink:href` or appearance target pointing at one of them is
//! pruned, and a fresh id must not meet one). References inside dropped content are never
//! looked at (they are dead before the first pruning round), so they need not be found.
//! The scan looks at each `=` and tokenizes the start tag around it (`<` cannot stand in text
//! or attribute values), exact for well-formed XML; content holding a comment, CDATA
//! section, processing instruction or namespace declaration is parsed as usual instead (the
//! namespace scope of its ids could change), as is content larger than half the token limit
//! or not ending with the element's own end tag. Ids go to an arena table ([`IdTable`]): no
//! allocation per id; an id that repeats maps to its first element, as in a full parse.
//!
//! The pass shares the reader's set-up: namespace classification ([`crate::citygml::ns`]),
//! the byte-order-mark handling and the per-token size limit and nesting depth of
//! [`ReadOptions`].

use crate::citygml::error::{Location, ReadError, WriteError};
use crate::citygml::ns::{self, Module, Ns};
use crate::citygml::read::ReadOptions;
use crate::citygml::source::{self, Limited};
use crate::model::Span;
use foldhash::{HashMap, HashMapExt, HashSet};
use quick_xml::events::{BytesStart, Event};
use quick_xml::name::{QName, ResolveResult};
use quick_xml::NsReader;
use std::io::{BufRead, Read};
use std::path::Path;

/// No node (no parent, no descendant).
pub(super) const NONE: u32 = u32::MAX;

/// What the rules need to know of an element's namespace.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum NsKind {
    Gml,
    Core,
    App,
    Gen,
    OtherCityGml,
    Other,
}

/// An element name, stored once per distinct qualified name and namespace.
#[derive(Debug)]
pub(super) struct Name {
    pub(super) qname: String,
    pub(super) local: String,
    pub(super) ns: NsKind,
    /// Local name starts with an upper-case letter (an object, not a property).
    pub(super) upper: bool,
}

/// One element (32 bytes: a city file has millions).
#[derive(Debug, Clone, Copy)]
pub(super) struct Node {
    pub(super) start: u64,
    pub(super) end: u64,
    /// Length of the start tag: the content starts at `start + tag_len`.
    pub(super) tag_len: u32,
    pub(super) parent: u32,
    /// Last descendant (the node itself when it has none).
    pub(super) last_desc: u32,
    pub(super) name: u32,
}

/// What a reference is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum RefKind {
    Href,
    AppTarget,
}

/// The element index of one document.
#[derive(Debug, Default)]
pub(super) struct Doc {
    /// Elements in document order (start-tag order).
    pub(super) nodes: Vec<Node>,
    pub(super) names: Vec<Name>,
    /// Every `gml:id` with its element; an id inside skipped content maps to the skipped
    /// element. See [`Doc::id_node`].
    pub(super) ids: IdTable,
    /// (node, kind, reference) in document order.
    pub(super) refs: Vec<(u32, RefKind, Box<str>)>,
    /// `name` attribute (2.0 generic attributes) or `gen:name` text (3.0), per node.
    pub(super) labels: HashMap<u32, Box<str>>,
    /// Namespace declarations of the root: prefix ("" = default) -> URI.
    pub(super) root_ns: Vec<(String, String)>,
    /// Prefixes ("" = default) declared again below the root.
    pub(super) redeclared: HashSet<String>,
    /// Elements whose content was skipped, and the bytes of content skipped.
    pub(super) skipped: (usize, u64),
}

impl Node {
    /// Byte offset of the element's content (after its start tag).
    pub(super) fn content_start(&self) -> u64 {
        self.start + u64::from(self.tag_len)
    }
}

impl Doc {
    /// The element holding `gml:id` `id`: the first in document order when the id repeats
    /// (node indices follow document order, and skipped content has no nodes of its own).
    pub(super) fn id_node(&self, id: &str) -> Option<u32> {
        self.ids.get(id)
    }

    /// Does the document hold `gml:id` `id`?
    pub(super) fn has_id(&self, id: &str) -> bool {
        self.ids.get(id).is_some()
    }

    /// The element starting at byte `start`.
    pub(super) fn node_at(&self, start: u64) -> Option<u32> {
        self.nodes
            .binary_search_by(|n| n.start.cmp(&start))
            .ok()
            .map(|i| i as u32)
    }

    pub(super) fn name(&self, n: u32) -> &Name {
        &self.names[self.nodes[n as usize].name as usize]
    }

    pub(super) fn parent(&self, n: u32) -> Option<u32> {
        let p = self.nodes[n as usize].parent;
        (p != NONE).then_some(p)
    }

    pub(super) fn children(&self, n: u32) -> Children<'_> {
        Children {
            doc: self,
            next: n + 1,
            last: self.nodes[n as usize].last_desc,
        }
    }

    /// Prefix (with colon, or empty for the default namespace) bound to `uri` on the root and
    /// never redeclared.
    pub(super) fn prefix_for(&self, uri: &str) -> Option<String> {
        self.root_ns
            .iter()
            .find(|(p, u)| u == uri && !self.redeclared.contains(p))
            .map(|(p, _)| {
                if p.is_empty() {
                    String::new()
                } else {
                    format!("{p}:")
                }
            })
    }
}

/// `gml:id`s: their bytes in one arena, found by hash (a sorted table, so that hundreds of
/// thousands of ids cost no allocation each). An id that repeats maps to its smallest node,
/// the first in document order.
#[derive(Debug, Default)]
pub(super) struct IdTable {
    bytes: Vec<u8>,
    /// (hash, start in `bytes`, length, node); sorted by hash once the scan is done.
    entries: Vec<(u64, usize, u32, u32)>,
    /// After [`IdTable::finish`]: the first entry of each range of hashes with the same top
    /// `bits` bits (one more at the end), so that a lookup reads about one entry.
    dir: Vec<u32>,
    bits: u32,
}

impl IdTable {
    fn hash(id: &[u8]) -> u64 {
        use std::hash::BuildHasher;
        foldhash::fast::FixedState::with_seed(0x05c7_110d).hash_one(id)
    }

    fn push(&mut self, id: &[u8], node: u32) {
        let start = self.bytes.len();
        self.bytes.extend_from_slice(id);
        self.entries
            .push((Self::hash(id), start, id.len() as u32, node));
    }

    /// Keep only the first `len` entries (ids of content that was given back to be parsed).
    fn truncate(&mut self, len: usize) {
        if let Some(&(_, start, _, _)) = self.entries.get(len) {
            self.bytes.truncate(start);
        }
        self.entries.truncate(len);
    }

    fn finish(&mut self) {
        self.entries.sort_unstable();
        self.bits = (self.entries.len().max(1).ilog2() + 1).min(24);
        let buckets = 1usize << self.bits;
        self.dir = Vec::with_capacity(buckets + 1);
        let mut e = 0;
        for b in 0..buckets {
            while self.entries.get(e).is_some_and(|x| self.bucket(x.0) < b) {
                e += 1;
            }
            self.dir.push(e as u32);
        }
        self.dir.push(self.entries.len() as u32);
    }

    fn bucket(&self, h: u64) -> usize {
        (h >> (64 - self.bits)) as usize
    }

    /// Smallest node holding `id`.
    pub(super) fn get(&self, id: &str) -> Option<u32> {
        let h = Self::hash(id.as_bytes());
        let entries = if self.dir.is_empty() {
            &self.entries[..] // before finish: all of them
        } else {
            let b = self.bucket(h);
            let (lo, hi) = (self.dir[b] as usize, self.dir[b + 1] as usize);
            &self.entries[lo..hi]
        };
        entries
            .iter()
            .filter(|e| e.0 == h)
            .filter(|e| self.bytes.get(e.1..e.1 + e.2 as usize) == Some(id.as_bytes()))
            .map(|e| e.3)
            .min()
    }

    /// Number of ids.
    pub(super) fn len(&self) -> usize {
        self.entries.len()
    }
}

/// Child elements of a node.
pub(super) struct Children<'a> {
    doc: &'a Doc,
    next: u32,
    last: u32,
}

impl Iterator for Children<'_> {
    type Item = u32;
    fn next(&mut self) -> Option<u32> {
        if self.next == NONE || self.next > self.last || self.last == NONE {
            return None;
        }
        let c = self.next;
        self.next = self.doc.nodes[c as usize].last_desc.saturating_add(1);
        Some(c)
    }
}

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

fn xml_err(path: &Path, at: u64, message: String) -> WriteError {
    WriteError::Read(ReadError::Xml {
        loc: Location {
            file: path.to_path_buf(),
            line: 0,
            column: 0,
            gml_id: None,
        },
        message: format!("at byte {at}: {message}"),
    })
}

#[derive(Clone, Copy, PartialEq)]
enum TextCapture {
    None,
    Target(u32),
    Label(u32),
}

/// A [`BufRead`] that can be given bytes back: the index reads a skipped element's content
/// and returns its end tag (or all of it, when the content cannot be skipped) to the XML
/// reader, so that namespace scopes and end-tag checks stay the reader's.
struct PushBack<R> {
    front: Vec<u8>,
    at: usize,
    inner: R,
}

impl<R: BufRead> PushBack<R> {
    fn new(inner: R) -> Self {
        PushBack {
            front: Vec::new(),
            at: 0,
            inner,
        }
    }

    /// Put `bytes` before whatever is still to be read.
    fn push_back(&mut self, bytes: &[u8]) {
        if self.at == self.front.len() {
            self.front.clear();
            self.front.extend_from_slice(bytes);
        } else {
            let rest = self.front.split_off(self.at);
            self.front.clear();
            self.front.extend_from_slice(bytes);
            self.front.extend_from_slice(&rest);
        }
        self.at = 0;
    }
}

impl<R: BufRead> Read for PushBack<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let avail = self.fill_buf()?;
        let n = avail.len().min(buf.len());
        buf[..n].copy_from_slice(&avail[..n]);
        self.consume(n);
        Ok(n)
    }
}

impl<R: BufRead> BufRead for PushBack<R> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        if self.at < self.front.len() {
            Ok(&self.front[self.at..])
        } else {
            self.inner.fill_buf()
        }
    }

    fn consume(&mut self, amt: usize) {
        if self.at < self.front.len() {
            self.at = (self.at + amt).min(self.front.len());
            if self.at == self.front.len() {
                self.front.clear();
                self.at = 0;
            }
        } else {
            self.inner.consume(amt);
        }
    }
}

type Source = PushBack<Limited<Box<dyn BufRead + Send>>>;

/// One streaming pass over the source: the element index. `skip` are the spans of elements
/// whose content is dropped with them (sorted by start; nested spans allowed).
pub(super) fn scan(path: &Path, skip: &[Span], opts: &ReadOptions) -> Result<Doc, WriteError> {
    let (mut reader, _) = source::open(path)?;
    let base = source::skip_bom(&mut reader, path)?;
    let mut reader =
        NsReader::from_reader(PushBack::new(Limited::new(reader, opts.max_event_bytes)));
    reader.config_mut().trim_text(false);
    reader.config_mut().check_end_names = true;
    let mut doc = Doc::default();
    let mut name_ids: HashMap<Box<[u8]>, Vec<(NsKind, u32)>> = HashMap::new();
    let mut stack: Vec<u32> = Vec::with_capacity(64);
    let mut buf = Vec::with_capacity(64 * 1024);
    let mut capture = TextCapture::None;
    let mut text: Vec<u8> = Vec::new();
    let mut skipped = 0u64;
    let mut next_skip = 0usize;
    let mut content = Vec::new();
    loop {
        let pos = reader.buffer_position() + base + skipped;
        reader.get_mut().inner.reset();
        let ev = match reader.read_event_into(&mut buf) {
            Ok(ev) => ev,
            Err(e) => {
                let at = reader.error_position() + base + skipped;
                if reader.get_mut().inner.exceeded() {
                    return Err(xml_err(
                        path,
                        pos,
                        format!(
                            "one XML token (tag, attribute value, text, comment or DOCTYPE) exceeds the limit of {} bytes",
                            opts.max_event_bytes
                        ),
                    ));
                }
                return Err(xml_err(path, at, e.to_string()));
            }
        };
        match ev {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let empty = matches!(ev, Event::Empty(_));
                let (res, _) = reader.resolve_element(e.name());
                let uri = match res {
                    ResolveResult::Bound(n) => Some(n.0),
                    _ => None,
                };
                let kind = ns_kind(uri);
                let qname = e.name();
                let known = name_ids
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
                        name_ids
                            .entry(qname.as_ref().into())
                            .or_default()
                            .push((kind, i));
                        i
                    }
                };
                let idx = doc.nodes.len() as u32;
                let content_start = reader.buffer_position() + base + skipped;
                let Ok(tag_len) = u32::try_from(content_start.saturating_sub(pos)) else {
                    return Err(xml_err(path, pos, "a start tag of 4 GiB or more".into()));
                };
                doc.nodes.push(Node {
                    start: pos,
                    end: if empty { content_start } else { 0 },
                    tag_len,
                    parent: stack.last().copied().unwrap_or(NONE),
                    last_desc: idx,
                    name,
                });
                scan_attrs(&reader, e, idx, kind, stack.is_empty(), &mut doc, path)?;
                let local = doc.names[name as usize].local.as_str();
                let capture_here = match (kind, local) {
                    (NsKind::App, "target") => Some(TextCapture::Target(idx)),
                    (NsKind::Gen, "name") => Some(TextCapture::Label(idx)),
                    _ => None,
                };
                if !empty {
                    stack.push(idx);
                    if stack.len() > opts.max_depth {
                        return Err(xml_err(
                            path,
                            pos,
                            format!("elements nested deeper than {}", opts.max_depth),
                        ));
                    }
                    if let Some(c) = capture_here {
                        if !(c == TextCapture::Target(idx)
                            && doc.refs.last().is_some_and(|r| r.0 == idx))
                        {
                            capture = c;
                            text.clear();
                        }
                    }
                    while skip.get(next_skip).is_some_and(|s| s.start < pos) {
                        next_skip += 1;
                    }
                    if let Some(s) = skip.get(next_skip).filter(|s| s.start == pos) {
                        let len = s.end.saturating_sub(content_start);
                        let n = skip_content(&mut reader, idx, len, opts, &mut content, &mut doc)
                            .map_err(|source| WriteError::Io {
                            file: path.to_path_buf(),
                            source,
                        })?;
                        if n > 0 {
                            skipped += n;
                            doc.skipped.0 += 1;
                            doc.skipped.1 += n;
                            while skip.get(next_skip).is_some_and(|x| x.start < s.end) {
                                next_skip += 1;
                            }
                        }
                    }
                }
            }
            Event::End(_) => {
                let end = reader.buffer_position() + base + skipped;
                if let Some(idx) = stack.pop() {
                    let last = doc.nodes.len() as u32 - 1;
                    let n = &mut doc.nodes[idx as usize];
                    n.end = end;
                    n.last_desc = last;
                    match capture {
                        TextCapture::Target(t) if t == idx => {
                            let s = String::from_utf8_lossy(&text).trim().to_string();
                            if !s.is_empty() {
                                doc.refs.push((idx, RefKind::AppTarget, s.into()));
                            }
                            capture = TextCapture::None;
                        }
                        TextCapture::Label(t) if t == idx => {
                            let s = String::from_utf8_lossy(&text).trim().to_string();
                            doc.labels.insert(idx, s.into());
                            capture = TextCapture::None;
                        }
                        _ => {}
                    }
                }
            }
            Event::Text(t) if capture != TextCapture::None => text.extend_from_slice(&t),
            Event::CData(t) if capture != TextCapture::None => text.extend_from_slice(&t),
            Event::Eof => break,
            _ => {}
        }
        buf.clear();
    }
    if !stack.is_empty() || doc.nodes.is_empty() {
        return Err(xml_err(
            path,
            reader.buffer_position() + base + skipped,
            "unexpected end of document".into(),
        ));
    }
    doc.ids.finish();
    Ok(doc)
}

/// Skip the content of the element `idx` just opened, `len` bytes up to the end of its end
/// tag: read them, record the `gml:id`s of the content, and give the end tag back to the
/// reader. Returns the bytes skipped; 0 when the content is given back whole to be parsed
/// (see the module docs).
fn skip_content(
    reader: &mut NsReader<Source>,
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
    let end_tag = memchr::memrchr(b'<', content).filter(|&k| {
        let tag = &content[k..];
        tag.get(1) == Some(&b'/')
            && tag.get(2..2 + qname.len()) == Some(qname)
            && tag
                .get(2 + qname.len())
                .is_some_and(|&b| b == b'>' || is_ws(b))
    });
    let before = doc.ids.len();
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
        doc.ids.truncate(before);
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
    fn is_gml(&mut self, reader: &NsReader<Source>, prefix: &[u8]) -> bool {
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

fn is_ws(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\r' | b'\n')
}

fn trim_ws(mut s: &[u8]) -> &[u8] {
    while let [first, rest @ ..] = s {
        if !is_ws(*first) {
            break;
        }
        s = rest;
    }
    while let [rest @ .., last] = s {
        if !is_ws(*last) {
            break;
        }
        s = rest;
    }
    s
}

/// Hand the values of the prefixed `id` attributes whose prefix `is_gml` in the element
/// content `c` (start and end tags, text) to `id`, in document order, unescaped. False when
/// `c` holds a comment, CDATA section, processing instruction, DOCTYPE or namespace
/// declaration, or is not well-formed enough to tell (the caller then parses it instead and
/// forgets the ids handed out).
fn gml_ids(c: &[u8], is_gml: impl FnMut(&[u8]) -> bool, id: impl FnMut(&[u8])) -> bool {
    gml_ids_in(c, is_gml, id).is_some()
}

fn gml_ids_in(
    c: &[u8],
    mut is_gml: impl FnMut(&[u8]) -> bool,
    mut id: impl FnMut(&[u8]),
) -> Option<()> {
    // A comment, CDATA section, processing instruction or DOCTYPE (`<` cannot stand in text
    // or attribute values, so `<!` and `<?` start one of them), or a namespace declaration.
    let mut marks = memchr::memchr2_iter(b'!', b'?', c);
    if marks.any(|p| p > 0 && c[p - 1] == b'<') || memchr::memmem::find(c, b"xmlns").is_some() {
        return None;
    }
    // Only tags holding an `=` can hold an id: find each `=`, then the tag around it.
    let mut i = 0;
    while let Some(eq) = memchr::memchr(b'=', &c[i..]) {
        let eq = i + eq;
        match memchr::memrchr(b'<', &c[i..eq]).map(|lt| i + lt) {
            // in text, or in text after an end tag
            None => i = eq + 1,
            Some(lt) if c.get(lt + 1) == Some(&b'/') => i = eq + 1,
            Some(lt) => i = start_tag_ids(c, lt, &mut is_gml, &mut id)?.max(eq + 1),
        }
    }
    Some(())
}

/// The ids of the start tag at `c[lt]` (see [`gml_ids`]); returns the index after its `>`.
fn start_tag_ids(
    c: &[u8],
    lt: usize,
    is_gml: &mut impl FnMut(&[u8]) -> bool,
    id: &mut impl FnMut(&[u8]),
) -> Option<usize> {
    let mut j = lt + 1;
    while j < c.len() && !is_ws(c[j]) && c[j] != b'>' && c[j] != b'/' {
        j += 1;
    }
    loop {
        let rest = c.get(j..)?;
        let k = memchr::memchr2(b'=', b'>', rest)?;
        if rest[k] == b'>' {
            return Some(j + k + 1);
        }
        let name = trim_ws(&rest[..k]);
        let mut v = j + k + 1;
        while c.get(v).is_some_and(|&b| is_ws(b)) {
            v += 1;
        }
        let quote = *c.get(v).filter(|&&q| q == b'"' || q == b'\'')?;
        let e = v + 1 + memchr::memchr(quote, &c[v + 1..])?;
        let value = &c[v + 1..e];
        if let Some(colon) = memchr::memchr(b':', name) {
            if &name[colon + 1..] == b"id" && is_gml(&name[..colon]) {
                let v = std::str::from_utf8(value).ok()?;
                if memchr::memchr(b'&', value).is_some() {
                    id(quick_xml::escape::unescape(v).ok()?.as_bytes());
                } else {
                    id(value);
                }
            }
        }
        j = e + 1;
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
        let attr = attr.map_err(|err| xml_err(path, 0, format!("bad attribute: {err}")))?;
        let key = attr.key.as_ref();
        let value = || -> Result<String, WriteError> {
            attr.unescape_value()
                .map(|v| v.into_owned())
                .map_err(|err| xml_err(path, 0, format!("bad attribute value: {err}")))
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
                            xml_err(path, 0, format!("bad attribute value: {err}"))
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

    #[test]
    fn a_node_is_32_bytes() {
        assert_eq!(std::mem::size_of::<Node>(), 32);
    }

    fn ids_of(c: &str) -> Option<Vec<String>> {
        let mut v = Vec::new();
        let ok = gml_ids(
            c.as_bytes(),
            |p| p == b"gml" || p == b"g",
            |id| v.push(String::from_utf8_lossy(id).into_owned()),
        );
        ok.then_some(v)
    }

    #[test]
    fn id_scan_table() {
        let some = |v: &[&str]| Some(v.iter().map(|s| s.to_string()).collect::<Vec<_>>());
        let table: &[(&str, Option<Vec<String>>)] = &[
            ("", some(&[])),
            ("text only 1 2 3", some(&[])),
            (r#"<a gml:id="x"/><b g:id='y'>t</b>"#, some(&["x", "y"])),
            // spaces around '=', other attributes first, '>' and '=' inside values
            (
                "<a\n  srsDimension=\"3\" v=\"a>b=c\"  gml:id = \"x\" ></a>",
                some(&["x"]),
            ),
            // unprefixed, other prefix, text that looks like an attribute
            (
                r#"<a id="u" xlink:id="v">gml:id="w"</a><e gml:id="z"/>"#,
                some(&["z"]),
            ),
            // '=' in text before, between and after tags; '?' and '!' in values
            (
                r#"a=b <x gml:id="1">c=d</x><y/>e=f<z k="v" gml:id="2"/>=<w/>"#,
                some(&["1", "2"]),
            ),
            (r#"<a v="x?y!z" gml:id="q"/>"#, some(&["q"])),
            // escaped value
            (r#"<a gml:id="a&amp;b"/>"#, some(&["a&b"])),
            // what the scan cannot judge: the caller parses instead
            (r#"<!-- <a gml:id="x"/> -->"#, None),
            (r#"<![CDATA[<a gml:id="x"/>]]>"#, None),
            (r#"<?pi x?>"#, None),
            (r#"<a xmlns:gml="urn:other" gml:id="x"/>"#, None),
            (r#"<a xmlns="urn:other"/>"#, None),
            (r#"<a gml:id="x"#, None),
            (r#"<a gml:id=x/>"#, None),
        ];
        for (c, want) in table {
            assert_eq!(&ids_of(c), want, "{c}");
        }
    }

    #[test]
    fn id_table_finds_the_first_node_and_forgets() {
        let mut t = IdTable::default();
        t.push(b"a", 7);
        t.push(b"b", 3);
        t.push(b"a", 5);
        let n = t.len();
        t.push(b"c", 9);
        t.truncate(n);
        assert_eq!(t.get("a"), Some(5), "before finish");
        t.finish();
        assert_eq!(t.get("a"), Some(5));
        assert_eq!(t.get("b"), Some(3));
        assert_eq!(t.get("c"), None);
        assert_eq!(t.get(""), None);
        let mut big = IdTable::default();
        for i in 0..5000u32 {
            big.push(format!("id{i}").as_bytes(), i);
        }
        big.finish();
        assert!((0..5000u32).all(|i| big.get(&format!("id{i}")) == Some(i)));
        assert_eq!(big.get("id5000"), None);
    }

    #[test]
    fn push_back_comes_first() {
        let mut r = PushBack::new(&b"world"[..]);
        let mut two = [0u8; 2];
        r.read_exact(&mut two).unwrap();
        r.push_back(b"hello ");
        r.push_back(b">");
        let mut s = String::new();
        r.read_to_string(&mut s).unwrap();
        assert_eq!(s, ">hello rld");
    }

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
        let full = scan(&path, &[], &opts).unwrap();
        let skip = [span_of(DOC, "A"), span_of(DOC, "B"), span_of(DOC, "C")];
        let fast = scan(&path, &skip, &opts).unwrap();
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
        let w = scan(&path, std::slice::from_ref(&wrong), &opts).unwrap();
        assert_eq!(w.skipped, (0, 0));
        assert_eq!(w.nodes.len(), full.nodes.len());
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
        assert!(scan(&big, &[], &ReadOptions::default()).is_ok());
        let e = scan(&big, &[], &tight).unwrap_err().to_string();
        assert!(e.contains("exceeds the limit of 524288 bytes"), "{e}");
        let shallow = ReadOptions {
            max_depth: 2,
            ..ReadOptions::default()
        };
        let e = scan(&path, &[], &shallow).unwrap_err().to_string();
        assert!(e.contains("nested deeper than 2"), "{e}");
    }
}
