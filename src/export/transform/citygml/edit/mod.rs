//! Streamed edits of whole documents, one top-level member at a time: [`subset()`] (keep city
//! objects by box, id, type) and [`filter_lods()`] (keep or remove LoD representations), the
//! conversions municipal teams do with citygml-tools, on files of any size.
//!
//! # How
//! Two passes over the source (plain or gzip), each holding one child of the root at a time
//! (a tree of its elements), so peak memory follows the largest member, not the file:
//!
//! 1. **Plan**: the rule decides on each `cityObjectMember` (drop it, or cut spans of it); the
//!    hashes of the `gml:id`s in what goes are kept (8 bytes an id: the one part of memory
//!    that grows with the document), and the box of the coordinates that stay.
//! 2. **Write**: the same decisions again (the rules are deterministic), and in what stays,
//!    every reference into removed content is pruned: an element with `xlink:href="#id"`, an
//!    appearance `target` (`#id` as text, `uri="#id"`); a property or GML object left without
//!    child elements goes with it (a `gml:MultiSurface` whose members all went, the
//!    `textureParameterization` of a CityGML 3.0 `TextureAssociation`), climbing up to the
//!    nearest feature. The root's `gml:boundedBy` gets the box of what stays (removed when
//!    nothing stays). Everything else is copied byte for byte: the prolog, namespaces,
//!    comments, ADE content, global appearances and groups (pruned as above).
//!
//! Feature envelopes inside members are kept as they are; the box of a member is that of its
//! coordinates (`gml:posList`, `gml:pos`, `gml:coordinates`), leaving out the prototype of an
//! implicit geometry (local coordinates; its reference point counts) and envelopes.
//!
//! # Example
//! ```
//! use skylod::export::transform::{Subset, subset};
//! let dir = tempfile::tempdir().unwrap();
//! let src = dir.path().join("in.gml");
//! std::fs::write(&src, br##"<CityModel xmlns="http://www.opengis.net/citygml/2.0"
//!  xmlns:gml="http://www.opengis.net/gml" xmlns:bldg="http://www.opengis.net/citygml/building/2.0">
//!  <gml:boundedBy><gml:Envelope srsName="EPSG:25832" srsDimension="3"><gml:lowerCorner>0 0 0</gml:lowerCorner>
//!  <gml:upperCorner>99 9 9</gml:upperCorner></gml:Envelope></gml:boundedBy>
//!  <cityObjectMember><bldg:Building gml:id="a"><bldg:lod1Solid><gml:Solid><gml:exterior>
//!  <gml:CompositeSurface><gml:surfaceMember><gml:Polygon><gml:exterior><gml:LinearRing>
//!  <gml:posList>0 0 0 2 0 0 2 1 3 0 0 0</gml:posList></gml:LinearRing></gml:exterior>
//!  </gml:Polygon></gml:surfaceMember></gml:CompositeSurface></gml:exterior></gml:Solid>
//!  </bldg:lod1Solid></bldg:Building></cityObjectMember>
//!  <cityObjectMember><bldg:Building gml:id="b"><bldg:lod1Solid><gml:Solid><gml:exterior>
//!  <gml:CompositeSurface><gml:surfaceMember><gml:Polygon><gml:exterior><gml:LinearRing>
//!  <gml:posList>90 0 0 99 0 0 99 9 9 90 0 0</gml:posList></gml:LinearRing></gml:exterior>
//!  </gml:Polygon></gml:surfaceMember></gml:CompositeSurface></gml:exterior></gml:Solid>
//!  </bldg:lod1Solid></bldg:Building></cityObjectMember></CityModel>"##).unwrap();
//! let out = dir.path().join("out.gml");
//! let rule = Subset { ids: vec!["a".into()], ..Subset::default() };
//! let s = subset(&src, &out, &rule, &Default::default()).unwrap();
//! assert_eq!((s.members, s.members_kept), (2, 1));
//! let text = std::fs::read_to_string(&out).unwrap();
//! assert!(text.contains(r#"gml:id="a""#) && !text.contains(r#"gml:id="b""#));
//! assert!(text.contains("<gml:upperCorner>2 1 3</gml:upperCorner>"));
//! ```

pub(crate) mod lods;
pub(crate) mod subset;
mod tree;
pub(crate) mod walk;

pub use lods::{filter_lods, LodMode, Lods};
pub use subset::{subset, BboxMode, Subset};

use crate::io::citygml::error::{Location, ReadError, WriteError};
use crate::io::citygml::write::{check_target, WriteOptions};
use crate::model::Bbox;
use std::fmt;
use std::io::Write;
use std::path::Path;
use tree::{Kind, Tree};
use walk::Piece;

