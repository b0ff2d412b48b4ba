//! Namespaces and attributes of a start tag: the few attributes the reader needs.

use super::state::{Attrs, Parser};
use crate::io::citygml::error::ReadError;
use crate::io::citygml::ns::{self, Ns};
use quick_xml::events::attributes::Attribute;
use quick_xml::events::BytesStart;
use quick_xml::name::{QName, ResolveResult};
use quick_xml::NsReader;
use std::borrow::Cow;

impl Parser<'_> {
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
        if !self.unknown_prefixes.contains_key(prefix) {
            self.unknown_prefixes
                .insert(prefix.to_vec(), self.warnings.len());
            self.warn(format!(
                "namespace prefix \"{}\" is not declared: its elements and attributes are kept verbatim, not interpreted",
                String::from_utf8_lossy(&prefix[..prefix.len().min(40)])
            ));
        }
    }

    /// The namespace of a prefixed attribute name (`None` for an undeclared prefix, which is
    /// put in `bad_prefix`). Bindings only change at elements that declare namespaces, so the
    /// answer per prefix is cached until the next such start or end ([`Parser::attr_ns_cache`]).
    fn attr_ns<R>(
        &mut self,
        reader: &NsReader<R>,
        key: QName<'_>,
        bad_prefix: &mut Option<Vec<u8>>,
    ) -> Option<Ns> {
        let prefix = key.prefix().map(|p| p.into_inner()).unwrap_or(b"");
        if let Some((_, ns)) = self.attr_ns_cache.iter().find(|(p, _)| **p == *prefix) {
            return Some(*ns);
        }
        let ns = match reader.resolve_attribute(key).0 {
            ResolveResult::Unknown(p) => {
                *bad_prefix = Some(p);
                return None;
            }
            ResolveResult::Bound(n) => ns::classify(n.0),
            ResolveResult::Unbound => Ns::None,
        };
        // a few prefixes in real files; capped so that a hostile file with thousands of
        // prefixes costs a resolver search per attribute, not a quadratic cache search
        if self.attr_ns_cache.len() < 8 {
            self.attr_ns_cache.push((prefix.into(), ns));
        }
        Some(ns)
    }

    /// An attribute's value, entity references resolved.
    fn attr_value<'e>(&self, attr: &Attribute<'e>) -> Result<Cow<'e, str>, ReadError> {
        attr.unescape_value().map_err(|err| ReadError::Xml {
            loc: self.loc(),
            message: format!("bad attribute value: {err}"),
        })
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
            match local {
                b"id" | b"href" => {
                    let Some(ns) = self.attr_ns(reader, attr.key, &mut bad_prefix) else {
                        continue;
                    };
                    if local == b"id" && ns == Ns::Gml {
                        a.id = Some(self.attr_value(&attr)?);
                    } else if local == b"href" && ns == Ns::Xlink {
                        a.href = Some(self.attr_value(&attr)?);
                    }
                }
                b"srsName" if attr.key.prefix().is_none() => {
                    a.srs_name = Some(self.attr_value(&attr)?)
                }
                b"srsDimension" if attr.key.prefix().is_none() => {
                    a.srs_dimension = Some(self.attr_value(&attr)?)
                }
                b"orientation" if attr.key.prefix().is_none() => {
                    a.orientation_minus = self.attr_value(&attr)?.trim() == "-"
                }
                b"cs" if attr.key.prefix().is_none() => {
                    a.cs = self.attr_value(&attr)?.bytes().next()
                }
                b"ts" if attr.key.prefix().is_none() => {
                    a.ts = self.attr_value(&attr)?.bytes().next()
                }
                b"decimal" if attr.key.prefix().is_none() => {
                    a.decimal = self.attr_value(&attr)?.bytes().next()
                }
                _ => {}
            }
        }
        if let Some(prefix) = bad_prefix {
            self.unbound_prefix(&prefix);
        }
        Ok(a)
    }
}

#[cfg(test)]
mod tests {
    fn duplicate_warnings(xml: &str) -> usize {
        let m = crate::io::citygml::read::read_bytes(xml.as_bytes(), "t.gml").unwrap();
        m.warnings
            .iter()
            .filter(|w| w.message.starts_with("duplicate gml:id"))
            .count()
    }

    #[test]
    fn attribute_prefixes_follow_namespace_scopes() {
        let doc = |inner: &str| {
            format!(
                r#"<CityModel xmlns="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml">
  <gml:boundedBy/>
  <cityObjectMember><GenericCityObject gml:id="a">{inner}</GenericCityObject></cityObjectMember>
</CityModel>"#
            )
        };
        // `gml` bound to another namespace inside x: that gml:id is no gml:id...
        let scoped = r#"<x xmlns:gml="urn:other"><y gml:id="d"/></x><z gml:id="d"/>"#;
        assert_eq!(duplicate_warnings(&doc(scoped)), 0);
        // ...and after x closes, gml is GML again
        let after = r#"<x xmlns:gml="urn:other"><y gml:id="d"/></x><z gml:id="d"/><w gml:id="d"/>"#;
        assert_eq!(duplicate_warnings(&doc(after)), 1);
        // a declaration on the element itself counts for its own attributes
        let own = r#"<z gml:id="d"/><x gml:id="d" xmlns:gml="urn:other"/>"#;
        assert_eq!(duplicate_warnings(&doc(own)), 0);
        // another prefix bound to GML is GML
        let other = r#"<z gml:id="d"/><x xmlns:g="http://www.opengis.net/gml"><y g:id="d"/></x>"#;
        assert_eq!(duplicate_warnings(&doc(other)), 1);
    }
}
