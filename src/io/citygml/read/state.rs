//! The reader's state: the [`Parser`] with its element stack, the model under construction and
//! the geometry arena; the small stack queries every concern uses.

use super::coords::CoordAttrs;
use super::xlink::Registry;
use super::ReadOptions;
use crate::io::citygml::error::Location;
use crate::io::citygml::ns::Ns;
use crate::model::{Asset, AssetKind, Building, CityGmlVersion, EnvelopeSite, Polygon, Warning};
use foldhash::{HashMap, HashMapExt, HashSet, HashSetExt};
use glam::DVec3;
use std::borrow::Cow;
use std::cell::{Cell, RefCell};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// One entry of the geometry arena.
#[derive(Debug, Clone, Copy)]
pub(super) enum Part {
    /// Index into the polygon arena.
    Poly(u32),
    /// Index into the href table.
    Href(u32),
    /// Implicit geometry: index into the implicit table; the next `len` parts are its relative geometry.
    Implicit { idx: u32, len: u32 },
}

#[derive(Debug)]
pub(super) struct HrefRef {
    pub(super) target: Box<str>,
    pub(super) reversed: bool,
    pub(super) loc: Location,
}

#[derive(Debug, Default)]
pub(super) struct Implicit {
    pub(super) matrix: Option<[f64; 16]>,
    pub(super) ref_point: Option<DVec3>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Owner {
    Asset(usize),
    Building(usize),
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Capture {
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
pub(super) enum CoordKind {
    PosList,
    Pos,
    Coordinates,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Kind {
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
pub(super) struct Frame {
    pub(super) kind: Kind,
    pub(super) start: u64,
    /// Byte range of the element's gml:id in [`Parser::open_ids`], and the id's hash.
    pub(super) id: Option<(usize, usize, u64)>,
    /// Parts start when this geometry element has an id to register.
    pub(super) register: Option<u32>,
    pub(super) dim: Option<u8>,
    pub(super) flip: bool,
    /// The start tag declares namespaces.
    pub(super) ns_decl: bool,
    pub(super) content_start: u64,
    /// Local name (for lod properties, building module etc.); only kept where needed.
    pub(super) name: Option<Box<str>>,
    /// Index of the element's gml:id in [`Parser::id_log`] ([`NO_REC`]: none).
    pub(super) rec: u32,
}

/// Least distance in bytes between two [`Parser::marks`].
pub(super) const MARK_STEP: u64 = 64 << 10;

/// No entry of [`Parser::id_log`].
pub(super) const NO_REC: u32 = u32::MAX;

/// One gml:id met in a document held in memory, so that its "duplicate gml:id" warning can be
/// placed after the last event (see [`Parser::id_log`]): 24 bytes per gml:id.
#[derive(Debug, Clone, Copy)]
pub(super) struct IdRec {
    /// Hash of the id ([`Parser::id_hasher`]).
    pub(super) hash: u64,
    /// File offset of the element's start tag.
    pub(super) pos: u64,
    /// Number of warnings before the element's duplicate warning would be.
    pub(super) warnings: u32,
    /// The entry of the nearest enclosing element with a gml:id ([`NO_REC`]: none).
    pub(super) parent: u32,
}

#[derive(Debug, Default)]
pub(super) struct PolyBuild {
    pub(super) exterior: Option<Vec<DVec3>>,
    pub(super) interiors: Vec<Vec<DVec3>>,
    pub(super) invalid: bool,
}

pub(super) struct PendingGeom {
    pub(super) owner: Owner,
    pub(super) index: usize,
    pub(super) range: (u32, u32),
}

pub(super) enum EnvOwner {
    Root,
    Building(usize),
    Asset(usize),
}

pub(super) struct Parser<'d> {
    pub(super) path: PathBuf,
    /// The same path, shared by every warning.
    pub(super) shared_path: Arc<Path>,
    pub(super) content_start: u64,
    pub(super) gml_prefix: Option<String>,
    pub(super) cur_prefix: String,
    pub(super) opts: ReadOptions,
    pub(super) event_pos: u64,
    /// Line counter: counted per event while streaming, or on demand from [`Parser::doc`].
    pub(super) lines: Cell<LineMark>,
    /// Where the line counter stood, every [`MARK_STEP`] bytes or more of a document in
    /// memory (increasing): lines of logged gml:ids are counted from the nearest one, without
    /// touching again the memory of the document before it (let go while parsing).
    pub(super) marks: RefCell<Vec<LineMark>>,
    /// The whole document when it is held in memory (file offsets, the byte-order mark
    /// included): lines are then counted only when a location needs one. Empty while
    /// streaming.
    pub(super) doc: &'d [u8],
    pub(super) stack: Vec<Frame>,
    pub(super) version: Option<CityGmlVersion>,
    pub(super) root_is_model: bool,
    pub(super) srs_name: Option<String>,
    // model parts
    pub(super) buildings: Vec<Building>,
    pub(super) assets: Vec<Asset>,
    pub(super) warnings: Vec<Warning>,
    pub(super) envelopes: Vec<EnvelopeSite>,
    pub(super) env_owners: Vec<EnvOwner>,
    pub(super) implicit_count: usize,
    pub(super) library_objects: Vec<String>,
    pub(super) objects_without_geometry: usize,
    // geometry arena
    pub(super) polys: Vec<Polygon>,
    pub(super) parts: Vec<Part>,
    pub(super) hrefs: Vec<HrefRef>,
    pub(super) implicits: Vec<Implicit>,
    /// Range of geometry parts per gml:id of a geometry element.
    pub(super) registry: Registry,
    /// Text of the gml:ids of the open elements, one after the other ([`Frame::id`] ranges).
    pub(super) open_ids: String,
    /// Namespace per attribute prefix, valid until an element that declares namespaces
    /// starts or ends (cleared there).
    pub(super) attr_ns_cache: Vec<(Box<[u8]>, Ns)>,
    /// Finds `xmlns` in a start tag's attributes.
    pub(super) xmlns: memchr::memmem::Finder<'static>,
    /// 64-bit hashes of every gml:id seen, for duplicate detection without storing strings
    /// (a false "duplicate" needs a 64-bit collision: negligible): while streaming only (a
    /// document in memory logs its ids in [`Parser::id_log`] instead).
    pub(super) seen_ids: HashSet<u64>,
    pub(super) id_hasher: foldhash::fast::FixedState,
    pub(super) pending: Vec<PendingGeom>,
    pub(super) polygon_elements: usize,
    /// Start tags per CityGML feature/object type (UpperCamelCase local names in CityGML
    /// namespaces), wherever they nest: a few dozen distinct names, searched linearly.
    pub(super) feature_counts: Vec<(Box<[u8]>, usize)>,
    /// Element and property names of the model, each allocated once ([`Parser::intern`]).
    pub(super) names: HashMap<Box<[u8]>, Arc<str>>,
    // transient state
    pub(super) capture: bool,
    pub(super) capture_kind: Capture,
    pub(super) capture_attrs: CoordAttrs,
    pub(super) text: Vec<u8>,
    pub(super) ring: Vec<DVec3>,
    pub(super) in_ring: u32,
    pub(super) poly: Option<PolyBuild>,
    pub(super) flips: u32,
    pub(super) dims: Vec<u8>,
    pub(super) skip_depth: u32,
    /// Foreign namespaces and undeclared prefixes warned about (once each), with the index
    /// of that warning.
    pub(super) ade_namespaces: HashMap<Vec<u8>, usize>,
    pub(super) unknown_prefixes: HashMap<Vec<u8>, usize>,
    /// gml:ids met that are not valid `xs:ID`s, and the indices of the warnings that list
    /// them: the first [`super::ids::INVALID_IDS_LISTED`]; the last of those is told, at the end, how
    /// many more there are.
    pub(super) invalid_ids: u64,
    pub(super) invalid_listed: Vec<usize>,
    /// LoD of relief geometry without a `lodN` property name: the last relief `lod` read.
    pub(super) relief_lod: u8,
    /// A relief `lod` was read ([`Parser::relief_lod`] set) in this parser.
    pub(super) relief_lod_set: bool,
    /// The root's envelope set [`Parser::srs_name`] (over any earlier `srsName`).
    pub(super) root_srs_set: bool,
    /// A chunk of a streamed read (see `stream`): the invalid-id summary and the warning
    /// about a root without envelope are the stream's.
    pub(super) streamed: bool,
    /// A chunk after the first of a streamed read.
    pub(super) stream_tail: bool,
    /// A chunk of a streamed read: hashes of its gml:ids met in earlier chunks (each of
    /// their occurrences here is a duplicate).
    pub(super) dup_before: HashSet<u64>,
    /// A chunk of a streamed read: hashes of the gml:ids it holds more than once, found
    /// where its ids are checked against the earlier chunks' (`None`: found from the id log
    /// when the model is assembled).
    pub(super) dup_within: Option<HashSet<u64>>,
    /// A chunk after the first of a streamed read: the root's gml:id, the nearest enclosing
    /// id of a top-level member.
    pub(super) root_id: Option<String>,
    /// Every gml:id met, in document order, when the document is in memory (none while
    /// streaming): duplicates are found once after the last event, by sorting the hashes,
    /// cheaper than one insert per id into a hash set of every id (random access to a table
    /// larger than the caches).
    pub(super) id_log: Vec<IdRec>,
}

/// Attributes we care about, extracted from one start tag.
#[derive(Default)]
pub(super) struct Attrs<'e> {
    pub(super) id: Option<Cow<'e, str>>,
    pub(super) href: Option<Cow<'e, str>>,
    pub(super) srs_name: Option<Cow<'e, str>>,
    pub(super) srs_dimension: Option<Cow<'e, str>>,
    pub(super) orientation_minus: bool,
    pub(super) cs: Option<u8>,
    pub(super) ts: Option<u8>,
    pub(super) decimal: Option<u8>,
}

/// Where the line counter stands: `line` is the line of offset `counted_to`, which lies after
/// the newline at `line_start - 1`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(super) struct LineMark {
    pub(super) line: u64,
    pub(super) line_start: u64,
    pub(super) counted_to: u64,
}

impl<'d> Parser<'d> {
    pub(super) fn new(path: &Path, opts: ReadOptions, doc: &'d [u8]) -> Self {
        Parser {
            path: path.to_path_buf(),
            shared_path: Arc::from(path),
            content_start: 0,
            gml_prefix: None,
            cur_prefix: String::new(),
            opts,
            event_pos: 0,
            lines: Cell::new(LineMark {
                line: 1,
                line_start: 0,
                counted_to: 0,
            }),
            marks: RefCell::new(Vec::new()),
            doc,
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
            registry: Registry::default(),
            open_ids: String::new(),
            attr_ns_cache: Vec::new(),
            xmlns: memchr::memmem::Finder::new(b"xmlns").into_owned(),
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
            ade_namespaces: HashMap::new(),
            names: HashMap::new(),
            unknown_prefixes: HashMap::new(),
            invalid_ids: 0,
            invalid_listed: Vec::new(),
            relief_lod: 2,
            relief_lod_set: false,
            root_srs_set: false,
            streamed: false,
            stream_tail: false,
            dup_before: HashSet::new(),
            dup_within: None,
            root_id: None,
            id_log: Vec::new(),
        }
    }

    pub(super) fn current_dim(&self) -> u8 {
        self.dims.last().copied().unwrap_or(3)
    }

    pub(super) fn innermost_feature(&self) -> (Option<usize>, Option<usize>) {
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

    pub(super) fn geom_owner(&self) -> Option<Owner> {
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

    pub(super) fn in_geometry(&self) -> bool {
        self.stack
            .iter()
            .rev()
            .any(|f| matches!(f.kind, Kind::GeomProp { .. }))
    }

    pub(super) fn in_implicit_rel(&self) -> bool {
        self.stack
            .iter()
            .rev()
            .any(|f| matches!(f.kind, Kind::Implicit(_)))
    }

    pub(super) fn top_is_implicit(&self) -> bool {
        matches!(self.stack.last().map(|f| f.kind), Some(Kind::Implicit(_)))
    }

    pub(super) fn in_ref_point(&self) -> bool {
        self.stack
            .iter()
            .rev()
            .take(3)
            .any(|f| matches!(f.kind, Kind::RefPointProp))
    }

    pub(super) fn current_implicit(&self) -> Option<usize> {
        self.stack.iter().rev().find_map(|f| match f.kind {
            Kind::Implicit(at) => match self.parts.get(at as usize) {
                Some(Part::Implicit { idx, .. }) => Some(*idx as usize),
                _ => None,
            },
            _ => None,
        })
    }

    /// The model's shared copy of an element or property name: a city has hundreds of
    /// thousands of assets and geometries but a few dozen names.
    pub(super) fn intern(&mut self, name: &[u8]) -> Arc<str> {
        if let Some(n) = self.names.get(name) {
            return n.clone();
        }
        let n: Arc<str> = String::from_utf8_lossy(name).into();
        self.names.insert(name.into(), n.clone());
        n
    }

    pub(super) fn new_asset(
        &mut self,
        kind: AssetKind,
        local: &[u8],
        id: Option<&str>,
        building: Option<usize>,
        parent: Option<usize>,
        pos: u64,
    ) -> usize {
        let idx = self.assets.len();
        let element = self.intern(local);
        self.assets.push(Asset {
            kind,
            id: id.map(compact_str::CompactString::from),
            element,
            building,
            parent,
            span: pos..pos,
            line: self.line(),
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
}
