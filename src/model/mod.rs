//! The in-memory city model: buildings and the *assets* that receive a level.
//!
//! The reader (`crate::io::citygml::read`) fills a [`CityModel`]; every later stage
//! (rough, trace, select, solar, write) works on it. Coordinates are `f64`
//! ([`glam::DVec3`]) in the model's CRS.
//!
//! # Polygon counts
//!
//! *Polygons* of a model ([`CityModel::polygon_count`]) are the polygons of its assets over
//! every LoD and geometry property, a polygon reused by xlink counted at each use: what the
//! writers copy and what `stats`, `convert`, the `lod` report and the tracing commands
//! report. Two other numbers have their own names: *traced polygons*
//! ([`CityModel::traced_polygon_count`], each asset's highest LoD only: what the full-detail
//! scene traces) and *polygon elements* ([`SourceFile::polygon_elements`], `gml:Polygon` and
//! kin in the document, each once, including those of no asset such as rooms or a
//! building's own geometry beside its surfaces).

// Coordinate reference systems: the `srsName` parser, local frames, conversions, PROJ.
pub mod crs;
pub(crate) mod poi;
// Progress, cancellation, memory given back between stages.
pub(crate) mod runtime;
mod shown;
mod squares;
// Deterministic synthetic districts (the paper's Eixample) and box scenes.
pub mod synth;
pub(crate) mod triangulate;

pub use shown::{made_line, shown, Shown, STDIN_NAME, STDIN_SHOWN};
pub use squares::squares;

pub use poi::{Poi, POI_OFFSET};
pub use runtime::available::available_bytes;
pub use runtime::mem::{give_back, reserve_heap, set_give_back};
pub use runtime::progress::{check, Progress, Silent, Stage};
pub use runtime::progress_text::{Detail, Line, ProgressText};
pub use triangulate::triangulate;

use compact_str::CompactString;
use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Byte span of an XML element in the (decompressed) source document.
pub type Span = Range<u64>;

/// CityGML version of a document, detected from its namespaces.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, PartialOrd, Ord)]
pub enum CityGmlVersion {
    /// CityGML 1.0 (`http://www.opengis.net/citygml/1.0`).
    #[serde(rename = "1.0")]
    V1_0,
    /// CityGML 2.0 (`http://www.opengis.net/citygml/2.0`).
    #[serde(rename = "2.0")]
    V2_0,
    /// CityGML 3.0 (`http://www.opengis.net/citygml/3.0`).
    #[serde(rename = "3.0")]
    V3_0,
}

impl CityGmlVersion {
    /// "1.0", "2.0" or "3.0".
    pub fn as_str(self) -> &'static str {
        match self {
            CityGmlVersion::V1_0 => "1.0",
            CityGmlVersion::V2_0 => "2.0",
            CityGmlVersion::V3_0 => "3.0",
        }
    }
}

impl fmt::Display for CityGmlVersion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// What an asset is; see the mapping table in DESIGN.md.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, PartialOrd, Ord)]
pub enum AssetKind {
    /// `RoofSurface`.
    Roof,
    /// `WallSurface`.
    Wall,
    /// `GroundSurface`.
    Ground,
    /// `ClosureSurface`.
    Closure,
    /// `OuterCeilingSurface`.
    OuterCeiling,
    /// `OuterFloorSurface`.
    OuterFloor,
    /// Outer `BuildingInstallation`.
    Installation,
    /// `Window` opening.
    Window,
    /// `Door` opening.
    Door,
    /// A building's own geometry when it has no thematic surfaces.
    Body,
    /// Any other city object with geometry (vegetation, furniture, bridges, ...).
    Other,
}

impl AssetKind {
    /// Every kind, in declaration order (the order of [`AssetKind`]'s `Ord`).
    pub const ALL: [AssetKind; 11] = [
        AssetKind::Roof,
        AssetKind::Wall,
        AssetKind::Ground,
        AssetKind::Closure,
        AssetKind::OuterCeiling,
        AssetKind::OuterFloor,
        AssetKind::Installation,
        AssetKind::Window,
        AssetKind::Door,
        AssetKind::Body,
        AssetKind::Other,
    ];

