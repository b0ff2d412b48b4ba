//! CityJSON 2.0 (`.city.json`) and CityJSONSeq (`.city.jsonl`) for the CityJSON tools (cjio,
//! cjval, 3DBAG's tyler, DuckDB readers).
//!
//! # Mapping
//!
//! * `Building` and `BuildingPart` become city objects of those types (`parents`/`children`
//!   linked); outer `BuildingInstallation`s become `BuildingInstallation` children of their
//!   building or part. Other city objects keep their CityGML type where CityJSON 2.0 has it
//!   (`SolitaryVegetationObject`, `PlantCover`, `CityFurniture`, `LandUse`, `WaterBody`, `Bridge`,
//!   `Tunnel`, `Road`, `Railway`, `TransportSquare`, `Waterway`, `TINRelief`,
//!   `OtherConstruction`, `GenericCityObject`) and are `GenericCityObject`s otherwise (with
//!   the CityGML element name as the attribute `citygml_type`).
//! * Thematic surfaces are semantic surfaces of their building's geometry (`RoofSurface`,
//!   `WallSurface`, `GroundSurface`, `ClosureSurface`, `OuterCeilingSurface`,
//!   `OuterFloorSurface`); openings are the semantic surfaces `Window` and `Door` with their
//!   wall or roof as `parent` (CityJSON 2.0 has no opening city objects). One semantic object
//!   per CityGML surface and geometry, so every polygon of a surface points to the same one.
//! * One `MultiSurface` per city object and LoD (`"lod": "2"`, ...; rings open, holes kept).
//!   CityJSON has no LoD 4: the exterior geometry of CityGML LoD4 is written as `"3"`, in a
//!   geometry of its own. A building's own geometry (e.g. an `lod1Solid` beside LoD2 surfaces)
//!   is written at the LoDs its surfaces do not cover; where they cover it, it would only
//!   repeat their polygons.
//! * `transform`: scale 0.001 (millimetres; 1e-8 degrees, about a millimetre, for latitude and
//!   longitude in a geographic CRS such as PLATEAU's EPSG:6697), translate = the lower corner of the written
//!   geometry, whole metres down; `metadata.referenceSystem` from the `srsName`
//!   (`https://www.opengis.net/def/crs/EPSG/0/<code>`, the horizontal code of a compound
//!   CRS, AdV `ETRS89_UTM<zone>` names as `EPSG:258<zone>`), `metadata.geographicalExtent`.
//! * Levels ([`Content::Levels`]): what the mixed CityGML output holds
//!   ([`crate::lod::mixed`]): level 2 every LoD of the asset, level 1 the rough geometry in
//!   the LoDs it replaces ([`crate::lod::level::properties`]), level 0 nothing. Every
//!   written surface, opening, installation or other object carries `skylod_level` (an
//!   attribute, or a property of the semantic object); a building left with nothing is
//!   dropped. [`Content::Full`] writes every building, also one without geometry.
//!
//! # Streaming
//!
//! One writer ([`write`]) goes over its source a chunk at a time ([`Chunks`]: a model in
//! memory is one chunk) and city objects are written one building at a time. CityJSONSeq
//! writes one line per building (its parts and installations included) or other city object,
//! each with its own vertices, so memory follows the chunk. CityJSON keeps only the shared
//! vertex list (integers) until the end of the document: a stream's on disk.
//!
//! # Example
//! ```
//! use skylod::export::{write_to, Chunks, Content, Format};
//! use skylod::model::synth::{generate, Preset};
//! let mut xml = Vec::new();
//! generate(&Preset::Small.defaults(), &mut xml).unwrap();
//! let model = skylod::io::citygml::read_bytes(&xml, "small.gml").unwrap();
//! let mut out = Vec::new();
//! let chunks = Chunks::model(&model, 0, Content::Full);
//! let (s, _) = write_to(Format::CityJsonSeq, &chunks, &mut out).unwrap();
//! let text = String::from_utf8(out).unwrap();
//! let header: serde_json::Value = serde_json::from_str(text.lines().next().unwrap()).unwrap();
//! assert_eq!(header["version"], "2.0");
//! assert_eq!(text.lines().count(), 1 + s.features);
//! ```

use super::chunks::{Chunks, Part};
use super::cityjson_source::{from_source, FromSource};
use super::cityjson_vertices::{record_uses, Vertices};
use super::{Content, ExportSummary};
use crate::io::citygml::read::StreamSummary;
use crate::model::{Asset, AssetKind, Bbox, CityModel, Polygon};
use foldhash::{HashMap, HashMapExt, HashSet, HashSetExt};
use glam::DVec3;
use serde_json::{json, Map, Value};
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::hash::BuildHasher;
use std::io::{self, Write};