/// What an edit did.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
#[non_exhaustive]
pub struct EditSummary {
    /// Top-level members read.
    pub members: usize,
    /// Top-level members written.
    pub members_kept: usize,
    /// Nested features removed (thematic surfaces, parts, installations left without
    /// geometry by [`filter_lods`]).
    pub features_removed: usize,
    /// LoD geometry properties removed ([`filter_lods`]).
    pub lod_properties_removed: usize,
    /// References into removed content pruned (`xlink:href`, appearance targets).
    pub references_pruned: usize,
    /// Bytes of the (decompressed) source.
    pub bytes_in: u64,
    /// Bytes written (before compression).
    pub bytes_out: u64,
}

impl EditSummary {
    /// `a.gml -> b.gml: 12 of 40 city object(s) kept, ...`.
    pub fn describe(&self, input: &Path, out: &Path) -> String {
        let mut s = format!(
            "{} of {} city object(s) kept",
            self.members_kept, self.members
        );
        if self.lod_properties_removed > 0 || self.features_removed > 0 {
            s += &format!(
                ", {} LoD propert(ies) and {} nested feature(s) removed",
                self.lod_properties_removed, self.features_removed
            );
        }
        s += &format!(
            ", {} reference(s) pruned, {} -> {} bytes",
            self.references_pruned, self.bytes_in, self.bytes_out
        );
        crate::model::made_line(input, out, &s)
    }
}

impl fmt::Display for EditSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} of {} kept", self.members_kept, self.members)
    }
}

/// What a rule knows of the document besides the member.
struct Context<'a> {
    /// The document's `srsName` (the root envelope's, else the first member's).
    srs_name: Option<&'a str>,
}

/// A decision on one top-level member: drop it, or keep it with the nodes to cut.
enum Decision {
    Drop,
    Keep(Vec<usize>),
}

/// An edit of whole documents, one member at a time. A rule is made afresh for each pass and
/// must decide the same way both times.
trait Rule {
    fn member(
        &mut self,
        tree: &Tree,
        ctx: &Context<'_>,
        counts: &mut EditSummary,
    ) -> Result<Decision, String>;
}

/// Which nodes go: `cut` marks, and every descendant of a cut node is gone too.
struct Cuts {
    cut: Vec<bool>,
}

impl Cuts {
    fn new(tree: &Tree, nodes: &[usize]) -> Cuts {
        let mut cut = vec![false; tree.nodes.len()];
        for &i in nodes {
            if let Some(c) = cut.get_mut(i) {
                *c = true;
            }
        }
        Cuts { cut }
    }

    /// Whether node `i` or one of its ancestors is cut.
    fn gone(&self, tree: &Tree, i: usize) -> bool {
        self.cut.get(i).copied().unwrap_or(false)
            || tree
                .ancestors(i)
                .any(|a| self.cut.get(a).copied().unwrap_or(false))
    }

    /// The outermost cut spans, in document order.
    fn spans(&self, tree: &Tree) -> Vec<std::ops::Range<usize>> {
        let mut out: Vec<std::ops::Range<usize>> = Vec::new();
        for (i, n) in tree.nodes.iter().enumerate() {
            if self.cut[i] && out.last().is_none_or(|l| n.span.start >= l.end) {
                out.push(n.span.clone());
            }
        }
        out
    }

    /// Cut node `i` for a pruned reference, and then every ancestor left without a child
    /// element, up to the nearest feature (a CityGML 3.0 `TextureAssociation` left without
    /// its `target` goes too). Whether the climb reached the member itself.
    fn prune(&mut self, tree: &Tree, alive: &mut [u32], i: usize) -> bool {
        let mut at = i;
        self.cut[at] = true;
        loop {
            let Some(p) = tree.nodes[at].parent else {
                return true;
            };
            let n = &tree.nodes[p];
            let texture_association = n.kind == Kind::Feature
                && &*n.local == "TextureAssociation"
                && &*tree.nodes[at].local == "target";
            alive[p] = alive[p].saturating_sub(1);
            if n.kind == Kind::Feature && !texture_association {
                return false;
            }
            if alive[p] > 0 && !texture_association {
                return false;
            }
            if p == 0 {
                return true;
            }
            self.cut[p] = true;
            at = p;
        }
    }
}

/// The box of the coordinates that stay.
fn kept_box(tree: &Tree, cuts: &Cuts) -> Bbox {
    let mut b = Bbox::EMPTY;
    for (i, n) in tree.nodes.iter().enumerate() {
        if !n.bbox.is_empty() && !cuts.gone(tree, i) {
            b.add(n.bbox.min);
            b.add(n.bbox.max);
        }
    }
    b
}

