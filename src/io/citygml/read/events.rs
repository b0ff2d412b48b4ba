//! The event loop: quick-xml events of one document dispatched to the [`Parser`].

use super::state::Parser;
use super::ReadOptions;
use crate::io::citygml::error::ReadError;
use crate::io::citygml::source;
use crate::model::CityModel;
use quick_xml::events::Event;
use quick_xml::NsReader;
use std::io::BufRead;
use std::path::Path;

/// Read from any buffered reader of the (decompressed) document.
pub fn read_from<R: BufRead>(
    reader: R,
    path: &Path,
    gzip: bool,
    opts: &ReadOptions,
) -> Result<CityModel, ReadError> {
    read_sized(reader, path, gzip, opts, 0)
}

/// [`read_from`] with the expected document size in bytes (0: unknown), used to size the
/// table of gml:ids once instead of growing it step by step.
pub(super) fn read_sized<R: BufRead>(
    mut reader: R,
    path: &Path,
    gzip: bool,
    opts: &ReadOptions,
    size_hint: u64,
) -> Result<CityModel, ReadError> {
    let mut p = Parser::new(path, opts.clone(), &[]);
    p.expect_bytes(size_hint);
    let base = source::skip_bom(&mut reader, path)?;
    let mut reader = configured(source::Limited::new(reader, opts.max_event_bytes));
    let mut buf = Vec::with_capacity(64 * 1024);
    let mut saw_root = false;
    loop {
        let pos = reader.buffer_position() + base;
        p.event_pos = pos;
        reader.get_mut().reset();
        let ev = match reader.read_event_into(&mut buf) {
            Ok(ev) => ev,
            Err(e) => {
                if reader.get_mut().exceeded() {
                    return Err(p.token_limit(pos));
                }
                let at = reader.error_position() + base;
                return Err(p.xml_error(at, e.to_string()));
            }
        };
        if !dispatch::<_, true>(&mut p, &reader, ev, pos, base, &mut saw_root)? {
            break;
        }
        if buf.len() > p.opts.max_event_bytes {
            return Err(p.token_limit(pos));
        }
        buf.clear();
    }
    let len = reader.buffer_position() + base;
    finish(p, len, saw_root, gzip)
}

/// Bytes parsed between two calls of `release` in [`read_slice`].
pub(super) const RELEASE_STEP: u64 = 32 << 20;

/// Read a whole (uncompressed) document held in memory: events borrow from `doc` (no copy
/// per event) and lines are counted only where a location needs one. `release(n)` is called
/// every [`RELEASE_STEP`] bytes with an offset `n` the parser has passed (lines counted up
/// to there): the memory of `doc[..n]` may be let go.
pub(super) fn read_slice(
    doc: &[u8],
    path: &Path,
    gzip: bool,
    opts: &ReadOptions,
    release: &dyn Fn(usize),
) -> Result<CityModel, ReadError> {
    let mut p = Parser::new(path, opts.clone(), doc);
    p.expect_bytes(doc.len() as u64);
    let (body, base) = match doc.strip_prefix(&BOM) {
        Some(body) => (body, 3),
        None => (doc, 0),
    };
    let mut reader = configured(body);
    let mut saw_root = false;
    let step = RELEASE_STEP;
    parse_events(
        &mut p,
        &mut reader,
        base,
        &mut saw_root,
        (release, step),
        false,
    )?;
    let len = reader.buffer_position() + base;
    p.event_pos = len;
    finish(p, len, saw_root, gzip)
}

/// The UTF-8 byte-order mark.
pub(super) const BOM: [u8; 3] = [0xEF, 0xBB, 0xBF];

/// The event loop over a slice of the document in memory: events until the slice's end, or
/// with `until_root` until the root element has started (`true` then). `base` turns the
/// reader's positions into file offsets; `release.0` is called every `release.1` bytes (see
/// [`read_slice`]).
pub(super) fn parse_events(
    p: &mut Parser<'_>,
    reader: &mut NsReader<&[u8]>,
    base: u64,
    saw_root: &mut bool,
    (release, step): (&dyn Fn(usize), u64),
    until_root: bool,
) -> Result<bool, ReadError> {
    let mut next_release = reader.buffer_position() + base + step;
    loop {
        let pos = reader.buffer_position() + base;
        p.event_pos = pos;
        if pos >= next_release {
            // count the lines so far, so that the bytes behind are never needed again
            p.line_mark();
            release(usize::try_from(pos - (1 << 20)).unwrap_or(0));
            next_release = pos + step;
        }
        let ev = match reader.read_event() {
            Ok(ev) => ev,
            Err(e) => {
                let at = reader.error_position() + base;
                if at.saturating_sub(pos) > p.opts.max_event_bytes as u64 {
                    return Err(p.token_limit(pos));
                }
                return Err(p.xml_error(at, e.to_string()));
            }
        };
        // the token is not copied, but the limit holds alike for both readers (checked
        // before the event is handled, as the streamed reader fails while reading it)
        if reader.buffer_position() + base - pos > p.opts.max_event_bytes as u64 {
            return Err(p.token_limit(pos));
        }
        let root_start = until_root && matches!(ev, Event::Start(_));
        if !dispatch::<_, false>(p, reader, ev, pos, base, saw_root)? {
            return Ok(false);
        }
        if root_start {
            return Ok(true);
        }
    }
}