/// Scale of the integer vertices: millimetres.
const SCALE: f64 = 0.001;

/// Scale of latitude and longitude in a geographic CRS: 1e-8 degrees, about a millimetre.
const SCALE_DEGREES: f64 = 1e-8;

/// EPSG codes of the geographic (latitude/longitude) CRSs city models use: WGS 84 (4326, 4979),
/// ETRS89 (4258, 4937), JGD2000/JGD2011 (4612, 6668, 6697), NAD83 (4269), GDA94/GDA2020 (4283,
/// 7844), CGCS2000 (4490), RGF93 (4171).
const GEOGRAPHIC: &[u32] = &[
    4326, 4979, 4258, 4937, 4612, 6668, 6697, 4269, 4283, 7844, 4490, 4171,
];

/// Which output of [`write`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    /// One CityJSON document.
    CityJson,
    /// CityJSONSeq: the CityJSON header object on the first line, then one
    /// `CityJSONFeature` per building (with its parts and installations) or other city object.
    Seq,
}

/// Write `chunks` as CityJSON or CityJSONSeq (`kind`), in passes over the chunks (see
/// [`super::write()`] for their numbers):
///
/// 1. **plan**: the bounding box (the header's extent and `transform`), the buildings' ids
///    (made unique in document order);
/// 2. **objects**: buildings (with their parts and installations) in document order, then, in
///    another pass when there are any, the city objects outside buildings. The
///    installations' and other objects' ids are made unique in the first of these passes,
///    after every building's.
///
/// CityJSONSeq writes each feature's vertices on its line. CityJSON shares one vertex list
/// over the document, numbered by first use: a model's in memory, a stream's on disk (the
/// objects passes run twice, the first recording every vertex use:
/// [`super::cityjson_vertices`]). With what was written, the source's summary; `Ok(None)`
/// where the stream declines (what was written is to be dropped).
///
/// # Errors
/// I/O errors of `w`, of the temporary files, or of a CityJSON source read again.
pub(crate) fn write(
    kind: Kind,
    chunks: &Chunks<'_>,
    w: &mut dyn Write,
) -> io::Result<Option<(ExportSummary, StreamSummary)>> {
    // a model's CityJSON source is read again for what it gives; a stream's chunks carry it
    let (whole_source, surface_attributes) = match *chunks {
        Chunks::Model {
            model,
            file,
            surface_attributes,
            ..
        } => (
            from_source(model, file, crate::io::citygml::read::CHUNK_BYTES)?,
            surface_attributes,
        ),
        Chunks::Stream { .. } => (None, None),
    };
    // 1. the plan
    let mut ids = Ids::default();
    let mut bbox = Bbox::EMPTY;
    let mut others = false;
    let Some(sum) = chunks.pass(0, |p: &Part<'_>| -> io::Result<()> {
        bbox.union(&extent(p.model, p.file, p.content));
        others |= p.assets().any(|(_, a)| a.building.is_none());
        for (b, bd) in p.buildings() {
            let global = p.buildings_before + b;
            if let Some(id) = ids.unique(building_id(bd, global)) {
                ids.buildings.insert(global, id);
            }
        }
        Ok(())
    })?
    else {
        return Ok(None);
    };
    let scale = scale_for(sum.srs_name.as_deref());
    let translate = if bbox.is_empty() {
        DVec3::ZERO
    } else {
        bbox.min.floor()
    };
    let frame = Frame {
        bbox,
        translate,
        scale,
        source: whole_source.as_ref(),
        surface_attributes,
    };
    let header = frame.header(sum.srs_name.as_deref());
    let parts: &[bool] = if others { &[false, true] } else { &[false] };
    let mut s = ExportSummary::default();
    let mut verts = Vertices::new(translate, scale);
    // the passes over the parts (buildings, then the other city objects) from pass `first`
    // on: `each` sees every chunk's plan and the part; false when the stream declines
    let mut over_parts = |first: usize,
                          each: &mut dyn FnMut(&Plan<'_>, bool) -> io::Result<()>|
     -> io::Result<bool> {
        for (k, &standalone) in parts.iter().enumerate() {
            let done = chunks.pass(first + k, |p: &Part<'_>| {
                each(&Plan::new(p, &frame, &mut ids), standalone)
            })?;
            if done.is_none() {
                return Ok(false);
            }
        }
        Ok(true)
    };
    if kind == Kind::Seq {
        serde_json::to_writer(&mut *w, &Value::Object(header))?;
        w.write_all(b"\n")?;
        let done = over_parts(1, &mut |plan, standalone| {
            for f in plan.features.iter().filter(|f| is_part(f, standalone)) {
                write_feature_line(plan, *f, &mut verts, &mut s, w)?;
            }
            Ok(())
        })?;
        return Ok(done.then_some((s, sum)));
    }
    if let Chunks::Stream { path, .. } = chunks {
        // a stream's vertices are numbered on disk, every use recorded in a first pass
        if !record_uses(path, &mut verts, &mut over_parts)? {
            return Ok(None);
        }
    }
    // `{...header` without its closing brace, then the city objects, then the vertices
    write_head_open(header, w)?;
    let mut first = true;
    let done = over_parts(1, &mut |plan, standalone| {
        for f in plan.features.iter().filter(|f| is_part(f, standalone)) {
            write_members(&plan.objects(*f, &mut verts, &mut s), &mut first, w)?;
        }
        verts.check()
    })?;
    if !done {
        return Ok(None);
    }
    w.write_all(b"},\"vertices\":[")?;
    s.vertices = verts.write_list(w)?;
    w.write_all(b"]}\n")?;
    Ok(Some((s, sum)))
}