    /// Thematic boundary surface of a building shell.
    pub fn is_shell_surface(self) -> bool {
        matches!(
            self,
            AssetKind::Roof
                | AssetKind::Wall
                | AssetKind::Ground
                | AssetKind::Closure
                | AssetKind::OuterCeiling
                | AssetKind::OuterFloor
        )
    }

    /// Window or door.
    pub fn is_opening(self) -> bool {
        matches!(self, AssetKind::Window | AssetKind::Door)
    }

    /// Lower-case name used in reports.
    pub fn as_str(self) -> &'static str {
        match self {
            AssetKind::Roof => "roof",
            AssetKind::Wall => "wall",
            AssetKind::Ground => "ground",
            AssetKind::Closure => "closure",
            AssetKind::OuterCeiling => "outer_ceiling",
            AssetKind::OuterFloor => "outer_floor",
            AssetKind::Installation => "installation",
            AssetKind::Window => "window",
            AssetKind::Door => "door",
            AssetKind::Body => "body",
            AssetKind::Other => "other",
        }
    }
}

impl fmt::Display for AssetKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A planar (or nearly planar) polygon: one exterior ring and any interior rings.
///
/// Rings are stored *open*: the closing point that repeats the first one is removed.
///
/// A city has millions of polygons, so a polygon is compact: every ring's points are in one
/// allocation (the exterior first, then each interior ring, then the interior rings' starts),
/// a short id inline: 48 bytes plus the points (and a long id).
///
/// ```
/// use glam::DVec3;
/// use skylod::model::Polygon;
/// let sq = |s: f64| vec![DVec3::ZERO, DVec3::new(s, 0.0, 0.0), DVec3::new(s, s, 0.0), DVec3::new(0.0, s, 0.0)];
/// let mut p = Polygon::new(sq(4.0));
/// p.push_interior(&sq(1.0));
/// assert_eq!((p.exterior().len(), p.interior_count()), (4, 1));
/// assert_eq!(p.interiors().next(), Some(&sq(1.0)[..]));
/// assert!((p.area() - 15.0).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Polygon {
    /// `gml:id` of the polygon, if it has one (ids up to 24 bytes are stored inline: no
    /// allocation for the short ids of most files).
    pub id: Option<CompactString>,
    /// Exterior ring then interior rings, open; then, one entry per interior ring, its start
    /// (in `x`): one allocation for the whole polygon.
    points: Box<[DVec3]>,
    /// Length of the exterior ring.
    ext: u32,
    /// Number of interior rings.
    holes: u32,
}

impl Polygon {
    /// A polygon without holes and without id.
    pub fn new(exterior: Vec<DVec3>) -> Self {
        let ext = exterior.len() as u32;
        Polygon {
            id: None,
            points: exterior.into_boxed_slice(),
            ext,
            holes: 0,
        }
    }

    /// A polygon from its rings (copied into one allocation).
    pub fn from_rings<R: AsRef<[DVec3]>>(
        id: Option<CompactString>,
        exterior: &[DVec3],
        interiors: &[R],
    ) -> Self {
        let n = exterior.len()
            + interiors.iter().map(|r| r.as_ref().len()).sum::<usize>()
            + interiors.len();
        let mut points = Vec::with_capacity(n);
        points.extend_from_slice(exterior);
        let mut starts = Vec::with_capacity(interiors.len());
        for r in interiors {
            starts.push(DVec3::new(points.len() as f64, 0.0, 0.0));
            points.extend_from_slice(r.as_ref());
        }
        points.extend_from_slice(&starts);
        Polygon {
            id,
            points: points.into_boxed_slice(),
            ext: exterior.len() as u32,
            holes: interiors.len() as u32,
        }
    }

    /// The same polygon with this id.
    pub fn with_id(mut self, id: Option<CompactString>) -> Self {
        self.id = id;
        self
    }

    /// End of the rings' points (the interior rings' starts follow).
    fn rings_end(&self) -> usize {
        self.points.len().saturating_sub(self.holes as usize)
    }

    /// Exterior ring, open, at least 3 points (empty for a default polygon).
    pub fn exterior(&self) -> &[DVec3] {
        &self.points[..(self.ext as usize).min(self.rings_end())]
    }

    /// Exterior ring, mutable.
    pub fn exterior_mut(&mut self) -> &mut [DVec3] {
        let e = (self.ext as usize).min(self.rings_end());
        &mut self.points[..e]
    }

