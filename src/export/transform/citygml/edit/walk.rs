//! The document as pieces: the bytes between children of the root (prolog, root start tag,
//! whitespace, comments, the end), and each child of the root whole. Only the current child
//! is held in memory.

use crate::io::citygml::error::{Location, ReadError};
use crate::io::citygml::source;
use quick_xml::events::Event;
use quick_xml::name::ResolveResult;
use quick_xml::NsReader;
use std::io::{self, BufRead, Read};
use std::path::Path;

/// One piece of the document, in order.
pub(crate) enum Piece<'a> {
    /// Bytes to copy as they are (the root's start tag is among them).
    Verbatim(&'a [u8]),
    /// The root's start tag (also given as [`Piece::Verbatim`]): its namespace declarations.
    Root(&'a [u8]),
    /// One child of the root: its local name, its bytes, the line it starts on.
    Child {
        local: &'a [u8],
        bytes: &'a [u8],
        line: u64,
    },
}

/// A reader that keeps what was consumed since the last [`Tee::drain`].
struct Tee<R> {
    inner: R,
    log: Vec<u8>,
}

impl<R: BufRead> Read for Tee<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        crate::io::files::read_through_buf(self, buf)
    }
}

impl<R: BufRead> BufRead for Tee<R> {
    fn fill_buf(&mut self) -> io::Result<&[u8]> {
        self.inner.fill_buf()
    }

    fn consume(&mut self, amt: usize) {
        if let Ok(b) = self.inner.fill_buf() {
            let n = amt.min(b.len());
            self.log.extend_from_slice(&b[..n]);
        }
        self.inner.consume(amt);
    }
}

/// Walk the document at `path`, handing each piece to `f`. Returns the document's
/// (decompressed) size.
///
/// # Errors
/// The source cannot be read, is not well-formed, has no `CityModel` root; or `f`'s error.
pub(crate) fn walk<E: From<ReadError>>(
    path: &Path,
    f: &mut dyn FnMut(Piece<'_>) -> Result<(), E>,
) -> Result<u64, E> {
    let (stream, _) = source::open(path)?;
    let mut reader = quick_xml::Reader::from_reader(Tee {
        inner: stream,
        log: Vec::new(),
    });
    reader.config_mut().check_end_names = true;
    let mut buf = Vec::new();
    let mut depth = 0usize;
    // drained bytes and lines before `log[0]`; what of `log` was handed over
    let (mut base, mut base_lines, mut flushed) = (0u64, 0u64, 0usize);
    let mut child: Option<(usize, Vec<u8>)> = None;
    let mut seen_root = false;
    loop {
        let before = reader.get_ref().log.len();
        buf.clear();
        let ev = match reader.read_event_into(&mut buf) {
            Ok(ev) => ev,
            Err(e) => {
                let log = &reader.get_ref().log;
                let at = log.len().min(before);
                return Err(xml_error(path, base_lines, &log[..at], e.to_string()).into());
            }
        };
        let now = reader.get_ref().log.len();
        // the reader may consume a tag's `<` with the text before it: a tag starts at its
        // `<`, and a start tag holds no other one
        let before = match ev {
            Event::Start(_) | Event::Empty(_) => {
                memchr::memrchr(b'<', &reader.get_ref().log[..now]).unwrap_or(before)
            }
            _ => before,
        };
        match ev {
            Event::Start(e) if depth == 0 => {
                root_check(path, base_lines, &reader.get_ref().log[..before], &e)?;
                seen_root = true;
                let log = &reader.get_ref().log;
                f(Piece::Verbatim(&log[flushed..now]))?;
                f(Piece::Root(&log[before..now]))?;
                flushed = now;
                depth = 1;
            }
            Event::Start(e) => {
                if depth == 1 {
                    child = Some((before, e.local_name().into_inner().to_vec()));
                }
                depth += 1;
            }
            Event::Empty(e) if depth == 1 => {
                let log = &reader.get_ref().log;
                f(Piece::Verbatim(&log[flushed..before]))?;
                f(Piece::Child {
                    local: e.local_name().into_inner(),
                    bytes: &log[before..now],
                    line: base_lines + lines(&log[..before]) + 1,
                })?;
                flushed = now;
            }
            Event::Empty(e) if depth == 0 => {
                root_check(path, base_lines, &reader.get_ref().log[..before], &e)?;
                seen_root = true;
            }
            Event::End(_) => {
                depth = depth.saturating_sub(1);
                if depth == 1 {
                    if let Some((start, local)) = child.take() {
                        let log = &reader.get_ref().log;
                        f(Piece::Verbatim(&log[flushed..start]))?;
                        f(Piece::Child {
                            local: &local,
                            bytes: &log[start..now],
                            line: base_lines + lines(&log[..start]) + 1,
                        })?;
                        flushed = now;
                    }
                }
            }
            Event::Eof if depth > 0 => {
                let log = &reader.get_ref().log;
                return Err(xml_error(
                    path,
                    base_lines,
                    log,
                    format!("unexpected end of the document: {depth} element(s) not closed"),
                )
                .into());
            }
            Event::Eof => break,
            _ => {}
        }
        // between children of the root, hand over what is done and forget it
        if depth <= 1 && flushed > 0 {
            let tee = reader.get_mut();
            base += flushed as u64;
            base_lines += lines(&tee.log[..flushed]);
            tee.log.drain(..flushed);
            flushed = 0;
        }
    }
    if !seen_root {
        return Err(ReadError::Empty(path.to_path_buf()).into());
    }
    let log = &reader.get_ref().log;
    f(Piece::Verbatim(&log[flushed..]))?;
    Ok(base + log.len() as u64)
}

/// One child of the root (a member) as a document of its own, for the parsers that build
/// its element tree (`edit`'s rules, `upgrade`): the root's start tag (its namespace
/// declarations in scope), the member, a closing `</r>`. Offsets are counted from the start
/// of the member.
pub(crate) struct MemberDoc {
    doc: Vec<u8>,
    base: usize,
}

impl MemberDoc {
    /// The member `member` (the bytes of one element) under the root start tag `root`.
    pub(crate) fn new(root: &[u8], member: &[u8]) -> MemberDoc {
        let mut doc = Vec::with_capacity(root.len() + member.len() + 8);
        doc.extend_from_slice(root);
        doc.extend_from_slice(member);
        doc.extend_from_slice(b"</r>");
        MemberDoc {
            doc,
            base: root.len(),
        }
    }

    /// A namespace-resolving reader over the document (end names not checked: `</r>` closes
    /// whatever the root is called).
    pub(crate) fn reader(&self) -> NsReader<&[u8]> {
        let mut reader = NsReader::from_reader(&self.doc[..]);
        reader.config_mut().check_end_names = false;
        reader
    }

    /// Where `reader` is, as an offset in the member (0 within the root's start tag).
    pub(crate) fn offset(&self, reader: &NsReader<&[u8]>) -> usize {
        (reader.buffer_position() as usize).saturating_sub(self.base)
    }

    /// The next event of `reader`, with the offset it starts at ([`MemberDoc::offset`]) and
    /// the namespace URI of its name (empty when it has none); an XML error as its offset and
    /// message.
    pub(crate) fn next<'d>(
        &self,
        reader: &mut NsReader<&'d [u8]>,
    ) -> Result<(usize, Vec<u8>, Event<'d>), (usize, String)> {
        let at = self.offset(reader);
        let (ns, ev) = reader
            .read_resolved_event()
            .map_err(|e| (at, e.to_string()))?;
        let uri = match ns {
            ResolveResult::Bound(n) => n.into_inner().to_vec(),
            _ => Vec::new(),
        };
        Ok((at, uri, ev))
    }
}

