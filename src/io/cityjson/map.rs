//! City objects → buildings and assets, the way DESIGN.md maps CityGML ("CityGML → assets").
//!
//! * `Building` and `BuildingPart` are buildings (`parents` links a part to its building).
//!   The semantic surfaces (`RoofSurface`, `WallSurface`, `GroundSurface`, `ClosureSurface`,
//!   `OuterCeilingSurface`, `OuterFloorSurface`) of a building's most detailed geometry
//!   (highest `lod`, `"2.2"` above `"1.3"`) are its assets, one per semantic object; `Window`
//!   and `Door` are openings nested in their `parent` surface. Everything else of a building
//!   (geometries of lower LoDs, geometries without semantics, polygons without a surface
//!   type) is the building's own geometry; a building without any semantic surface gets it
//!   as a `Body` asset, as CityGML's `lod1Solid` does.
//! * `BuildingInstallation` and `BuildingConstructiveElement` are installations of their
//!   parent building; interior objects (`BuildingRoom`, `BuildingStorey`, `BuildingUnit`,
//!   `BuildingFurniture`) and `CityObjectGroup` are counted and left out, like CityGML rooms.
//! * Any other city object with polygons is an `Other` asset named by its type
//!   (`GenericCityObject`s written by skylod name their CityGML type in `citygml_type`).
//! * `MultiSurface`, `CompositeSurface`, `Solid`, `MultiSolid`, `CompositeSolid`; a
//!   `GeometryInstance` is its template transformed by the 4×4 matrix and moved to its
//!   reference point (CityGML's implicit geometry). Points and lines carry no polygons.

use super::doc::{CityObject, Geometry, Semantics, Templates, Transform};
use super::CityJsonError;
use crate::model::{Asset, AssetKind, Building, LodGeometry, Polygon, Warning};
use glam::{DMat4, DVec3, DVec4};
use serde::Deserialize;
use serde_json::Value;
use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

/// Largest coordinate magnitude accepted (the CityGML reader's limit).
const MAX_COORDINATE: f64 = 1e12;

/// Where an asset came from in the CityJSON document: what the CityJSON writer needs to copy
/// attributes and semantics from the source.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Origin {
    /// Key of the city object in `CityObjects`.
    pub object: String,
    /// Index of the geometry in the object's `geometry` and of the semantic surface object in
    /// its `semantics.surfaces` (`None` for a whole object: body, installation, other).
    pub surface: Option<(usize, usize)>,
}

/// The model being built, over one document or every line of CityJSONSeq.
pub(crate) struct Mapper {
    pub file: Arc<Path>,
    pub buildings: Vec<Building>,
    pub assets: Vec<Asset>,
    pub origins: Vec<Origin>,
    pub warnings: Vec<Warning>,
    features: std::collections::BTreeMap<String, usize>,
    polygon_elements: usize,
    implicit_geometries: usize,
    objects_without_geometry: usize,
    /// Building or part by id.
    by_id: HashMap<String, usize>,
    /// (building, parent id) of parts; (asset, parent id) of installations: resolved at the end.
    part_parents: Vec<(usize, String)>,
    installation_parents: Vec<(usize, String)>,
}

/// The vertices one batch of city objects refers to, in real coordinates.
pub(crate) struct Vertices<'a> {
    pub list: &'a [DVec3],
    pub templates: Option<&'a Templates>,
    /// Template vertices, in real coordinates (never transformed).
    pub template_list: &'a [DVec3],
}

/// One polygon of a geometry with its semantic surface index.
struct Surf {
    polygon: Polygon,
    sem: Option<usize>,
}

/// The polygons of one geometry of a city object.
struct GeomOut<'a> {
    /// Integer LoD (`"2.2"` → 2).
    lod: u8,
    /// The LoD as written (`"2.2"` → 2.2): the most detailed of an object's geometries wins.
    value: f64,
    /// CityGML-like property name (`lod2MultiSurface`, `lod2Solid`, `lod1ImplicitRepresentation`).
    property: String,
    surfs: Vec<Surf>,
    semantics: Option<&'a Semantics>,
}

