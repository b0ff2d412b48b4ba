//! One child of the document root (a `cityObjectMember`, a global `appearanceMember`, ...)
//! parsed into a flat tree of its elements: span, parent, what kind of element, its `gml:id`,
//! the reference it holds and the box of its coordinates. The rules of [`super::subset`] and
//! [`super::lods`] decide on this tree which spans to cut; the tree never holds more than one
//! member, so memory follows the largest member, not the file.

use super::walk::MemberDoc;
use crate::io::citygml::ns::{classify, Module, Ns};
use crate::io::citygml::read::coords::parse_gml_points;
use crate::model::Bbox;
use glam::DVec3;
use quick_xml::events::{BytesStart, Event};
use quick_xml::name::ResolveResult;
use quick_xml::NsReader;
use std::ops::Range;

/// What an element is, for the rules.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Kind {
    /// A feature or object (upper-case local name, not GML): `Building`, `WallSurface`,
    /// `X3DMaterial`, an ADE's feature.
    Feature,
    /// A LoD geometry property of a feature: `lod<N>MultiSurface`, `lod<N>Solid`,
    /// `lod<N>ImplicitRepresentation`, `lod0FootPrint`, ... (CityGML 1.0 to 3.0).
    Lod(u8),
    /// A GML element (geometry, envelope, ...).
    Gml,
    /// Anything else (properties, attributes, xAL).
    Other,
}

/// One element of a [`Tree`].
#[derive(Debug, Clone)]
pub(super) struct Node {
    /// Bytes of the element in the member, start tag to end tag.
    pub(super) span: Range<usize>,
    /// The enclosing element, `None` for the member itself.
    pub(super) parent: Option<usize>,
    pub(super) kind: Kind,
    /// Local name.
    pub(super) local: Box<str>,
    /// Hash of its `gml:id` ([`id_hash`]).
    pub(super) id: Option<u64>,
    /// Hash of the id it refers to: `xlink:href="#id"`, an appearance `target` (`#id` as text
    /// or `uri="#id"`).
    pub(super) href: Option<u64>,
    /// A second reference: an appearance `target` with both `uri="#id"` and an `xlink:href`
    /// (to its texture coordinates).
    pub(super) uri: Option<u64>,
    /// Box of the coordinates of a `posList` / `pos` / `coordinates` element (empty for any
    /// other element, and for the prototype geometry of an implicit geometry and envelopes,
    /// which are not world coordinates of the object).
    pub(super) bbox: Bbox,
    /// The sum of those coordinates and how many there are, a closed `posList` ring's
    /// repeated first point counted once (as CityJSON stores a ring): the centroid of
    /// [`super::subset`]'s `centroid` mode.
    pub(super) sum: (DVec3, u32),
}

/// A member as a tree of elements, in document order (a parent before its children).
#[derive(Debug, Default)]
pub(super) struct Tree {
    pub(super) nodes: Vec<Node>,
    /// The `gml:id` of the member's first child element (the top-level feature).
    pub(super) feature_id: Option<String>,
    /// The first `srsName` in the member.
    pub(super) srs_name: Option<String>,
}

/// The hash of a `gml:id` in the sets of removed ids.
pub(super) fn id_hash(id: &[u8]) -> u64 {
    use std::hash::BuildHasher;
    foldhash::fast::FixedState::with_seed(0x5b5e_7c17).hash_one(id)
}

/// Where in the member an error lies, and why.
#[derive(Debug)]
pub(super) struct TreeError {
    pub(super) at: usize,
    pub(super) message: String,
}