    /// Number of interior rings (holes).
    pub fn interior_count(&self) -> usize {
        self.holes as usize
    }

    /// Interior ring `k`, open.
    pub fn interior(&self, k: usize) -> Option<&[DVec3]> {
        let end = self.rings_end();
        if k >= self.holes as usize {
            return None;
        }
        let start = |k: usize| self.points.get(end + k).map(|q| q.x as usize);
        let s = start(k)?;
        let e = if k + 1 < self.holes as usize {
            start(k + 1)?
        } else {
            end
        };
        self.points.get(s..e)
    }

    /// Interior rings (holes), open, in order.
    pub fn interiors(&self) -> impl ExactSizeIterator<Item = &[DVec3]> + Clone + '_ {
        (0..self.holes as usize).map(move |k| self.interior(k).unwrap_or(&[]))
    }

    /// Add an interior ring (the polygon's points are copied into a new allocation).
    pub fn push_interior(&mut self, ring: &[DVec3]) {
        let mut rings: Vec<Vec<DVec3>> = self.interiors().map(<[DVec3]>::to_vec).collect();
        rings.push(ring.to_vec());
        let ext = self.exterior().to_vec();
        *self = Polygon::from_rings(self.id.take(), &ext, &rings);
    }

    /// All points of all rings.
    pub fn points(&self) -> impl Iterator<Item = &DVec3> {
        self.points[..self.rings_end()].iter()
    }

    /// All points of all rings (exterior first), mutable: for transforms.
    pub fn points_mut(&mut self) -> &mut [DVec3] {
        let e = self.rings_end();
        &mut self.points[..e]
    }

    /// Reverse every ring in place (the orientation flips, each ring keeps its place).
    pub fn reverse_rings(&mut self) {
        let end = self.rings_end();
        let mut bounds: Vec<usize> = Vec::with_capacity(self.holes as usize + 2);
        bounds.push(0);
        bounds.push((self.ext as usize).min(end));
        for k in 0..self.holes as usize {
            let s = self.points.get(end + k).map_or(end, |q| q.x as usize);
            bounds.push(s.clamp(*bounds.last().unwrap_or(&0), end));
        }
        bounds.push(end);
        for w in bounds.windows(2) {
            if let Some(r) = self.points.get_mut(w[0]..w[1]) {
                r.reverse();
            }
        }
    }

    /// Newell normal of the exterior ring, not normalised (length = 2 x area).
    pub fn newell_normal(&self) -> DVec3 {
        newell(self.exterior())
    }

    /// Area of the polygon (exterior minus holes), by Newell's method.
    pub fn area(&self) -> f64 {
        let ext = newell(self.exterior());
        let n = ext.normalize_or_zero();
        let holes: f64 = self.interiors().map(|r| newell(r).dot(n).abs()).sum();
        (ext.length() - holes).max(0.0) * 0.5
    }
}

/// Newell's normal of a ring (open or closed), not normalised.
pub fn newell(ring: &[DVec3]) -> DVec3 {
    let mut n = DVec3::ZERO;
    let len = ring.len();
    for i in 0..len {
        let a = ring[i];
        let b = ring[(i + 1) % len];
        n.x += (a.y - b.y) * (a.z + b.z);
        n.y += (a.z - b.z) * (a.x + b.x);
        n.z += (a.x - b.x) * (a.y + b.y);
    }
    n
}

/// Axis-aligned bounding box in model coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bbox {
    /// Minimum corner.
    pub min: DVec3,
    /// Maximum corner.
    pub max: DVec3,
}

impl Default for Bbox {
    fn default() -> Self {
        Bbox::EMPTY
    }
}

impl Bbox {
    /// The empty box (min = +inf, max = -inf).
    pub const EMPTY: Bbox = Bbox {
        min: DVec3::splat(f64::INFINITY),
        max: DVec3::splat(f64::NEG_INFINITY),
    };

