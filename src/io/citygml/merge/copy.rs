//! The second pass: the members of an input copied into the merged document, their start
//! tags rewritten ([`super::ids`]).

use super::ids::{rewrite_start, Rewrite};
use super::scan::{next_event, ns_of, open, xml_err};
use crate::io::citygml::error::ReadError;
use crate::io::citygml::ns::{classify, Ns};
use quick_xml::events::{BytesText, Event};
use quick_xml::Writer;
use std::io::Write;
use std::path::Path;

pub(super) fn xmlns_key(prefix: &[u8]) -> Vec<u8> {
    if prefix.is_empty() {
        b"xmlns".to_vec()
    } else {
        [b"xmlns:".as_slice(), prefix].concat()
    }
}

pub(super) enum CopyError {
    Read(ReadError),
    Io(std::io::Error),
}

/// Copy the children of the root of `path` that `want` selects (by namespace URI and local
/// name), each on its own line, applying `rw`. Returns how many were copied.
pub(super) fn copy_children(
    path: &Path,
    out: &mut dyn Write,
    mut rw: Option<&mut Rewrite<'_>>,
    want: &mut dyn FnMut(&[u8], &[u8]) -> bool,
) -> Result<usize, CopyError> {
    let mut reader = open(path).map_err(CopyError::Read)?;
    let mut w = Writer::new(out);
    let mut buf = Vec::new();
    let mut depth = 0usize;
    let mut copying = false;
    let mut in_target = false;
    let mut n = 0;
    loop {
        let (pos, ev) = next_event(&mut reader, &mut buf, path).map_err(CopyError::Read)?;
        match &ev {
            Event::Eof => break,
            Event::Start(e) | Event::Empty(e) => {
                let empty = matches!(ev, Event::Empty(_));
                if depth == 1 {
                    let (ns, local) = reader.resolve_element(e.name());
                    copying = want(&ns_of(ns), local.as_ref());
                    if copying {
                        n += 1;
                        w.get_mut().write_all(b"\n ").map_err(CopyError::Io)?;
                    }
                }
                if copying {
                    let (ens, elocal) = reader.resolve_element(e.name());
                    in_target = !empty
                        && elocal.as_ref() == b"target"
                        && matches!(classify(&ns_of(ens)), Ns::CityGml(..));
                    let start = match rw.as_deref_mut() {
                        Some(r) => rewrite_start(&reader, e, r, depth == 1, path, pos)
                            .map_err(CopyError::Read)?,
                        None => None,
                    };
                    let e = start.as_ref().unwrap_or(e).borrow();
                    let ev = if empty {
                        Event::Empty(e)
                    } else {
                        Event::Start(e)
                    };
                    w.write_event(ev).map_err(CopyError::Io)?;
                }
                if !empty {
                    depth += 1;
                }
            }
            Event::End(_) => {
                depth = depth.saturating_sub(1);
                if copying {
                    w.write_event(ev.borrow()).map_err(CopyError::Io)?;
                }
                in_target = false;
                if depth == 1 {
                    copying = false;
                }
            }
            Event::Text(t) if copying && in_target => {
                let text = t
                    .decode()
                    .map_err(|e| CopyError::Read(xml_err(path, pos, e)))?;
                let trimmed = text.trim();
                let new = rw.as_deref_mut().and_then(|r| {
                    let id = trimmed.strip_prefix('#')?;
                    let new = r.ids.get(id)?;
                    r.rewritten += 1;
                    Some(text.replace(trimmed, &format!("#{new}")))
                });
                match new {
                    Some(s) => w
                        .write_event(Event::Text(BytesText::new(&s)))
                        .map_err(CopyError::Io)?,
                    None => w.write_event(ev.borrow()).map_err(CopyError::Io)?,
                }
            }
            _ if copying => w.write_event(ev.borrow()).map_err(CopyError::Io)?,
            _ => {}
        }
        buf.clear();
    }
    Ok(n)
}