/// A namespace-aware reader over `source`, configured as every read wants it (text kept
/// whole, end names checked).
pub(super) fn configured<R>(source: R) -> NsReader<R> {
    let mut reader = NsReader::from_reader(source);
    reader.config_mut().trim_text(false);
    reader.config_mut().check_end_names = true;
    reader
}

/// A reader over `text` (a document's start, `base` its offset in the file) whose events
/// `p` has been given until the root element started (the reader is just past its start
/// tag); `None` where it did not start there (not well-formed, no root, an error). `step`:
/// as in [`parse_events`], nothing released.
pub(super) fn start_root<'t>(
    p: &mut Parser<'_>,
    text: &'t [u8],
    base: u64,
    step: u64,
) -> Option<NsReader<&'t [u8]>> {
    let mut reader = configured(text);
    let mut saw_root = false;
    let started = parse_events(p, &mut reader, base, &mut saw_root, (&|_| {}, step), true);
    matches!(started, Ok(true)).then_some(reader)
}

pub(super) fn finish(
    p: Parser<'_>,
    len: u64,
    saw_root: bool,
    gzip: bool,
) -> Result<CityModel, ReadError> {
    if !saw_root {
        return Err(ReadError::Empty(p.path));
    }
    if !p.stack.is_empty() {
        return Err(p.xml_error(len, "unexpected end of document (truncated?)".into()));
    }
    p.finish(len, gzip)
}

