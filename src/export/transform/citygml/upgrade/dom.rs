//! One child of the document root as a small owned element tree (names resolved to their
//! namespaces, text and attribute values kept escaped as written), and its serialisation.
//! The tree never holds more than one member, so memory follows the largest member.

use super::names::Src;
use crate::export::transform::citygml::edit::walk::MemberDoc;
use quick_xml::events::{BytesStart, Event};
use quick_xml::name::ResolveResult;
use quick_xml::NsReader;
use std::io::Write;

/// A node of an [`El`].
#[derive(Debug, Clone)]
pub(super) enum Node {
    El(El),
    /// Character data as written (escaped).
    Text(Vec<u8>),
    /// A comment, CDATA section or processing instruction, written as it was.
    Raw(Vec<u8>),
}

/// An element: its namespace, local name, the name it is written with, attributes (key as
/// written, value escaped) and children.
#[derive(Debug, Clone, Default)]
pub(super) struct El {
    pub(super) ns: Src,
    pub(super) local: String,
    pub(super) name: String,
    pub(super) attrs: Vec<(String, Vec<u8>)>,
    pub(super) kids: Vec<Node>,
}

impl El {
    /// A new element written as `name` (`prefix:local`).
    pub(super) fn new(name: &str) -> El {
        let local = name.rsplit(':').next().unwrap_or(name).to_string();
        El {
            ns: Src::Out,
            local,
            name: name.to_string(),
            ..El::default()
        }
    }

    /// `self` with the child `c`.
    pub(super) fn with(mut self, c: El) -> El {
        self.kids.push(Node::El(c));
        self
    }

    /// `self` with the escaped text `t`.
    pub(super) fn text(mut self, t: &[u8]) -> El {
        self.kids.push(Node::Text(t.to_vec()));
        self
    }

    /// The child elements.
    pub(super) fn els(&self) -> impl Iterator<Item = &El> {
        self.kids.iter().filter_map(|n| match n {
            Node::El(e) => Some(e),
            _ => None,
        })
    }

    /// The child elements, owned.
    pub(super) fn into_els(self) -> impl Iterator<Item = El> {
        self.kids.into_iter().filter_map(|n| match n {
            Node::El(e) => Some(e),
            _ => None,
        })
    }

    /// The first child element with this local name.
    pub(super) fn child(&self, local: &str) -> Option<&El> {
        self.els().find(|e| e.local == local)
    }

    /// The text of the element (escaped), children's text left out.
    pub(super) fn own_text(&self) -> Vec<u8> {
        let mut t = Vec::new();
        for n in &self.kids {
            if let Node::Text(b) = n {
                t.extend_from_slice(b);
            }
        }
        t
    }

    /// The value of the attribute whose key ends in `:local` or is `local`.
    pub(super) fn attr(&self, local: &str) -> Option<&[u8]> {
        self.attrs.iter().find_map(|(k, v)| {
            let l = k.rsplit(':').next().unwrap_or(k);
            (l == local && !k.starts_with("xmlns")).then_some(v.as_slice())
        })
    }

    /// Remove the attribute whose local name is `local`; its value.
    pub(super) fn take_attr(&mut self, local: &str) -> Option<Vec<u8>> {
        let i = self.attrs.iter().position(|(k, _)| {
            k.rsplit(':').next().unwrap_or(k) == local && !k.starts_with("xmlns")
        })?;
        Some(self.attrs.remove(i).1)
    }

    /// Write the element.
    pub(super) fn write(&self, w: &mut Vec<u8>) {
        w.push(b'<');
        w.extend_from_slice(self.name.as_bytes());
        for (k, v) in &self.attrs {
            w.push(b' ');
            w.extend_from_slice(k.as_bytes());
            w.extend_from_slice(b"=\"");
            for &c in v {
                if c == b'"' {
                    w.extend_from_slice(b"&quot;");
                } else {
                    w.push(c);
                }
            }
            w.push(b'"');
        }
        if self.kids.is_empty() {
            w.extend_from_slice(b"/>");
            return;
        }
        w.push(b'>');
        for n in &self.kids {
            match n {
                Node::El(e) => e.write(w),
                Node::Text(t) | Node::Raw(t) => w.extend_from_slice(t),
            }
        }
        w.extend_from_slice(b"</");
        w.extend_from_slice(self.name.as_bytes());
        w.push(b'>');
    }

    /// Write the element to `w`; bytes written.
    pub(super) fn write_to(&self, w: &mut dyn Write, buf: &mut Vec<u8>) -> std::io::Result<u64> {
        buf.clear();
        self.write(buf);
        w.write_all(buf)?;
        Ok(buf.len() as u64)
    }
}

/// Where in the member an error lies, and why.
#[derive(Debug)]
pub(super) struct DomError {
    pub(super) at: usize,
    pub(super) message: String,
}

