//! The event loop: quick-xml events of one document dispatched to the [`Parser`].

use super::state::Parser;
use super::ReadOptions;
use crate::citygml::error::ReadError;
use crate::citygml::source;
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
    let mut p = Parser::new(path, opts.clone());
    p.expect_bytes(size_hint);
    let base = source::skip_bom(&mut reader, path)?;
    let mut reader = NsReader::from_reader(source::Limited::new(reader, opts.max_event_bytes));
    reader.config_mut().trim_text(false);
    reader.config_mut().check_end_names = true;
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
        match ev {
            Event::Start(e) => {
                if p.stack.is_empty() && saw_root {
                    return Err(p.xml_error(pos, "more than one root element".into()));
                }
                saw_root = true;
                let (res, _) = reader.resolve_element(e.name());
                let uri = p.bound(&res);
                p.content_start = reader.buffer_position() + base;
                p.start(&reader, uri, &e, pos, false)?;
                p.count_lines(&e, pos + 1);
            }
            Event::Empty(e) => {
                if p.stack.is_empty() && saw_root {
                    return Err(p.xml_error(pos, "more than one root element".into()));
                }
                saw_root = true;
                let (res, _) = reader.resolve_element(e.name());
                let uri = p.bound(&res);
                p.content_start = reader.buffer_position() + base;
                p.start(&reader, uri, &e, pos, true)?;
                p.count_lines(&e, pos + 1);
                let end = reader.buffer_position() + base;
                p.end(end)?;
            }
            Event::End(e) => {
                p.count_lines(&e, pos + 2);
                let end = reader.buffer_position() + base;
                p.end(end)?;
            }
            Event::Text(t) => {
                if p.capture {
                    p.capture_text(&t, pos)?;
                } else if p.stack.is_empty() && !t.iter().all(u8::is_ascii_whitespace) {
                    let what = if saw_root { "after" } else { "outside" };
                    return Err(p.xml_error(pos, format!("text {what} the root element")));
                }
                p.count_lines(&t, pos);
            }
            Event::CData(t) => {
                if p.capture {
                    p.capture_text(&t, pos)?;
                } else if p.stack.is_empty() {
                    return Err(p.xml_error(pos, "CDATA outside the root element".into()));
                }
                p.count_lines(&t, pos + 9);
            }
            Event::Comment(t) => p.count_lines(&t, pos + 4),
            Event::DocType(t) => p.count_lines(&t, pos + 9),
            Event::PI(t) => p.count_lines(&t, pos + 2),
            Event::GeneralRef(r) => {
                if p.stack.is_empty() {
                    return Err(
                        p.xml_error(pos, "entity reference outside the root element".into())
                    );
                }
                if p.capture {
                    p.capture_ref(&r, pos)?;
                }
            }
            Event::Decl(_) => {}
            Event::Eof => break,
        }
        if buf.len() > p.opts.max_event_bytes {
            return Err(p.token_limit(pos));
        }
        buf.clear();
    }
    let len = reader.buffer_position() + base;
    if !saw_root {
        return Err(ReadError::Empty(path.to_path_buf()));
    }
    if !p.stack.is_empty() {
        return Err(p.xml_error(len, "unexpected end of document (truncated?)".into()));
    }
    p.finish(len, gzip)
}