impl Tree {
    /// The member at `member` (the bytes of one element), in a document whose root start tag
    /// is `root` (its namespace declarations are in scope).
    pub(super) fn parse(root: &[u8], member: &[u8]) -> Result<Tree, TreeError> {
        let doc = MemberDoc::new(root, member);
        let mut reader = doc.reader();
        let mut tree = Tree::default();
        let mut stack: Vec<usize> = Vec::new();
        let mut depth = 0usize;
        // (node, srsDimension) of the coordinate element being read, and its text
        let mut capture: Option<(usize, u8)> = None;
        let mut text = Vec::new();
        // depth at which an implicit geometry's prototype or an envelope began
        let mut skip_from: Option<usize> = None;
        loop {
            let (at, uri, ev) = doc
                .next(&mut reader)
                .map_err(|(at, message)| TreeError { at, message })?;
            match ev {
                Event::Start(e) | Event::Empty(e) if depth == 0 => {
                    let _ = e;
                    depth = 1;
                }
                Event::Start(ref e) | Event::Empty(ref e) => {
                    let empty = matches!(ev, Event::Empty(_));
                    let end = doc.offset(&reader);
                    // a tag starts at its `<` (the reader may count it with the text before)
                    let at = memchr::memrchr(b'<', &member[..end.min(member.len())]).unwrap_or(at);
                    let idx = tree.nodes.len();
                    let mut node = node_of(&reader, e, &uri, stack.last().copied(), at..end);
                    let local = node.local.clone();
                    let skipped = matches!(&*local, "relativeGMLGeometry" | "relativeGeometry")
                        || (&*local == "boundedBy" && node.kind == Kind::Gml);
                    if skipped && skip_from.is_none() && !empty {
                        skip_from = Some(depth);
                    }
                    if tree.srs_name.is_none() {
                        tree.srs_name = attr_value(&reader, e, b"srsName", false);
                    }
                    if idx == 1 && tree.feature_id.is_none() {
                        tree.feature_id = attr_value(&reader, e, b"id", true);
                    }
                    if !empty && skip_from.is_none() && node.kind == Kind::Gml {
                        if let "posList" | "pos" | "coordinates" = &*local {
                            let dim = attr_value(&reader, e, b"srsDimension", false)
                                .and_then(|d| d.parse().ok())
                                .unwrap_or(3);
                            capture = Some((idx, dim));
                            text.clear();
                        }
                    }
                    if !empty && &*local == "target" && is_appearance(&uri) && node.uri.is_none() {
                        capture = Some((idx, 0));
                        text.clear();
                    }
                    if empty {
                        node.span = at..end;
                    }
                    tree.nodes.push(node);
                    if !empty {
                        stack.push(idx);
                        depth += 1;
                    }
                }
                Event::Text(t) if capture.is_some() => text.extend_from_slice(&t),
                Event::CData(t) if capture.is_some() => text.extend_from_slice(&t),
                Event::GeneralRef(r) if capture.is_some() => {
                    text.push(b'&');
                    text.extend_from_slice(&r);
                    text.push(b';');
                }
                Event::End(_) => {
                    depth = depth.saturating_sub(1);
                    if skip_from == Some(depth) {
                        skip_from = None;
                    }
                    let Some(idx) = stack.pop() else {
                        break;
                    };
                    let end = doc.offset(&reader);
                    if let Some((c, dim)) = capture.take() {
                        if c == idx {
                            close_capture(&mut tree.nodes[idx], dim, &text)
                                .map_err(|m| TreeError { at, message: m })?;
                        } else {
                            capture = Some((c, dim));
                        }
                    }
                    tree.nodes[idx].span.end = end;
                }
                Event::Eof => break,
                _ => {}
            }
        }
        Ok(tree)
    }

    /// The node's ancestors, nearest first.
    pub(super) fn ancestors(&self, mut i: usize) -> impl Iterator<Item = usize> + '_ {
        std::iter::from_fn(move || {
            let p = self.nodes.get(i)?.parent?;
            i = p;
            Some(p)
        })
    }

    /// The local name of the member's first child element (the top-level feature's type).
    pub(super) fn feature_type(&self) -> Option<&str> {
        self.nodes.get(1).map(|n| &*n.local)
    }

    /// The mean of the coordinates of the top-level feature's own geometry, as cjio takes the
    /// centroid of a CityJSON object: its surfaces and openings (in CityJSON, semantic
    /// surfaces of its geometry) count, the features nested in it that CityJSON makes objects
    /// of their own (`BuildingPart`, `BuildingInstallation`, `Room`, ...) do not; `None`
    /// without coordinates.
    pub(super) fn own_centroid(&self) -> Option<DVec3> {
        let mut own = vec![false; self.nodes.len()];
        let (mut sum, mut count) = (DVec3::ZERO, 0u64);
        for (i, n) in self.nodes.iter().enumerate() {
            own[i] = i == 1
                || n.parent.is_some_and(|p| {
                    let q = &self.nodes[p];
                    let nested = p != 1 && q.kind == Kind::Feature && !is_surface(&q.local);
                    own[p] && !nested
                });
            if own[i] {
                sum += n.sum.0;
                count += u64::from(n.sum.1);
            }
        }
        (count > 0).then(|| sum / count as f64)
    }
}