/// The member at `member` (the bytes of one element) in a document whose root start tag is
/// `root` (its namespace declarations are in scope).
pub(super) fn parse(root: &[u8], member: &[u8]) -> Result<El, DomError> {
    let doc = MemberDoc::new(root, member);
    let mut reader = doc.reader();
    let mut stack: Vec<El> = Vec::new();
    let mut depth = 0usize;
    loop {
        let (_, uri, ev) = doc
            .next(&mut reader)
            .map_err(|(at, message)| DomError { at, message })?;
        match ev {
            Event::Start(_) | Event::Empty(_) if depth == 0 => depth = 1,
            Event::Start(ref e) | Event::Empty(ref e) => {
                let el = element(&reader, e, &uri);
                if matches!(ev, Event::Empty(_)) {
                    match stack.last_mut() {
                        Some(p) => p.kids.push(Node::El(el)),
                        None => return Ok(el),
                    }
                } else {
                    stack.push(el);
                }
            }
            Event::End(_) => {
                let Some(el) = stack.pop() else {
                    break;
                };
                match stack.last_mut() {
                    Some(p) => p.kids.push(Node::El(el)),
                    None => return Ok(el),
                }
            }
            Event::Text(t) => push_text(&mut stack, &t),
            Event::GeneralRef(r) => {
                let mut t = Vec::with_capacity(r.len() + 2);
                t.push(b'&');
                t.extend_from_slice(&r);
                t.push(b';');
                push_text(&mut stack, &t);
            }
            Event::CData(c) => raw(&mut stack, b"<![CDATA[", &c, b"]]>"),
            Event::Comment(c) => raw(&mut stack, b"<!--", &c, b"-->"),
            Event::PI(p) => raw(&mut stack, b"<?", &p, b"?>"),
            Event::Eof => break,
            _ => {}
        }
    }
    Err(DomError {
        at: member.len(),
        message: "the member ended early".into(),
    })
}

fn push_text(stack: &mut [El], t: &[u8]) {
    if let Some(p) = stack.last_mut() {
        if let Some(Node::Text(prev)) = p.kids.last_mut() {
            prev.extend_from_slice(t);
        } else {
            p.kids.push(Node::Text(t.to_vec()));
        }
    }
}

fn raw(stack: &mut [El], open: &[u8], body: &[u8], close: &[u8]) {
    if let Some(p) = stack.last_mut() {
        let mut b = open.to_vec();
        b.extend_from_slice(body);
        b.extend_from_slice(close);
        p.kids.push(Node::Raw(b));
    }
}

fn element(reader: &NsReader<&[u8]>, e: &BytesStart<'_>, uri: &[u8]) -> El {
    let src = Src::of(uri);
    let local = String::from_utf8_lossy(e.local_name().into_inner()).into_owned();
    let name = String::from_utf8_lossy(e.name().into_inner()).into_owned();
    let mut attrs = Vec::new();
    for a in e.attributes().with_checks(false).flatten() {
        let key = a.key.into_inner();
        let value = a.value.into_owned();
        if key == b"xmlns" || key.starts_with(b"xmlns:") {
            // declarations of the namespaces the upgrade rewrites are made on the root
            if !Src::of(&value).rewritten() {
                attrs.push((String::from_utf8_lossy(key).into_owned(), value));
            }
            continue;
        }
        let local = String::from_utf8_lossy(a.key.local_name().into_inner()).into_owned();
        let k = match a.key.prefix() {
            None => local,
            Some(p) if p.into_inner() == b"xml" => format!("xml:{local}"),
            Some(_) => {
                let (ans, _) = reader.resolve_attribute(a.key);
                let auri: &[u8] = match ans {
                    ResolveResult::Bound(n) => n.0,
                    _ => b"",
                };
                match Src::of(auri) {
                    Src::Gml => format!("gml:{local}"),
                    Src::Xlink => format!("xlink:{local}"),
                    Src::Xsi => format!("xsi:{local}"),
                    Src::Module(m) => format!("{}:{local}", m.prefix()),
                    Src::Core => format!("core:{local}"),
                    _ => String::from_utf8_lossy(key).into_owned(),
                }
            }
        };
        attrs.push((k, value));
    }
    El {
        ns: src,
        local,
        name,
        attrs,
        kids: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_and_write_back() {
        let root = br#"<CityModel xmlns="http://www.opengis.net/citygml/2.0" xmlns:g="http://www.opengis.net/gml" xmlns:x="urn:x">"#;
        let m = br#"<cityObjectMember><x:Thing a='say "hi"' g:id="t1">a &amp; b<!-- c --><g:pos>1 2 3</g:pos></x:Thing></cityObjectMember>"#;
        let el = parse(root, m).unwrap();
        assert_eq!(el.ns, Src::Core);
        let thing = el.child("Thing").unwrap();
        assert_eq!(thing.ns, Src::Foreign);
        assert_eq!(thing.attr("id"), Some(&b"t1"[..]));
        assert_eq!(thing.attrs[1].0, "gml:id");
        assert_eq!(thing.own_text(), b"a &amp; b");
        assert_eq!(thing.child("pos").unwrap().ns, Src::Gml);
        let mut w = Vec::new();
        thing.write(&mut w);
        assert_eq!(
            String::from_utf8(w).unwrap(),
            r#"<x:Thing a="say &quot;hi&quot;" gml:id="t1">a &amp; b<!-- c --><g:pos>1 2 3</g:pos></x:Thing>"#
        );
        assert!(parse(root, b"<cityObjectMember><a>").is_err());
    }
}