/// Whether feature `f` is written in the pass of buildings (`standalone` false) or of the
/// other city objects.
fn is_part(f: &Feature, standalone: bool) -> bool {
    matches!(f, Feature::Standalone(_)) == standalone
}

/// The id building `bd`, building `global` of the document, asks for.
fn building_id(bd: &crate::model::Building, global: usize) -> String {
    bd.id
        .clone()
        .unwrap_or_else(|| format!("building_{global}"))
}

/// The whole document's box and transform, and what its objects get from elsewhere than
/// their chunk.
struct Frame<'s> {
    bbox: Bbox,
    translate: DVec3,
    scale: DVec3,
    /// A model's CityJSON source's attributes (a streamed chunk carries its own).
    source: Option<&'s FromSource>,
    /// Extra attributes of the semantic surface objects of some assets.
    surface_attributes: Option<&'s BTreeMap<usize, Map<String, Value>>>,
}

impl Frame<'_> {
    /// The document's header (empty `CityObjects` and `vertices`) in CRS `srs_name`.
    fn header(&self, srs_name: Option<&str>) -> Map<String, Value> {
        let mut meta = Map::new();
        if let Some(rs) = srs_name.and_then(reference_system) {
            meta.insert("referenceSystem".into(), rs.into());
        }
        if let Some(b) = self.bbox.to_array() {
            meta.insert("geographicalExtent".into(), json!(b));
        }
        let t = self.translate;
        let mut h = Map::new();
        h.insert("type".into(), "CityJSON".into());
        h.insert("version".into(), "2.0".into());
        h.insert(
            "transform".into(),
            json!({"scale": self.scale.to_array(), "translate": [t.x, t.y, t.z]}),
        );
        h.insert("metadata".into(), Value::Object(meta));
        h.insert("CityObjects".into(), json!({}));
        h.insert("vertices".into(), json!([]));
        h
    }
}

/// The document's unique ids: candidates taken in the writer's order (buildings, then
/// installations and other objects), a repeated one given `_2`, `_3`, ...; only the renamed
/// ones are kept as text.
#[derive(Default)]
struct Ids {
    /// 128-bit hashes of the ids taken.
    used: HashSet<u128>,
    /// Renamed buildings, by index in the whole document.
    buildings: HashMap<usize, String>,
    /// Renamed installations and other objects, by asset index in the whole document.
    assets: HashMap<usize, String>,
    /// Chunks whose assets' ids were taken.
    chunks_done: usize,
}

impl Ids {
    fn hash(id: &str) -> u128 {
        let a = foldhash::fast::FixedState::with_seed(0x51c1_0d5e).hash_one(id);
        let b = foldhash::fast::FixedState::with_seed(0x7e57_ab1e).hash_one(id);
        (u128::from(a) << 64) | u128::from(b)
    }

    /// Take `cand`, or `cand_2`, `cand_3`, ... when taken: `Some` of the id when renamed.
    fn unique(&mut self, cand: String) -> Option<String> {
        if self.used.insert(Self::hash(&cand)) {
            return None;
        }
        let mut k = 2;
        loop {
            let id = format!("{cand}_{k}");
            if self.used.insert(Self::hash(&id)) {
                return Some(id);
            }
            k += 1;
        }
    }
}

/// One CityJSONSeq line: feature `f` of `plan` as a `CityJSONFeature` with its own vertex
/// list (nothing when it has no city object to write).
fn write_feature_line(
    plan: &Plan<'_>,
    f: Feature,
    verts: &mut Vertices,
    s: &mut ExportSummary,
    w: &mut dyn Write,
) -> io::Result<()> {
    verts.clear();
    let objs = plan.objects(f, verts, s);
    if objs.is_empty() {
        return Ok(());
    }
    w.write_all(b"{\"type\":\"CityJSONFeature\",\"id\":")?;
    serde_json::to_writer(&mut *w, &plan.feature_id(f))?;
    w.write_all(b",\"CityObjects\":{")?;
    write_members(&objs, &mut true, w)?;
    w.write_all(b"},\"vertices\":[")?;
    s.vertices += verts.write_list(w)?;
    w.write_all(b"]}\n")?;
    s.features += 1;
    Ok(())
}