/// A feature that CityJSON keeps inside its parent's geometry: a thematic surface or an
/// opening.
fn is_surface(local: &str) -> bool {
    local.ends_with("Surface") || matches!(local, "Window" | "Door")
}

fn is_appearance(uri: &[u8]) -> bool {
    matches!(classify(uri), Ns::CityGml(Module::Appearance, _))
}

fn node_of(
    reader: &NsReader<&[u8]>,
    e: &BytesStart<'_>,
    uri: &[u8],
    parent: Option<usize>,
    span: Range<usize>,
) -> Node {
    let local = String::from_utf8_lossy(e.local_name().into_inner()).into_owned();
    let ns = classify(uri);
    let kind = match ns {
        Ns::Gml => Kind::Gml,
        Ns::Xlink | Ns::None => Kind::Other,
        Ns::Foreign if crate::io::citygml::ns::is_standard_foreign(uri) => Kind::Other,
        _ => match lod_of(&local) {
            Some(n) => Kind::Lod(n),
            None if local.starts_with(|c: char| c.is_ascii_uppercase()) => Kind::Feature,
            None => Kind::Other,
        },
    };
    let id = attr_value(reader, e, b"id", true).map(|v| id_hash(v.as_bytes()));
    let href = attr_value(reader, e, b"href", true);
    let target_uri = (local == "target" && is_appearance(uri))
        .then(|| attr_value(reader, e, b"uri", false))
        .flatten();
    Node {
        span,
        parent,
        kind,
        local: local.into(),
        id,
        href: href.as_deref().and_then(local_target),
        uri: target_uri.as_deref().and_then(local_target),
        bbox: Bbox::EMPTY,
        sum: (DVec3::ZERO, 0),
    }
}

/// The id of a local reference `#id` (references to other documents are not ours to prune).
fn local_target(r: &str) -> Option<u64> {
    r.trim().strip_prefix('#').map(|id| id_hash(id.as_bytes()))
}

/// `lod<N><Upper>...` → N.
fn lod_of(local: &str) -> Option<u8> {
    let b = local.as_bytes();
    match b {
        [b'l', b'o', b'd', n @ b'0'..=b'4', c, ..] if c.is_ascii_uppercase() => Some(n - b'0'),
        _ => None,
    }
}

/// The value of the attribute `local` (prefixed, like `gml:id`, `xlink:href`, or not).
fn attr_value(
    reader: &NsReader<&[u8]>,
    e: &BytesStart<'_>,
    local: &[u8],
    prefixed: bool,
) -> Option<String> {
    for a in e.attributes().with_checks(false).flatten() {
        if a.key.local_name().into_inner() != local || a.key.prefix().is_some() != prefixed {
            continue;
        }
        if prefixed {
            let (ns, _) = reader.resolve_attribute(a.key);
            let ok = match ns {
                ResolveResult::Bound(n) => {
                    matches!(classify(n.into_inner()), Ns::Gml | Ns::Xlink)
                }
                _ => false,
            };
            if !ok {
                continue;
            }
        }
        return Some(String::from_utf8_lossy(&a.value).into_owned());
    }
    None
}