/// Building semantic surface types and their asset kinds.
fn building_surface(ty: &str) -> Option<AssetKind> {
    Some(match ty {
        "RoofSurface" => AssetKind::Roof,
        "WallSurface" => AssetKind::Wall,
        "GroundSurface" => AssetKind::Ground,
        "ClosureSurface" => AssetKind::Closure,
        "OuterCeilingSurface" => AssetKind::OuterCeiling,
        "OuterFloorSurface" => AssetKind::OuterFloor,
        "Window" => AssetKind::Window,
        "Door" => AssetKind::Door,
        _ => return None,
    })
}

/// City object types that are inside a building (left out, as CityGML rooms are).
const INTERIOR: &[&str] = &[
    "BuildingRoom",
    "BuildingStorey",
    "BuildingUnit",
    "BuildingFurniture",
    "CityObjectGroup",
];

/// Real coordinates of the integer (or, without `transform`, real) vertices.
pub(crate) fn real_vertices(
    raw: &[[f64; 3]],
    transform: Option<&Transform>,
    file: &Path,
    line: u64,
) -> Result<Vec<DVec3>, CityJsonError> {
    let (s, t) = match transform {
        Some(t) => (DVec3::from(t.scale), DVec3::from(t.translate)),
        None => (DVec3::ONE, DVec3::ZERO),
    };
    raw.iter()
        .enumerate()
        .map(|(k, v)| {
            let p = DVec3::from(*v) * s + t;
            if p.is_finite() && p.abs().max_element() <= MAX_COORDINATE {
                Ok(p)
            } else {
                Err(CityJsonError::at(
                    file,
                    line,
                    None,
                    format!(
                        "vertex {k} {v:?} is not a finite coordinate of magnitude at most 1e12"
                    ),
                ))
            }
        })
        .collect()
}

impl Mapper {
    pub fn new(file: &Path) -> Self {
        Mapper {
            file: Arc::from(file),
            buildings: Vec::new(),
            assets: Vec::new(),
            origins: Vec::new(),
            warnings: Vec::new(),
            features: Default::default(),
            polygon_elements: 0,
            implicit_geometries: 0,
            objects_without_geometry: 0,
            by_id: HashMap::new(),
            part_parents: Vec::new(),
            installation_parents: Vec::new(),
        }
    }

    pub fn warn(&mut self, line: u64, id: &str, message: String) {
        self.warnings.push(Warning {
            file: Arc::clone(&self.file),
            line: line.max(1),
            column: 1,
            gml_id: (!id.is_empty()).then(|| id.to_string()),
            message,
        });
    }

