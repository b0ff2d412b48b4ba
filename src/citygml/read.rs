//! Streaming CityGML reader: XML events -> [`CityModel`] of buildings and assets.
//!
//! Namespace-aware ([`quick_xml::NsReader`]): elements are matched by namespace URI, so any
//! prefix and default namespaces work, for CityGML 1.0, 2.0 and 3.0. The document text is never
//! held in memory: each event is handled and dropped, memory grows with the model only.
//!
//! Geometry is collected into a per-document arena of *parts* (polygons, `xlink:href`
//! references, implicit-geometry headers); every geometry element with a `gml:id` records its
//! range of parts, so references (forward ones too) are resolved after the last event.
//!
//! # Example
//! ```
//! let xml = br#"<CityModel xmlns="http://www.opengis.net/citygml/2.0"
//!   xmlns:bldg="http://www.opengis.net/citygml/building/2.0" xmlns:gml="http://www.opengis.net/gml">
//!  <cityObjectMember><bldg:Building gml:id="b1"><bldg:boundedBy><bldg:RoofSurface gml:id="r1">
//!   <bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember><gml:Polygon><gml:exterior>
//!    <gml:LinearRing><gml:posList>0 0 5 1 0 5 1 1 5 0 0 5</gml:posList></gml:LinearRing>
//!   </gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface>
//!  </bldg:RoofSurface></bldg:boundedBy></bldg:Building></cityObjectMember></CityModel>"#;
//! let model = skylod::citygml::read::read_bytes(xml, "inline.gml").unwrap();
//! assert_eq!(model.buildings.len(), 1);
//! assert_eq!(model.assets[0].kind, skylod::model::AssetKind::Roof);
//! assert_eq!(model.assets[0].detail_polygons()[0].exterior.len(), 3);
//! ```

use super::error::{Location, ReadError};
use super::ns::{self, Module, Ns};
use crate::model::{
    Asset, AssetKind, Bbox, Building, CityGmlVersion, CityModel, EnvelopeSite, LodGeometry,
    Polygon, SourceFile, Warning,
};
use foldhash::{HashMap, HashMapExt, HashSet, HashSetExt};
use glam::DVec3;
use quick_xml::events::{BytesStart, Event};
use quick_xml::name::ResolveResult;
use quick_xml::NsReader;
use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Limits that protect against hostile input.
#[derive(Debug, Clone)]
pub struct ReadOptions {
    /// Maximum element nesting depth.
    pub max_depth: usize,
    /// Maximum size of one XML event (a tag with its attributes, or one text node), bytes.
    pub max_event_bytes: usize,
    /// Maximum depth of chained `xlink:href` geometry references.
    pub max_href_depth: usize,
    /// Maximum number of steps (polygons and references visited) spent resolving
    /// `xlink:href` geometry references, on top of five per polygon element of the document;
    /// protects against exponential reference trees ("billion laughs" built from xlinks).
    pub max_href_work: usize,
}

impl Default for ReadOptions {
    fn default() -> Self {
        ReadOptions {
            max_depth: 4096,
            max_event_bytes: 64 << 20,
            max_href_depth: 64,
            max_href_work: 2_000_000,
        }
    }
}

/// Read one CityGML file (`.gml`, `.xml`, gzip-compressed or not).
pub fn read_file(path: &Path) -> Result<CityModel, ReadError> {
    read_file_with(path, &ReadOptions::default())
}

/// [`read_file`] with explicit limits.
pub fn read_file_with(path: &Path, opts: &ReadOptions) -> Result<CityModel, ReadError> {
    let (reader, gzip) = super::source::open(path)?;
    read_from(reader, path, gzip, opts)
}

/// Read a document held in memory (tests, examples). `name` is used in messages.
pub fn read_bytes(bytes: &[u8], name: impl AsRef<Path>) -> Result<CityModel, ReadError> {
    read_from(bytes, name.as_ref(), false, &ReadOptions::default())
}

