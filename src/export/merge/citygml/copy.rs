//! The second pass: the members of an input copied into the merged document, their start
//! tags rewritten: renamed ids, the references that follow them, and the namespace
//! declarations the input needs.

use super::scan::{next_event, ns_of, open, xml_err};
use crate::io::citygml::error::ReadError;
use crate::io::citygml::ns::{classify, Ns};
use quick_xml::escape::escape;
use quick_xml::events::attributes::Attribute;
use quick_xml::events::{BytesStart, BytesText, Event};
use quick_xml::name::QName;
use quick_xml::{NsReader, Writer};
use std::collections::HashMap;
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

/// Renaming applied to the members of one input.
pub(super) struct Rewrite<'a> {
    pub(super) ids: &'a HashMap<String, String>,
    /// Declarations added to each member's start tag.
    pub(super) decls: &'a [(Vec<u8>, Vec<u8>)],
    pub(super) rewritten: usize,
}
/// The start tag `e` with renamed ids and references (and, on a member, the declarations the
/// input needs), or `None` when nothing changes.
fn rewrite_start<R>(
    reader: &NsReader<R>,
    e: &BytesStart<'_>,
    rw: &mut Rewrite<'_>,
    member: bool,
    path: &Path,
    pos: u64,
) -> Result<Option<BytesStart<'static>>, ReadError> {
    let add_decls = member && !rw.decls.is_empty();
    if rw.ids.is_empty() && !add_decls {
        return Ok(None);
    }
    let mut changed = add_decls;
    let mut attrs: Vec<(Vec<u8>, Vec<u8>)> = Vec::new();
    for a in e.attributes().with_checks(false) {
        let a = a.map_err(|err| xml_err(path, pos, err))?;
        let (ns, local) = reader.resolve_attribute(a.key);
        let ns = ns_of(ns);
        let kind = match local.as_ref() {
            b"id" if classify(&ns) == Ns::Gml => Some(false),
            b"href" if classify(&ns) == Ns::Xlink => Some(true),
            b"uri" if ns.is_empty() => Some(true),
            _ => None,
        };
        let mut value = a.value.to_vec();
        if let Some(is_ref) = kind {
            let v = a.unescape_value().map_err(|err| xml_err(path, pos, err))?;
            let id = if is_ref {
                v.strip_prefix('#')
            } else {
                Some(&*v)
            };
            if let Some(new) = id.and_then(|id| rw.ids.get(id)) {
                let new = if is_ref {
                    format!("#{new}")
                } else {
                    new.clone()
                };
                value = escape(new.as_str()).as_bytes().to_vec();
                changed = true;
                if is_ref {
                    rw.rewritten += 1;
                }
            }
        }
        attrs.push((a.key.as_ref().to_vec(), value));
    }
    if !changed {
        return Ok(None);
    }
    let name = String::from_utf8_lossy(e.name().as_ref()).into_owned();
    let mut out = BytesStart::new(name);
    for (k, v) in &attrs {
        out.push_attribute(Attribute {
            key: QName(k),
            value: v.as_slice().into(),
        });
    }
    if add_decls {
        for (p, u) in rw.decls {
            let key = xmlns_key(p);
            if !attrs.iter().any(|(k, _)| *k == key) {
                out.push_attribute(Attribute {
                    key: QName(&key),
                    value: u.as_slice().into(),
                });
            }
        }
    }
    Ok(Some(out))
}
