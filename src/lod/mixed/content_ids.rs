//! The `gml:id`s of content the writer's index pass does not parse ([`super::index`]): a
//! tokenizer exact for well-formed XML that gives up where it cannot judge ([`gml_ids`]),
//! and [`Prescan`], which runs it over every skipped span of a plain document on all cores
//! before the pass, so that the pass jumps over those spans instead of reading them.
//!
//! The prescan reads the skipped spans in chunks of a few MiB (positioned reads, one buffer
//! per thread: no page faults of a memory map, no copy through the pass's buffer), finds
//! each span's start tag, its own end tag and the prefixed `id` attributes in between, and
//! keeps the ids as their hashes (the table matches them by hash: [`IdTable::push_hashed`]). What depends on where the pass stands is
//! decided there, when it reaches the span: that the content starts where the pass found
//! it, and which prefixes are bound to GML in that scope. A span the prescan cannot judge
//! (a comment, CDATA section, processing instruction or namespace declaration inside, no
//! own end tag, content over the size limit, a read error) is read by the pass as before.

use super::id_table::IdTable;
use crate::model::Span;
use std::borrow::Cow;
use std::fs::File;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Mutex, OnceLock};

/// What the prescan found in one skipped span.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Found {
    /// Byte offset of the content (after the start tag).
    pub(super) content_start: u64,
    /// Byte offset of the element's own end tag.
    pub(super) end_tag: u64,
    /// Prefixes of the content's `id` attributes: bits of the chunk's prefix table
    /// ([`Prescan::prefixes_of`]).
    prefixes: u64,
    /// Of those, the prefixes with a value that is not valid UTF-8 or badly escaped.
    pub(super) bad: u64,
    chunk: u32,
    ids: (u32, u32),
}

/// One id of a chunk: the hash of its unescaped value ([`IdTable::hash`]) and its prefix (a
/// bit of the chunk's prefix table).
#[derive(Debug, Clone, Copy)]
struct ChunkId {
    hash: u64,
    prefix: u8,
}

/// The ids of the spans read at once, and what was found per span (in the chunk's span
/// order).
#[derive(Debug, Default)]
struct Chunk {
    prefixes: Vec<Vec<u8>>,
    ids: Vec<ChunkId>,
    found: Vec<Option<Found>>,
}

/// The ids of every outermost skipped span of a plain document, found by worker threads
/// ahead of the index pass, chunk by chunk; see the module docs.
#[derive(Debug)]
pub(super) struct Prescan<'s> {
    file: File,
    skip: &'s [Span],
    max_content: u64,
    /// The outermost spans the prescan reads (indices into `skip`), in order…
    outer: Vec<u32>,
    /// …cut into chunks: chunk `c` holds `outer[starts[c]..starts[c + 1]]`.
    starts: Vec<u32>,
    /// Per skip span: its chunk (`u32::MAX`: none).
    chunk_of: Vec<u32>,
    /// Each chunk once scanned, by a worker or by the pass, whichever comes first.
    chunks: Vec<OnceLock<Chunk>>,
    next: AtomicUsize,
    stop: AtomicBool,
    /// The pass's buffer for the chunks it scans itself.
    pass_buf: Mutex<Vec<u8>>,
}

/// Per skip span the pass jumped over: its node and the prefixes bound to GML there.
pub(super) type Taken = Vec<Option<(u32, u64)>>;

/// Spans read at once: up to this many bytes (the default)…
pub(super) const CHUNK_BYTES: u64 = 4 << 20;
/// …and no more than this between two of them (kept content is read by the pass).
const CHUNK_GAP: u64 = 64 << 10;