fn close_capture(node: &mut Node, dim: u8, text: &[u8]) -> Result<(), String> {
    if dim == 0 {
        // an appearance target's text
        let t = String::from_utf8_lossy(text);
        node.uri = local_target(&t);
        return Ok(());
    }
    let mut pts = Vec::new();
    parse_gml_points(node.local.as_bytes(), text, dim, &mut pts)?;
    for &p in &pts {
        node.bbox.add(p);
    }
    if pts.len() > 1 && pts.first() == pts.last() {
        pts.pop();
    }
    node.sum = (
        pts.iter().sum(),
        u32::try_from(pts.len()).unwrap_or(u32::MAX),
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const ROOT: &[u8] = br#"<CityModel xmlns="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml" xmlns:bldg="http://www.opengis.net/citygml/building/2.0" xmlns:app="http://www.opengis.net/citygml/appearance/2.0" xmlns:xlink="http://www.w3.org/1999/xlink">"#;

    #[test]
    fn kinds_ids_refs_and_boxes() {
        let member = br##"<cityObjectMember> <bldg:Building gml:id="B1"><gml:boundedBy><gml:Envelope><gml:pos>99 99 99</gml:pos></gml:Envelope></gml:boundedBy><bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember><gml:Polygon gml:id="p1"><gml:exterior><gml:LinearRing><gml:posList srsDimension="3">0 0 0 4 0 0 4 3 5 0 0 0</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember><gml:surfaceMember xlink:href="#p9"/></gml:MultiSurface></bldg:lod2MultiSurface><app:appearance><app:Appearance><app:surfaceDataMember><app:X3DMaterial><app:target>#p1</app:target></app:X3DMaterial></app:surfaceDataMember></app:Appearance></app:appearance></bldg:Building></cityObjectMember>"##;
        let t = Tree::parse(ROOT, member).unwrap();
        assert_eq!(t.feature_id.as_deref(), Some("B1"));
        assert_eq!(t.feature_type(), Some("Building"));
        let by = |l: &str| t.nodes.iter().position(|n| &*n.local == l).unwrap();
        assert_eq!(t.nodes[by("Building")].kind, Kind::Feature);
        assert_eq!(t.nodes[by("lod2MultiSurface")].kind, Kind::Lod(2));
        assert_eq!(t.nodes[by("Polygon")].id, Some(id_hash(b"p1")));
        let pl = &t.nodes[by("posList")];
        assert_eq!(
            (pl.bbox.min.x, pl.bbox.max.y, pl.bbox.max.z),
            (0.0, 3.0, 5.0)
        );
        // the envelope's pos is not a coordinate of the object
        assert!(t.nodes[by("pos")].bbox.is_empty());
        assert_eq!(t.nodes[by("target")].uri, Some(id_hash(b"p1")));
        let refs: Vec<_> = t
            .nodes
            .iter()
            .flat_map(|n| n.href.into_iter().chain(n.uri))
            .collect();
        assert_eq!(refs, vec![id_hash(b"p9"), id_hash(b"p1")]);
        // spans cut the member's bytes at element boundaries
        let poly = &t.nodes[by("Polygon")];
        assert!(member[poly.span.clone()].starts_with(b"<gml:Polygon"));
        assert!(member[poly.span.clone()].ends_with(b"</gml:Polygon>"));
        assert!(member[t.nodes[by("Building")].span.clone()].starts_with(b"<bldg:Building"));
        let m = &t.nodes[0];
        assert_eq!(m.span, 0..member.len());
        assert_eq!(t.ancestors(by("Polygon")).count(), 5);
    }

    #[test]
    fn lod_names() {
        assert_eq!(lod_of("lod0FootPrint"), Some(0));
        assert_eq!(lod_of("lod4Solid"), Some(4));
        assert_eq!(lod_of("lod2ImplicitRepresentation"), Some(2));
        assert_eq!(lod_of("lod"), None);
        assert_eq!(lod_of("lod5Solid"), None);
        assert_eq!(lod_of("lodding"), None);
    }

    #[test]
    fn malformed_member_is_an_error() {
        let e =
            Tree::parse(ROOT, b"<cityObjectMember><bldg:Building><!-- never closed").unwrap_err();
        assert!(e.at > 0, "{}", e.message);
    }
}