    /// Add a batch of city objects (a document's, or one CityJSONSeq line's, `line` its
    /// line number: 0 for a whole document).
    pub fn add(
        &mut self,
        objects: &[(String, CityObject)],
        verts: &Vertices<'_>,
        line: u64,
    ) -> Result<(), CityJsonError> {
        // buildings first, so that installations and parts of this batch find them
        let first = self.buildings.len();
        for (id, o) in objects {
            if o.ty == "Building" || o.ty == "BuildingPart" {
                let b = self.buildings.len();
                self.buildings.push(Building {
                    id: Some(id.clone()),
                    is_part: o.ty == "BuildingPart",
                    parent: None,
                    span: 0..0,
                    line: line.max(1),
                    assets: Vec::new(),
                    geometries: Vec::new(),
                    file: 0,
                });
                if self.by_id.insert(id.clone(), b).is_some() {
                    self.warn(line, id, "duplicate city object id".into());
                }
                if let Some(p) = o.parents.first() {
                    self.part_parents.push((b, p.clone()));
                }
            }
        }
        let mut b = first;
        for (id, o) in objects {
            *self.features.entry(o.ty.clone()).or_default() += 1;
            let geoms = self.geometries(id, o, verts, line)?;
            if o.ty == "Building" || o.ty == "BuildingPart" {
                self.building(b, id, geoms, line);
                b += 1;
            } else if INTERIOR.contains(&o.ty.as_str()) {
                // inside a building: not an occluder
            } else if geoms.iter().all(|g| g.surfs.is_empty()) {
                self.objects_without_geometry += 1;
            } else {
                let installation =
                    o.ty == "BuildingInstallation" || o.ty == "BuildingConstructiveElement";
                let element = match o.attribute("citygml_type") {
                    Some(Value::String(t)) if o.ty == "GenericCityObject" => t.clone(),
                    _ => o.ty.clone(),
                };
                let function = o.attribute("function").and_then(|f| match f {
                    Value::String(s) => Some(s.clone()),
                    Value::Number(n) => Some(n.to_string()),
                    _ => None,
                });
                let kind = if installation {
                    AssetKind::Installation
                } else {
                    AssetKind::Other
                };
                let geometries = geoms
                    .into_iter()
                    .filter(|g| !g.surfs.is_empty())
                    .map(|g| lod_geometry(g.lod, &g.property, polygons(g.surfs)))
                    .collect();
                let a = self.push_asset(
                    Asset {
                        line: line.max(1),
                        function,
                        ..Asset::new(kind, Some(id), &element, geometries)
                    },
                    id,
                    None,
                );
                if installation {
                    match o.parents.first() {
                        Some(p) => self.installation_parents.push((a, p.clone())),
                        None => self.warn(line, id, "installation without a parent".into()),
                    }
                }
            }
        }
        Ok(())
    }

    fn push_asset(&mut self, a: Asset, object: &str, surface: Option<(usize, usize)>) -> usize {
        let i = self.assets.len();
        if let Some(b) = a.building {
            if let Some(bd) = self.buildings.get_mut(b) {
                bd.assets.push(i);
            }
        }
        self.assets.push(a);
        self.origins.push(Origin {
            object: object.to_string(),
            surface,
        });
        i
    }

    /// A building's geometries: surfaces of the most detailed semantic geometries as assets,
    /// the rest as the building's own geometry.
    fn building(&mut self, b: usize, id: &str, geoms: Vec<GeomOut<'_>>, line: u64) {
        let best = geoms
            .iter()
            .filter(|g| !g.surfs.is_empty())
            .map(|g| g.value)
            .fold(f64::NEG_INFINITY, f64::max);
        let mut unclassified = 0;
        let mut surfaces = 0;
        for (gi, g) in geoms.into_iter().enumerate() {
            let GeomOut {
                lod,
                value,
                property,
                surfs,
                semantics,
            } = g;
            if surfs.is_empty() {
                continue;
            }
            let mut own = Vec::new();
            match semantics.filter(|_| value == best) {
                Some(sem) => {
                    let kind_of = |k: Option<usize>| {
                        let s = sem.surfaces.get(k?)?;
                        building_surface(&s.ty).map(|kind| (k, kind))
                    };
                    let mut groups: std::collections::BTreeMap<usize, Vec<Polygon>> =
                        Default::default();
                    for s in surfs {
                        match kind_of(s.sem) {
                            Some((Some(k), _)) => groups.entry(k).or_default().push(s.polygon),
                            _ => own.push(s.polygon),
                        }
                    }
                    // the wall or roof of an opening is an asset also without polygons of
                    // its own (as a CityGML surface that holds only its openings)
                    let parents: Vec<usize> = groups
                        .keys()
                        .filter_map(|&k| sem.surfaces.get(k)?.parent)
                        .filter(|&p| kind_of(Some(p)).is_some())
                        .collect();
                    for p in parents {
                        groups.entry(p).or_default();
                    }
                    unclassified += own.len();
                    surfaces += groups.len();
                    let mut asset_of: HashMap<usize, usize> = HashMap::new();
                    for (k, polys) in groups {
                        let Some(s) = sem.surfaces.get(k) else {
                            continue;
                        };
                        let Some(kind) = building_surface(&s.ty) else {
                            continue;
                        };
                        let sid = s.id();
                        let geometries = if polys.is_empty() {
                            Vec::new()
                        } else {
                            vec![lod_geometry(lod, &property, polys)]
                        };
                        let a = Asset {
                            building: Some(b),
                            line: line.max(1),
                            ..Asset::new(kind, sid.as_deref(), &s.ty, geometries)
                        };
                        let i = self.push_asset(a, id, Some((gi, k)));
                        asset_of.insert(k, i);
                    }
                    for (&k, &i) in &asset_of {
                        let parent = sem
                            .surfaces
                            .get(k)
                            .and_then(|s| s.parent)
                            .and_then(|p| asset_of.get(&p).copied())
                            .filter(|&p| p != i);
                        if let Some(a) = self.assets.get_mut(i) {
                            if a.kind.is_opening() {
                                a.parent = parent;
                            }
                        }
                    }
                }
                None => own = polygons(surfs),
            }
            if !own.is_empty() {
                if let Some(bd) = self.buildings.get_mut(b) {
                    bd.geometries.push(lod_geometry(lod, &property, own));
                }
            }
        }
        if unclassified > 0 && surfaces > 0 {
            self.warn(
                line,
                id,
                format!(
                    "{unclassified} polygon(s) of the most detailed geometry have no building \
                     surface semantics: kept as the building's own geometry, not traced"
                ),
            );
        }
    }