impl<'s> Prescan<'s> {
    /// The chunks of the outermost spans of `skip` (sorted by start, nested spans allowed,
    /// as the pass gets them) in `file` (a handle of its own: its reads are positioned),
    /// read `chunk_bytes` at a time ([`CHUNK_BYTES`]). Content longer than `max_content`
    /// bytes is left to the pass.
    pub(super) fn new(file: File, skip: &'s [Span], max_content: u64, chunk_bytes: u64) -> Self {
        let mut outer = Vec::new();
        let mut starts = Vec::new();
        let mut chunk_of = vec![u32::MAX; skip.len()];
        let mut outer_end = 0u64;
        let (mut first, mut last) = (0u64, 0u64);
        for (i, s) in skip.iter().enumerate() {
            if s.start < outer_end {
                continue; // inside a span before it: jumped over with it
            }
            outer_end = s.end;
            if s.end <= s.start || s.end - s.start > max_content.saturating_mul(2) {
                continue;
            }
            let joins = !outer.is_empty()
                && s.start.saturating_sub(last) <= CHUNK_GAP
                && s.end - first <= chunk_bytes;
            if !joins {
                first = s.start;
                starts.push(outer.len() as u32);
            }
            last = s.end;
            chunk_of[i] = (starts.len() - 1) as u32;
            outer.push(i as u32);
        }
        starts.push(outer.len() as u32);
        let chunks = (1..starts.len()).map(|_| OnceLock::new()).collect();
        Prescan {
            file,
            skip,
            max_content,
            outer,
            starts,
            chunk_of,
            chunks,
            next: AtomicUsize::new(0),
            stop: AtomicBool::new(false),
            pass_buf: Mutex::new(Vec::new()),
        }
    }

    /// Run `pass` while `workers` threads scan the chunks in document order ahead of it.
    pub(super) fn alongside<T>(&self, workers: usize, pass: impl FnOnce(&Self) -> T) -> T {
        std::thread::scope(|scope| {
            for _ in 0..workers {
                let worker = std::thread::Builder::new().spawn_scoped(scope, || {
                    let mut buf = Vec::new();
                    while !self.stop.load(Ordering::Relaxed) {
                        let c = self.next.fetch_add(1, Ordering::Relaxed);
                        let Some(cell) = self.chunks.get(c) else {
                            break;
                        };
                        cell.get_or_init(|| self.scan_chunk(c, &mut buf));
                    }
                });
                if worker.is_err() {
                    break; // the pass scans what no worker did
                }
            }
            let out = pass(self);
            self.stop.store(true, Ordering::Relaxed);
            out
        })
    }

    /// The chunk `c`, scanned here unless a worker did or does. While a worker scans it, the
    /// pass scans the next chunk no one has taken rather than wait (both cores stay busy when
    /// the pass catches up with the workers).
    fn chunk(&self, c: usize) -> Option<&Chunk> {
        let cell = self.chunks.get(c)?;
        let mut buf = self.pass_buf.lock().unwrap_or_else(|e| e.into_inner());
        while cell.get().is_none() {
            let k = self.next.fetch_add(1, Ordering::Relaxed);
            let Some(ahead) = self.chunks.get(k) else {
                break;
            };
            ahead.get_or_init(|| self.scan_chunk(k, &mut buf));
        }
        Some(cell.get_or_init(|| self.scan_chunk(c, &mut buf)))
    }

    /// What was found in skip span `span`, if anything.
    pub(super) fn found(&self, span: usize) -> Option<Found> {
        let c = *self.chunk_of.get(span)? as usize;
        let chunk = self.chunk(c)?;
        let spans = &self.outer[self.starts[c] as usize..self.starts[c + 1] as usize];
        let k = spans.binary_search(&(span as u32)).ok()?;
        chunk.found.get(k).copied().flatten()
    }

    /// The prefixes of the ids of `f`, each with its bit.
    pub(super) fn prefixes_of(&self, f: &Found) -> impl Iterator<Item = (u32, &[u8])> {
        let bits = f.prefixes;
        self.chunks[f.chunk as usize]
            .get()
            .into_iter()
            .flat_map(|c| c.prefixes.iter().enumerate())
            .filter(move |&(b, _)| bits >> b & 1 == 1)
            .map(|(b, p)| (b as u32, p.as_slice()))
    }

    /// Put the GML ids of the spans the pass jumped over (`taken`, per skip span) into
    /// `table`, each with its span's node; each chunk is freed once handed over.
    pub(super) fn into_table(self, taken: &Taken, table: &mut IdTable) {
        for (c, cell) in self.chunks.into_iter().enumerate() {
            let Some(chunk) = cell.into_inner() else {
                continue;
            };
            let spans = &self.outer[self.starts[c] as usize..self.starts[c + 1] as usize];
            for (&span, f) in spans.iter().zip(&chunk.found) {
                let (Some(f), Some(Some((node, gml)))) = (f, taken.get(span as usize)) else {
                    continue;
                };
                for id in &chunk.ids[f.ids.0 as usize..f.ids.1 as usize] {
                    if gml >> id.prefix & 1 == 1 {
                        table.push_hashed(id.hash, *node);
                    }
                }
            }
        }
    }