/// A CityJSON document's header (`header`, without its `vertices` and `CityObjects`) up to
/// the opening of `"CityObjects":{`, for city objects written one by one ([`write_members`]).
fn write_head_open(mut header: Map<String, Value>, w: &mut dyn Write) -> io::Result<()> {
    header.remove("vertices");
    header.remove("CityObjects");
    let head = serde_json::to_string(&Value::Object(header))?;
    w.write_all(&head.as_bytes()[..head.len() - 1])?;
    w.write_all(b",\"CityObjects\":{")
}

/// City objects as `"id":{...}` members of `CityObjects`, a comma before each one but the
/// first of the object (`first`, cleared once one is written).
fn write_members(objs: &[(String, Value)], first: &mut bool, w: &mut dyn Write) -> io::Result<()> {
    for (id, obj) in objs {
        if !std::mem::take(first) {
            w.write_all(b",")?;
        }
        serde_json::to_writer(&mut *w, id)?;
        w.write_all(b":")?;
        serde_json::to_writer(&mut *w, obj)?;
    }
    Ok(())
}

/// The `https://www.opengis.net/def/crs/EPSG/0/<code>` form of an `srsName`, when it names an
/// EPSG code (the first one of a compound CRS) or an AdV `ETRS89_UTM<zone>` CRS.
///
/// ```
/// use skylod::export::reference_system;
/// let want = Some("https://www.opengis.net/def/crs/EPSG/0/25832".to_string());
/// assert_eq!(reference_system("urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783"), want);
/// assert_eq!(reference_system("urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH"), want);
/// assert_eq!(reference_system("http://www.opengis.net/def/crs/EPSG/0/25832"), want);
/// let gk4 = Some("https://www.opengis.net/def/crs/EPSG/0/31468".to_string());
/// assert_eq!(reference_system("urn:adv:crs:DE_DHDN_3GK4*DE_DHHN92_NH"), gk4);
/// assert_eq!(reference_system("urn:adv:crs:DE_DHDN_3GK4_BY120*DE_DHHN92_NH"), gk4);
/// assert_eq!(reference_system("#local-CRS-1"), None);
/// ```
pub fn reference_system(srs_name: &str) -> Option<String> {
    epsg_code(srs_name).map(|c| format!("https://www.opengis.net/def/crs/EPSG/0/{c}"))
}

/// The horizontal EPSG code of an `srsName` (see [`reference_system`]): the one parser
/// [`crate::model::crs::Crs::parse`], so AdV names (`urn:adv:crs:DE_DHDN_3GK4*...` = EPSG:31468,
/// `ETRS89_UTM32*...` = 25832) and compound names give their horizontal code.
fn epsg_code(srs_name: &str) -> Option<u32> {
    crate::model::crs::Crs::parse(srs_name).epsg
}

/// Scale per axis for a CRS: millimetres, or about a millimetre in degrees for the horizontal
/// axes of a geographic CRS.
fn scale_for(srs_name: Option<&str>) -> DVec3 {
    match srs_name.and_then(epsg_code) {
        Some(c) if GEOGRAPHIC.contains(&c) => DVec3::new(SCALE_DEGREES, SCALE_DEGREES, SCALE),
        _ => DVec3::splat(SCALE),
    }
}

/// One MultiSurface being built: boundaries, semantic objects, one value per surface.
#[derive(Default)]
struct Geom {
    boundaries: Vec<Vec<Vec<u32>>>,
    values: Vec<Option<usize>>,
    surfaces: Vec<Map<String, Value>>,
    /// Semantic object of an asset in this geometry.
    of_asset: HashMap<usize, usize>,
}

impl Geom {
    fn add(&mut self, verts: &mut Vertices, polys: &[Polygon], sem: Option<usize>) -> usize {
        let mut n = 0;
        for p in polys {
            let Some(ext) = verts.ring(p.exterior()) else {
                continue;
            };
            let mut rings = vec![ext];
            rings.extend(p.interiors().filter_map(|r| verts.ring(r)));
            self.boundaries.push(rings);
            self.values.push(sem);
            n += 1;
        }
        n
    }