    /// True when no point was added.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x
    }

    /// Grow to include `p`.
    pub fn add(&mut self, p: DVec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// Grow to include another box.
    pub fn union(&mut self, o: &Bbox) {
        if !o.is_empty() {
            self.min = self.min.min(o.min);
            self.max = self.max.max(o.max);
        }
    }

    /// Box of a set of points.
    pub fn of_points<'a>(pts: impl IntoIterator<Item = &'a DVec3>) -> Bbox {
        let mut b = Bbox::EMPTY;
        for p in pts {
            b.add(*p);
        }
        b
    }

    /// Centre of the box.
    pub fn center(&self) -> DVec3 {
        (self.min + self.max) * 0.5
    }

    /// `[minx, miny, minz, maxx, maxy, maxz]`, or `None` when empty.
    pub fn to_array(&self) -> Option<[f64; 6]> {
        if self.is_empty() {
            return None;
        }
        Some([
            self.min.x, self.min.y, self.min.z, self.max.x, self.max.y, self.max.z,
        ])
    }
}

/// Geometry of an asset at one LoD, as found in one `lodN...` property.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LodGeometry {
    /// Level of detail 0..=4.
    pub lod: u8,
    /// Local name of the property element, e.g. `lod3MultiSurface`.
    pub property: Arc<str>,
    /// Byte span of the property element in the source (start tag to end tag).
    pub span: Span,
    /// Byte span of the property's content (between its start and end tags).
    pub content: Span,
    /// Polygons (xlinks resolved, implicit geometry transformed).
    pub polygons: Vec<Polygon>,
}

/// An asset: the unit that receives a level (0 dropped, 1 rough, 2 full detail).
#[derive(Debug, Clone, PartialEq)]
pub struct Asset {
    /// What it is.
    pub kind: AssetKind,
    /// `gml:id` of the element, if any (up to 24 bytes inline).
    pub id: Option<CompactString>,
    /// Local name of the XML element, e.g. `RoofSurface`, `SolitaryVegetationObject`.
    pub element: Arc<str>,
    /// Index into [`CityModel::buildings`] of the building or part it belongs to.
    pub building: Option<usize>,
    /// Index into [`CityModel::assets`] of the asset it is nested in (an opening's wall).
    pub parent: Option<usize>,
    /// Byte span of the element in the source.
    pub span: Span,
    /// 1-based line of the start tag in the source.
    pub line: u64,
    /// `function` code (installations), if given.
    pub function: Option<String>,
    /// Geometry per LoD property, in document order.
    pub geometries: Vec<LodGeometry>,
    /// Index into [`CityModel::files`] of the source document.
    pub file: usize,
}

impl Asset {
    /// An asset of `kind` (element `element`, `gml:id` `id`) with `geometries`, in file 0,
    /// in no building, nested in nothing, with no `function`, at span `0..0` of line 1: what
    /// tests and examples build by hand (the reader fills every field). Other fields by
    /// struct update.
    ///
    /// ```
    /// use skylod::model::{Asset, AssetKind, LodGeometry};
    /// let roof = Asset {
    ///     building: Some(0),
    ///     ..Asset::new(AssetKind::Roof, Some("r1"), "RoofSurface", vec![LodGeometry::default()])
    /// };
    /// assert_eq!((roof.id.as_deref(), roof.building, roof.file), (Some("r1"), Some(0), 0));
    /// ```
    pub fn new(
        kind: AssetKind,
        id: Option<&str>,
        element: &str,
        geometries: Vec<LodGeometry>,
    ) -> Asset {
        Asset {
            kind,
            id: id.map(Into::into),
            element: element.into(),
            building: None,
            parent: None,
            span: 0..0,
            line: 1,
            function: None,
            geometries,
            file: 0,
        }
    }

    /// Highest LoD present, if the asset has geometry.
    pub fn max_lod(&self) -> Option<u8> {
        self.geometries.iter().map(|g| g.lod).max()
    }

    /// Index in [`Asset::geometries`] of the "full detail" geometry: the first geometry
    /// property at the highest LoD present. The one rule behind [`Asset::detail_polygons`]
    /// and the hollow read's counts (which keep a count per geometry, not its polygons).
    pub fn detail_geometry(&self) -> Option<usize> {
        let top = self.max_lod()?;
        self.geometries.iter().position(|g| g.lod == top)
    }

    /// Polygons of the highest LoD present (the "full detail" geometry,
    /// [`Asset::detail_geometry`]).
    pub fn detail_polygons(&self) -> &[Polygon] {
        let g = self.detail_geometry().and_then(|k| self.geometries.get(k));
        g.map_or(&[], |g| g.polygons.as_slice())
    }