    /// Read chunk `c` at once into `buf` and scan each of its spans (nothing found on a
    /// read error: the pass reads them itself and reports it).
    fn scan_chunk(&self, c: usize, buf: &mut Vec<u8>) -> Chunk {
        let spans = &self.outer[self.starts[c] as usize..self.starts[c + 1] as usize];
        let mut chunk = Chunk::default();
        let (Some(&a), Some(&b)) = (spans.first(), spans.last()) else {
            return chunk;
        };
        let (first, last) = (self.skip[a as usize].start, self.skip[b as usize].end);
        let Ok(len) = usize::try_from(last - first) else {
            return chunk;
        };
        buf.resize(len, 0);
        if read_exact_at(&self.file, buf, first).is_err() {
            return chunk;
        }
        chunk.found = spans
            .iter()
            .map(|&i| {
                let s = &self.skip[i as usize];
                let bytes = &buf[(s.start - first) as usize..(s.end - first) as usize];
                scan_span(bytes, s.start, self.max_content, &mut chunk, c as u32)
            })
            .collect();
        chunk
    }
}

#[cfg(unix)]
fn read_exact_at(file: &File, buf: &mut [u8], at: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::read_exact_at(file, buf, at)
}

#[cfg(not(unix))]
fn read_exact_at(_: &File, _: &mut [u8], _: u64) -> std::io::Result<()> {
    Err(std::io::ErrorKind::Unsupported.into())
}

/// The element `bytes` (start tag to end tag) found at byte `at`: where its content starts
/// and ends, and the ids of its content, added to `chunk`. `None` where the pass must read
/// it (see the module docs); `chunk` is then as before.
fn scan_span(bytes: &[u8], at: u64, max_content: u64, chunk: &mut Chunk, c: u32) -> Option<Found> {
    if bytes.first() != Some(&b'<') {
        return None;
    }
    let qend = 1 + bytes[1..]
        .iter()
        .position(|&b| is_ws(b) || b == b'>' || b == b'/')?;
    let qname = &bytes[1..qend];
    if qname.is_empty() {
        return None;
    }
    // the start tag ends at the first `>` outside a quoted attribute value
    let mut quote = 0u8;
    let mut gt = None;
    for (k, &b) in bytes.iter().enumerate().skip(qend) {
        if quote != 0 {
            if b == quote {
                quote = 0;
            }
        } else if b == b'"' || b == b'\'' {
            quote = b;
        } else if b == b'>' {
            gt = Some(k);
            break;
        }
    }
    let gt = gt?;
    if bytes[gt - 1] == b'/' {
        return None; // an empty element has no content
    }
    let content = &bytes[gt + 1..];
    if content.is_empty() || content.len() as u64 > max_content {
        return None;
    }
    let k = memchr::memrchr(b'<', content).filter(|&k| is_end_tag(&content[k..], qname))?;
    let ids0 = chunk.ids.len();
    let (mut prefixes, mut bad, mut ok) = (0u64, 0u64, true);
    let scanned = prefixed_ids(&content[..k], |p, v| {
        let bit = match chunk.prefixes.iter().position(|q| q == p) {
            Some(b) => b,
            None if chunk.prefixes.len() < 64 => {
                chunk.prefixes.push(p.to_vec());
                chunk.prefixes.len() - 1
            }
            None => {
                ok = false;
                return;
            }
        };
        prefixes |= 1 << bit;
        match unescape_value(v) {
            Some(u) => chunk.ids.push(ChunkId {
                hash: IdTable::hash(&u),
                prefix: bit as u8,
            }),
            None => bad |= 1 << bit,
        }
    });
    if scanned.is_none() || !ok {
        chunk.ids.truncate(ids0);
        return None;
    }
    let content_start = at + gt as u64 + 1;
    Some(Found {
        content_start,
        end_tag: content_start + k as u64,
        prefixes,
        bad,
        chunk: c,
        ids: (ids0 as u32, chunk.ids.len() as u32),
    })
}

/// Does `tag` start with the end tag of `qname` (`</qname` then space or `>`)?
pub(super) fn is_end_tag(tag: &[u8], qname: &[u8]) -> bool {
    tag.get(1) == Some(&b'/')
        && tag.get(2..2 + qname.len()) == Some(qname)
        && tag
            .get(2 + qname.len())
            .is_some_and(|&b| b == b'>' || is_ws(b))
}