/// The ids in what goes.
fn removed_ids(tree: &Tree, cuts: &Cuts, all: bool, into: &mut foldhash::HashSet<u64>) {
    for (i, n) in tree.nodes.iter().enumerate() {
        if let Some(id) = n.id {
            if all || cuts.gone(tree, i) {
                into.insert(id);
            }
        }
    }
}

/// Whether a child of the root is a top-level member.
pub(crate) fn is_member(local: &[u8]) -> bool {
    matches!(local, b"cityObjectMember" | b"featureMember")
}

/// The root envelope as found: the prefixes of `boundedBy` and `Envelope`, `srsName`,
/// `srsDimension`.
#[derive(Debug, Clone, Default)]
struct RootEnvelope {
    bounded_by: String,
    prefix: String,
    srs_name: Option<String>,
    dimension: u8,
}

impl RootEnvelope {
    /// From the bytes of the root's `gml:boundedBy`; `None` without a `gml:Envelope`.
    fn parse(bytes: &[u8]) -> Option<RootEnvelope> {
        let mut r = quick_xml::Reader::from_reader(bytes);
        let mut bounded_by = None;
        loop {
            match r.read_event().ok()? {
                quick_xml::events::Event::Start(e) | quick_xml::events::Event::Empty(e) => {
                    let name = String::from_utf8_lossy(e.name().into_inner()).into_owned();
                    let prefix = name.rfind(':').map_or("", |i| &name[..=i]).to_string();
                    if bounded_by.is_none() {
                        bounded_by = Some(prefix);
                        continue;
                    }
                    if e.local_name().into_inner() != b"Envelope" {
                        continue;
                    }
                    let attr = |k: &[u8]| {
                        e.attributes().with_checks(false).flatten().find_map(|a| {
                            (a.key.into_inner() == k)
                                .then(|| String::from_utf8_lossy(&a.value).into_owned())
                        })
                    };
                    return Some(RootEnvelope {
                        bounded_by: bounded_by.unwrap_or_default(),
                        prefix,
                        srs_name: attr(b"srsName"),
                        dimension: attr(b"srsDimension")
                            .and_then(|d| d.parse().ok())
                            .unwrap_or(3),
                    });
                }
                quick_xml::events::Event::Eof => return None,
                _ => {}
            }
        }
    }

    /// The root's `boundedBy` for the box `b` (nothing for an empty box).
    fn xml(&self, b: &Bbox) -> Vec<u8> {
        let site = crate::model::EnvelopeSite {
            span: 0..0,
            bbox: *b,
            srs_name: self.srs_name.clone(),
            dimension: self.dimension,
            prefix: self.prefix.clone(),
            file: 0,
        };
        match crate::io::citygml::write::envelope_xml(&site) {
            Some(env) => {
                format!("<{p}boundedBy>{env}</{p}boundedBy>", p = self.bounded_by).into_bytes()
            }
            None => Vec::new(),
        }
    }
}

fn tree_of(root: &[u8], bytes: &[u8], input: &Path, line: u64) -> Result<Tree, ReadError> {
    Tree::parse(root, bytes).map_err(|e| ReadError::Xml {
        loc: walk::location(input, line - 1, &bytes[..e.at.min(bytes.len())]),
        message: e.message,
    })
}

/// Prune the references into removed content that stay in `tree` (see the module docs).
/// Whether the member itself is left empty.
fn prune_references(
    tree: &Tree,
    cuts: &mut Cuts,
    removed: &foldhash::HashSet<u64>,
    counts: &mut EditSummary,
) -> bool {
    if removed.is_empty() {
        return false;
    }
    let mut alive = vec![0u32; tree.nodes.len()];
    for (i, n) in tree.nodes.iter().enumerate() {
        if let Some(p) = n.parent {
            if !cuts.gone(tree, i) {
                alive[p] += 1;
            }
        }
    }
    let mut emptied = false;
    for (i, n) in tree.nodes.iter().enumerate() {
        let refs_removed = [n.href, n.uri]
            .iter()
            .flatten()
            .any(|h| removed.contains(h));
        if refs_removed && !cuts.gone(tree, i) {
            counts.references_pruned += 1;
            emptied |= cuts.prune(tree, &mut alive, i);
        }
    }
    emptied
}

/// `bytes` without the cut spans.
fn write_cut(w: &mut dyn Write, bytes: &[u8], tree: &Tree, cuts: &Cuts) -> std::io::Result<u64> {
    let mut at = 0;
    let mut n = 0u64;
    for s in cuts.spans(tree) {
        let part = bytes.get(at..s.start).unwrap_or_default();
        w.write_all(part)?;
        n += part.len() as u64;
        at = s.end;
    }
    let rest = bytes.get(at..).unwrap_or_default();
    w.write_all(rest)?;
    Ok(n + rest.len() as u64)
}

