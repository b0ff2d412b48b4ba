//! Counts of what a model holds: `skylod stats`, and its JSON ([`StatsOutput`]).

use crate::model::{AssetKind, Bbox, CityModel};
use schemars::JsonSchema;
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet};
use std::io::Write;

/// The whole `stats --json` document: one shape whatever the number of inputs, so that a
/// pipeline never has to test for it.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
#[non_exhaustive]
pub struct StatsOutput {
    /// One entry per file read, in input order.
    pub files: Vec<FileStats>,
    /// Sum over the files.
    pub total: Stats,
}

impl StatsOutput {
    /// The document of `files` and their `total`.
    pub fn new(files: Vec<FileStats>, total: Stats) -> Self {
        StatsOutput { files, total }
    }

    /// The text of `skylod stats`: per file its path and [`Stats::write_table`], then the
    /// total when there are several files.
    pub fn write_table(&self, out: &mut impl Write) -> std::io::Result<()> {
        for f in &self.files {
            writeln!(out, "{}", f.path)?;
            f.stats.write_table(out)?;
        }
        if self.files.len() > 1 {
            writeln!(out, "total ({} files)", self.files.len())?;
            self.total.write_table(out)?;
        }
        Ok(())
    }
}

/// One file of `stats --json`: its path, then its counts.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
#[non_exhaustive]
pub struct FileStats {
    /// Path as given.
    pub path: String,
    /// Its counts.
    #[serde(flatten)]
    pub stats: Stats,
}

impl FileStats {
    /// The counts `stats` of the file at `path`.
    pub fn new(path: String, stats: Stats) -> Self {
        FileStats { path, stats }
    }
}

/// Counts of one model (one file or several merged).
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema, Default)]
#[schemars(deny_unknown_fields)]
pub struct Stats {
    /// "1.0", "2.0", "3.0", or "mixed" over files of several versions.
    pub citygml_version: Option<String>,
    /// `srsName` of the model (or "mixed").
    pub srs_name: Option<String>,
    /// `Building` elements.
    pub buildings: usize,
    /// `BuildingPart` elements.
    pub building_parts: usize,
    /// Roof surfaces.
    pub roof_surfaces: usize,
    /// Wall surfaces.
    pub wall_surfaces: usize,
    /// Ground surfaces.
    pub ground_surfaces: usize,
    /// Closure surfaces.
    pub closure_surfaces: usize,
    /// Outer ceiling surfaces.
    pub outer_ceiling_surfaces: usize,
    /// Outer floor surfaces.
    pub outer_floor_surfaces: usize,
    /// Outer building installations.
    pub installations: usize,
    /// Windows.
    pub windows: usize,
    /// Doors.
    pub doors: usize,
    /// Buildings whose own geometry is their only geometry (no thematic surfaces).
    pub bodies: usize,
    /// Other city objects with geometry.
    pub other_objects: usize,
    /// All assets.
    pub assets: usize,
    /// Polygons of the assets over all LoDs and properties, an xlinked polygon counted at
    /// each use ([`CityModel::polygon_count`]): the number `convert`, `lod` and the tracing
    /// commands report.
    pub polygons: usize,
    /// Of those, each asset's highest LoD only: what `svf`, `sun-hours` and `horizon` trace
    /// ([`CityModel::traced_polygon_count`]).
    pub traced_polygons: usize,
    /// Polygon elements in the documents, each counted once however often it is referenced,
    /// including those of no asset (rooms, interior surfaces, a building's own geometry
    /// beside its thematic surfaces).
    pub polygon_elements: usize,
    /// LoDs present.
    pub lods: Vec<u8>,
    /// `ImplicitGeometry` elements.
    pub implicit_geometries: usize,
    /// Warnings met while reading.
    pub warnings: usize,
    /// `[minx, miny, minz, maxx, maxy, maxz]` of all asset geometry.
    pub bbox: Option<[f64; 6]>,
    /// Elements per CityGML feature or object type, wherever they nest (the surfaces of an
    /// installation, the openings of interior walls, rooms, appearances…), as citygml-tools
    /// counts them: compare these with the file.
    pub features: BTreeMap<String, usize>,
}

impl Stats {
    /// The counts as an indented table, one `name value` line per field (`-` for none),
    /// the counts per type under their field's name.
    pub fn write_table(&self, out: &mut impl Write) -> std::io::Result<()> {
        let v = serde_json::to_value(self).unwrap_or_default();
        if let Some(obj) = v.as_object() {
            for (k, v) in obj {
                if let serde_json::Value::Object(types) = v {
                    writeln!(out, "  {k}")?;
                    for (t, n) in types {
                        writeln!(out, "    {t:<22} {n}")?;
                    }
                    continue;
                }
                let shown = match v {
                    serde_json::Value::String(s) => s.clone(),
                    serde_json::Value::Null => "-".into(),
                    other => other.to_string(),
                };
                writeln!(out, "  {k:<24} {shown}")?;
            }
        }
        Ok(())
    }