/// Read from any buffered reader of the (decompressed) document.
pub fn read_from<R: BufRead>(
    mut reader: R,
    path: &Path,
    gzip: bool,
    opts: &ReadOptions,
) -> Result<CityModel, ReadError> {
    let mut p = Parser::new(path, opts.clone());
    let base = super::source::skip_bom(&mut reader, path)?;
    let mut reader =
        NsReader::from_reader(super::source::Limited::new(reader, opts.max_event_bytes));
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

/// Largest accepted coordinate magnitude: far beyond any real CRS (geocentric coordinates are
/// about 6.4e6 m) yet small enough that areas and cross products of coordinates stay finite.
pub const MAX_COORDINATE: f64 = 1e12;

/// One entry of the geometry arena.
#[derive(Debug, Clone, Copy)]
enum Part {
    /// Index into the polygon arena.
    Poly(u32),
    /// Index into the href table.
    Href(u32),
    /// Implicit geometry: index into the implicit table; the next `len` parts are its relative geometry.
    Implicit { idx: u32, len: u32 },
}

#[derive(Debug)]
struct HrefRef {
    target: Box<str>,
    reversed: bool,
    loc: Location,
}

#[derive(Debug, Default)]
struct Implicit {
    matrix: Option<[f64; 16]>,
    ref_point: Option<DVec3>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Owner {
    Asset(usize),
    Building(usize),
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Capture {
    None,
    /// Coordinates of a ring (posList/pos/coordinates).
    RingCoords(CoordKind),
    /// `gml:pos` of an implicit geometry's reference point.
    RefPoint,
    /// 16 numbers of an implicit transformation matrix.
    Matrix,
    /// `libraryObject` URI.
    Library,
    /// `function` of an asset.
    Function(usize),
    /// `lod` of a relief feature.
    ReliefLod,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum CoordKind {
    PosList,
    Pos,
    Coordinates,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Plain,
    Root,
    Member,
    Skip,
    Building(usize),
    Asset(usize),
    GeomProp {
        lod: u8,
        start: u32,
        owner: Option<Owner>,
    },
    Polygon,
    Ring {
        exterior: bool,
    },
    Capture(Capture),
    Implicit(u32),
    RefPointProp,
    BoundedBy,
    Envelope(usize),
}

#[derive(Debug)]
struct Frame {
    kind: Kind,
    start: u64,
    id: Option<Box<str>>,
    /// Parts start when this geometry element has an id to register.
    register: Option<u32>,
    dim: Option<u8>,
    flip: bool,
    content_start: u64,
    /// Local name (for lod properties, building module etc.); only kept where needed.
    name: Option<Box<str>>,
}

#[derive(Debug, Default)]
struct PolyBuild {
    exterior: Option<Vec<DVec3>>,
    interiors: Vec<Vec<DVec3>>,
    invalid: bool,
}

struct PendingGeom {
    owner: Owner,
    index: usize,
    range: (u32, u32),
}

enum EnvOwner {
    Root,
    Building(usize),
    Asset(usize),
}

struct Parser {
    path: PathBuf,
    /// The same path, shared by every warning.
    shared_path: Arc<Path>,
    content_start: u64,
    gml_prefix: Option<String>,
    cur_prefix: String,
    opts: ReadOptions,
    event_pos: u64,
    line: u64,
    line_start: u64,
    stack: Vec<Frame>,
    version: Option<CityGmlVersion>,
    root_is_model: bool,
    srs_name: Option<String>,
    // model parts
    buildings: Vec<Building>,
    assets: Vec<Asset>,
    warnings: Vec<Warning>,
    envelopes: Vec<EnvelopeSite>,
    env_owners: Vec<EnvOwner>,
    implicit_count: usize,
    library_objects: Vec<String>,
    objects_without_geometry: usize,
    // geometry arena
    polys: Vec<Polygon>,
    parts: Vec<Part>,
    hrefs: Vec<HrefRef>,
    implicits: Vec<Implicit>,
    /// Range of geometry parts per gml:id of a geometry element.
    registry: HashMap<Box<str>, (u32, u32)>,
    /// 64-bit hashes of every gml:id seen, for duplicate detection without storing strings
    /// (a false "duplicate" needs a 64-bit collision: negligible).
    seen_ids: HashSet<u64>,
    id_hasher: foldhash::fast::FixedState,
    pending: Vec<PendingGeom>,
    polygon_elements: usize,
    /// Start tags per CityGML feature/object type (UpperCamelCase local names in CityGML
    /// namespaces), wherever they nest: a few dozen distinct names, searched linearly.
    feature_counts: Vec<(Box<[u8]>, usize)>,
    // transient state
    capture: bool,
    capture_kind: Capture,
    capture_attrs: CoordAttrs,
    text: Vec<u8>,
    ring: Vec<DVec3>,
    in_ring: u32,
    poly: Option<PolyBuild>,
    flips: u32,
    dims: Vec<u8>,
    skip_depth: u32,
    ade_namespaces: HashSet<Vec<u8>>,
    unknown_prefixes: HashSet<Vec<u8>>,
    relief_lod: u8,
}

#[derive(Debug, Clone, Copy, Default)]
struct CoordAttrs {
    dim: Option<u8>,
    cs: u8,
    ts: u8,
    decimal: u8,
}

/// Attributes we care about, extracted from one start tag.
#[derive(Default)]
struct Attrs {
    id: Option<String>,
    href: Option<String>,
    srs_name: Option<String>,
    srs_dimension: Option<String>,
    orientation_minus: bool,
    cs: Option<u8>,
    ts: Option<u8>,
    decimal: Option<u8>,
}

const SHELL_NAMES: &[(&[u8], AssetKind)] = &[
    (b"RoofSurface", AssetKind::Roof),
    (b"WallSurface", AssetKind::Wall),
    (b"GroundSurface", AssetKind::Ground),
    (b"ClosureSurface", AssetKind::Closure),
    (b"OuterCeilingSurface", AssetKind::OuterCeiling),
    (b"OuterFloorSurface", AssetKind::OuterFloor),
];

const INTERIOR_NAMES: &[&[u8]] = &[
    b"IntBuildingInstallation",
    b"Room",
    b"BuildingRoom",
    b"BuildingFurniture",
    b"InteriorWallSurface",
    b"CeilingSurface",
    b"FloorSurface",
];

impl Parser {
    fn new(path: &Path, opts: ReadOptions) -> Self {
        Parser {
            path: path.to_path_buf(),
            shared_path: Arc::from(path),
            content_start: 0,
            gml_prefix: None,
            cur_prefix: String::new(),
            opts,
            event_pos: 0,
            line: 1,
            line_start: 0,
            stack: Vec::with_capacity(64),
            version: None,
            root_is_model: false,
            srs_name: None,
            buildings: Vec::new(),
            assets: Vec::new(),
            warnings: Vec::new(),
            envelopes: Vec::new(),
            env_owners: Vec::new(),
            implicit_count: 0,
            library_objects: Vec::new(),
            objects_without_geometry: 0,
            polys: Vec::new(),
            parts: Vec::new(),
            hrefs: Vec::new(),
            implicits: Vec::new(),
            registry: HashMap::new(),
            seen_ids: HashSet::new(),
            id_hasher: foldhash::fast::FixedState::with_seed(0x5eed),
            pending: Vec::new(),
            polygon_elements: 0,
            feature_counts: Vec::new(),
            capture: false,
            capture_kind: Capture::None,
            capture_attrs: CoordAttrs::default(),
            text: Vec::new(),
            ring: Vec::new(),
            in_ring: 0,
            poly: None,
            flips: 0,
            dims: Vec::new(),
            skip_depth: 0,
            ade_namespaces: HashSet::new(),
            unknown_prefixes: HashSet::new(),
            relief_lod: 2,
        }
    }

    /// Advance the line counter over `bytes`, which start at file offset `content_start`.
    #[inline]
    fn count_lines(&mut self, bytes: &[u8], content_start: u64) {
        if let Some((n, last)) = newlines(bytes) {
            self.line += n;
            self.line_start = content_start + last as u64 + 1;
        }
    }

    fn nearest_id(&self) -> Option<String> {
        self.stack
            .iter()
            .rev()
            .find_map(|f| f.id.as_deref().map(str::to_string))
    }

    fn loc_at(&self, pos: u64) -> Location {
        Location {
            file: self.path.clone(),
            line: self.line,
            column: pos.saturating_sub(self.line_start) + 1,
            gml_id: self.nearest_id(),
        }
    }

    fn loc(&self) -> Location {
        self.loc_at(self.event_pos)
    }

    fn xml_error(&self, at: u64, message: String) -> ReadError {
        ReadError::Xml {
            loc: self.loc_at(at.max(self.line_start)),
            message,
        }
    }

    /// The namespace URI of a resolved element name. An undeclared prefix is not
    /// namespace-well-formed, but real data has them (e.g. PLATEAU ADE elements): the element
    /// is kept verbatim, not interpreted, with one warning per prefix.
    fn bound<'a>(&mut self, res: &'a ResolveResult<'a>) -> Option<&'a [u8]> {
        match res {
            ResolveResult::Bound(ns) => Some(ns.0),
            ResolveResult::Unbound => None,
            ResolveResult::Unknown(prefix) => {
                self.unbound_prefix(prefix);
                None
            }
        }
    }

    fn unbound_prefix(&mut self, prefix: &[u8]) {
        if self.unknown_prefixes.insert(prefix.to_vec()) {
            self.warn(format!(
                "namespace prefix \"{}\" is not declared: its elements and attributes are kept verbatim, not interpreted",
                String::from_utf8_lossy(&prefix[..prefix.len().min(40)])
            ));
        }
    }

    fn token_limit(&self, pos: u64) -> ReadError {
        ReadError::Limit {
            loc: self.loc_at(pos),
            message: format!(
                "one XML token (tag, attribute value, text, comment or DOCTYPE) exceeds the limit of {} bytes",
                self.opts.max_event_bytes
            ),
        }
    }

    /// Append captured character data (coordinates, codes), within the token size limit.
    fn capture_text(&mut self, t: &[u8], pos: u64) -> Result<(), ReadError> {
        if self.text.len() + t.len() > self.opts.max_event_bytes {
            return Err(self.token_limit(pos));
        }
        self.text.extend_from_slice(t);
        Ok(())
    }

    /// An entity or character reference inside captured text: the five predefined entities
    /// and character references are resolved; DTD-declared entities are never expanded.
    fn capture_ref(&mut self, r: &quick_xml::events::BytesRef, pos: u64) -> Result<(), ReadError> {
        let predefined: Option<&[u8]> = match r.as_ref() {
            b"lt" => Some(b"<"),
            b"gt" => Some(b">"),
            b"amp" => Some(b"&"),
            b"apos" => Some(b"'"),
            b"quot" => Some(b"\""),
            _ => None,
        };
        if let Some(b) = predefined {
            return self.capture_text(b, pos);
        }
        match r.resolve_char_ref() {
            Ok(Some(c)) => {
                let mut tmp = [0u8; 4];
                let s = c.encode_utf8(&mut tmp);
                self.capture_text(s.as_bytes(), pos)
            }
            Ok(None) => Err(ReadError::Xml {
                loc: self.loc_at(pos),
                message: format!(
                    "entity reference &{};: entities declared in a DTD are not expanded",
                    String::from_utf8_lossy(&r[..r.len().min(40)])
                ),
            }),
            Err(e) => Err(ReadError::Xml {
                loc: self.loc_at(pos),
                message: format!("bad character reference: {e}"),
            }),
        }
    }

    fn warn(&mut self, message: impl Into<String>) {
        // Warnings share one path (real files can have one per gml:id).
        self.warnings.push(Warning {
            file: self.shared_path.clone(),
            line: self.line,
            column: self.event_pos.saturating_sub(self.line_start) + 1,
            gml_id: self.nearest_id(),
            message: message.into(),
        });
    }

    fn parse_attrs<R>(&mut self, reader: &NsReader<R>, e: &BytesStart) -> Result<Attrs, ReadError> {
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
            let value = || -> Result<String, ReadError> {
                attr.unescape_value()
                    .map(|v| v.into_owned())
                    .map_err(|err| ReadError::Xml {
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

    fn current_dim(&self) -> u8 {
        self.dims.last().copied().unwrap_or(3)
    }

    fn innermost_feature(&self) -> (Option<usize>, Option<usize>) {
        let mut asset = None;
        for f in self.stack.iter().rev() {
            match f.kind {
                Kind::Asset(a) if asset.is_none() => asset = Some(a),
                Kind::Building(b) => return (Some(b), asset),
                _ => {}
            }
        }
        (None, asset)
    }

    fn geom_owner(&self) -> Option<Owner> {
        for f in self.stack.iter().rev() {
            match f.kind {
                Kind::Skip => return None,
                Kind::Asset(a) => return Some(Owner::Asset(a)),
                Kind::Building(b) => return Some(Owner::Building(b)),
                _ => {}
            }
        }
        None
    }

    fn new_asset(
        &mut self,
        kind: AssetKind,
        local: &[u8],
        id: Option<&str>,
        building: Option<usize>,
        parent: Option<usize>,
        pos: u64,
    ) -> usize {
        let idx = self.assets.len();
        self.assets.push(Asset {
            kind,
            id: id.map(str::to_string),
            element: String::from_utf8_lossy(local).into_owned(),
            building,
            parent,
            span: pos..pos,
            line: self.line,
            function: None,
            geometries: Vec::new(),
            file: 0,
        });
        if let Some(b) = building {
            if let Some(bb) = self.buildings.get_mut(b) {
                bb.assets.push(idx);
            }
        }
        idx
    }

    fn start<R>(
        &mut self,
        reader: &NsReader<R>,
        uri: Option<&[u8]>,
        e: &BytesStart,
        pos: u64,
        _empty: bool,
    ) -> Result<(), ReadError> {
        if self.stack.len() >= self.opts.max_depth {
            return Err(ReadError::Limit {
                loc: self.loc(),
                message: format!("element nesting deeper than {}", self.opts.max_depth),
            });
        }
        let ns = uri.map(ns::classify).unwrap_or(Ns::None);
        let local_name = e.local_name();
        let local = local_name.as_ref();
        // the prefix text is only needed for the first GML element and for envelopes
        if ns == Ns::Gml && (self.gml_prefix.is_none() || local == b"Envelope") {
            self.cur_prefix.clear();
            if let Some(p) = e.name().prefix() {
                self.cur_prefix
                    .push_str(&String::from_utf8_lossy(p.as_ref()));
                self.cur_prefix.push(':');
            }
            if self.gml_prefix.is_none() {
                self.gml_prefix = Some(self.cur_prefix.clone());
            }
        }
        let attrs = self.parse_attrs(reader, e)?;

        // ids: syntax and uniqueness
        if let Some(id) = &attrs.id {
            if id.is_empty() || !(id.as_bytes()[0].is_ascii_alphabetic() || id.starts_with('_')) {
                // built by hand, not with format!: some exporters (Ingolstadt) give every
                // element such an id, and this warning is then a visible part of reading time
                const TAIL: &str = "\" is not a valid xs:ID (must start with a letter or '_')";
                let mut msg = String::with_capacity(8 + id.len() + TAIL.len());
                msg.push_str("gml:id \"");
                msg.push_str(id);
                msg.push_str(TAIL);
                self.warn(msg);
            }
            let h = std::hash::BuildHasher::hash_one(&self.id_hasher, id.as_str());
            if !self.seen_ids.insert(h) {
                self.warn(format!("duplicate gml:id \"{id}\""));
            }
        }

        if let Ns::CityGml(_, v) = ns {
            if self.version.is_none() {
                self.version = Some(v);
            }
            if local.first().is_some_and(u8::is_ascii_uppercase) {
                match self.feature_counts.iter_mut().find(|(n, _)| **n == *local) {
                    Some((_, c)) => *c += 1,
                    None => self.feature_counts.push((local.into(), 1)),
                }
            }
        }
        if ns == Ns::Foreign {
            if let Some(u) = uri {
                if !ns::is_standard_foreign(u) && !self.ade_namespaces.contains(u) {
                    self.ade_namespaces.insert(u.to_vec());
                    let msg = format!(
                        "element {} in namespace {} is not CityGML (ADE or foreign content): kept verbatim, not interpreted",
                        String::from_utf8_lossy(local),
                        String::from_utf8_lossy(u)
                    );
                    self.warn(msg);
                }
            }
        }

        let depth = self.stack.len();
        let parent_kind = self.stack.last().map(|f| f.kind);
        let kind;
        let mut dim = None;
        let mut name: Option<Box<str>> = None;

        if let Some(d) = &attrs.srs_dimension {
            match d.trim() {
                "2" => dim = Some(2),
                "3" => dim = Some(3),
                other => {
                    return Err(ReadError::Dimension {
                        loc: self.loc(),
                        value: other.chars().take(40).collect(),
                    })
                }
            }
        }
        if let Some(s) = &attrs.srs_name {
            if ns != Ns::Gml && depth > 0 {
                self.warn(format!(
                    "srsName on non-geometry element {}",
                    String::from_utf8_lossy(local)
                ));
            }
            if self.srs_name.is_none() {
                self.srs_name = Some(s.clone());
            }
        }

        if depth == 0 {
            match ns {
                Ns::CityGml(Module::Core, _) if local == b"CityModel" => {
                    self.root_is_model = true;
                    kind = Kind::Root;
                }
                Ns::CityGml(..) => kind = Kind::Root,
                _ => {
                    kind = Kind::Root;
                }
            }
        } else if self.skip_depth > 0 {
            kind = self.geometry_kind(ns, local, &attrs, pos)?;
        } else {
            kind = match ns {
                Ns::Gml => self.gml_kind(local, parent_kind, &attrs, pos)?,
                Ns::CityGml(module, _) => {
                    self.citygml_kind(module, local, parent_kind, &attrs, pos, &mut name)?
                }
                _ => {
                    if matches!(parent_kind, Some(Kind::Root)) && !self.root_is_model {
                        Kind::Plain
                    } else if matches!(parent_kind, Some(Kind::Member)) {
                        // A foreign (ADE) top-level feature: an "Other" asset if it has geometry.
                        let a = self.new_asset(
                            AssetKind::Other,
                            local,
                            attrs.id.as_deref(),
                            None,
                            None,
                            pos,
                        );
                        Kind::Asset(a)
                    } else if is_lod_property(local).is_some() {
                        self.open_geom_prop(local, &mut name)
                    } else {
                        Kind::Plain
                    }
                }
            };
        }

        if let Some(href) = &attrs.href {
            let is_prop = matches!(kind, Kind::GeomProp { .. });
            if is_prop || (self.in_geometry() && (ns == Ns::Gml || self.in_implicit_rel())) {
                self.push_href(href, pos);
            }
        }

        let register = if attrs.id.is_some() && ns == Ns::Gml {
            Some(self.parts.len() as u32)
        } else {
            None
        };
        if let Some(d) = dim {
            self.dims.push(d);
        }
        let flip = attrs.orientation_minus && ns == Ns::Gml;
        if flip {
            self.flips += 1;
        }
        if matches!(kind, Kind::Skip) {
            self.skip_depth += 1;
        }
        if let Kind::Polygon = kind {
            self.polygon_elements += 1;
            self.poly = Some(PolyBuild::default());
        }
        self.stack.push(Frame {
            kind,
            start: pos,
            id: attrs.id.map(String::into_boxed_str),
            register,
            dim,
            flip,
            content_start: self.content_start,
            name,
        });
        Ok(())
    }

    fn in_geometry(&self) -> bool {
        self.stack
            .iter()
            .rev()
            .any(|f| matches!(f.kind, Kind::GeomProp { .. }))
    }

    fn in_implicit_rel(&self) -> bool {
        self.stack
            .iter()
            .rev()
            .any(|f| matches!(f.kind, Kind::Implicit(_)))
    }

    fn push_href(&mut self, href: &str, _pos: u64) {
        let reversed = self.flips % 2 == 1;
        let loc = self.loc();
        let target = href.trim();
        let idx = self.hrefs.len() as u32;
        self.hrefs.push(HrefRef {
            target: target.into(),
            reversed,
            loc,
        });
        self.parts.push(Part::Href(idx));
    }

    fn open_geom_prop(&mut self, local: &[u8], name: &mut Option<Box<str>>) -> Kind {
        let lod = is_lod_property(local).unwrap_or(self.relief_lod);
        *name = Some(String::from_utf8_lossy(local).into());
        Kind::GeomProp {
            lod,
            start: self.parts.len() as u32,
            owner: self.geom_owner(),
        }
    }

    /// Kinds of GML elements.
    fn gml_kind(
        &mut self,
        local: &[u8],
        parent: Option<Kind>,
        attrs: &Attrs,
        pos: u64,
    ) -> Result<Kind, ReadError> {
        match local {
            b"boundedBy" => {
                return Ok(Kind::BoundedBy);
            }
            b"Envelope" if matches!(parent, Some(Kind::BoundedBy)) => {
                // owner: the frame below boundedBy
                let owner = self
                    .stack
                    .len()
                    .checked_sub(2)
                    .and_then(|i| self.stack.get(i))
                    .map(|f| f.kind);
                let env_owner = match owner {
                    Some(Kind::Root) => Some(EnvOwner::Root),
                    Some(Kind::Building(b)) => Some(EnvOwner::Building(b)),
                    Some(Kind::Asset(a)) => Some(EnvOwner::Asset(a)),
                    _ => None,
                };
                if let Some(o) = env_owner {
                    let idx = self.envelopes.len();
                    self.envelopes.push(EnvelopeSite {
                        span: pos..pos,
                        bbox: Bbox::EMPTY,
                        srs_name: attrs.srs_name.clone(),
                        dimension: match attrs.srs_dimension.as_deref().map(str::trim) {
                            Some("2") => 2,
                            _ => 3,
                        },
                        prefix: self.cur_prefix.clone(),
                        file: 0,
                    });
                    self.env_owners.push(o);
                    if matches!(owner, Some(Kind::Root)) {
                        if let Some(s) = &attrs.srs_name {
                            self.srs_name = Some(s.clone());
                        }
                    }
                    return Ok(Kind::Envelope(idx));
                }
                return Ok(Kind::Plain);
            }
            _ => {}
        }
        self.geometry_kind(Ns::Gml, local, attrs, pos)
    }

    /// Geometry element kinds (also used inside skipped interiors so that counts and ids stay right).
    fn geometry_kind(
        &mut self,
        ns: Ns,
        local: &[u8],
        _attrs: &Attrs,
        _pos: u64,
    ) -> Result<Kind, ReadError> {
        if ns != Ns::Gml {
            if let Some(_lod) = is_lod_property(local) {
                let mut n = None;
                return Ok(self.open_geom_prop(local, &mut n));
            }
            if local == b"ImplicitGeometry" {
                return Ok(self.open_implicit());
            }
            if local == b"transformationMatrix" && self.top_is_implicit() {
                return Ok(self.begin_capture(Capture::Matrix, CoordAttrs::default()));
            }
            if local == b"libraryObject" && self.top_is_implicit() {
                return Ok(self.begin_capture(Capture::Library, CoordAttrs::default()));
            }
            if local == b"referencePoint" && self.top_is_implicit() {
                return Ok(Kind::RefPointProp);
            }
            if self.skip_depth > 0 && INTERIOR_NAMES.contains(&local) {
                return Ok(Kind::Skip);
            }
            return Ok(Kind::Plain);
        }
        let parent = self.stack.last().map(|f| f.kind);
        Ok(match local {
            b"Polygon" | b"PolygonPatch" | b"Triangle" | b"Rectangle" => Kind::Polygon,
            b"exterior" | b"outerBoundaryIs" if matches!(parent, Some(Kind::Polygon)) => {
                self.ring.clear();
                self.in_ring += 1;
                Kind::Ring { exterior: true }
            }
            b"interior" | b"innerBoundaryIs" if matches!(parent, Some(Kind::Polygon)) => {
                self.ring.clear();
                self.in_ring += 1;
                Kind::Ring { exterior: false }
            }
            b"posList" | b"pos" | b"coordinates" => {
                let k = match local {
                    b"posList" => CoordKind::PosList,
                    b"pos" => CoordKind::Pos,
                    _ => CoordKind::Coordinates,
                };
                let attrs = CoordAttrs {
                    dim: _attrs
                        .srs_dimension
                        .as_deref()
                        .and_then(|d| match d.trim() {
                            "2" => Some(2),
                            "3" => Some(3),
                            _ => None,
                        }),
                    cs: _attrs.cs.unwrap_or(b','),
                    ts: _attrs.ts.unwrap_or(b' '),
                    decimal: _attrs.decimal.unwrap_or(b'.'),
                };
                if self.in_ring > 0 {
                    self.begin_capture(Capture::RingCoords(k), attrs)
                } else if k == CoordKind::Pos && self.in_ref_point() {
                    self.begin_capture(Capture::RefPoint, attrs)
                } else {
                    Kind::Plain
                }
            }
            _ => Kind::Plain,
        })
    }

    fn top_is_implicit(&self) -> bool {
        matches!(self.stack.last().map(|f| f.kind), Some(Kind::Implicit(_)))
    }

    fn in_ref_point(&self) -> bool {
        self.stack
            .iter()
            .rev()
            .take(3)
            .any(|f| matches!(f.kind, Kind::RefPointProp))
    }

    fn open_implicit(&mut self) -> Kind {
        self.implicit_count += 1;
        let idx = self.implicits.len() as u32;
        self.implicits.push(Implicit::default());
        let at = self.parts.len() as u32;
        self.parts.push(Part::Implicit { idx, len: 0 });
        Kind::Implicit(at)
    }

    fn begin_capture(&mut self, c: Capture, attrs: CoordAttrs) -> Kind {
        self.capture = true;
        self.capture_kind = c;
        self.capture_attrs = attrs;
        self.text.clear();
        Kind::Capture(c)
    }

    /// Kinds of CityGML elements: buildings, assets, properties.
    fn citygml_kind(
        &mut self,
        module: Module,
        local: &[u8],
        parent: Option<Kind>,
        attrs: &Attrs,
        pos: u64,
        name: &mut Option<Box<str>>,
    ) -> Result<Kind, ReadError> {
        let id = attrs.id.as_deref();
        // members of the CityModel
        if matches!(parent, Some(Kind::Root)) && self.root_is_model {
            if local == b"appearanceMember" || local.starts_with(b"version") {
                return Ok(Kind::Skip);
            }
            if local.ends_with(b"Member") || local.ends_with(b"Members") {
                return Ok(Kind::Member);
            }
        }
        if module == Module::Appearance {
            return Ok(Kind::Skip);
        }
        let is_building_module = matches!(
            module,
            Module::Building | Module::Construction | Module::Core
        );
        let (building, asset) = self.innermost_feature();
        if module == Module::Building && (local == b"Building" || local == b"BuildingPart") {
            let is_part = local == b"BuildingPart";
            let idx = self.buildings.len();
            self.buildings.push(Building {
                id: id.map(str::to_string),
                is_part,
                parent: building,
                span: pos..pos,
                line: self.line,
                assets: Vec::new(),
                geometries: Vec::new(),
                file: 0,
            });
            return Ok(Kind::Building(idx));
        }
        if is_building_module && INTERIOR_NAMES.contains(&local) {
            return Ok(Kind::Skip);
        }
        let asset_kind = asset.map(|a| self.assets[a].kind);
        if is_building_module {
            if let Some((_, k)) = SHELL_NAMES.iter().find(|(n, _)| *n == local) {
                let k = *k;
                if building.is_some() || asset.is_none() {
                    match asset_kind {
                        Some(ak) if !ak.is_shell_surface() => return Ok(Kind::Plain),
                        _ => {
                            let a = self.new_asset(k, local, id, building, asset, pos);
                            return Ok(Kind::Asset(a));
                        }
                    }
                }
            }
            if local == b"BuildingInstallation" || local == b"BuildingConstructiveElement" {
                if asset.is_none() {
                    let a = self.new_asset(AssetKind::Installation, local, id, building, None, pos);
                    return Ok(Kind::Asset(a));
                }
                return Ok(Kind::Plain);
            }
            let opening = match local {
                b"Window" | b"WindowSurface" => Some(AssetKind::Window),
                b"Door" | b"DoorSurface" => Some(AssetKind::Door),
                _ => None,
            };
            if let Some(k) = opening {
                match asset_kind {
                    None
                    | Some(
                        AssetKind::Roof
                        | AssetKind::Wall
                        | AssetKind::Ground
                        | AssetKind::Closure
                        | AssetKind::OuterCeiling
                        | AssetKind::OuterFloor,
                    ) => {
                        let a = self.new_asset(k, local, id, building, asset, pos);
                        return Ok(Kind::Asset(a));
                    }
                    _ => return Ok(Kind::Plain),
                }
            }
        }
        if local == b"function" && module == Module::Building {
            if let Some(Kind::Asset(a)) = parent {
                if self.assets[a].function.is_none() {
                    return Ok(self.begin_capture(Capture::Function(a), CoordAttrs::default()));
                }
            }
        }
        if module == Module::Relief && local == b"lod" {
            return Ok(self.begin_capture(Capture::ReliefLod, CoordAttrs::default()));
        }
        if module == Module::Relief && (local == b"tin" || local == b"grid") {
            return Ok(self.open_geom_prop(local, name));
        }
        if matches!(parent, Some(Kind::Member))
            || (matches!(parent, Some(Kind::Root)) && !self.root_is_model)
        {
            // A top-level city object that is not a building.
            if local == b"Appearance" {
                return Ok(Kind::Skip);
            }
            let a = self.new_asset(AssetKind::Other, local, id, None, None, pos);
            return Ok(Kind::Asset(a));
        }
        if is_lod_property(local).is_some() {
            return Ok(self.open_geom_prop(local, name));
        }
        self.geometry_kind(Ns::CityGml(module, CityGmlVersion::V2_0), local, attrs, pos)
    }

    fn end(&mut self, end: u64) -> Result<(), ReadError> {
        let Some(mut frame) = self.stack.pop() else {
            return Ok(());
        };
        if frame.dim.is_some() {
            self.dims.pop();
        }
        match frame.kind {
            Kind::Capture(c) => {
                self.capture = false;
                self.capture_kind = Capture::None;
                self.finish_capture(c)?;
            }
            Kind::Ring { exterior } => {
                self.in_ring = self.in_ring.saturating_sub(1);
                self.finish_ring(exterior, &frame);
            }
            Kind::Polygon => {
                let id = frame.id.take();
                let pushed = self.finish_polygon(id.as_deref().map(str::to_string));
                let id = if frame.register.is_some() { id } else { None };
                if let (Some(start), Some(id)) = (frame.register, id) {
                    let end = self.parts.len() as u32;
                    self.registry
                        .entry(id)
                        .or_insert((start, if pushed { end } else { start }));
                }
            }
            Kind::GeomProp { lod, start, owner } => {
                let range = (start, self.parts.len() as u32);
                if let Some(owner) = owner {
                    if range.1 > range.0 {
                        let geom = LodGeometry {
                            lod,
                            property: frame.name.as_deref().unwrap_or("").to_string(),
                            span: frame.start..end,
                            content: frame.content_start..self.event_pos.max(frame.content_start),
                            polygons: Vec::new(),
                        };
                        let list = match owner {
                            Owner::Asset(a) => self.assets.get_mut(a).map(|x| &mut x.geometries),
                            Owner::Building(b) => {
                                self.buildings.get_mut(b).map(|x| &mut x.geometries)
                            }
                        };
                        if let Some(list) = list {
                            let index = list.len();
                            list.push(geom);
                            self.pending.push(PendingGeom {
                                owner,
                                index,
                                range,
                            });
                        }
                    }
                }
            }
            Kind::Implicit(at) => {
                let len = self.parts.len() as u32 - at - 1;
                if let Some(Part::Implicit { len: l, .. }) = self.parts.get_mut(at as usize) {
                    *l = len;
                }
            }
            Kind::Building(b) => {
                if let Some(bb) = self.buildings.get_mut(b) {
                    bb.span.end = end;
                }
            }
            Kind::Asset(a) => {
                let empty = self
                    .assets
                    .get(a)
                    .map(|x| x.geometries.is_empty())
                    .unwrap_or(false);
                let is_last = a + 1 == self.assets.len();
                if let Some(x) = self.assets.get_mut(a) {
                    x.span.end = end;
                }
                if empty && is_last && self.assets[a].kind == AssetKind::Other {
                    self.assets.pop();
                    self.objects_without_geometry += 1;
                    // envelopes owned by the removed asset are left verbatim
                    for (i, o) in self.env_owners.iter_mut().enumerate() {
                        if matches!(o, EnvOwner::Asset(x) if *x == a) {
                            *o = EnvOwner::Root;
                            self.envelopes[i].bbox = Bbox::EMPTY;
                            self.envelopes[i].dimension = 0; // marks "keep as is"
                        }
                    }
                }
            }
            Kind::Envelope(i) => {
                if let Some(env) = self.envelopes.get_mut(i) {
                    env.span.end = end;
                }
            }
            Kind::Skip => self.skip_depth = self.skip_depth.saturating_sub(1),
            _ => {}
        }
        if let Some(start) = frame.register {
            if let Some(id) = frame.id.take() {
                let end = self.parts.len() as u32;
                self.registry.entry(id).or_insert((start, end));
            }
        }
        if frame.flip {
            self.flips = self.flips.saturating_sub(1);
        }
        Ok(())
    }

    fn finish_capture(&mut self, c: Capture) -> Result<(), ReadError> {
        let text = std::mem::take(&mut self.text);
        let result = match c {
            Capture::RingCoords(k) => {
                let dim = self.capture_attrs.dim.unwrap_or_else(|| self.current_dim());
                let mut ring = std::mem::take(&mut self.ring);
                let r = match k {
                    CoordKind::PosList => parse_pos_list(&text, dim, &mut ring),
                    CoordKind::Pos => parse_pos(&text, &mut ring),
                    CoordKind::Coordinates => {
                        parse_coordinates(&text, self.capture_attrs, &mut ring)
                    }
                };
                self.ring = ring;
                r
            }
            Capture::RefPoint => {
                let mut pts = Vec::with_capacity(1);
                let r = parse_pos(&text, &mut pts);
                if r.is_ok() {
                    if let Some(idx) = self.current_implicit() {
                        self.implicits[idx].ref_point = pts.first().copied();
                    }
                }
                r
            }
            Capture::Matrix => {
                let mut vals = Vec::with_capacity(16);
                let r = parse_numbers(&text, &mut vals);
                if r.is_ok() {
                    if vals.len() == 16 {
                        let mut m = [0.0; 16];
                        m.copy_from_slice(&vals);
                        if let Some(idx) = self.current_implicit() {
                            self.implicits[idx].matrix = Some(m);
                        }
                    } else {
                        self.warn(format!(
                            "transformationMatrix has {} values, 16 expected: identity used",
                            vals.len()
                        ));
                    }
                }
                r
            }
            Capture::Library => {
                let s = String::from_utf8_lossy(&text).trim().to_string();
                if !s.is_empty() {
                    self.library_objects.push(s);
                }
                Ok(())
            }
            Capture::Function(a) => {
                let s = String::from_utf8_lossy(&text).trim().to_string();
                if let Some(x) = self.assets.get_mut(a) {
                    x.function = Some(s);
                }
                Ok(())
            }
            Capture::ReliefLod => {
                if let Ok(v) = String::from_utf8_lossy(&text).trim().parse::<u8>() {
                    self.relief_lod = v.min(4);
                }
                Ok(())
            }
            Capture::None => Ok(()),
        };
        self.text = text;
        self.text.clear();
        result.map_err(|e| self.coord_error(e))
    }

    fn current_implicit(&self) -> Option<usize> {
        self.stack.iter().rev().find_map(|f| match f.kind {
            Kind::Implicit(at) => match self.parts.get(at as usize) {
                Some(Part::Implicit { idx, .. }) => Some(*idx as usize),
                _ => None,
            },
            _ => None,
        })
    }

    fn coord_error(&self, e: CoordError) -> ReadError {
        match e {
            CoordError::Token(t) => ReadError::Coordinate {
                loc: self.loc(),
                token: t,
            },
            CoordError::Count { count, dimension } => ReadError::CoordinateCount {
                loc: self.loc(),
                count,
                dimension,
            },
        }
    }

    fn finish_ring(&mut self, exterior: bool, _frame: &Frame) {
        let mut ring = std::mem::take(&mut self.ring);
        let closed = ring.len() >= 2 && ring.first() == ring.last();
        if closed {
            ring.pop();
        } else if ring.len() >= 3 {
            self.warn("ring is not closed (first point differs from last): closed implicitly");
        }
        // drop consecutive duplicates
        ring.dedup();
        while ring.len() > 1 && ring.first() == ring.last() {
            ring.pop();
        }
        let valid = ring.len() >= 3;
        if valid && zero_area(&ring) {
            self.warn(format!(
                "{} ring has zero area (collinear points or a ring folding back on itself)",
                if exterior { "exterior" } else { "interior" }
            ));
        }
        if !valid {
            self.warn(format!(
                "ring with {} distinct point(s), at least 3 needed: {}",
                ring.len(),
                if exterior {
                    "polygon dropped"
                } else {
                    "hole dropped"
                }
            ));
        }
        if let Some(p) = self.poly.as_mut() {
            if exterior {
                if valid {
                    p.exterior = Some(ring);
                } else {
                    p.invalid = true;
                }
            } else if valid {
                p.interiors.push(ring);
            }
        }
        self.ring = Vec::with_capacity(16);
    }

    /// Push the polygon being built; false when it was dropped.
    fn finish_polygon(&mut self, id: Option<String>) -> bool {
        let Some(p) = self.poly.take() else {
            return false;
        };
        if p.invalid {
            return false;
        }
        let Some(mut exterior) = p.exterior else {
            self.warn("polygon without exterior ring dropped");
            return false;
        };
        let mut interiors = p.interiors;
        if self.flips % 2 == 1 {
            exterior.reverse();
            interiors.iter_mut().for_each(|r| r.reverse());
        }
        let idx = self.polys.len() as u32;
        self.polys.push(Polygon {
            id,
            exterior,
            interiors,
        });
        self.parts.push(Part::Poly(idx));
        true
    }

    fn finish(mut self, len: u64, gzip: bool) -> Result<CityModel, ReadError> {
        let Some(version) = self.version else {
            return Err(ReadError::NotCityGml {
                loc: Location {
                    file: self.path.clone(),
                    line: 1,
                    column: 1,
                    gml_id: None,
                },
                message: "no element in a CityGML 1.0, 2.0 or 3.0 namespace".into(),
            });
        };
        // resolve geometry: references first, then move or clone the polygons
        let pending = std::mem::take(&mut self.pending);
        let mut refs: Vec<Vec<PolyRef>> = Vec::with_capacity(pending.len());
        let mut uses = vec![0u32; self.polys.len()];
        let mut budget = self
            .opts
            .max_href_work
            .saturating_add(self.parts.len().saturating_mul(4));
        for pg in &pending {
            let mut out = Vec::new();
            self.resolve(pg.range, false, 0, None, &mut out, &mut budget)?;
            for r in &out {
                if let Some(u) = uses.get_mut(r.poly as usize) {
                    *u += 1;
                }
            }
            refs.push(out);
        }
        let mut polys = std::mem::take(&mut self.polys);
        for (pg, rs) in pending.iter().zip(&refs) {
            let resolved = self.materialise(rs, &mut polys, &mut uses);
            let list = match pg.owner {
                Owner::Asset(a) => self.assets.get_mut(a).map(|x| &mut x.geometries),
                Owner::Building(b) => self.buildings.get_mut(b).map(|x| &mut x.geometries),
            };
            if let Some(g) = list.and_then(|l| l.get_mut(pg.index)) {
                g.polygons = resolved;
            }
        }
        // drop empty geometries (curves, points)
        for a in &mut self.assets {
            a.geometries.retain(|g| !g.polygons.is_empty());
        }
        for b in &mut self.buildings {
            b.geometries.retain(|g| !g.polygons.is_empty());
        }
        // Body assets: a building's own geometry when it has no thematic surfaces
        for b in 0..self.buildings.len() {
            let has_surfaces = self.buildings[b]
                .assets
                .iter()
                .any(|&a| self.assets[a].kind.is_shell_surface());
            if !has_surfaces && !self.buildings[b].geometries.is_empty() {
                let geoms = std::mem::take(&mut self.buildings[b].geometries);
                let idx = self.assets.len();
                let bb = &self.buildings[b];
                self.assets.push(Asset {
                    kind: AssetKind::Body,
                    id: bb.id.clone(),
                    element: if bb.is_part {
                        "BuildingPart"
                    } else {
                        "Building"
                    }
                    .to_string(),
                    building: Some(b),
                    parent: None,
                    span: bb.span.clone(),
                    line: bb.line,
                    function: None,
                    geometries: geoms,
                    file: 0,
                });
                self.buildings[b].assets.push(idx);
            }
        }
        // Assets with no geometry left (e.g. a surface with only curves) are dropped from the
        // model but stay verbatim in the output.
        // envelopes
        let envs: Vec<Bbox> = self
            .env_owners
            .iter()
            .map(|o| match o {
                EnvOwner::Root => {
                    let mut b = Bbox::EMPTY;
                    for a in &self.assets {
                        b.union(&a.bbox());
                    }
                    for bd in &self.buildings {
                        for g in &bd.geometries {
                            for p in &g.polygons {
                                for q in p.points() {
                                    b.add(*q);
                                }
                            }
                        }
                    }
                    b
                }
                EnvOwner::Building(b) => self.building_bbox(*b),
                EnvOwner::Asset(a) => {
                    let mut b = self.assets.get(*a).map(|x| x.bbox()).unwrap_or_default();
                    for x in &self.assets {
                        if x.parent == Some(*a) {
                            b.union(&x.bbox());
                        }
                    }
                    b
                }
            })
            .collect();
        for (e, b) in self.envelopes.iter_mut().zip(envs) {
            if e.dimension == 0 {
                e.dimension = 3;
                e.bbox = Bbox::EMPTY;
            } else {
                e.bbox = b;
            }
        }
        let mut has_root_env = false;
        for o in &self.env_owners {
            if matches!(o, EnvOwner::Root) {
                has_root_env = true;
            }
        }
        if !has_root_env && self.root_is_model {
            self.warnings.push(Warning {
                file: self.shared_path.clone(),
                line: 1,
                column: 1,
                gml_id: None,
                message: "CityModel has no gml:boundedBy envelope".into(),
            });
        }
        let file = SourceFile {
            path: self.path.clone(),
            version,
            srs_name: self.srs_name.clone(),
            gzip,
            len,
            gml_prefix: self.gml_prefix.clone().unwrap_or_else(|| "gml:".into()),
            envelopes: std::mem::take(&mut self.envelopes),
            implicit_geometries: self.implicit_count,
            library_objects: std::mem::take(&mut self.library_objects),
            objects_without_geometry: self.objects_without_geometry,
            polygon_elements: self.polygon_elements,
            features: self
                .feature_counts
                .iter()
                .map(|(name, n)| (String::from_utf8_lossy(name).into_owned(), *n))
                .collect(),
        };
        Ok(CityModel {
            files: vec![file],
            buildings: self.buildings,
            assets: self.assets,
            warnings: self.warnings,
        })
    }

    fn building_bbox(&self, b: usize) -> Bbox {
        let mut bb = Bbox::EMPTY;
        for (i, x) in self.buildings.iter().enumerate() {
            // the building itself and its parts (transitively)
            let mut cur = Some(i);
            let mut inside = false;
            while let Some(c) = cur {
                if c == b {
                    inside = true;
                    break;
                }
                cur = self.buildings.get(c).and_then(|y| y.parent);
            }
            if !inside {
                continue;
            }
            for &a in &x.assets {
                if let Some(asset) = self.assets.get(a) {
                    bb.union(&asset.bbox());
                }
            }
            for g in &x.geometries {
                for p in &g.polygons {
                    for q in p.points() {
                        bb.add(*q);
                    }
                }
            }
        }
        bb
    }

    /// Collect the polygons a range of parts stands for (xlinks followed, implicit geometry
    /// marked), as references into the polygon arena.
    fn resolve(
        &self,
        range: (u32, u32),
        reversed: bool,
        depth: usize,
        implicit: Option<u32>,
        out: &mut Vec<PolyRef>,
        budget: &mut usize,
    ) -> Result<(), ReadError> {
        let mut i = range.0 as usize;
        let end = (range.1 as usize).min(self.parts.len());
        while i < end {
            if *budget == 0 {
                let loc = match self.parts[i] {
                    Part::Href(h) => self.hrefs.get(h as usize).map(|x| x.loc.clone()),
                    _ => None,
                };
                return Err(ReadError::Limit {
                    loc: loc.unwrap_or_else(|| self.loc_at(0)),
                    message: format!(
                        "xlink:href references expand to more than {} polygons and references",
                        self.opts
                            .max_href_work
                            .saturating_add(self.parts.len().saturating_mul(4))
                    ),
                });
            }
            *budget -= 1;
            match self.parts[i] {
                Part::Poly(p) => {
                    out.push(PolyRef {
                        poly: p,
                        reversed,
                        implicit,
                    });
                    i += 1;
                }
                Part::Href(h) => {
                    let Some(href) = self.hrefs.get(h as usize) else {
                        i += 1;
                        continue;
                    };
                    let Some(target) = href.target.strip_prefix('#') else {
                        return Err(ReadError::DanglingHref {
                            loc: href.loc.clone(),
                            href: format!(
                                "{} (only same-document references are supported)",
                                href.target
                            ),
                        });
                    };
                    let Some(&r) = self.registry.get(target) else {
                        return Err(ReadError::DanglingHref {
                            loc: href.loc.clone(),
                            href: href.target.to_string(),
                        });
                    };
                    if depth >= self.opts.max_href_depth {
                        return Err(ReadError::HrefCycle {
                            loc: href.loc.clone(),
                            href: href.target.to_string(),
                        });
                    }
                    self.resolve(
                        r,
                        reversed ^ href.reversed,
                        depth + 1,
                        implicit,
                        out,
                        budget,
                    )?;
                    i += 1;
                }
                Part::Implicit { idx, len } => {
                    let inner = (i as u32 + 1, (i as u32 + 1 + len).min(end as u32));
                    self.resolve(inner, reversed, depth + 1, Some(idx), out, budget)?;
                    i = inner.1 as usize;
                }
            }
        }
        Ok(())
    }

    /// Turn references into polygons: a polygon used once is moved out of the arena, one used
    /// several times is cloned (the last use moves it); implicit geometry is transformed.
    fn materialise(
        &self,
        refs: &[PolyRef],
        polys: &mut [Polygon],
        uses: &mut [u32],
    ) -> Vec<Polygon> {
        let mut out = Vec::with_capacity(refs.len());
        for r in refs {
            let Some(slot) = polys.get_mut(r.poly as usize) else {
                continue;
            };
            let mut p = if r.implicit.is_none() && uses[r.poly as usize] <= 1 {
                std::mem::take(slot)
            } else {
                uses[r.poly as usize] -= 1;
                slot.clone()
            };
            if r.reversed {
                p.exterior.reverse();
                p.interiors.iter_mut().for_each(|x| x.reverse());
            }
            if let Some(idx) = r.implicit {
                let imp = self.implicits.get(idx as usize);
                let m = imp.and_then(|x| x.matrix);
                let rp = imp.and_then(|x| x.ref_point).unwrap_or(DVec3::ZERO);
                let tf = |q: &mut DVec3| {
                    let v = match m {
                        Some(m) => DVec3::new(
                            m[0] * q.x + m[1] * q.y + m[2] * q.z + m[3],
                            m[4] * q.x + m[5] * q.y + m[6] * q.z + m[7],
                            m[8] * q.x + m[9] * q.y + m[10] * q.z + m[11],
                        ),
                        None => *q,
                    };
                    *q = v + rp;
                };
                p.exterior.iter_mut().for_each(tf);
                p.interiors.iter_mut().flatten().for_each(tf);
            }
            out.push(p);
        }
        out
    }
}

#[derive(Debug, Clone, Copy)]
struct PolyRef {
    poly: u32,
    reversed: bool,
    implicit: Option<u32>,
}

/// `lodN...` property name -> N.
fn is_lod_property(local: &[u8]) -> Option<u8> {
    if local.len() > 4 && local.starts_with(b"lod") {
        let d = local[3];
        if (b'0'..=b'4').contains(&d) && local[4].is_ascii_uppercase() {
            return Some(d - b'0');
        }
    }
    None
}

/// True when a ring (at least 3 distinct points) encloses no area: its Newell normal,
/// computed relative to the first point so that large offsets cancel, is negligible against
/// the ring's extent.
fn zero_area(ring: &[DVec3]) -> bool {
    let Some(&o) = ring.first() else {
        return true;
    };
    let mut n = DVec3::ZERO;
    let mut extent2 = 0.0f64;
    let mut prev = DVec3::ZERO;
    for q in &ring[1..] {
        let d = *q - o;
        n += prev.cross(d);
        extent2 = extent2.max(d.length_squared());
        prev = d;
    }
    n.length() <= 1e-12 * extent2
}

/// Number of `\n` in `bytes` and the index of the last one; `None` when there is none.
fn newlines(bytes: &[u8]) -> Option<(u64, usize)> {
    if bytes.len() >= 32 {
        // long tokens (coordinate lists, tags with attributes) rarely hold a newline: one SIMD
        // search for the last, then a count before it
        let last = memchr::memrchr(b'\n', bytes)?;
        let n = memchr::memchr_iter(b'\n', &bytes[..last]).count() as u64;
        return Some((n + 1, last));
    }
    // short tokens eight bytes at a time (SWAR), where a SIMD search does not pay
    const LO7: u64 = 0x7f7f_7f7f_7f7f_7f7f;
    const NL: u64 = 0x0a0a_0a0a_0a0a_0a0a;
    let mut count = 0u64;
    let mut last = None;
    let mut chunks = bytes.chunks_exact(8);
    let mut base = 0usize;
    for c in &mut chunks {
        let mut w = [0u8; 8];
        w.copy_from_slice(c);
        let x = u64::from_le_bytes(w) ^ NL;
        // exactly the zero bytes of x (no borrow between bytes) get their high bit set
        let z = !(((x & LO7).wrapping_add(LO7)) | x | LO7);
        if z != 0 {
            count += u64::from(z.count_ones());
            last = Some(base + (63 - z.leading_zeros() as usize) / 8);
        }
        base += 8;
    }
    for (i, &c) in chunks.remainder().iter().enumerate() {
        if c == b'\n' {
            count += 1;
            last = Some(base + i);
        }
    }
    last.map(|l| (count, l))
}

#[derive(Debug)]
enum CoordError {
    Token(String),
    Count { count: usize, dimension: u8 },
}

fn parse_f64(tok: &[u8]) -> Result<f64, CoordError> {
    let bad = || CoordError::Token(String::from_utf8_lossy(&tok[..tok.len().min(40)]).into_owned());
    // fast-float2 parses the same grammar as `str::parse::<f64>` (incl. "nan", "inf"), from bytes.
    let v: f64 = fast_float2::parse(tok).map_err(|_| bad())?;
    if v.abs() <= MAX_COORDINATE {
        Ok(v)
    } else {
        Err(bad())
    }
}

fn tokens(text: &[u8]) -> impl Iterator<Item = &[u8]> {
    text.split(|c| c.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
}

fn parse_numbers(text: &[u8], out: &mut Vec<f64>) -> Result<(), CoordError> {
    for t in tokens(text) {
        out.push(parse_f64(t)?);
    }
    Ok(())
}

fn parse_pos_list(text: &[u8], dim: u8, out: &mut Vec<DVec3>) -> Result<(), CoordError> {
    let mut vals = [0.0f64; 3];
    let mut n = 0usize;
    let d = dim as usize;
    for t in tokens(text) {
        vals[n % d] = parse_f64(t)?;
        n += 1;
        if n % d == 0 {
            out.push(DVec3::new(
                vals[0],
                vals[1],
                if d == 3 { vals[2] } else { 0.0 },
            ));
        }
    }
    if n % d != 0 {
        return Err(CoordError::Count {
            count: n,
            dimension: dim,
        });
    }
    Ok(())
}

fn parse_pos(text: &[u8], out: &mut Vec<DVec3>) -> Result<(), CoordError> {
    let mut vals = [0.0f64; 3];
    let mut n = 0usize;
    for t in tokens(text) {
        if n >= 3 {
            return Err(CoordError::Count {
                count: n + 1,
                dimension: 3,
            });
        }
        vals[n] = parse_f64(t)?;
        n += 1;
    }
    if n < 2 {
        return Err(CoordError::Count {
            count: n,
            dimension: 3,
        });
    }
    out.push(DVec3::new(
        vals[0],
        vals[1],
        if n == 3 { vals[2] } else { 0.0 },
    ));
    Ok(())
}

fn parse_coordinates(text: &[u8], a: CoordAttrs, out: &mut Vec<DVec3>) -> Result<(), CoordError> {
    let tuple_sep = |c: &u8| {
        if a.ts == b' ' {
            c.is_ascii_whitespace()
        } else {
            *c == a.ts
        }
    };
    let mut conv = Vec::new();
    for tuple in text
        .split(tuple_sep)
        .filter(|t| !t.iter().all(u8::is_ascii_whitespace))
    {
        let mut vals = [0.0f64; 3];
        let mut n = 0;
        for v in tuple.split(|c| *c == a.cs) {
            let v = v.trim_ascii();
            if v.is_empty() {
                continue;
            }
            if n >= 3 {
                return Err(CoordError::Count {
                    count: n + 1,
                    dimension: 3,
                });
            }
            let v = if a.decimal != b'.' {
                conv.clear();
                conv.extend(v.iter().map(|&c| if c == a.decimal { b'.' } else { c }));
                parse_f64(&conv)?
            } else {
                parse_f64(v)?
            };
            vals[n] = v;
            n += 1;
        }
        if n < 2 {
            return Err(CoordError::Count {
                count: n,
                dimension: 3,
            });
        }
        out.push(DVec3::new(
            vals[0],
            vals[1],
            if n == 3 { vals[2] } else { 0.0 },
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn newlines_match_a_plain_count() {
        // every length up to 80, newlines (and bytes that could fool a SWAR test: 0x0b, 0x8a,
        // 0x09) at every position
        for len in 0..80usize {
            for seed in 0..len.max(1) {
                let v: Vec<u8> = (0..len)
                    .map(|i| match (i * 7 + seed) % 5 {
                        0 => b'\n',
                        1 => 0x0b,
                        2 => 0x8a,
                        3 => 0x09,
                        _ => b'a',
                    })
                    .collect();
                let n = v.iter().filter(|&&c| c == b'\n').count() as u64;
                let last = v.iter().rposition(|&c| c == b'\n');
                assert_eq!(newlines(&v), last.map(|l| (n, l)), "{v:?}");
            }
        }
    }

    #[test]
    fn lod_property_names() {
        assert_eq!(is_lod_property(b"lod3MultiSurface"), Some(3));
        assert_eq!(is_lod_property(b"lod0FootPrint"), Some(0));
        assert_eq!(is_lod_property(b"lod"), None);
        assert_eq!(is_lod_property(b"lod5Solid"), None);
        assert_eq!(is_lod_property(b"lodging"), None);
    }

    #[test]
    fn pos_list_dims() {
        let mut v = Vec::new();
        parse_pos_list(b" 1 2 3\n4 5 6 ", 3, &mut v).unwrap();
        assert_eq!(v, vec![DVec3::new(1., 2., 3.), DVec3::new(4., 5., 6.)]);
        v.clear();
        parse_pos_list(b"1 2 3 4", 2, &mut v).unwrap();
        assert_eq!(v.len(), 2);
        assert!(matches!(
            parse_pos_list(b"1 2 3 4", 3, &mut v),
            Err(CoordError::Count {
                count: 4,
                dimension: 3
            })
        ));
        assert!(matches!(
            parse_pos_list(b"1 NaN 3", 3, &mut v),
            Err(CoordError::Token(_))
        ));
        assert!(matches!(
            parse_pos_list(b"1 inf 3", 3, &mut v),
            Err(CoordError::Token(_))
        ));
        assert!(matches!(
            parse_pos_list(b"1 x 3", 3, &mut v),
            Err(CoordError::Token(_))
        ));
        assert!(matches!(
            parse_pos_list(b"1 1e309 3", 3, &mut v),
            Err(CoordError::Token(_))
        ));
    }

    #[test]
    fn coordinates_element() {
        let mut v = Vec::new();
        let a = CoordAttrs {
            dim: None,
            cs: b',',
            ts: b' ',
            decimal: b'.',
        };
        parse_coordinates(b"1,2,3 4,5,6\n7,8", a, &mut v).unwrap();
        assert_eq!(v.len(), 3);
        assert_eq!(v[2], DVec3::new(7., 8., 0.));
        v.clear();
        let a = CoordAttrs {
            dim: None,
            cs: b';',
            ts: b'|',
            decimal: b',',
        };
        parse_coordinates(b"1,5;2;3|4;5;6", a, &mut v).unwrap();
        assert_eq!(v[0], DVec3::new(1.5, 2., 3.));
    }
}
