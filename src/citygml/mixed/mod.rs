//! Mixed level-of-detail CityGML writer (DESIGN.md "Output", paper 4.6).
//!
//! [`write_mixed`] writes one source document of a [`CityModel`] again, every asset at the
//! level chosen for it:
//!
//! * **level 2**: the asset is copied verbatim;
//! * **level 1**: the asset's geometry is replaced by its rough geometry
//!   ([`RoughGeometry`]), in the same LoD property, so that a tool reading one LoD sees the
//!   whole model;
//! * **level 0**: the asset is dropped.
//!
//! The output keeps the version, the namespaces and everything the edits do not touch byte
//! for byte (it is written through [`write_document`]). It is schema-valid when the input is.
//!
//! # Rules and decisions
//!
//! **Level 1.** Which property gets what is decided by [`crate::level::properties`], the one
//! definition the report, the traced LoD scene and `evaluate` share. Let `L` be the LoD of the rough geometry (`rough.lod`, the LoD its input was
//! taken from). Every polygonal LoD property of the asset at LoD `L` *and above* gets the rough
//! geometry: a property left at a higher LoD with its full detail would make the asset full
//! detail for a tool reading that LoD. Properties *below* `L` are kept verbatim (they are
//! already coarser and describe the same object). The encoding follows the property's schema
//! type: `lodNSolid` gets a `gml:Solid` whose exterior is a `gml:CompositeSurface` (GML 3.1.1,
//! CityGML 1.0/2.0) or a `gml:Shell` (GML 3.2, CityGML 3.0) of the rough polygons (the six faces
//! of an oriented box for installations, openings and bodies: a closed shell);
//! `lodNMultiSurface`, `lodNGeometry`, `lod0FootPrint`, `lod0RoofEdge` get a `gml:MultiSurface`;
//! other `lodNSurface` properties (a `gml:_Surface`) get a `gml:CompositeSurface`. Properties
//! whose type admits none of these (`lodNImplicitRepresentation`, relief `tin`/`grid`) are
//! kept verbatim: an implicit geometry is a shared prototype and cannot hold world
//! coordinates. When the rough geometry *is* the property's own geometry (a shell surface whose
//! LoD2 is used unchanged beside its LoD3) that property is kept verbatim too, ids included.
//! A property given by reference (`<bldg:lod2MultiSurface xlink:href="#x"/>`) is rewritten as a
//! property holding the rough geometry. If the rough geometry is empty the asset is kept verbatim.
//! A property is never given *more* polygons than it holds: when the rough geometry has more
//! polygons (the six faces of the box of a window that is a single quad, degenerate when the
//! window is flat), the property is kept verbatim, as it is already as rough as it gets; its
//! polygons lie inside the box the rough stage traced, so the selection stays conservative.
//!
//! New geometry gets deterministic `gml:id`s `skylod_<asset id or a<index>>_g<property>` with
//! `_<n>` per polygon (and `_s` for a shell or composite surface), in the document's GML
//! prefix, with `srsDimension="3"` on every `posList`. Characters that an `xs:ID` cannot hold
//! are replaced by `_`; a candidate that meets any id of the document, or one already
//! generated, gets a `_<k>` suffix until it is unique.
//!
//! **Level 0.** The asset's element is removed with its enclosing property element
//! (`bldg:boundedBy`, `bldg:opening`, `bldg:outerBuildingInstallation`, `con:fillingSurface`,
//! `core:cityObjectMember`, ...) because an empty property is invalid. Generally: when an
//! element is removed, its parent goes too if it is a property (lower-case local name) or a GML
//! object that is left without child elements; features (upper-case, non-GML) stop the climb,
//! the document root is never removed. A *Body* asset (a building's own geometry) at level 0
//! loses its geometry properties. A level-0 asset that contains kept assets (a wall with a
//! level-2 window) is kept as a container without geometry: its LoD properties are removed, the
//! rest stays, and it carries `skylod_level` 0 (a reader sees no asset there: it has no
//! geometry). A building or building part that held assets or geometry and is left with no kept
//! asset, no own geometry and no kept part is removed as a whole, with its `cityObjectMember` /
//! `consistsOfBuildingPart` / `buildingPart` wrapper; a building's own geometry that is not an
//! asset (e.g. an `lod1Solid` beside LoD2 thematic surfaces) counts as kept geometry.
//!
//! **Level attribute.** Every kept asset carries its level as a generic attribute named
//! `skylod_level`: `gen:intAttribute` in CityGML 1.0/2.0, `core:genericAttribute/gen:IntAttribute`
//! in 3.0, inserted after the feature's leading GML and core CityObject properties (description,
//! name, boundedBy, creationDate, terminationDate, externalReference, generalizesTo,
//! relativeToTerrain, relativeToWater, appearance, other generic attributes; in 3.0 also
//! validFrom/validTo, relatedTo), which is where the XSD admits it. The document's prefixes are
//! used when the root declares them (and no element redeclares them); otherwise the namespaces
//! are declared on the inserted element. A `skylod_level` already present (output written
//! again) is replaced. For a Body asset the attribute goes on the building.
//!
//! **References.** After the edits, every `xlink:href="#id"` in content that is kept is checked:
//! when its target lies in removed or replaced content, the referencing element is pruned. A
//! member of a *connected* structure (`Solid`, `Shell`, `CompositeSurface`, `CompositeSolid`,
//! `CompositeCurve`, `OrientableSurface`, `Surface`, `TriangulatedSurface`, `Tin`) makes the
//! outermost such structure broken: it is removed as a whole (a solid missing faces is not a
//! solid; the level-1 faces written instead do not form a shell), e.g. a building's `lod3Solid`
//! made of references to the polygons of level-1 surfaces. Members of aggregates (`MultiSurface`,
//! `MultiGeometry`, ...) are removed one by one, and an aggregate or property left empty is
//! removed by the climbing rule above. Non-geometry references (`bldg:opening xlink:href`,
//! `core:generalizesTo`, ...) whose target is gone are removed likewise. This runs to a fixed
//! point together with the building rule, since a pruned property can empty a building.
//!
//! **Appearances.** `app:target` (text `#id`, or `uri="#id"` on a 2.0 ParameterizedTexture
//! target; in 3.0 the `TextureAssociation` holding it) pointing into removed or replaced content
//! is removed; a surface data object (`ParameterizedTexture`, `X3DMaterial`,
//! `GeoreferencedTexture`) left without targets is removed with its `surfaceDataMember` /
//! `surfaceData`; an `Appearance` left without surface data is removed with its
//! `appearanceMember` / `appearance`.
//!
//! **Envelopes.** Every `gml:Envelope` whose owner's geometry the reader knew is recomputed
//! from the geometry actually written (kept polygons, minus pruned references, plus rough
//! geometry); an envelope whose owner is left without geometry is removed with its
//! `gml:boundedBy` (optional everywhere). [`WriteOptions::keep_envelopes`] keeps them as they are.
//!
//! # Implementation
//!
//! The reader records the spans of assets, buildings and LoD properties but not the enclosing
//! property elements, appearances, references or every `gml:id`. Since appearances need a
//! second streaming pass over the source anyway (allowed by the design), that one pass
//! (namespace-aware, [`quick_xml::NsReader`]) records a compact index of every element (spans,
//! parent, name, id, reference), and every decision above is taken on it; the reader stays as it
//! is (its speed is benchmarked). Memory is about 40 bytes per element plus the ids.
//!
//! # Example
//! ```
//! use skylod::citygml::{read_file, mixed::write_mixed, write::WriteOptions};
//! use skylod::rough::{rough_model, RoughOptions};
//! let dir = tempfile::tempdir().unwrap();
//! let src = dir.path().join("in.gml");
//! std::fs::write(&src, br#"<CityModel xmlns="http://www.opengis.net/citygml/2.0"
//!  xmlns:gml="http://www.opengis.net/gml" xmlns:bldg="http://www.opengis.net/citygml/building/2.0">
//!  <cityObjectMember><bldg:Building gml:id="b"><bldg:boundedBy><bldg:RoofSurface gml:id="r">
//!  <bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember><gml:Polygon><gml:exterior>
//!  <gml:LinearRing><gml:posList>0 0 5 2 0 5 2 4 5 0 4 5 0 0 5</gml:posList></gml:LinearRing>
//!  </gml:exterior></gml:Polygon></gml:surfaceMember><gml:surfaceMember><gml:Polygon><gml:exterior>
//!  <gml:LinearRing><gml:posList>2 0 5 4 0 5 4 4 5 2 4 5 2 0 5</gml:posList></gml:LinearRing>
//!  </gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface>
//!  </bldg:RoofSurface></bldg:boundedBy><bldg:boundedBy><bldg:WallSurface gml:id="w">
//!  <bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember><gml:Polygon><gml:exterior>
//!  <gml:LinearRing><gml:posList>0 0 0 4 0 0 4 0 5 0 0 5 0 0 0</gml:posList></gml:LinearRing>
//!  </gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface>
//!  </bldg:WallSurface></bldg:boundedBy></bldg:Building></cityObjectMember></CityModel>"#).unwrap();
//! let model = read_file(&src).unwrap();
//! let rough = rough_model(&model, &RoughOptions::default());
//! let out = dir.path().join("out.gml");
//! // roof rough (level 1), wall dropped (level 0)
//! let s = write_mixed(&model, 0, &rough, &[1, 0], &out, &WriteOptions::default()).unwrap();
//! assert_eq!(s.levels, [1, 1, 0]);
//! assert_eq!((s.polygons_in, s.polygons_out), (3, 1)); // two roof halves merged, wall dropped
//! let text = std::fs::read_to_string(&out).unwrap();
//! assert!(!text.contains("WallSurface"));
//! assert!(text.contains(r#"<gen:intAttribute xmlns:gen="http://www.opengis.net/citygml/generics/2.0" name="skylod_level"><gen:value>1</gen:value></gen:intAttribute>"#));
//! assert!(text.contains(r#"<gml:MultiSurface gml:id="skylod_r_g0">"#));
//! let again = read_file(&out).unwrap();
//! assert_eq!(again.assets.len(), 1);
//! ```