/// Run `make`'s rule over the document at `input` into `out` (see the module docs); with no
/// `out`, the first pass only: the rule sees every member and nothing is written.
fn run<'r>(
    input: &Path,
    out: Option<&Path>,
    opts: &WriteOptions,
    make: &dyn Fn() -> Box<dyn Rule + 'r>,
) -> Result<EditSummary, WriteError> {
    if let Some(out) = out {
        check_target(out, opts, std::iter::once(input))?;
    }
    let bad_rule = |m: String, line: u64| ReadError::Xml {
        loc: Location {
            file: input.to_path_buf(),
            line,
            column: 0,
            gml_id: None,
        },
        message: m,
    };
    // Pass 1: what goes (ids), the box of what stays.
    let mut removed: foldhash::HashSet<u64> = Default::default();
    let mut kept = Bbox::EMPTY;
    let (mut root, mut srs, mut envelope) = (Vec::new(), None::<String>, None::<RootEnvelope>);
    let mut first = true;
    let mut scratch = EditSummary::default();
    let mut rule = make();
    walk::walk::<ReadError>(input, &mut |piece| {
        match piece {
            Piece::Root(b) => root = b.to_vec(),
            Piece::Child { local, bytes, line } => {
                if local == b"boundedBy" && first {
                    envelope = RootEnvelope::parse(bytes);
                    srs = envelope.as_ref().and_then(|e| e.srs_name.clone());
                } else if is_member(local) {
                    let tree = tree_of(&root, bytes, input, line)?;
                    if srs.is_none() {
                        srs.clone_from(&tree.srs_name);
                    }
                    let ctx = Context {
                        srs_name: srs.as_deref(),
                    };
                    match rule.member(&tree, &ctx, &mut scratch) {
                        Ok(Decision::Drop) => {
                            removed_ids(&tree, &Cuts::new(&tree, &[]), true, &mut removed)
                        }
                        Ok(Decision::Keep(nodes)) => {
                            let cuts = Cuts::new(&tree, &nodes);
                            removed_ids(&tree, &cuts, false, &mut removed);
                            let b = kept_box(&tree, &cuts);
                            if !b.is_empty() {
                                kept.add(b.min);
                                kept.add(b.max);
                            }
                        }
                        Err(m) => return Err(bad_rule(m, line)),
                    }
                }
                first = false;
            }
            Piece::Verbatim(_) => {}
        }
        Ok(())
    })?;
    let Some(out) = out else {
        return Ok(scratch);
    };
    // Pass 2: the same decisions, references pruned, written.
    let mut counts = EditSummary::default();
    let mut rule = make();
    let mut first = true;
    let io = |e| WriteError::Io {
        file: out.to_path_buf(),
        source: e,
    };
    let bytes_in = std::cell::Cell::new(0u64);
    let bytes_out = crate::io::citygml::write::atomic_write(out, |w| {
        let mut n = 0u64;
        let read = walk::walk::<WriteError>(input, &mut |piece| {
            match piece {
                Piece::Verbatim(b) => {
                    w.write_all(b).map_err(io)?;
                    n += b.len() as u64;
                }
                Piece::Root(_) => {}
                Piece::Child { local, bytes, line } => {
                    let was_first = std::mem::replace(&mut first, false);
                    if local == b"boundedBy" && was_first {
                        let xml = match &envelope {
                            Some(e) => e.xml(&kept),
                            None => bytes.to_vec(),
                        };
                        w.write_all(&xml).map_err(io)?;
                        n += xml.len() as u64;
                        return Ok(());
                    }
                    let tree = tree_of(&root, bytes, input, line)?;
                    let mut cuts = if is_member(local) {
                        counts.members += 1;
                        let ctx = Context {
                            srs_name: srs.as_deref(),
                        };
                        match rule.member(&tree, &ctx, &mut counts) {
                            Ok(Decision::Drop) => return Ok(()),
                            Ok(Decision::Keep(nodes)) => Cuts::new(&tree, &nodes),
                            Err(m) => return Err(bad_rule(m, line).into()),
                        }
                    } else {
                        Cuts::new(&tree, &[])
                    };
                    if prune_references(&tree, &mut cuts, &removed, &mut counts) {
                        return Ok(());
                    }
                    if is_member(local) {
                        counts.members_kept += 1;
                    }
                    n += write_cut(w, bytes, &tree, &cuts).map_err(io)?;
                }
            }
            Ok(())
        })?;
        bytes_in.set(read);
        Ok(n)
    })?;
    counts.bytes_in = bytes_in.get();
    counts.bytes_out = bytes_out;
    Ok(counts)
}
