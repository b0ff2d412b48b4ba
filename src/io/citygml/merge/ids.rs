//! Colliding `gml:id`s renamed, and the references to them that follow (see the module docs
//! of [`crate::io::citygml::merge`], "Identifiers").

use super::copy::xmlns_key;
use super::scan::{ns_of, xml_err};
use crate::io::citygml::error::ReadError;
use crate::io::citygml::ns::{classify, Ns};
use quick_xml::escape::escape;
use quick_xml::events::attributes::Attribute;
use quick_xml::events::BytesStart;
use quick_xml::name::QName;
use quick_xml::NsReader;
use std::collections::{HashMap, HashSet};
use std::path::Path;

/// The new name of an id of the `k`-th input (1-based) that collides: `<id>__<k>`, or the first
/// of `<id>__<k>_2`, `<id>__<k>_3`, ... that `taken` does not hold.
///
/// ```
/// use std::collections::HashSet;
/// use skylod::io::citygml::merge::renamed_id;
/// let taken: HashSet<String> = ["w".into(), "w__2".into()].into();
/// assert_eq!(renamed_id("w", 3, &taken), "w__3");
/// assert_eq!(renamed_id("w", 2, &taken), "w__2_2");
/// ```
pub fn renamed_id(id: &str, k: usize, taken: &HashSet<String>) -> String {
    let base = format!("{id}__{k}");
    if !taken.contains(&base) {
        return base;
    }
    (2usize..)
        .map(|n| format!("{base}_{n}"))
        .find(|c| !taken.contains(c))
        .unwrap_or(base)
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
pub(super) fn rewrite_start<R>(
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