use super::error::{ReadError, WriteError};
use super::ns::{self, Module, Ns};
use super::source;
use super::write::WriteOptions;
use super::write::{check_target, envelope_xml, escape_attr, write_document, Edit, GmlWriter};
use crate::model::{Asset, AssetKind, Bbox, CityGmlVersion, CityModel, Polygon};
use crate::rough::RoughGeometry;
use foldhash::{HashMap, HashMapExt, HashSet, HashSetExt};
use quick_xml::events::{BytesStart, Event};
use quick_xml::name::ResolveResult;
use quick_xml::NsReader;
use std::fmt::Write as _;
use std::path::Path;

/// What [`write_mixed`] wrote.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct MixedSummary {
    /// Bytes written (before compression).
    pub bytes: u64,
    /// Assets of the file per level `[level 0, level 1, level 2]`.
    pub levels: [usize; 3],
    /// Level-0 assets kept as containers of kept assets (no geometry of their own).
    pub containers: usize,
    /// Asset polygons of the file in the input (all LoDs, references counted per use).
    pub polygons_in: usize,
    /// Asset polygons written (kept verbatim plus rough; references counted per use).
    pub polygons_out: usize,
    /// Buildings and building parts removed because nothing of them was kept.
    pub buildings_dropped: usize,
    /// `xlink:href` references found pointing into removed or replaced content (each one
    /// pruned; references that vanish with a structure such a pruning removed, e.g. the other
    /// faces of a broken `gml:Solid`, are not counted again).
    pub hrefs_pruned: usize,
    /// Appearance targets pruned.
    pub appearance_targets_pruned: usize,
}

/// Write file `file` of `model` to `out` with every asset at its level (see the module docs).
///
/// `rough[i]` and `levels[i]` belong to `model.assets[i]`; only the assets of `file` are
/// looked at. Levels above 2 count as 2.
pub fn write_mixed(
    model: &CityModel,
    file: usize,
    rough: &[RoughGeometry],
    levels: &[u8],
    out: &Path,
    opts: &WriteOptions,
) -> Result<MixedSummary, WriteError> {
    if levels.len() != model.assets.len() || rough.len() != model.assets.len() {
        return Err(WriteError::Invalid(format!(
            "{} assets, {} levels and {} rough geometries: one of each per asset expected",
            model.assets.len(),
            levels.len(),
            rough.len()
        )));
    }
    let Some(src) = model.files.get(file) else {
        return Err(WriteError::Invalid(format!("no source file {file}")));
    };
    check_target(out, opts, std::iter::once(src.path.as_path()))?;
    let doc = scan(&src.path)?;
    let mut plan = Plan::new(model, file, rough, levels, &doc);
    plan.run(opts.keep_envelopes);
    let edits = plan.edits();
    let wopts = WriteOptions {
        keep_envelopes: true,
        ..opts.clone()
    };
    let w = write_document(model, file, edits, out, &wopts)?;
    let mut summary = plan.summary;
    summary.bytes = w.bytes;
    Ok(summary)
}

// ---------------------------------------------------------------------------------------------
// The element index
// ---------------------------------------------------------------------------------------------

const NONE: u32 = u32::MAX;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum NsKind {
    Gml,
    Core,
    App,
    Gen,
    OtherCityGml,
    Other,
}

#[derive(Debug)]
struct Name {
    qname: String,
    local: String,
    ns: NsKind,
    upper: bool,
}