    /// Resolve the parents (parts, installations), make the bodies, and hand over the model.
    pub fn finish(mut self) -> (Vec<Building>, Vec<Asset>, Vec<Origin>, Vec<Warning>, Counts) {
        for (b, p) in std::mem::take(&mut self.part_parents) {
            match self.by_id.get(&p).copied().filter(|&q| q != b) {
                Some(q) => self.buildings[b].parent = Some(q),
                None => {
                    let id = self.buildings[b].id.clone().unwrap_or_default();
                    let line = self.buildings[b].line;
                    self.warn(line, &id, format!("parent {p:?} is not a building"));
                }
            }
        }
        for (a, p) in std::mem::take(&mut self.installation_parents) {
            match self.by_id.get(&p).copied() {
                Some(q) => {
                    self.assets[a].building = Some(q);
                    self.buildings[q].assets.push(a);
                }
                None => {
                    let id = self.origins[a].object.clone();
                    let line = self.assets[a].line;
                    self.warn(
                        line,
                        &id,
                        format!("parent {p:?} of an installation is not a building"),
                    );
                }
            }
        }
        for b in 0..self.buildings.len() {
            if let Some(body) = self.buildings[b].take_body(b, &self.assets) {
                let id = body.id.as_deref().unwrap_or_default().to_string();
                self.push_asset(body, &id, None);
            }
        }
        let counts = Counts {
            features: self.features,
            polygon_elements: self.polygon_elements,
            implicit_geometries: self.implicit_geometries,
            objects_without_geometry: self.objects_without_geometry,
        };
        (
            self.buildings,
            self.assets,
            self.origins,
            self.warnings,
            counts,
        )
    }