    /// The semantic object of asset `i` (a thematic surface or an opening) in this geometry,
    /// made on first use with its parent's (an opening's wall or roof) linked both ways; the
    /// parent's is made too when the parent has no polygons of its own here.
    fn semantic(&mut self, model: &CityModel, content: Content<'_>, i: usize) -> Option<usize> {
        if let Some(k) = self.of_asset.get(&i) {
            return Some(*k);
        }
        let a = model.assets.get(i)?;
        let ty = semantic_type(a.kind)?;
        let parent = a
            .parent
            .filter(|&p| p != i)
            .and_then(|p| self.semantic(model, content, p));
        let mut m = Map::new();
        m.insert("type".into(), ty.into());
        if content.has_levels() {
            m.insert("skylod_level".into(), content.level(i).into());
        }
        let k = self.surfaces.len();
        if let Some(p) = parent {
            m.insert("parent".into(), p.into());
            if let Some(Value::Array(c)) = self
                .surfaces
                .get_mut(p)
                .map(|ps| ps.entry("children").or_insert_with(|| json!([])))
            {
                c.push(k.into());
            }
        }
        self.surfaces.push(m);
        self.of_asset.insert(i, k);
        Some(k)
    }

    fn to_json(&self, lod: u8, kind: &str) -> Value {
        let mut g = Map::new();
        g.insert("type".into(), kind.into());
        g.insert("lod".into(), lod.min(3).to_string().into());
        g.insert("boundaries".into(), json!(self.boundaries));
        if !self.surfaces.is_empty() {
            g.insert(
                "semantics".into(),
                json!({"surfaces": self.surfaces, "values": self.values}),
            );
        }
        Value::Object(g)
    }
}

/// A line of CityJSONSeq: a root building with its parts and installations, or one other
/// city object.
#[derive(Debug, Clone, Copy)]
enum Feature {
    Building(usize),
    Standalone(usize),
}

/// What to write of one chunk: ids, kept objects.
pub(super) struct Plan<'a> {
    model: &'a CityModel,
    content: Content<'a>,
    /// Ids per building (index into `model.buildings`) of this file.
    building_ids: HashMap<usize, String>,
    /// Ids per installation or standalone asset.
    asset_ids: HashMap<usize, String>,
    /// Parts (index) of each building or part.
    parts: HashMap<usize, Vec<usize>>,
    /// Buildings written.
    kept: HashSet<usize>,
    features: Vec<Feature>,
    /// Extra attributes of the semantic surface objects of some assets.
    surface_attributes: Option<&'a BTreeMap<usize, Map<String, Value>>>,
    /// A CityJSON source's attributes and semantic surface members, copied to the output.
    source: Option<&'a FromSource>,
}

/// The box of what file `file` of `model` contributes with `content`.
fn extent(model: &CityModel, file: usize, content: Content<'_>) -> Bbox {
    let mut bbox = Bbox::EMPTY;
    let assets = model.assets.iter().enumerate();
    for (i, a) in assets.filter(|(_, a)| a.file == file) {
        for (_, polys) in asset_lods(a, i, content) {
            polys
                .iter()
                .flat_map(Polygon::points)
                .for_each(|q| bbox.add(*q));
        }
    }
    for (b, bd) in model.buildings.iter().enumerate() {
        if bd.file == file {
            for (_, g) in own_geometries(model, b) {
                g.iter()
                    .flat_map(Polygon::points)
                    .for_each(|q| bbox.add(*q));
            }
        }
    }
    bbox
}

/// A building's own geometry written: its LoD properties at LoDs none of its assets has.
fn own_geometries(model: &CityModel, b: usize) -> Vec<(u8, &[Polygon])> {
    let Some(bd) = model.buildings.get(b) else {
        return Vec::new();
    };
    let covered: HashSet<u8> = bd
        .assets
        .iter()
        .filter_map(|&i| model.assets.get(i))
        .flat_map(|a| a.geometries.iter().map(|g| g.lod))
        .collect();
    bd.geometries
        .iter()
        .filter(|g| !covered.contains(&g.lod) && !g.polygons.is_empty())
        .map(|g| (g.lod, g.polygons.as_slice()))
        .collect()
}