#[derive(Debug, Clone, Copy)]
struct Node {
    start: u64,
    end: u64,
    content_start: u64,
    parent: u32,
    last_desc: u32,
    name: u32,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum RefKind {
    Href,
    AppTarget,
}

#[derive(Debug, Default)]
struct Doc {
    nodes: Vec<Node>,
    names: Vec<Name>,
    ids: HashMap<Box<str>, u32>,
    /// (node, kind, reference) in document order.
    refs: Vec<(u32, RefKind, Box<str>)>,
    /// `name` attribute (2.0 generic attributes) or `gen:name` text (3.0), per node.
    labels: HashMap<u32, Box<str>>,
    /// Namespace declarations of the root: prefix ("" = default) -> URI.
    root_ns: Vec<(String, String)>,
    /// Prefixes ("" = default) declared again below the root.
    redeclared: HashSet<String>,
}

impl Doc {
    fn node_at(&self, start: u64) -> Option<u32> {
        self.nodes
            .binary_search_by(|n| n.start.cmp(&start))
            .ok()
            .map(|i| i as u32)
    }

    fn name(&self, n: u32) -> &Name {
        &self.names[self.nodes[n as usize].name as usize]
    }

    fn parent(&self, n: u32) -> Option<u32> {
        let p = self.nodes[n as usize].parent;
        (p != NONE).then_some(p)
    }

    fn children(&self, n: u32) -> Children<'_> {
        Children {
            doc: self,
            next: n + 1,
            last: self.nodes[n as usize].last_desc,
        }
    }

    /// Prefix (with colon, or empty for the default namespace) bound to `uri` on the root and
    /// never redeclared.
    fn prefix_for(&self, uri: &str) -> Option<String> {
        self.root_ns
            .iter()
            .find(|(p, u)| u == uri && !self.redeclared.contains(p))
            .map(|(p, _)| {
                if p.is_empty() {
                    String::new()
                } else {
                    format!("{p}:")
                }
            })
    }
}

struct Children<'a> {
    doc: &'a Doc,
    next: u32,
    last: u32,
}

impl Iterator for Children<'_> {
    type Item = u32;
    fn next(&mut self) -> Option<u32> {
        if self.next == NONE || self.next > self.last || self.last == NONE {
            return None;
        }
        let c = self.next;
        self.next = self.doc.nodes[c as usize].last_desc.saturating_add(1);
        Some(c)
    }
}

fn ns_kind(uri: Option<&[u8]>) -> NsKind {
    match uri.map(ns::classify) {
        Some(Ns::Gml) => NsKind::Gml,
        Some(Ns::CityGml(Module::Core, _)) => NsKind::Core,
        Some(Ns::CityGml(Module::Appearance, _)) => NsKind::App,
        Some(Ns::CityGml(Module::Generics, _)) => NsKind::Gen,
        Some(Ns::CityGml(..)) => NsKind::OtherCityGml,
        _ => NsKind::Other,
    }
}

fn xml_err(path: &Path, at: u64, message: String) -> WriteError {
    WriteError::Read(ReadError::Xml {
        loc: super::error::Location {
            file: path.to_path_buf(),
            line: 0,
            column: 0,
            gml_id: None,
        },
        message: format!("at byte {at}: {message}"),
    })
}

#[derive(Clone, Copy, PartialEq)]
enum TextCapture {
    None,
    Target(u32),
    Label(u32),
}

/// One streaming pass over the source: the element index.
fn scan(path: &Path) -> Result<Doc, WriteError> {
    let (mut reader, _) = source::open(path)?;
    let base = source::skip_bom(&mut reader, path)?;
    let mut reader = NsReader::from_reader(reader);
    reader.config_mut().trim_text(false);
    reader.config_mut().check_end_names = true;
    let mut doc = Doc::default();
    let mut name_ids: HashMap<(Vec<u8>, NsKind), u32> = HashMap::new();
    let mut stack: Vec<u32> = Vec::with_capacity(64);
    let mut buf = Vec::with_capacity(64 * 1024);
    let mut capture = TextCapture::None;
    let mut text: Vec<u8> = Vec::new();
    loop {
        let pos = reader.buffer_position() + base;
        let ev = match reader.read_event_into(&mut buf) {
            Ok(ev) => ev,
            Err(e) => return Err(xml_err(path, reader.error_position() + base, e.to_string())),
        };
        match ev {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let empty = matches!(ev, Event::Empty(_));
                let (res, _) = reader.resolve_element(e.name());
                let uri = match res {
                    ResolveResult::Bound(n) => Some(n.0),
                    _ => None,
                };
                let kind = ns_kind(uri);
                let qname = e.name();
                let key = (qname.as_ref().to_vec(), kind);
                let name = match name_ids.get(&key) {
                    Some(&i) => i,
                    None => {
                        let i = doc.names.len() as u32;
                        let local = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
                        doc.names.push(Name {
                            qname: String::from_utf8_lossy(qname.as_ref()).into_owned(),
                            upper: local.starts_with(|c: char| c.is_ascii_uppercase()),
                            local,
                            ns: kind,
                        });
                        name_ids.insert(key, i);
                        i
                    }
                };
                let idx = doc.nodes.len() as u32;
                let content_start = reader.buffer_position() + base;
                doc.nodes.push(Node {
                    start: pos,
                    end: if empty { content_start } else { 0 },
                    content_start,
                    parent: stack.last().copied().unwrap_or(NONE),
                    last_desc: idx,
                    name,
                });
                scan_attrs(&reader, e, idx, kind, stack.is_empty(), &mut doc, path)?;
                let local = doc.names[name as usize].local.as_str();
                let capture_here = match (kind, local) {
                    (NsKind::App, "target") => Some(TextCapture::Target(idx)),
                    (NsKind::Gen, "name") => Some(TextCapture::Label(idx)),
                    _ => None,
                };
                if !empty {
                    stack.push(idx);
                    if let Some(c) = capture_here {
                        if !(c == TextCapture::Target(idx)
                            && doc.refs.last().is_some_and(|r| r.0 == idx))
                        {
                            capture = c;
                            text.clear();
                        }
                    }
                }
            }
            Event::End(_) => {
                let end = reader.buffer_position() + base;
                if let Some(idx) = stack.pop() {
                    let last = doc.nodes.len() as u32 - 1;
                    let n = &mut doc.nodes[idx as usize];
                    n.end = end;
                    n.last_desc = last;
                    match capture {
                        TextCapture::Target(t) if t == idx => {
                            let s = String::from_utf8_lossy(&text).trim().to_string();
                            if !s.is_empty() {
                                doc.refs.push((idx, RefKind::AppTarget, s.into()));
                            }
                            capture = TextCapture::None;
                        }
                        TextCapture::Label(t) if t == idx => {
                            let s = String::from_utf8_lossy(&text).trim().to_string();
                            doc.labels.insert(idx, s.into());
                            capture = TextCapture::None;
                        }
                        _ => {}
                    }
                }
            }
            Event::Text(t) if capture != TextCapture::None => text.extend_from_slice(&t),
            Event::CData(t) if capture != TextCapture::None => text.extend_from_slice(&t),
            Event::Eof => break,
            _ => {}
        }
        buf.clear();
    }
    if !stack.is_empty() || doc.nodes.is_empty() {
        return Err(xml_err(
            path,
            reader.buffer_position() + base,
            "unexpected end of document".into(),
        ));
    }
    Ok(doc)
}