/// Hand the unescaped attribute value `v` to `f`; false when it is not valid UTF-8 or
/// badly escaped.
fn unescaped(v: &[u8], f: impl FnOnce(&[u8])) -> bool {
    unescape_value(v).map(|u| f(&u)).is_some()
}

/// The unescaped attribute value `v` (borrowed when it holds no reference); `None` when it
/// is not valid UTF-8 or badly escaped.
pub(super) fn unescape_value(v: &[u8]) -> Option<Cow<'_, [u8]>> {
    let s = std::str::from_utf8(v).ok()?;
    if memchr::memchr(b'&', v).is_none() {
        return Some(Cow::Borrowed(v));
    }
    let u = quick_xml::escape::unescape(s).ok()?;
    Some(Cow::Owned(u.into_owned().into_bytes()))
}

pub(super) fn is_ws(b: u8) -> bool {
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
/// pushes none of the ids).
pub(super) fn gml_ids(c: &[u8], is_gml: impl FnMut(&[u8]) -> bool, id: impl FnMut(&[u8])) -> bool {
    let mut ids = Vec::new();
    if prefixed_ids(c, |p, v| ids.push((p, v))).is_none() {
        return false;
    }
    let mut id = id;
    let mut is_gml = is_gml;
    // check every value first, so that nothing is handed out when one is bad
    let ok = ids.iter().all(|&(p, v)| !is_gml(p) || unescaped(v, |_| ()));
    if ok {
        for &(p, v) in &ids {
            if is_gml(p) {
                unescaped(v, &mut id);
            }
        }
    }
    ok
}

/// Hand the prefix and raw value of every prefixed `id` attribute in the element content
/// `c` to `id`, in document order; `None` when `c` holds what [`gml_ids`] cannot judge.
pub(super) fn prefixed_ids<'a>(c: &'a [u8], mut id: impl FnMut(&'a [u8], &'a [u8])) -> Option<()> {
    // One pass: each `!` and `?` (after `<` they start a comment, CDATA section, processing
    // instruction or DOCTYPE, since `<` cannot stand in text or attribute values; they
    // cannot stand in a tag before its first `=`), and each `=`: only tags holding an `=`
    // can hold an id or a namespace declaration; the tag around it is tokenized whole.
    let mut i = 0;
    while let Some(eq) = memchr::memchr3(b'=', b'!', b'?', &c[i..]) {
        let eq = i + eq;
        if c[eq] != b'=' {
            if eq > 0 && c[eq - 1] == b'<' {
                return None;
            }
            i = eq + 1;
            continue;
        }
        match memchr::memrchr(b'<', &c[i..eq]).map(|lt| i + lt) {
            // in text, or in text after an end tag
            None => i = eq + 1,
            Some(lt) if c.get(lt + 1) == Some(&b'/') => i = eq + 1,
            Some(lt) => i = start_tag_ids(c, lt, &mut id)?.max(eq + 1),
        }
    }
    Some(())
}

/// The prefixed ids of the start tag at `c[lt]` (see [`prefixed_ids`]); returns the index
/// after its `>`, `None` at a namespace declaration.
fn start_tag_ids<'a>(
    c: &'a [u8],
    lt: usize,
    id: &mut impl FnMut(&'a [u8], &'a [u8]),
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
        if name.starts_with(b"xmlns") && matches!(name.get(5), None | Some(b':')) {
            return None;
        }
        let mut v = j + k + 1;
        while c.get(v).is_some_and(|&b| is_ws(b)) {
            v += 1;
        }
        let quote = *c.get(v).filter(|&&q| q == b'"' || q == b'\'')?;
        let e = v + 1 + memchr::memchr(quote, &c[v + 1..])?;
        if let Some(colon) = memchr::memchr(b':', name) {
            if &name[colon + 1..] == b"id" {
                id(&name[..colon], &c[v + 1..e]);
            }
        }
        j = e + 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
            (r#"<a x="1"/><b xmlns:q = 'urn:other'>t</b>"#, None),
            (r#"<a gml:id="x"/>text<?pi?>"#, None),
            // text may say what it likes; an attribute named like a declaration is not one
            (
                r#"<a xmlnsx="1" gml:id="x">xmlns:gml="u" ! ? a!b</a>"#,
                some(&["x"]),
            ),
            (r#"<a gml:id="x"#, None),
            (r#"<a gml:id=x/>"#, None),
        ];
        for (c, want) in table {
            assert_eq!(&ids_of(c), want, "{c}");
        }
    }
}