    /// Polygons of a given LoD (all properties of that LoD).
    pub fn polygons_at(&self, lod: u8) -> impl Iterator<Item = &Polygon> {
        self.geometries
            .iter()
            .filter(move |g| g.lod == lod)
            .flat_map(|g| g.polygons.iter())
    }

    /// Number of polygons over all LoDs and properties: the asset's share of
    /// [`CityModel::polygon_count`].
    pub fn polygon_count(&self) -> usize {
        self.geometries.iter().map(|g| g.polygons.len()).sum()
    }

    /// Box of all polygons of all LoDs.
    pub fn bbox(&self) -> Bbox {
        let mut b = Bbox::EMPTY;
        add_geometries(&mut b, &self.geometries);
        b
    }
}

/// Every point of every polygon of `geometries` added to `b`.
fn add_geometries(b: &mut Bbox, geometries: &[LodGeometry]) {
    for g in geometries {
        for p in &g.polygons {
            for q in p.points() {
                b.add(*q);
            }
        }
    }
}

/// The box of a root envelope: every polygon of the `assets` and of the `buildings`' own
/// geometry (the reader's recomputed envelopes, the writer's over a streamed chunk).
pub fn content_bbox(assets: &[Asset], buildings: &[Building]) -> Bbox {
    content_bbox_of(assets.iter().map(Asset::bbox), buildings)
}

/// [`content_bbox`] from the assets' boxes ([`Asset::bbox`], in the assets' order) where they
/// are at hand: the same box, bit for bit.
pub fn content_bbox_of(boxes: impl IntoIterator<Item = Bbox>, buildings: &[Building]) -> Bbox {
    let mut b = Bbox::EMPTY;
    for a in boxes {
        b.union(&a);
    }
    for bd in buildings {
        add_geometries(&mut b, &bd.geometries);
    }
    b
}

/// A `Building` or `BuildingPart`.
#[derive(Debug, Clone, PartialEq)]
pub struct Building {
    /// `gml:id`, if any.
    pub id: Option<String>,
    /// True for `BuildingPart`.
    pub is_part: bool,
    /// Enclosing building for a part.
    pub parent: Option<usize>,
    /// Byte span of the element.
    pub span: Span,
    /// 1-based line of the start tag.
    pub line: u64,
    /// Indices of the assets directly owned by this building or part.
    pub assets: Vec<usize>,
    /// The building's own geometry properties (lodNSolid, lodNMultiSurface, ...),
    /// also when thematic surfaces exist (then usually xlinks to them).
    pub geometries: Vec<LodGeometry>,
    /// Index into [`CityModel::files`].
    pub file: usize,
}

impl Building {
    /// Its element name: `BuildingPart` or `Building`.
    pub fn element(&self) -> &'static str {
        if self.is_part {
            "BuildingPart"
        } else {
            "Building"
        }
    }

    /// The rule of every reader for a building without shell surfaces: when none of the
    /// `assets` it owns is a shell surface ([`AssetKind::is_shell_surface`]) and it has
    /// geometry of its own, that geometry is taken out of it as a [`AssetKind::Body`] asset of
    /// building `b` with its id, element, span and line (in file 0, as the readers number
    /// files); otherwise `None`. The caller adds the asset to the model and to
    /// [`Building::assets`].
    pub fn take_body(&mut self, b: usize, assets: &[Asset]) -> Option<Asset> {
        let has_surfaces = self
            .assets
            .iter()
            .any(|&a| assets.get(a).is_some_and(|a| a.kind.is_shell_surface()));
        if has_surfaces || self.geometries.is_empty() {
            return None;
        }
        Some(Asset {
            building: Some(b),
            span: self.span.clone(),
            line: self.line,
            ..Asset::new(
                AssetKind::Body,
                self.id.as_deref(),
                self.element(),
                std::mem::take(&mut self.geometries),
            )
        })
    }

    /// A building (not a part) with `gml:id` `id` that owns `assets`, in file 0, with no
    /// geometry of its own, at span `0..0` of line 1: what tests and examples build by hand
    /// (the reader fills every field). Other fields by struct update, as [`Asset::new`].
    ///
    /// ```
    /// use skylod::model::Building;
    /// let b = Building { span: 0..10, ..Building::new(Some("b1"), vec![0, 1]) };
    /// assert_eq!((b.id.as_deref(), b.is_part, b.assets.len()), (Some("b1"), false, 2));
    /// ```
    pub fn new(id: Option<&str>, assets: Vec<usize>) -> Building {
        Building {
            id: id.map(str::to_string),
            is_part: false,
            parent: None,
            span: 0..0,
            line: 1,
            assets,
            geometries: Vec::new(),
            file: 0,
        }
    }
}