fn scan_attrs<R>(
    reader: &NsReader<R>,
    e: &BytesStart,
    idx: u32,
    kind: NsKind,
    is_root: bool,
    doc: &mut Doc,
    path: &Path,
) -> Result<(), WriteError> {
    if memchr::memchr(b'=', e.attributes_raw()).is_none() {
        return Ok(());
    }
    let local = doc.names[doc.nodes[idx as usize].name as usize]
        .local
        .clone();
    for attr in e.attributes().with_checks(false) {
        let attr = attr.map_err(|err| xml_err(path, 0, format!("bad attribute: {err}")))?;
        let key = attr.key.as_ref();
        let value = || -> Result<String, WriteError> {
            attr.unescape_value()
                .map(|v| v.into_owned())
                .map_err(|err| xml_err(path, 0, format!("bad attribute value: {err}")))
        };
        if key == b"xmlns" || key.starts_with(b"xmlns:") {
            let prefix = String::from_utf8_lossy(key.get(6..).unwrap_or_default()).into_owned();
            if is_root {
                doc.root_ns.push((prefix, value()?));
            } else {
                doc.redeclared.insert(prefix);
            }
            continue;
        }
        let lname = attr.key.local_name();
        match lname.as_ref() {
            b"id" | b"href" if attr.key.prefix().is_some() => {
                let (res, _) = reader.resolve_attribute(attr.key);
                let ResolveResult::Bound(n) = res else {
                    continue;
                };
                match (lname.as_ref(), ns::classify(n.0)) {
                    (b"id", Ns::Gml) => {
                        doc.ids.entry(value()?.into()).or_insert(idx);
                    }
                    (b"href", Ns::Xlink) => {
                        doc.refs
                            .push((idx, RefKind::Href, value()?.trim().to_string().into()));
                    }
                    _ => {}
                }
            }
            b"uri" if attr.key.prefix().is_none() && kind == NsKind::App && local == "target" => {
                doc.refs
                    .push((idx, RefKind::AppTarget, value()?.trim().to_string().into()));
            }
            b"name" if attr.key.prefix().is_none() && kind == NsKind::Gen => {
                doc.labels.insert(idx, value()?.into());
            }
            _ => {}
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// The plan
// ---------------------------------------------------------------------------------------------

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Enc {
    MultiSurface,
    CompositeSurface,
    Solid,
    Keep,
}

/// Schema encoding of rough geometry for a LoD property (by local name).
fn encoding(prop: &str) -> Enc {
    if prop.contains("Implicit") || prop.contains("Curve") || prop.contains("TerrainIntersection") {
        Enc::Keep
    } else if prop.ends_with("Solid") {
        Enc::Solid
    } else if prop.ends_with("MultiSurface")
        || prop.ends_with("Geometry")
        || prop == "lod0FootPrint"
        || prop == "lod0RoofEdge"
    {
        Enc::MultiSurface
    } else if prop.starts_with("lod") && prop.ends_with("Surface") {
        Enc::CompositeSurface
    } else {
        Enc::Keep
    }
}

const CONNECTED: &[&str] = &[
    "Solid",
    "Shell",
    "CompositeSurface",
    "CompositeSolid",
    "CompositeCurve",
    "OrientableSurface",
    "Surface",
    "TriangulatedSurface",
    "Tin",
];

const CORE_LEADING: &[&str] = &[
    "creationDate",
    "terminationDate",
    "validFrom",
    "validTo",
    "externalReference",
    "generalizesTo",
    "relativeToTerrain",
    "relativeToWater",
    "relatedTo",
    "appearance",
    "genericAttribute",
];

struct Replacement {
    node: u32,
    /// Content span of the property in the source.
    content: crate::model::Span,
    /// Rewrite the whole element (it was a reference or empty), else only its content.
    whole: bool,
    xml: String,
    polygons: Vec<Polygon>,
}

struct Plan<'a> {
    model: &'a CityModel,
    file: usize,
    rough: &'a [RoughGeometry],
    levels: &'a [u8],
    doc: &'a Doc,
    version: CityGmlVersion,
    gml: String,
    gml_decl: String,
    removed: Vec<bool>,
    replaced: Vec<bool>,
    replacements: Vec<Replacement>,
    inserts: Vec<Edit>,
    envelope_edits: Vec<Edit>,
    containers: Vec<bool>,
    used_ids: HashSet<String>,
    ref_nodes: HashSet<u32>,
    /// Per building: its parts, and the assets of the file it owns.
    parts: Vec<Vec<usize>>,
    owned: Vec<Vec<usize>>,
    summary: MixedSummary,
}

impl<'a> Plan<'a> {
    fn new(
        model: &'a CityModel,
        file: usize,
        rough: &'a [RoughGeometry],
        levels: &'a [u8],
        doc: &'a Doc,
    ) -> Self {
        let src = &model.files[file];
        let gml_uri = if src.version == CityGmlVersion::V3_0 {
            ns::GML_32
        } else {
            ns::GML_311
        };
        let (gml, gml_decl) = if src.gml_prefix.is_empty() {
            (
                "gml:".to_string(),
                format!(" xmlns:gml=\"{}\"", String::from_utf8_lossy(gml_uri)),
            )
        } else {
            (src.gml_prefix.clone(), String::new())
        };
        Plan {
            model,
            file,
            rough,
            levels,
            doc,
            version: src.version,
            gml,
            gml_decl,
            removed: vec![false; doc.nodes.len()],
            replaced: vec![false; doc.nodes.len()],
            replacements: Vec::new(),
            inserts: Vec::new(),
            envelope_edits: Vec::new(),
            containers: vec![false; model.assets.len()],
            used_ids: HashSet::new(),
            ref_nodes: doc.refs.iter().map(|r| r.0).collect(),
            parts: {
                let mut v = vec![Vec::new(); model.buildings.len()];
                for (i, b) in model.buildings.iter().enumerate() {
                    if let Some(p) = b.parent.filter(|&p| p < v.len()) {
                        v[p].push(i);
                    }
                }
                v
            },
            owned: {
                let mut v = vec![Vec::new(); model.buildings.len()];
                for (i, a) in model.assets.iter().enumerate() {
                    if let Some(b) = a.building.filter(|&b| b < v.len() && a.file == file) {
                        v[b].push(i);
                    }
                }
                v
            },
            summary: MixedSummary::default(),
        }
    }

    fn level(&self, a: usize) -> u8 {
        self.levels[a].min(2)
    }

    fn file_assets(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.model.assets.len()).filter(|&a| self.model.assets[a].file == self.file)
    }

    /// Element of an asset (the building for a Body).
    fn asset_node(&self, a: &Asset) -> Option<u32> {
        self.doc.node_at(a.span.start)
    }

    fn is_dead(&self, n: u32) -> bool {
        let mut x = n;
        let mut first = true;
        loop {
            if self.removed[x as usize] || (!first && self.replaced[x as usize]) {
                return true;
            }
            first = false;
            match self.doc.parent(x) {
                Some(p) => x = p,
                None => return false,
            }
        }
    }

    fn has_living_child(&self, p: u32, pred: impl Fn(&Name) -> bool) -> bool {
        self.doc
            .children(p)
            .any(|c| !self.removed[c as usize] && pred(self.doc.name(c)))
    }

    /// Should `p` go after losing a child?
    fn empty_after_loss(&self, p: u32) -> bool {
        if self.doc.parent(p).is_none() || self.replaced[p as usize] {
            return false;
        }
        let name = self.doc.name(p);
        match (name.ns, name.local.as_str()) {
            (NsKind::App, "ParameterizedTexture" | "X3DMaterial" | "GeoreferencedTexture") => !self
                .has_living_child(p, |n| {
                    n.local == "target" || n.local == "textureParameterization"
                }),
            (NsKind::App, "Appearance") => !self.has_living_child(p, |n| {
                n.local == "surfaceDataMember" || n.local == "surfaceData"
            }),
            (NsKind::App, "TextureAssociation") => {
                !self.has_living_child(p, |n| n.local == "target")
            }
            // CityGML 3.0: a relation must name the object it relates to.
            (_, "CityObjectRelation") => !self.has_living_child(p, |n| n.local == "relatedTo"),
            (NsKind::Gml, _) => !self.has_living_child(p, |_| true),
            _ if !name.upper => !self.has_living_child(p, |_| true),
            _ => false,
        }
    }

    /// Remove `n` and climb (see the module docs). The root is never removed.
    fn remove(&mut self, n: u32) {
        if self.doc.parent(n).is_none() {
            return;
        }
        self.removed[n as usize] = true;
        let mut x = n;
        while let Some(p) = self.doc.parent(x) {
            if self.empty_after_loss(p) {
                self.removed[p as usize] = true;
                x = p;
            } else {
                break;
            }
        }
    }

    fn run(&mut self, keep_envelopes: bool) {
        let assets: Vec<usize> = self.file_assets().collect();
        let mut children: HashMap<usize, Vec<usize>> = HashMap::new();
        for &a in &assets {
            if let Some(p) = self.model.assets[a].parent {
                children.entry(p).or_default().push(a);
            }
        }
        for &a in &assets {
            let l = self.level(a);
            self.summary.levels[l as usize] += 1;
            self.summary.polygons_in += self.model.assets[a].polygon_count();
        }
        // containers: level 0 with a kept descendant
        fn kept_below(
            a: usize,
            children: &HashMap<usize, Vec<usize>>,
            levels: &[u8],
            depth: usize,
        ) -> bool {
            depth < 64
                && children.get(&a).is_some_and(|cs| {
                    cs.iter()
                        .any(|&c| levels[c] > 0 || kept_below(c, children, levels, depth + 1))
                })
        }
        for &a in &assets {
            if self.level(a) == 0 && kept_below(a, &children, self.levels, 0) {
                self.containers[a] = true;
                self.summary.containers += 1;
            }
        }
        // level 0 and 1
        for &a in &assets {
            let asset = &self.model.assets[a];
            match self.level(a) {
                0 => {
                    if asset.kind == AssetKind::Body || self.containers[a] {
                        for g in &asset.geometries {
                            if let Some(n) = self.doc.node_at(g.span.start) {
                                self.remove(n);
                            }
                        }
                    } else if let Some(n) = self.asset_node(asset) {
                        self.remove(n);
                    }
                }
                1 => self.roughen(a),
                _ => {}
            }
        }
        // references and buildings, to a fixed point
        loop {
            let mut changed = self.prune_refs();
            if !changed {
                changed = self.drop_buildings();
            }
            if !changed {
                break;
            }
        }
        // level attributes
        for &a in &assets {
            let l = self.level(a);
            if l == 0 && !self.containers[a] {
                continue;
            }
            let asset = &self.model.assets[a];
            let Some(n) = self.asset_node(asset) else {
                continue;
            };
            if self.is_dead(n) {
                continue;
            }
            self.insert_level(n, l);
        }
        // written geometry: polygon counts and envelopes
        let written = self.written();
        self.summary.polygons_out = written.iter().filter(|w| w.asset).map(|w| w.polygons).sum();
        if !keep_envelopes {
            self.envelopes(&written);
        }
    }

    fn fresh_id(&mut self, base: &str, polygons: usize) -> String {
        let clean: String = base
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        let mut k = 0usize;
        loop {
            let cand = if k == 0 {
                clean.clone()
            } else {
                format!("{clean}_{k}")
            };
            let taken = |s: &str| self.doc.ids.contains_key(s) || self.used_ids.contains(s);
            let clash = taken(&cand)
                || taken(&format!("{cand}_s"))
                || (0..polygons).any(|i| taken(&format!("{cand}_{i}")));
            if !clash {
                self.used_ids.insert(cand.clone());
                self.used_ids.insert(format!("{cand}_s"));
                for i in 0..polygons {
                    self.used_ids.insert(format!("{cand}_{i}"));
                }
                return cand;
            }
            k += 1;
        }
    }

    fn geometry_xml(&self, enc: Enc, id: &str, polys: &[Polygon]) -> String {
        let w = GmlWriter {
            gml: self.gml.clone(),
            ids: true,
        };
        let g = &self.gml;
        let decl = &self.gml_decl;
        let id = escape_attr(id);
        let mut s = String::with_capacity(256 + polys.len() * 256);
        let members = |s: &mut String| {
            for (n, p) in polys.iter().enumerate() {
                let _ = write!(s, "<{g}surfaceMember>");
                w.polygon(s, &format!("{id}_{n}"), p);
                let _ = write!(s, "</{g}surfaceMember>");
            }
        };
        match enc {
            Enc::MultiSurface | Enc::Keep => {
                let _ = write!(s, "<{g}MultiSurface{decl} {g}id=\"{id}\">");
                members(&mut s);
                let _ = write!(s, "</{g}MultiSurface>");
            }
            Enc::CompositeSurface => {
                let _ = write!(s, "<{g}CompositeSurface{decl} {g}id=\"{id}\">");
                members(&mut s);
                let _ = write!(s, "</{g}CompositeSurface>");
            }
            Enc::Solid => {
                let shell = if self.version == CityGmlVersion::V3_0 {
                    "Shell"
                } else {
                    "CompositeSurface"
                };
                let _ = write!(
                    s,
                    "<{g}Solid{decl} {g}id=\"{id}\"><{g}exterior><{g}{shell} {g}id=\"{id}_s\">"
                );
                members(&mut s);
                let _ = write!(s, "</{g}{shell}></{g}exterior></{g}Solid>");
            }
        }
        s
    }

    /// Level 1: replace the asset's geometry properties at and above the rough LoD.
    fn roughen(&mut self, a: usize) {
        let asset = &self.model.assets[a];
        let r = &self.rough[a];
        if r.polygons.is_empty() {
            return;
        }
        let base = match &asset.id {
            Some(id) => format!("skylod_{id}"),
            None => format!("skylod_a{a}"),
        };
        for (j, out) in crate::level::properties(asset, Some(r), 1)
            .iter()
            .enumerate()
        {
            if !out.rough {
                continue;
            }
            let g = out.geometry;
            let enc = encoding(&g.property);
            let Some(n) = self.doc.node_at(g.span.start) else {
                continue;
            };
            let id = self.fresh_id(&format!("{base}_g{j}"), r.polygons.len());
            let geom = self.geometry_xml(enc, &id, &r.polygons);
            let node = self.doc.nodes[n as usize];
            let has_ref = self.ref_nodes.contains(&n);
            let whole = has_ref || node.end == node.content_start || g.content.is_empty();
            let xml = if whole {
                let q = &self.doc.name(n).qname;
                format!("<{q}>{geom}</{q}>")
            } else {
                geom
            };
            self.replaced[n as usize] = true;
            self.replacements.push(Replacement {
                node: n,
                content: g.content.clone(),
                whole,
                xml,
                polygons: r.polygons.clone(),
            });
        }
    }

    /// Prune references into removed or replaced content; true when something changed.
    fn prune_refs(&mut self) -> bool {
        let mut changed = false;
        for i in 0..self.doc.refs.len() {
            let (r, kind, ref target) = self.doc.refs[i];
            if self.replaced[r as usize] || self.is_dead(r) {
                continue;
            }
            let Some(id) = target.strip_prefix('#') else {
                continue;
            };
            let Some(&t) = self.doc.ids.get(id) else {
                continue;
            };
            if !self.is_dead(t) {
                continue;
            }
            changed = true;
            match kind {
                RefKind::AppTarget => {
                    self.summary.appearance_targets_pruned += 1;
                    let victim = match self.doc.parent(r) {
                        Some(p)
                            if self.doc.name(p).ns == NsKind::App
                                && self.doc.name(p).local == "TextureAssociation" =>
                        {
                            p
                        }
                        _ => r,
                    };
                    self.remove(victim);
                }
                RefKind::Href => {
                    self.summary.hrefs_pruned += 1;
                    let mut victim = r;
                    let mut x = r;
                    if self.doc.name(r).ns == NsKind::Gml {
                        while let Some(p) = self.doc.parent(x) {
                            let name = self.doc.name(p);
                            if name.ns != NsKind::Gml {
                                break;
                            }
                            if CONNECTED.contains(&name.local.as_str()) {
                                victim = p;
                            }
                            x = p;
                        }
                    }
                    self.remove(victim);
                }
            }
        }
        changed
    }

    /// Remove buildings left with nothing; true when something changed.
    fn drop_buildings(&mut self) -> bool {
        let m = self.model;
        let mut changed = false;
        for b in (0..m.buildings.len()).rev() {
            let bd = &m.buildings[b];
            if bd.file != self.file {
                continue;
            }
            let Some(n) = self.doc.node_at(bd.span.start) else {
                continue;
            };
            if self.is_dead(n) || self.doc.parent(n).is_none() {
                continue;
            }
            let parts = &self.parts[b];
            let own = &self.owned[b];
            let had = !own.is_empty() || !bd.geometries.is_empty() || !parts.is_empty();
            if !had {
                continue;
            }
            let geom_alive = |gs: &[crate::model::LodGeometry]| {
                gs.iter().any(|g| {
                    self.doc
                        .node_at(g.span.start)
                        .is_some_and(|x| !self.is_dead(x))
                })
            };
            let asset_kept = own.iter().any(|&a| {
                let asset = &m.assets[a];
                if self.level(a) == 0 {
                    return false;
                }
                if asset.kind == AssetKind::Body {
                    geom_alive(&asset.geometries)
                } else {
                    self.asset_node(asset).is_some_and(|x| !self.is_dead(x))
                }
            });
            let part_kept = parts.iter().any(|&p| {
                self.doc
                    .node_at(m.buildings[p].span.start)
                    .is_some_and(|x| !self.is_dead(x))
            });
            if !asset_kept && !part_kept && !geom_alive(&bd.geometries) {
                self.remove(n);
                self.summary.buildings_dropped += 1;
                changed = true;
            }
        }
        changed
    }

    /// Insert (or replace) the `skylod_level` attribute of the feature at node `n`.
    fn insert_level(&mut self, n: u32, level: u8) {
        let doc = self.doc;
        let mut pos = doc.nodes[n as usize].content_start;
        for c in doc.children(n) {
            let name = doc.name(c);
            let leading = match name.ns {
                NsKind::Gml => true,
                NsKind::Core => CORE_LEADING.contains(&name.local.as_str()),
                NsKind::App => name.local == "appearance",
                // generic attributes, not the properties of a gen:GenericCityObject
                NsKind::Gen => {
                    name.local.ends_with("Attribute") || name.local == "genericAttributeSet"
                }
                _ => false,
            };
            if !leading {
                break;
            }
            pos = doc.nodes[c as usize].end;
            if self.is_level_attribute(c) && !self.removed[c as usize] {
                self.removed[c as usize] = true;
            }
        }
        let v3 = self.version == CityGmlVersion::V3_0;
        let gen_uri = match self.version {
            CityGmlVersion::V1_0 => "http://www.opengis.net/citygml/generics/1.0",
            CityGmlVersion::V2_0 => "http://www.opengis.net/citygml/generics/2.0",
            CityGmlVersion::V3_0 => "http://www.opengis.net/citygml/generics/3.0",
        };
        let (gen, gen_decl) = match doc.prefix_for(gen_uri).filter(|p| !p.is_empty()) {
            Some(p) => (p, String::new()),
            None => ("gen:".to_string(), format!(" xmlns:gen=\"{gen_uri}\"")),
        };
        let mut s = String::with_capacity(200);
        if v3 {
            let core_uri = "http://www.opengis.net/citygml/3.0";
            let (core, core_decl) = match doc.prefix_for(core_uri) {
                Some(p) if !(p.is_empty() && gen.is_empty()) => (p, String::new()),
                _ => ("core:".to_string(), format!(" xmlns:core=\"{core_uri}\"")),
            };
            let _ = write!(
                s,
                "<{core}genericAttribute{core_decl}{gen_decl}><{gen}IntAttribute><{gen}name>skylod_level</{gen}name><{gen}value>{level}</{gen}value></{gen}IntAttribute></{core}genericAttribute>"
            );
        } else {
            let _ = write!(
                s,
                "<{gen}intAttribute{gen_decl} name=\"skylod_level\"><{gen}value>{level}</{gen}value></{gen}intAttribute>"
            );
        }
        self.inserts.push(Edit {
            span: pos..pos,
            replacement: s.into_bytes(),
        });
    }

    /// A `skylod_level` generic attribute written earlier.
    fn is_level_attribute(&self, c: u32) -> bool {
        let doc = self.doc;
        let name = doc.name(c);
        let is_label = |x: u32| doc.labels.get(&x).is_some_and(|l| &**l == "skylod_level");
        match (name.ns, name.local.as_str()) {
            (NsKind::Gen, "intAttribute") => is_label(c),
            (NsKind::Core, "genericAttribute") => doc.children(c).any(|ia| {
                doc.name(ia).local == "IntAttribute"
                    && doc
                        .children(ia)
                        .any(|x| doc.name(x).local == "name" && is_label(x))
            }),
            _ => false,
        }
    }

    fn polygon_alive(&self, p: &Polygon) -> bool {
        match &p.id {
            Some(id) => self
                .doc
                .ids
                .get(id.as_str())
                .is_none_or(|&n| !self.is_dead(n)),
            None => true,
        }
    }

    /// Geometry properties actually written, with their boxes and polygon counts.
    fn written(&self) -> Vec<Written> {
        let m = self.model;
        let mut out = Vec::new();
        let mut replaced: HashMap<u32, usize> = HashMap::new();
        for (i, r) in self.replacements.iter().enumerate() {
            replaced.insert(r.node, i);
        }
        let mut push = |node: u32, polys: &mut dyn Iterator<Item = &Polygon>, asset: bool| {
            let mut bbox = Bbox::EMPTY;
            let mut count = 0;
            for p in polys {
                count += 1;
                for q in p.points() {
                    bbox.add(*q);
                }
            }
            out.push(Written {
                node,
                bbox,
                polygons: count,
                asset,
            });
        };
        let groups = m
            .assets
            .iter()
            .filter(|a| a.file == self.file)
            .map(|a| (&a.geometries, true))
            .chain(
                m.buildings
                    .iter()
                    .filter(|b| b.file == self.file)
                    .map(|b| (&b.geometries, false)),
            );
        for (geoms, asset) in groups {
            for g in geoms {
                let Some(n) = self.doc.node_at(g.span.start) else {
                    continue;
                };
                if self.is_dead(n) {
                    continue;
                }
                match replaced.get(&n) {
                    Some(&i) => push(n, &mut self.replacements[i].polygons.iter(), asset),
                    None => push(
                        n,
                        &mut g.polygons.iter().filter(|p| self.polygon_alive(p)),
                        asset,
                    ),
                }
            }
        }
        out.sort_by_key(|w| w.node);
        out
    }

    fn envelopes(&mut self, written: &[Written]) {
        let src = &self.model.files[self.file];
        for env in &src.envelopes {
            if env.bbox.is_empty() {
                continue; // owner unknown: kept verbatim
            }
            let Some(n) = self.doc.node_at(env.span.start) else {
                continue;
            };
            if self.is_dead(n) {
                continue;
            }
            let Some(owner) = self.doc.parent(n).and_then(|p| self.doc.parent(p)) else {
                continue;
            };
            let last = self.doc.nodes[owner as usize].last_desc;
            let lo = written.partition_point(|w| w.node < owner);
            let mut bbox = Bbox::EMPTY;
            for w in written[lo..].iter().take_while(|w| w.node <= last) {
                bbox.union(&w.bbox);
            }
            if bbox.is_empty() {
                if let Some(bb) = self.doc.parent(n) {
                    self.remove(bb);
                }
                continue;
            }
            let mut site = env.clone();
            site.bbox = bbox;
            if let Some(xml) = envelope_xml(&site) {
                self.envelope_edits.push(Edit {
                    span: env.span.clone(),
                    replacement: xml.into_bytes(),
                });
            }
        }
    }

    fn edits(&mut self) -> Vec<Edit> {
        let mut edits = Vec::new();
        for (i, node) in self.doc.nodes.iter().enumerate() {
            if self.removed[i] && self.doc.parent(i as u32).is_none_or(|p| !self.is_dead(p)) {
                edits.push(Edit {
                    span: node.start..node.end,
                    replacement: Vec::new(),
                });
            }
        }
        for r in &self.replacements {
            if self.is_dead(r.node) {
                continue;
            }
            let node = self.doc.nodes[r.node as usize];
            let span = if r.whole {
                node.start..node.end
            } else {
                r.content.clone()
            };
            edits.push(Edit {
                span,
                replacement: r.xml.clone().into_bytes(),
            });
        }
        edits.append(&mut self.envelope_edits);
        edits.append(&mut self.inserts);
        edits
    }
}

struct Written {
    node: u32,
    bbox: Bbox,
    polygons: usize,
    asset: bool,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::citygml::read::read_file;
    use crate::rough::{rough_model, RoughOptions};

    const HEAD2: &str = r#"<?xml version="1.0"?>
<CityModel xmlns="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml"
 xmlns:bldg="http://www.opengis.net/citygml/building/2.0" xmlns:xlink="http://www.w3.org/1999/xlink"
 xmlns:app="http://www.opengis.net/citygml/appearance/2.0" xmlns:gen="http://www.opengis.net/citygml/generics/2.0">
<gml:boundedBy><gml:Envelope srsName="EPSG:25832"><gml:lowerCorner>0 0 0</gml:lowerCorner><gml:upperCorner>9 9 9</gml:upperCorner></gml:Envelope></gml:boundedBy>
"#;

    fn poly(id: &str, pts: &str) -> String {
        format!(
            "<gml:Polygon gml:id=\"{id}\"><gml:exterior><gml:LinearRing><gml:posList>{pts}</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon>"
        )
    }

    fn surface(kind: &str, id: &str, pid: &str, pts: &str) -> String {
        format!(
            "<bldg:boundedBy><bldg:{kind} gml:id=\"{id}\"><gml:name>n</gml:name><bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember>{}</gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface></bldg:{kind}></bldg:boundedBy>",
            poly(pid, pts)
        )
    }

    fn house() -> String {
        let mut s = String::from(HEAD2);
        s.push_str("<cityObjectMember><bldg:Building gml:id=\"b1\">");
        s.push_str("<bldg:lod2Solid><gml:Solid><gml:exterior><gml:CompositeSurface><gml:surfaceMember xlink:href=\"#p1\"/><gml:surfaceMember xlink:href=\"#p2\"/></gml:CompositeSurface></gml:exterior></gml:Solid></bldg:lod2Solid>");
        s.push_str(&surface(
            "RoofSurface",
            "r1",
            "p1",
            "0 0 5 4 0 5 4 4 5 0 4 5 0 0 5",
        ));
        s.push_str(&surface(
            "WallSurface",
            "w1",
            "p2",
            "0 0 0 4 0 0 4 0 5 0 0 5 0 0 0",
        ));
        s.push_str("</bldg:Building></cityObjectMember>");
        s.push_str("<cityObjectMember><bldg:Building gml:id=\"b2\">");
        s.push_str(&surface(
            "RoofSurface",
            "r2",
            "p3",
            "10 0 5 14 0 5 14 4 5 10 4 5 10 0 5",
        ));
        s.push_str("</bldg:Building></cityObjectMember>");
        s.push_str("<app:appearanceMember><app:Appearance><app:surfaceDataMember><app:X3DMaterial><app:diffuseColor>1 0 0</app:diffuseColor><app:target>#p1</app:target></app:X3DMaterial></app:surfaceDataMember><app:surfaceDataMember><app:X3DMaterial><app:target>#p2</app:target><app:target>#p3</app:target></app:X3DMaterial></app:surfaceDataMember></app:Appearance></app:appearanceMember>");
        s.push_str("</CityModel>\n");
        s
    }

    fn run(xml: &str, levels: &[u8]) -> (String, MixedSummary) {
        let dir = tempfile::tempdir().unwrap();
        let src = dir.path().join("in.gml");
        std::fs::write(&src, xml).unwrap();
        let model = read_file(&src).unwrap();
        let rough = rough_model(&model, &RoughOptions::default());
        let out = dir.path().join("out.gml");
        let s = write_mixed(&model, 0, &rough, levels, &out, &WriteOptions::default()).unwrap();
        let text = std::fs::read_to_string(&out).unwrap();
        read_file(&out).unwrap();
        (text, s)
    }

    #[test]
    fn all_full_detail_keeps_everything_but_adds_levels() {
        let (text, s) = run(&house(), &[2, 2, 2]);
        assert_eq!(s.levels, [0, 0, 3]);
        assert_eq!(text.matches("skylod_level").count(), 3);
        assert!(text.contains("xlink:href=\"#p1\""));
        assert_eq!(s.hrefs_pruned, 0);
        // level attribute after gml:name, before the geometry
        let i = text.find("<gml:name>n</gml:name><gen:intAttribute name=\"skylod_level\">");
        assert!(i.is_some(), "{text}");
    }

    #[test]
    fn rough_replaces_and_prunes_solid_and_targets() {
        let (text, s) = run(&house(), &[1, 2, 2]);
        // the roof's polygon p1 is replaced: the building solid referencing it is broken
        assert!(!text.contains("lod2Solid"), "{text}");
        assert!(!text.contains("\"p1\""));
        assert!(text.contains("gml:id=\"skylod_r1_g0\""));
        assert_eq!(s.hrefs_pruned, 1);
        assert_eq!(s.appearance_targets_pruned, 1);
        assert!(!text.contains("#p1"));
        assert!(text.contains("<app:target>#p2</app:target>"));
        assert!(
            !text.contains("diffuseColor"),
            "material left without targets is dropped"
        );
    }

    #[test]
    fn level0_drops_wrappers_buildings_and_appearances() {
        let (text, s) = run(&house(), &[2, 0, 0]);
        assert!(!text.contains("w1"));
        assert!(
            !text.contains("b2"),
            "building with nothing kept is dropped"
        );
        assert_eq!(s.buildings_dropped, 1);
        assert_eq!(text.matches("<bldg:boundedBy>").count(), 1);
        assert_eq!(text.matches("<cityObjectMember>").count(), 1);
        assert!(!text.contains("#p3"));
        assert!(!text.contains("#p2"));
        assert!(text.contains("#p1"));
        // envelope recomputed from the roof only
        assert!(
            text.contains("<gml:upperCorner>4 4 5</gml:upperCorner>"),
            "{text}"
        );
        let (text, s) = run(&house(), &[0, 0, 0]);
        assert_eq!(s.buildings_dropped, 2);
        assert!(!text.contains("Building"));
        assert!(!text.contains("appearanceMember"));
        assert!(!text.contains("boundedBy"), "envelope of nothing removed");
    }

    #[test]
    fn writing_twice_replaces_the_level_attribute() {
        let dir = tempfile::tempdir().unwrap();
        let src = dir.path().join("in.gml");
        std::fs::write(&src, house()).unwrap();
        let model = read_file(&src).unwrap();
        let rough = rough_model(&model, &RoughOptions::default());
        let out = dir.path().join("out.gml");
        write_mixed(
            &model,
            0,
            &rough,
            &[1, 1, 1],
            &out,
            &WriteOptions::default(),
        )
        .unwrap();
        let m2 = read_file(&out).unwrap();
        let r2 = rough_model(&m2, &RoughOptions::default());
        let out2 = dir.path().join("out2.gml");
        write_mixed(&m2, 0, &r2, &[2, 2, 2], &out2, &WriteOptions::default()).unwrap();
        let text = std::fs::read_to_string(&out2).unwrap();
        assert_eq!(text.matches("skylod_level").count(), 3);
        assert_eq!(text.matches("<gen:value>2</gen:value>").count(), 3);
    }

    #[test]
    fn ids_do_not_collide() {
        let xml = house().replace("gml:id=\"b2\"", "gml:id=\"skylod_r1_g0\"");
        let (text, _) = run(&xml, &[1, 2, 2]);
        assert!(text.contains("gml:id=\"skylod_r1_g0_1\""), "{text}");
    }

    #[test]
    fn bad_arguments() {
        let dir = tempfile::tempdir().unwrap();
        let src = dir.path().join("in.gml");
        std::fs::write(&src, house()).unwrap();
        let model = read_file(&src).unwrap();
        let e = write_mixed(
            &model,
            0,
            &[],
            &[],
            &dir.path().join("o.gml"),
            &WriteOptions::default(),
        );
        assert!(matches!(e, Err(WriteError::Invalid(_))));
    }

    #[test]
    fn encodings() {
        assert_eq!(encoding("lod2Solid"), Enc::Solid);
        assert_eq!(encoding("lod3MultiSurface"), Enc::MultiSurface);
        assert_eq!(encoding("lod3Geometry"), Enc::MultiSurface);
        assert_eq!(encoding("lod2Surface"), Enc::CompositeSurface);
        assert_eq!(encoding("lod2ImplicitRepresentation"), Enc::Keep);
        assert_eq!(encoding("lod2MultiCurve"), Enc::Keep);
        assert_eq!(encoding("tin"), Enc::Keep);
    }
}
