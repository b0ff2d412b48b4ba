//! Namespaces and attributes of a start tag: the few attributes the reader needs.

use super::state::{Attrs, Parser};
use crate::citygml::error::ReadError;
use crate::citygml::ns::{self, Ns};
use quick_xml::events::BytesStart;
use quick_xml::name::ResolveResult;
use quick_xml::NsReader;
use std::borrow::Cow;

impl Parser {
    /// The namespace URI of a resolved element name. An undeclared prefix is not
    /// namespace-well-formed, but real data has them (e.g. PLATEAU ADE elements): the element
    /// is kept verbatim, not interpreted, with one warning per prefix.
    pub(super) fn bound<'a>(&mut self, res: &'a ResolveResult<'a>) -> Option<&'a [u8]> {
        match res {
            ResolveResult::Bound(ns) => Some(ns.0),
            ResolveResult::Unbound => None,
            ResolveResult::Unknown(prefix) => {
                self.unbound_prefix(prefix);
                None
            }
        }
    }

    pub(super) fn unbound_prefix(&mut self, prefix: &[u8]) {
        if self.unknown_prefixes.insert(prefix.to_vec()) {
            self.warn(format!(
                "namespace prefix \"{}\" is not declared: its elements and attributes are kept verbatim, not interpreted",
                String::from_utf8_lossy(&prefix[..prefix.len().min(40)])
            ));
        }
    }

    /// The attributes the reader needs, borrowed from the tag (copied only when they hold
    /// entity references).
    pub(super) fn parse_attrs<'e, R>(
        &mut self,
        reader: &NsReader<R>,
        e: &'e BytesStart,
    ) -> Result<Attrs<'e>, ReadError> {
        let mut a = Attrs::default();
        if memchr::memchr(b'=', e.attributes_raw()).is_none() {
            return Ok(a);
        }
        let mut bad_prefix = None;
        for attr in e.attributes().with_checks(false) {
            let attr = match attr {
                Ok(a) => a,
                Err(err) => {
                    return Err(ReadError::Xml {
                        loc: self.loc(),
                        message: format!("bad attribute: {err}"),
                    })
                }
            };
            let local = attr.key.local_name();
            let local = local.as_ref();
            let value = || -> Result<Cow<'e, str>, ReadError> {
                attr.unescape_value().map_err(|err| ReadError::Xml {
                    loc: self.loc(),
                    message: format!("bad attribute value: {err}"),
                })
            };
            match local {
                b"id" => {
                    let (res, _) = reader.resolve_attribute(attr.key);
                    if let ResolveResult::Unknown(prefix) = res {
                        bad_prefix = Some(prefix);
                        continue;
                    }
                    if let ResolveResult::Bound(n) = res {
                        if ns::classify(n.0) == Ns::Gml {
                            a.id = Some(value()?);
                        }
                    }
                }
                b"href" => {
                    let (res, _) = reader.resolve_attribute(attr.key);
                    if let ResolveResult::Unknown(prefix) = res {
                        bad_prefix = Some(prefix);
                        continue;
                    }
                    if let ResolveResult::Bound(n) = res {
                        if n.0 == ns::XLINK {
                            a.href = Some(value()?);
                        }
                    }
                }
                b"srsName" if attr.key.prefix().is_none() => a.srs_name = Some(value()?),
                b"srsDimension" if attr.key.prefix().is_none() => a.srs_dimension = Some(value()?),
                b"orientation" if attr.key.prefix().is_none() => {
                    a.orientation_minus = value()?.trim() == "-"
                }
                b"cs" if attr.key.prefix().is_none() => a.cs = value()?.bytes().next(),
                b"ts" if attr.key.prefix().is_none() => a.ts = value()?.bytes().next(),
                b"decimal" if attr.key.prefix().is_none() => a.decimal = value()?.bytes().next(),
                _ => {}
            }
        }
        if let Some(prefix) = bad_prefix {
            self.unbound_prefix(&prefix);
        }
        Ok(a)
    }
}