/// A `gml:Envelope` inside a `gml:boundedBy` whose owner's geometry is known.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvelopeSite {
    /// Byte span of the `gml:Envelope` element.
    pub span: Span,
    /// Box of the coordinates found in the owning feature (empty if none).
    pub bbox: Bbox,
    /// `srsName` attribute of the envelope, if any.
    pub srs_name: Option<String>,
    /// `srsDimension` of the envelope (2 or 3).
    pub dimension: u8,
    /// Namespace prefix of the element with its colon (`"gml:"`), empty for a default namespace.
    pub prefix: String,
    /// Index into [`CityModel::files`].
    pub file: usize,
}

/// A problem in the input that did not stop reading.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Warning {
    /// Source file (shared by all warnings of a file).
    pub file: Arc<Path>,
    /// 1-based line.
    pub line: u64,
    /// 1-based column.
    pub column: u64,
    /// `gml:id` of the nearest element that has one.
    pub gml_id: Option<String>,
    /// Human-readable message.
    pub message: String,
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}: ", shown(&self.file), self.line, self.column)?;
        if let Some(id) = &self.gml_id {
            write!(f, "[{id}] ")?;
        }
        f.write_str(&self.message)
    }
}

/// Where the bytes of a source document are: a file read again by its path whenever a
/// writer needs them, or the whole document held in memory (a model read from bytes, standard
/// input), plain or gzip-compressed as it was given.
#[derive(Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum Source {
    /// A file on disk.
    File(PathBuf),
    /// The document's bytes, kept for as long as the model (shared, never copied again).
    Memory(Arc<[u8]>),
}

impl Source {
    /// The file, for a source on disk.
    pub fn path(&self) -> Option<&Path> {
        match self {
            Source::File(p) => Some(p),
            Source::Memory(_) => None,
        }
    }
}

impl fmt::Debug for Source {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Source::File(p) => f.debug_tuple("File").field(p).finish(),
            Source::Memory(b) => write!(f, "Memory({} bytes)", b.len()),
        }
    }
}

/// Facts about one source document.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceFile {
    /// The input's name: its path as given, `-` for standard input (messages show it with
    /// [`shown`]: `<stdin>`).
    pub path: PathBuf,
    /// Where the document's bytes are, for the writers that copy from it.
    pub source: Source,
    /// CityGML version.
    pub version: CityGmlVersion,
    /// `srsName` of the model (envelope or first geometry).
    pub srs_name: Option<String>,
    /// True when the file was gzip-compressed.
    pub gzip: bool,
    /// Length of the decompressed document in bytes.
    pub len: u64,
    /// Prefix (with colon) bound to the GML namespace in the document, e.g. `"gml:"`.
    pub gml_prefix: String,
    /// Envelopes to recompute on write.
    pub envelopes: Vec<EnvelopeSite>,
    /// Number of `ImplicitGeometry` elements.
    pub implicit_geometries: usize,
    /// Number of `libraryObject` references (recorded, not fetched).
    pub library_objects: Vec<String>,
    /// Number of city objects that are not buildings and carry no geometry.
    pub objects_without_geometry: usize,
    /// Number of polygon elements (`Polygon`, `PolygonPatch`, `Triangle`, `Rectangle`) in the
    /// document, each counted once however often it is referenced.
    pub polygon_elements: usize,
    /// Elements per CityGML feature or object type (local name: `WallSurface`,
    /// `BuildingInstallation`, `Room`, `Appearance`, …), wherever they nest.
    pub features: std::collections::BTreeMap<String, usize>,
    /// For a CityJSON document (read by `crate::io::cityjson`): its `version` and whether it came
    /// as CityJSONSeq; `None` for CityGML. A CityJSON file has no XML to copy: the writers
    /// that copy spans refuse it.
    pub cityjson: Option<CityJsonFormat>,
}