    /// Polygons of every geometry of an object: (LoD, property name, polygons), in order.
    fn geometries<'a>(
        &mut self,
        id: &str,
        o: &'a CityObject,
        verts: &Vertices<'a>,
        line: u64,
    ) -> Result<Vec<GeomOut<'a>>, CityJsonError> {
        let mut out = Vec::with_capacity(o.geometry.len());
        for g in &o.geometry {
            out.push(self.geometry(id, g, verts, line)?);
        }
        Ok(out)
    }

    fn geometry<'a>(
        &mut self,
        id: &str,
        g: &'a Geometry,
        verts: &Vertices<'a>,
        line: u64,
    ) -> Result<GeomOut<'a>, CityJsonError> {
        let err = |m: String| CityJsonError::at(&self.file, line, Some(id), m);
        if g.ty == "GeometryInstance" {
            self.implicit_geometries += 1;
            let t = verts
                .templates
                .and_then(|t| g.template.and_then(|k| t.templates.get(k)));
            let Some(t) = t else {
                let t = g.template.map_or("(none)".to_string(), |t| t.to_string());
                return Err(err(format!(
                    "GeometryInstance: template {t} is not in geometry-templates"
                )));
            };
            let refpt: Vec<usize> = Vec::deserialize(&g.boundaries())
                .map_err(|e| err(format!("GeometryInstance boundaries: {e}")))?;
            let p = refpt
                .first()
                .and_then(|&k| verts.list.get(k))
                .copied()
                .ok_or_else(|| {
                    err("GeometryInstance: reference point missing or out of range".into())
                })?;
            let m = match g.matrix.as_deref() {
                Some(m) if m.len() == 16 && m.iter().all(|x| x.is_finite()) => {
                    // row by row → glam's columns
                    DMat4::from_cols_array(&[
                        m[0], m[4], m[8], m[12], m[1], m[5], m[9], m[13], m[2], m[6], m[10], m[14],
                        m[3], m[7], m[11], m[15],
                    ])
                }
                None => DMat4::IDENTITY,
                Some(_) => {
                    return Err(err(
                        "GeometryInstance: transformationMatrix is not 16 finite numbers".into(),
                    ))
                }
            };
            let placed: Vec<DVec3> = verts
                .template_list
                .iter()
                .map(|q| (m * DVec4::new(q.x, q.y, q.z, 1.0)).truncate() + p)
                .collect();
            let mut out = self.surfaces(id, t, &placed, line, false)?;
            out.property = format!("lod{}ImplicitRepresentation", out.lod);
            return Ok(out);
        }
        self.surfaces(id, g, verts.list, line, true)
    }

    /// The polygons of a geometry over `list`, with their semantic index.
    fn surfaces<'a>(
        &mut self,
        id: &str,
        g: &'a Geometry,
        list: &[DVec3],
        line: u64,
        count: bool,
    ) -> Result<GeomOut<'a>, CityJsonError> {
        let file = Arc::clone(&self.file);
        let err = |m: String| CityJsonError::at(&file, line, Some(id), m);
        let value = match g.lod.as_ref().map(|l| (l, l.value())) {
            Some((_, Some(v))) => v,
            Some((l, None)) => return Err(err(format!("{} geometry: bad lod {l:?}", g.ty))),
            None => return Err(err(format!("{} geometry without lod", g.ty))),
        };
        let bad = |e: serde_json::Error| err(format!("{} boundaries: {e}", g.ty));
        let sem_bad = |e: serde_json::Error| err(format!("{} semantics values: {e}", g.ty));
        let values = g
            .semantics
            .as_ref()
            .map(|s| &s.values)
            .filter(|v| !v.is_null());
        // (rings, semantic value) per surface
        let mut flat: Vec<(Vec<Vec<usize>>, Option<usize>)> = Vec::new();
        match g.ty.as_str() {
            "MultiSurface" | "CompositeSurface" => {
                let b: Vec<Vec<Vec<usize>>> = Vec::deserialize(&g.boundaries()).map_err(bad)?;
                let v: Vec<Option<usize>> = match values {
                    Some(v) => Vec::deserialize(v).map_err(sem_bad)?,
                    None => Vec::new(),
                };
                for (k, s) in b.into_iter().enumerate() {
                    flat.push((s, v.get(k).copied().flatten()));
                }
            }
            "Solid" => {
                let b: Vec<Vec<Vec<Vec<usize>>>> =
                    Vec::deserialize(&g.boundaries()).map_err(bad)?;
                let v: Vec<Vec<Option<usize>>> = match values {
                    Some(v) => Vec::deserialize(v).map_err(sem_bad)?,
                    None => Vec::new(),
                };
                for (i, shell) in b.into_iter().enumerate() {
                    for (k, s) in shell.into_iter().enumerate() {
                        flat.push((s, v.get(i).and_then(|x| x.get(k)).copied().flatten()));
                    }
                }
            }
            "MultiSolid" | "CompositeSolid" => {
                let b: Vec<Vec<Vec<Vec<Vec<usize>>>>> =
                    Vec::deserialize(&g.boundaries()).map_err(bad)?;
                let v: Vec<Vec<Vec<Option<usize>>>> = match values {
                    Some(v) => Vec::deserialize(v).map_err(sem_bad)?,
                    None => Vec::new(),
                };
                for (j, solid) in b.into_iter().enumerate() {
                    for (i, shell) in solid.into_iter().enumerate() {
                        for (k, s) in shell.into_iter().enumerate() {
                            let sv = v.get(j).and_then(|x| x.get(i)).and_then(|x| x.get(k));
                            flat.push((s, sv.copied().flatten()));
                        }
                    }
                }
            }
            "MultiPoint" | "MultiLineString" => {}
            other => {
                self.warn(line, id, format!("geometry type {other:?} is not read"));
            }
        }
        let n_sem = g.semantics.as_ref().map_or(0, |s| s.surfaces.len());
        if count {
            for s in g.semantics.iter().flat_map(|s| &s.surfaces) {
                *self.features.entry(s.ty.clone()).or_default() += 1;
            }
        }
        let mut out = Vec::with_capacity(flat.len());
        let mut bad_sem = 0usize;
        for (rings, sem) in flat {
            if count {
                self.polygon_elements += 1;
            }
            let sem = match sem {
                Some(k) if k >= n_sem => {
                    bad_sem += 1;
                    None
                }
                s => s,
            };
            let mut pts: Vec<Vec<DVec3>> = Vec::with_capacity(rings.len());
            for r in &rings {
                let mut ring = Vec::with_capacity(r.len());
                for &k in r {
                    let p = list.get(k).copied().ok_or_else(|| {
                        err(format!(
                            "vertex index {k} out of range ({} vertices)",
                            list.len()
                        ))
                    })?;
                    ring.push(p);
                }
                while ring.len() > 1 && ring.first() == ring.last() {
                    ring.pop();
                }
                pts.push(ring);
            }
            match pts.split_first() {
                Some((ext, holes)) if ext.len() >= 3 => out.push(Surf {
                    polygon: Polygon::from_rings(None, ext, holes),
                    sem,
                }),
                _ => self.warn(
                    line,
                    id,
                    format!("{} surface with fewer than 3 points: skipped", g.ty),
                ),
            }
        }
        if bad_sem > 0 {
            self.warn(
                line,
                id,
                format!("{bad_sem} semantic value(s) beyond the {n_sem} surfaces: ignored"),
            );
        }
        Ok(GeomOut {
            lod: value as u8,
            value,
            property: format!("lod{}{}", value as u8, g.ty),
            surfs: out,
            semantics: g.semantics.as_ref(),
        })
    }
}

/// Counts of the document for its [`crate::model::SourceFile`].
pub(crate) struct Counts {
    pub features: std::collections::BTreeMap<String, usize>,
    pub polygon_elements: usize,
    pub implicit_geometries: usize,
    pub objects_without_geometry: usize,
}

fn polygons(surfs: Vec<Surf>) -> Vec<Polygon> {
    surfs.into_iter().map(|s| s.polygon).collect()
}

fn lod_geometry(lod: u8, property: &str, polygons: Vec<Polygon>) -> LodGeometry {
    LodGeometry {
        lod,
        property: property.into(),
        span: 0..0,
        content: 0..0,
        polygons,
    }
}