impl<'a> Plan<'a> {
    /// The plan of part `p` in the document's `frame`, with the document's unique ids (the
    /// installations' and other objects' made unique on the first call for the part).
    fn new(p: &Part<'a>, frame: &Frame<'a>, ids: &mut Ids) -> Self {
        let model = p.model;
        let mut plan = Plan {
            model,
            content: p.content,
            building_ids: HashMap::new(),
            asset_ids: HashMap::new(),
            parts: HashMap::new(),
            kept: HashSet::new(),
            features: Vec::new(),
            surface_attributes: frame.surface_attributes,
            source: p.from_source.or(frame.source),
        };
        for (b, bd) in p.buildings() {
            if let Some(parent) = bd.parent {
                plan.parts.entry(parent).or_default().push(b);
            }
            let global = p.buildings_before + b;
            let id = ids.buildings.get(&global).cloned();
            plan.building_ids
                .insert(b, id.unwrap_or_else(|| building_id(bd, global)));
        }
        for (b, bd) in p.buildings() {
            if bd.parent.is_none() {
                plan.mark_kept(b);
                plan.features.push(Feature::Building(b));
            }
        }
        // the first pass over the objects takes the ids, chunk after chunk
        let fresh = p.index >= ids.chunks_done;
        for (i, a) in p.assets() {
            if a.building.is_none() {
                plan.features.push(Feature::Standalone(i));
            }
            if !standalone_or_installation(a) {
                continue;
            }
            // bodies are never installations nor outside a building: `i` is not a body
            let global = p.assets_before + i;
            let cand = model.asset_name(i, global);
            if fresh {
                if let Some(id) = ids.unique(cand.clone()) {
                    ids.assets.insert(global, id);
                }
            }
            let id = ids.assets.get(&global).cloned().unwrap_or(cand);
            plan.asset_ids.insert(i, id);
        }
        if fresh {
            ids.chunks_done = p.index + 1;
        }
        plan
    }

    /// Mark `b` and its parts kept when they hold something; returns whether `b` is kept.
    fn mark_kept(&mut self, b: usize) -> bool {
        let parts = self.parts.get(&b).cloned().unwrap_or_default();
        let mut keep = matches!(self.content, Content::Full);
        for p in parts {
            keep |= self.mark_kept(p);
        }
        if let Some(bd) = self.model.buildings.get(b) {
            keep |= !own_geometries(self.model, b).is_empty();
            keep |= bd.assets.iter().any(|&i| {
                self.model
                    .assets
                    .get(i)
                    .is_some_and(|a| !asset_lods(a, i, self.content).is_empty())
            });
        }
        if keep {
            self.kept.insert(b);
        }
        keep
    }

    fn feature_id(&self, f: Feature) -> String {
        match f {
            Feature::Building(b) => self.building_ids.get(&b).cloned(),
            Feature::Standalone(i) => self.asset_ids.get(&i).cloned(),
        }
        .unwrap_or_default()
    }

    /// The objects of the part (`standalone`: the city objects outside buildings) made and
    /// dropped: their vertex uses told to `verts`.
    pub(super) fn count_uses(&self, standalone: bool, verts: &mut Vertices, s: &mut ExportSummary) {
        for f in self.features.iter().filter(|f| is_part(f, standalone)) {
            self.objects(*f, verts, s);
        }
    }

    /// The city objects of a feature, their vertices added to `verts`.
    fn objects(
        &self,
        f: Feature,
        verts: &mut Vertices,
        s: &mut ExportSummary,
    ) -> Vec<(String, Value)> {
        let mut out = Vec::new();
        match f {
            Feature::Building(b) => {
                if self.kept.contains(&b) {
                    self.building(b, verts, s, &mut out);
                }
            }
            Feature::Standalone(i) => {
                if let Some(o) = self.standalone(i, verts, s) {
                    out.push(o);
                }
            }
        }
        s.objects += out.len();
        out
    }