/// How a CityJSON source was encoded ([`SourceFile::cityjson`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CityJsonFormat {
    /// The document's `version`: `"1.0"`, `"1.1"`, `"2.0"`.
    pub version: String,
    /// True for CityJSONSeq (`.city.jsonl`: a header line, then `CityJSONFeature` lines).
    pub seq: bool,
}

impl SourceFile {
    /// An empty file named `path` (read from that path) of CityGML `version`: no CRS, no
    /// envelope, nothing counted, GML bound to `gml:`; what tests and examples build by hand
    /// (the reader fills every field). Other fields by struct update.
    ///
    /// ```
    /// use skylod::model::{CityGmlVersion, SourceFile};
    /// let f = SourceFile {
    ///     srs_name: Some("EPSG:25832".into()),
    ///     ..SourceFile::new("a.gml", CityGmlVersion::V2_0)
    /// };
    /// assert_eq!((f.path.to_str(), f.len, f.gzip), (Some("a.gml"), 0, false));
    /// ```
    pub fn new(path: impl Into<PathBuf>, version: CityGmlVersion) -> SourceFile {
        let path = path.into();
        SourceFile {
            source: Source::File(path.clone()),
            path,
            version,
            srs_name: None,
            gzip: false,
            len: 0,
            gml_prefix: "gml:".into(),
            envelopes: Vec::new(),
            implicit_geometries: 0,
            library_objects: Vec::new(),
            objects_without_geometry: 0,
            polygon_elements: 0,
            features: Default::default(),
            cityjson: None,
        }
    }
}

/// A city model read from one or more CityGML documents.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CityModel {
    /// Source documents, in reading order.
    pub files: Vec<SourceFile>,
    /// Buildings and building parts.
    pub buildings: Vec<Building>,
    /// Assets.
    pub assets: Vec<Asset>,
    /// Warnings met while reading.
    pub warnings: Vec<Warning>,
}

impl CityModel {
    /// Box of every asset polygon.
    pub fn bbox(&self) -> Bbox {
        // Every point of a city: in parallel over the assets (rayon's pool).
        self.assets
            .par_iter()
            .with_min_len(1024)
            .fold(
                || Bbox::EMPTY,
                |mut b, a| {
                    b.union(&a.bbox());
                    b
                },
            )
            .reduce(
                || Bbox::EMPTY,
                |mut a, b| {
                    a.union(&b);
                    a
                },
            )
    }

    /// The model's *polygons*: those of every asset over all LoDs and properties, an
    /// xlinked polygon counted at each use (see the module's "Polygon counts").
    pub fn polygon_count(&self) -> usize {
        self.assets.iter().map(|a| a.polygon_count()).sum()
    }

    /// *Traced polygons*: each asset's highest LoD ([`Asset::detail_polygons`]), what the
    /// full-detail scene of `svf`, `sun-hours` and `horizon` traces; at most
    /// [`CityModel::polygon_count`].
    pub fn traced_polygon_count(&self) -> usize {
        self.assets.iter().map(|a| a.detail_polygons().len()).sum()
    }

    /// The name of asset `i`, asset `global` of the whole document (`i` itself but in a
    /// chunk of a streamed read), in exports and tables: its `gml:id`, else its building's id
    /// and its index among the building's assets (`B1_3`), else `asset_<global>`.
    pub fn asset_name(&self, i: usize, global: usize) -> String {
        let Some(a) = self.assets.get(i) else {
            return format!("asset_{global}");
        };
        if let Some(id) = &a.id {
            return id.to_string();
        }
        if let Some(b) = a.building.and_then(|b| self.buildings.get(b)) {
            if let Some(bid) = &b.id {
                let k = b.assets.iter().position(|&x| x == i).unwrap_or(global);
                return format!("{bid}_{k}");
            }
        }
        format!("asset_{global}")
    }

    /// The top-level building of a building or part.
    pub fn root_building(&self, mut b: usize) -> usize {
        while let Some(p) = self.buildings.get(b).and_then(|x| x.parent) {
            b = p;
        }
        b
    }