/// Hand one event to the parser; `false` at the end of the document. `COUNT`: count the lines
/// of every event (streaming), else they are counted on demand from the document in memory.
#[inline(always)]
fn dispatch<R, const COUNT: bool>(
    p: &mut Parser<'_>,
    reader: &NsReader<R>,
    ev: Event<'_>,
    pos: u64,
    base: u64,
    saw_root: &mut bool,
) -> Result<bool, ReadError> {
    match ev {
        Event::Start(ref e) | Event::Empty(ref e) => {
            let empty = matches!(ev, Event::Empty(_));
            if p.stack.is_empty() && *saw_root {
                return Err(p.xml_error(pos, "more than one root element".into()));
            }
            *saw_root = true;
            let (res, _) = reader.resolve_element(e.name());
            let uri = p.bound(&res);
            p.content_start = reader.buffer_position() + base;
            p.start(reader, uri, e, pos, empty)?;
            if COUNT {
                p.count_lines(e, pos + 1);
            }
            if empty {
                let end = reader.buffer_position() + base;
                p.end(end)?;
            }
        }
        Event::End(e) => {
            if COUNT {
                p.count_lines(&e, pos + 2);
            }
            let end = reader.buffer_position() + base;
            p.end(end)?;
        }
        Event::Text(t) => {
            if p.capture {
                p.capture_text(&t, pos)?;
            } else if p.stack.is_empty() && !t.iter().all(u8::is_ascii_whitespace) {
                let what = if *saw_root { "after" } else { "outside" };
                return Err(p.xml_error(pos, format!("text {what} the root element")));
            }
            if COUNT {
                p.count_lines(&t, pos);
            }
        }
        Event::CData(t) => {
            if p.capture {
                p.capture_text(&t, pos)?;
            } else if p.stack.is_empty() {
                return Err(p.xml_error(pos, "CDATA outside the root element".into()));
            }
            if COUNT {
                p.count_lines(&t, pos + 9);
            }
        }
        Event::Comment(t) if COUNT => p.count_lines(&t, pos + 4),
        Event::DocType(t) if COUNT => p.count_lines(&t, pos + 9),
        Event::PI(t) if COUNT => p.count_lines(&t, pos + 2),
        Event::GeneralRef(r) => {
            if p.stack.is_empty() {
                return Err(p.xml_error(pos, "entity reference outside the root element".into()));
            }
            if p.capture {
                p.capture_ref(&r, pos)?;
            }
        }
        Event::Comment(_) | Event::DocType(_) | Event::PI(_) | Event::Decl(_) => {}
        Event::Eof => return Ok(false),
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Warnings, buildings' lines and errors of a document read in place (lines counted on
    /// demand) and streamed (lines counted per event).
    fn both(doc: &str) -> [String; 2] {
        let opts = ReadOptions::default();
        let show = |r: Result<CityModel, ReadError>| match r {
            Ok(m) => {
                let mut s = String::new();
                for w in &m.warnings {
                    s += &format!("{}:{} {:?} {}\n", w.line, w.column, w.gml_id, w.message);
                }
                for b in &m.buildings {
                    s += &format!("building {:?} line {}\n", b.id, b.line);
                }
                for a in &m.assets {
                    s += &format!("asset {:?} line {}\n", a.id, a.line);
                }
                s
            }
            Err(e) => format!("error {e}"),
        };
        let path = Path::new("t.gml");
        [
            show(read_slice(doc.as_bytes(), path, false, &opts, &|_| {})),
            show(read_from(doc.as_bytes(), path, false, &opts)),
        ]
    }

    const HEAD: &str = "\u{feff}<?xml version=\"1.0\"?>\n<!-- a\ncomment -->\n<CityModel \
        xmlns=\"http://www.opengis.net/citygml/2.0\"\n xmlns:bldg=\"http://www.opengis.net/citygml/building/2.0\"\n \
        xmlns:gml=\"http://www.opengis.net/gml\">\n";
    const BODY: &str = "<cityObjectMember><bldg:Building\n gml:id=\"1b\"><bldg:boundedBy>\n\
        <bldg:RoofSurface gml:id=\"r1\"><bldg:lod2MultiSurface><gml:MultiSurface>\
        <gml:surfaceMember><gml:Polygon gml:id=\"p1\"><gml:exterior>\n<gml:LinearRing><gml:posList>\
        0 0 5 1 0 5\n1 1 5 0 0 5</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon>\
        </gml:surfaceMember>\n<gml:surfaceMember><gml:Polygon gml:id=\"p1\"><gml:exterior>\
        <gml:LinearRing><gml:posList>0 0 5 1 0 5 0 0 5</gml:posList></gml:LinearRing>\
        </gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface>\
        </bldg:lod2MultiSurface></bldg:RoofSurface></bldg:boundedBy></bldg:Building>\
        </cityObjectMember>\n<![CDATA[\n]]><?pi \n?>";

    #[test]
    fn lines_on_demand_match_lines_per_event() {
        let ok = format!("{HEAD}{BODY}{BODY}</CityModel>\n");
        let [slice, stream] = both(&ok);
        assert!(slice.contains("duplicate gml:id"), "{slice}");
        assert!(slice.contains("building Some(\"1b\") line 7"), "{slice}");
        assert_eq!(slice, stream);
        // errors: a bad tag after many lines, a truncated document, text after the root
        for bad in [
            format!("{HEAD}{BODY}\n\n<a b=>"),
            format!("{HEAD}{BODY}\n"),
            format!("{HEAD}{BODY}</CityModel>\n\nx"),
        ] {
            let [slice, stream] = both(&bad);
            assert!(slice.starts_with("error"), "{slice}");
            assert_eq!(slice, stream);
        }
    }

    #[test]
    fn token_limit_holds_in_place_too() {
        let opts = ReadOptions {
            max_event_bytes: 1000,
            ..ReadOptions::default()
        };
        let doc = format!("{HEAD}<!--{}-->{BODY}</CityModel>", "c".repeat(5000));
        let e = read_slice(doc.as_bytes(), Path::new("t.gml"), false, &opts, &|_| {}).unwrap_err();
        assert!(matches!(e, ReadError::Limit { .. }), "{e}");
        // a huge tag is refused before it is handled: reported at the enclosing element's id
        // (as the streamed reader does when the tag outgrows its buffer)
        let attr = format!(
            "<bldg:RoofSurface note=\"{}\" gml:id=\"r1\">",
            "a".repeat(5000)
        );
        let doc = format!(
            "{HEAD}{}</CityModel>",
            BODY.replacen("<bldg:RoofSurface gml:id=\"r1\">", &attr, 1)
        );
        let e = read_slice(doc.as_bytes(), Path::new("t.gml"), false, &opts, &|_| {}).unwrap_err();
        assert!(matches!(e, ReadError::Limit { .. }), "{e}");
        assert!(e.to_string().contains("[gml:id 1b]"), "{e}");
        let ok = format!("{HEAD}<!--{}-->{BODY}</CityModel>", "c".repeat(500));
        assert!(read_slice(ok.as_bytes(), Path::new("t.gml"), false, &opts, &|_| {}).is_ok());
    }
}