    fn building(
        &self,
        b: usize,
        verts: &mut Vertices,
        s: &mut ExportSummary,
        out: &mut Vec<(String, Value)>,
    ) {
        let model = self.model;
        let Some(bd) = model.buildings.get(b) else {
            return;
        };
        let id = self.building_ids.get(&b).cloned().unwrap_or_default();
        let mut geoms: BTreeMap<u8, Geom> = BTreeMap::new();
        let mut attributes = self.source_attributes(bd.id.as_deref());
        let mut children: Vec<String> = Vec::new();
        let mut installations: Vec<usize> = Vec::new();
        // Surfaces first, then openings (their parent's semantic object must exist).
        let assets: Vec<usize> = bd
            .assets
            .iter()
            .copied()
            .filter(|&i| model.assets.get(i).is_some_and(|a| !a.kind.is_opening()))
            .chain(
                bd.assets
                    .iter()
                    .copied()
                    .filter(|&i| model.assets.get(i).is_some_and(|a| a.kind.is_opening())),
            )
            .collect();
        for i in assets {
            let Some(a) = model.assets.get(i) else {
                continue;
            };
            if a.kind == AssetKind::Installation {
                installations.push(i);
                continue;
            }
            let level = self.content.level(i);
            let lods = asset_lods(a, i, self.content);
            if lods.is_empty() {
                continue;
            }
            if a.kind == AssetKind::Body && self.content.has_levels() {
                attributes.insert("skylod_level".into(), level.into());
            }
            for (lod, polys) in lods {
                let g = geoms.entry(lod).or_default();
                let sem = g.semantic(model, self.content, i);
                let copied = self.source.and_then(|s| s.surfaces.get(&i));
                let extra = self.surface_attributes.and_then(|m| m.get(&i));
                for extra in [copied, extra].into_iter().flatten() {
                    if let Some(surface) = sem.and_then(|k| g.surfaces.get_mut(k)) {
                        for (key, v) in extra {
                            // the writer's own members (skylod_level) stay
                            if key != "skylod_level" || !surface.contains_key(key) {
                                surface.insert(key.clone(), v.clone());
                            }
                        }
                    }
                }
                s.polygons += g.add(verts, &polys, sem);
            }
        }
        for (lod, polys) in own_geometries(model, b) {
            // Own geometry at a LoD of its own: a geometry apart from the surfaces'.
            let g = geoms.entry(lod).or_default();
            s.polygons += g.add(verts, polys, None);
        }
        for p in self.parts.get(&b).into_iter().flatten() {
            if self.kept.contains(p) {
                if let Some(pid) = self.building_ids.get(p) {
                    children.push(pid.clone());
                }
            }
        }
        let mut inst_objs = Vec::new();
        for i in installations {
            if let Some(o) = self.installation(i, &id, verts, s) {
                children.push(o.0.clone());
                inst_objs.push(o);
            }
        }
        let mut obj = Map::new();
        obj.insert(
            "type".into(),
            if bd.is_part {
                "BuildingPart"
            } else {
                "Building"
            }
            .into(),
        );
        if !attributes.is_empty() {
            obj.insert("attributes".into(), Value::Object(attributes));
        }
        let geometry: Vec<Value> = geoms
            .iter()
            .filter(|(_, g)| !g.boundaries.is_empty())
            .map(|(lod, g)| g.to_json(*lod, "MultiSurface"))
            .collect();
        if !geometry.is_empty() {
            obj.insert("geometry".into(), Value::Array(geometry));
        }
        if let Some(parent) = bd.parent.and_then(|p| self.building_ids.get(&p)) {
            obj.insert("parents".into(), json!([parent]));
        }
        if !children.is_empty() {
            obj.insert("children".into(), json!(children));
        }
        out.push((id, Value::Object(obj)));
        out.append(&mut inst_objs);
        for p in self.parts.get(&b).into_iter().flatten() {
            if self.kept.contains(p) {
                self.building(*p, verts, s, out);
            }
        }
    }

    fn installation(
        &self,
        i: usize,
        parent: &str,
        verts: &mut Vertices,
        s: &mut ExportSummary,
    ) -> Option<(String, Value)> {
        let a = self.model.assets.get(i)?;
        let mut obj = self.simple_object(i, a, "BuildingInstallation", "MultiSurface", verts, s)?;
        obj.1["parents"] = json!([parent]);
        if let Some(f) = &a.function {
            obj.1["attributes"]["function"] = f.as_str().into();
        }
        Some(obj)
    }

    fn standalone(
        &self,
        i: usize,
        verts: &mut Vertices,
        s: &mut ExportSummary,
    ) -> Option<(String, Value)> {
        let a = self.model.assets.get(i)?;
        let known = [
            "SolitaryVegetationObject",
            "PlantCover",
            "CityFurniture",
            "LandUse",
            "WaterBody",
            "Bridge",
            "Tunnel",
            "Road",
            "Railway",
            "TransportSquare",
            "Waterway",
            "TINRelief",
            "OtherConstruction",
            "GenericCityObject",
        ];
        let ty = if a.kind == AssetKind::Other {
            known.iter().copied().find(|k| *k == &*a.element)
        } else {
            None
        };
        let geom = if ty == Some("TINRelief") {
            "CompositeSurface"
        } else {
            "MultiSurface"
        };
        let mut obj =
            self.simple_object(i, a, ty.unwrap_or("GenericCityObject"), geom, verts, s)?;
        if ty.is_none() {
            obj.1["attributes"]["citygml_type"] = (&*a.element).into();
        }
        Some(obj)
    }

    /// The attributes of city object `id` in a CityJSON source (empty otherwise).
    fn source_attributes(&self, id: Option<&str>) -> Map<String, Value> {
        self.source
            .zip(id)
            .and_then(|(s, id)| s.objects.get(id).cloned())
            .unwrap_or_default()
    }