fn lines(b: &[u8]) -> u64 {
    memchr::memchr_iter(b'\n', b).count() as u64
}

/// The location of the end of `before` (the bytes read since the last drain).
pub(crate) fn location(path: &Path, base_lines: u64, before: &[u8]) -> Location {
    let line_start = memchr::memrchr(b'\n', before).map_or(0, |i| i + 1);
    Location {
        file: path.to_path_buf(),
        line: base_lines + lines(before) + 1,
        column: (before.len() - line_start) as u64 + 1,
        gml_id: None,
    }
}

fn xml_error(path: &Path, base_lines: u64, before: &[u8], message: String) -> ReadError {
    ReadError::Xml {
        loc: location(path, base_lines, before),
        message,
    }
}

fn root_check(
    path: &Path,
    base_lines: u64,
    before: &[u8],
    e: &quick_xml::events::BytesStart<'_>,
) -> Result<(), ReadError> {
    if e.local_name().into_inner() == b"CityModel" {
        return Ok(());
    }
    Err(ReadError::NotCityGml {
        loc: location(path, base_lines, before),
        message: format!(
            "the root is <{}>, not a CityModel",
            String::from_utf8_lossy(e.name().into_inner())
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::MemberDoc;
    use quick_xml::events::Event;

    #[test]
    fn a_member_reads_in_its_root_namespaces_with_offsets_in_the_member() {
        let root = br#"<core:CityModel xmlns:core="urn:c" xmlns:b="urn:b">"#;
        let member = b"<b:Building><b:x>1</b:x></b:Building>";
        let doc = MemberDoc::new(root, member);
        let mut reader = doc.reader();
        let mut starts = Vec::new();
        loop {
            let (at, uri, ev) = doc.next(&mut reader).unwrap();
            match ev {
                Event::Start(e) => starts.push((at, uri, e.local_name().as_ref().to_vec())),
                Event::End(_) => assert!(doc.offset(&reader) <= member.len() + 4),
                Event::Eof => break,
                _ => {}
            }
        }
        let want: Vec<(usize, Vec<u8>, Vec<u8>)> = vec![
            (0, b"urn:c".to_vec(), b"CityModel".to_vec()),
            (0, b"urn:b".to_vec(), b"Building".to_vec()),
            (12, b"urn:b".to_vec(), b"x".to_vec()),
        ];
        assert_eq!(starts, want);
        let bad = MemberDoc::new(root, b"<!x>");
        let mut reader = bad.reader();
        let err = loop {
            match bad.next(&mut reader) {
                Ok((_, _, Event::Eof)) => panic!("no error"),
                Ok(_) => {}
                Err(e) => break e,
            }
        };
        assert_eq!(err.0, 0);
        assert!(!err.1.is_empty());
    }
}