    /// Count a model.
    ///
    /// ```
    /// let m = skylod::model::CityModel::default();
    /// let s = skylod::export::report::Stats::of(&m);
    /// assert_eq!(s.buildings, 0);
    /// assert_eq!(s.bbox, None);
    /// ```
    pub fn of(model: &CityModel) -> Stats {
        let mut s = Stats::default();
        let mut lods = BTreeSet::new();
        for b in &model.buildings {
            if b.is_part {
                s.building_parts += 1;
            } else {
                s.buildings += 1;
            }
            lods.extend(b.geometries.iter().map(|g| g.lod));
        }
        for a in &model.assets {
            s.assets += 1;
            match a.kind {
                AssetKind::Roof => s.roof_surfaces += 1,
                AssetKind::Wall => s.wall_surfaces += 1,
                AssetKind::Ground => s.ground_surfaces += 1,
                AssetKind::Closure => s.closure_surfaces += 1,
                AssetKind::OuterCeiling => s.outer_ceiling_surfaces += 1,
                AssetKind::OuterFloor => s.outer_floor_surfaces += 1,
                AssetKind::Installation => s.installations += 1,
                AssetKind::Window => s.windows += 1,
                AssetKind::Door => s.doors += 1,
                AssetKind::Body => s.bodies += 1,
                AssetKind::Other => s.other_objects += 1,
            }
            s.polygons += a.polygon_count();
            s.traced_polygons += a.detail_polygons().len();
            lods.extend(a.geometries.iter().map(|g| g.lod));
        }
        s.lods = lods.into_iter().collect();
        s.polygon_elements = model.files.iter().map(|f| f.polygon_elements).sum();
        s.implicit_geometries = model.files.iter().map(|f| f.implicit_geometries).sum();
        s.warnings = model.warnings.len();
        s.bbox = model.bbox().to_array();
        s.citygml_version = common(model.files.iter().map(|f| Some(f.version.to_string())));
        s.srs_name = common(model.files.iter().map(|f| f.srs_name.clone()));
        for f in &model.files {
            for (k, n) in &f.features {
                *s.features.entry(k.clone()).or_default() += n;
            }
        }
        s
    }

    /// Add the counts of `other` (a further chunk of the same document, see
    /// [`crate::io::citygml::read::stream`]): sums, LoDs and features merged, boxes joined; the
    /// version and CRS are left to the caller (the document's, not a chunk's).
    pub fn add(&mut self, other: &Stats) {
        let (version, srs) = (self.citygml_version.take(), self.srs_name.take());
        *self = Stats::total([&*self, other]);
        (self.citygml_version, self.srs_name) = (version, srs);
    }

    /// Sum of several files' stats.
    pub fn total<'a>(all: impl IntoIterator<Item = &'a Stats>) -> Stats {
        let mut t = Stats::default();
        let mut lods = BTreeSet::new();
        let mut bbox = Bbox::EMPTY;
        let mut versions = Vec::new();
        let mut srs = Vec::new();
        for s in all {
            t.buildings += s.buildings;
            t.building_parts += s.building_parts;
            t.roof_surfaces += s.roof_surfaces;
            t.wall_surfaces += s.wall_surfaces;
            t.ground_surfaces += s.ground_surfaces;
            t.closure_surfaces += s.closure_surfaces;
            t.outer_ceiling_surfaces += s.outer_ceiling_surfaces;
            t.outer_floor_surfaces += s.outer_floor_surfaces;
            t.installations += s.installations;
            t.windows += s.windows;
            t.doors += s.doors;
            t.bodies += s.bodies;
            t.other_objects += s.other_objects;
            t.assets += s.assets;
            t.polygons += s.polygons;
            t.traced_polygons += s.traced_polygons;
            t.polygon_elements += s.polygon_elements;
            t.implicit_geometries += s.implicit_geometries;
            t.warnings += s.warnings;
            lods.extend(s.lods.iter().copied());
            if let Some(b) = s.bbox {
                bbox.add(glam::DVec3::new(b[0], b[1], b[2]));
                bbox.add(glam::DVec3::new(b[3], b[4], b[5]));
            }
            for (k, n) in &s.features {
                *t.features.entry(k.clone()).or_default() += n;
            }
            versions.push(s.citygml_version.clone());
            srs.push(s.srs_name.clone());
        }
        t.lods = lods.into_iter().collect();
        t.bbox = bbox.to_array();
        t.citygml_version = common(versions);
        t.srs_name = common(srs);
        t
    }
}

fn common(values: impl IntoIterator<Item = Option<String>>) -> Option<String> {
    let set: BTreeSet<Option<String>> = values.into_iter().collect();
    match set.len() {
        0 => None,
        1 => set.into_iter().next().flatten(),
        _ => Some("mixed".to_string()),
    }
}