    /// Append another model (e.g. a second tile), re-indexing its references.
    pub fn merge(&mut self, mut other: CityModel) {
        if *self == CityModel::default() {
            // The first model is taken as it is: no copy of a city's vectors.
            *self = other;
            return;
        }
        let f0 = self.files.len();
        let b0 = self.buildings.len();
        let a0 = self.assets.len();
        for b in &mut other.buildings {
            b.parent = b.parent.map(|p| p + b0);
            b.assets.iter_mut().for_each(|a| *a += a0);
            b.file += f0;
        }
        for a in &mut other.assets {
            a.building = a.building.map(|p| p + b0);
            a.parent = a.parent.map(|p| p + a0);
            a.file += f0;
        }
        for f in &mut other.files {
            f.envelopes.iter_mut().for_each(|e| e.file += f0);
        }
        self.files.append(&mut other.files);
        self.buildings.append(&mut other.buildings);
        self.assets.append(&mut other.assets);
        self.warnings.append(&mut other.warnings);
    }
}

#[cfg(test)]
mod body_tests;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn area_with_hole() {
        let sq = |s: f64| {
            vec![
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(s, 0.0, 0.0),
                DVec3::new(s, s, 0.0),
                DVec3::new(0.0, s, 0.0),
            ]
        };
        let mut p = Polygon::new(sq(4.0));
        assert!((p.area() - 16.0).abs() < 1e-12);
        p.push_interior(&sq(1.0));
        assert!((p.area() - 15.0).abs() < 1e-12);
        assert!(p.newell_normal().z > 0.0);
    }

    #[test]
    fn rings_in_one_allocation() {
        let r = |k: f64, n: usize| {
            (0..n)
                .map(|i| DVec3::splat(k + i as f64))
                .collect::<Vec<_>>()
        };
        let mut p = Polygon::from_rings(Some("p".into()), &r(0.0, 4), &[r(10.0, 3), r(20.0, 5)]);
        assert_eq!(std::mem::size_of::<Polygon>(), 48);
        assert_eq!(p.exterior(), &r(0.0, 4)[..]);
        assert_eq!(p.interior_count(), 2);
        assert_eq!(p.interior(1), Some(&r(20.0, 5)[..]));
        assert_eq!(p.interior(2), None);
        assert_eq!(p.points().count(), 12);
        p.reverse_rings();
        let rev = |mut v: Vec<DVec3>| {
            v.reverse();
            v
        };
        assert_eq!(p.exterior(), &rev(r(0.0, 4))[..]);
        let holes: Vec<&[DVec3]> = p.interiors().collect();
        assert_eq!(holes, [&rev(r(10.0, 3))[..], &rev(r(20.0, 5))[..]]);
        p.push_interior(&r(30.0, 3));
        assert_eq!(p.interiors().len(), 3);
        assert_eq!(p.id.as_deref(), Some("p"));
        let plain = Polygon::new(r(0.0, 3));
        assert_eq!((plain.interior_count(), plain.exterior().len()), (0, 3));
        p.exterior_mut()[0] = DVec3::ZERO;
        assert_eq!(p.exterior()[0], DVec3::ZERO);
    }

    #[test]
    fn merge_takes_the_first_model_and_reindexes_the_next() {
        let mut one = CityModel::default();
        one.files
            .push(SourceFile::new("a.gml", CityGmlVersion::V2_0));
        one.buildings.push(Building {
            span: 0..1,
            ..Building::new(Some("b"), vec![0])
        });
        one.assets.push(Asset {
            building: Some(0),
            span: 0..1,
            ..Asset::new(AssetKind::Roof, Some("r"), "RoofSurface", Vec::new())
        });
        let mut m = CityModel::default();
        m.merge(one.clone());
        assert_eq!(m, one);
        m.merge(one.clone());
        assert_eq!(
            (m.files.len(), m.buildings.len(), m.assets.len()),
            (2, 2, 2)
        );
        assert_eq!(m.buildings[1].assets, [1]);
        assert_eq!((m.assets[1].building, m.assets[1].file), (Some(1), 1));
    }

    #[test]
    fn bbox_union() {
        let mut b = Bbox::EMPTY;
        assert!(b.is_empty());
        assert_eq!(b.to_array(), None);
        b.add(DVec3::new(1.0, 2.0, 3.0));
        b.add(DVec3::new(-1.0, 5.0, 0.0));
        assert_eq!(b.to_array(), Some([-1.0, 2.0, 0.0, 1.0, 5.0, 3.0]));
    }
}