    /// A city object of one asset: its geometry per LoD, `skylod_level`; `None` when nothing
    /// of it is written.
    fn simple_object(
        &self,
        i: usize,
        a: &Asset,
        ty: &str,
        geom: &str,
        verts: &mut Vertices,
        s: &mut ExportSummary,
    ) -> Option<(String, Value)> {
        let lods = asset_lods(a, i, self.content);
        let mut geoms: BTreeMap<u8, Geom> = BTreeMap::new();
        for (lod, polys) in lods {
            s.polygons += geoms.entry(lod).or_default().add(verts, &polys, None);
        }
        let geometry: Vec<Value> = geoms
            .iter()
            .filter(|(_, g)| !g.boundaries.is_empty())
            .map(|(lod, g)| g.to_json(*lod, geom))
            .collect();
        if geometry.is_empty() && self.content.has_levels() {
            return None;
        }
        let mut obj = json!({"type": ty, "attributes": self.source_attributes(a.id.as_deref())});
        if !geometry.is_empty() {
            obj["geometry"] = Value::Array(geometry);
        }
        if self.content.has_levels() {
            obj["attributes"]["skylod_level"] = self.content.level(i).into();
        }
        let id = self.asset_ids.get(&i).cloned().unwrap_or_default();
        Some((id, obj))
    }
}

/// Installations and assets outside any building are city objects of their own.
fn standalone_or_installation(a: &Asset) -> bool {
    a.building.is_none() || a.kind == AssetKind::Installation
}

/// CityJSON semantic surface type of a thematic surface or opening.
fn semantic_type(kind: AssetKind) -> Option<&'static str> {
    Some(match kind {
        AssetKind::Roof => "RoofSurface",
        AssetKind::Wall => "WallSurface",
        AssetKind::Ground => "GroundSurface",
        AssetKind::Closure => "ClosureSurface",
        AssetKind::OuterCeiling => "OuterCeilingSurface",
        AssetKind::OuterFloor => "OuterFloorSurface",
        AssetKind::Window => "Window",
        AssetKind::Door => "Door",
        AssetKind::Installation | AssetKind::Body | AssetKind::Other => return None,
    })
}

/// The polygons asset `i` has in the output, per LoD (ascending; several properties of one
/// LoD together): see the module docs.
fn asset_lods<'a>(a: &'a Asset, i: usize, content: Content<'a>) -> Vec<(u8, Cow<'a, [Polygon]>)> {
    let mut out: Vec<(u8, Cow<'a, [Polygon]>)> = Vec::new();
    match content.level(i) {
        0 => {}
        1 => {
            let Some(r) = content.rough(i) else {
                return out;
            };
            let mut rough_at: HashSet<u8> = HashSet::new();
            for p in crate::lod::level::properties(a, Some(r), 1) {
                let (g, polys, replaced) = (p.geometry, p.polygons, p.rough);
                if replaced && !rough_at.insert(g.lod) {
                    continue;
                }
                out.push((g.lod, polys));
            }
        }
        _ => out.extend(
            a.geometries
                .iter()
                .map(|g| (g.lod, Cow::Borrowed(g.polygons.as_slice()))),
        ),
    }
    out.retain(|(_, p)| !p.is_empty());
    out.sort_by_key(|(l, _)| *l);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn members_are_written_between_the_head_and_the_vertices() {
        let mut head = Map::new();
        head.insert("type".into(), json!("CityJSON"));
        head.insert("CityObjects".into(), json!({}));
        head.insert("version".into(), json!("2.0"));
        let mut w = Vec::new();
        write_head_open(head, &mut w).unwrap();
        let mut first = true;
        write_members(&[], &mut first, &mut w).unwrap();
        assert!(first);
        let a = [("a".to_string(), json!({"type": "Building"}))];
        let bc = [("b".to_string(), json!(1)), ("c".to_string(), json!(2))];
        write_members(&a, &mut first, &mut w).unwrap();
        write_members(&bc, &mut first, &mut w).unwrap();
        let s = String::from_utf8(w).unwrap();
        let want = r#"{"type":"CityJSON","version":"2.0","CityObjects":{"a":{"type":"Building"},"b":1,"c":2"#;
        assert_eq!(s, want);
    }

    #[test]
    fn reference_systems() {
        let t = [
            ("EPSG:25831", Some(25831)),
            ("urn:ogc:def:crs:EPSG::6697", Some(6697)),
            (
                "urn:ogc:def:crs,crs:EPSG:6.12:31466,crs:EPSG:6.12:5783",
                Some(31466),
            ),
            ("urn:adv:crs:ETRS89_UTM33*DE_DHHN2016_NH", Some(25833)),
            ("urn:adv:crs:DE_DHDN_3GK4*DE_DHHN92_NH", Some(31468)),
            ("", None),
        ];
        for (srs, code) in t {
            assert_eq!(
                reference_system(srs),
                code.map(|c| format!("https://www.opengis.net/def/crs/EPSG/0/{c}")),
                "{srs}"
            );
        }
    }
}
