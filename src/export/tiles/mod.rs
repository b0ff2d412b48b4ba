//! 3D Tiles 1.1 for web viewers (DESIGN.md "3D Tiles"): `DIR/tileset.json`, the tiles as
//! glTF binary under `DIR/tiles/<level>/<x>_<y>.glb`, and with the viewer option
//! `DIR/index.html`, a CesiumJS page.
//!
//! * **Tree** ([`plan`]): a quadtree over the model's extent; a building stays whole in one
//!   leaf. Leaves hold what the content says of each object (`convert`: full detail; `lod`:
//!   level 2 full detail, 1 rough, 0 absent); every other tile holds the rough forms (skylod's
//!   level 1) of the objects below it whose extent reaches 1/32 of its square's side,
//!   refinement `REPLACE`.
//! * **Geometric error**: measured ([`feature`]): the largest distance from an object's full
//!   detail to what the tile shows of it, or the object's extent where the tile leaves it out;
//!   a tile's error is the largest of its objects' and never below its children's.
//! * **Georeference** ([`georef`]): every vertex goes from the model's CRS to ECEF
//!   (EPSG:4978) in the pure-Rust path ([`crate::model::crs::ToEcef`]: heights taken as
//!   ellipsoidal); each tile's `transform` puts an east-north-up frame at its centre,
//!   relative to its parent's, and its bounding volume is the box of its content and of its
//!   children's boxes in that frame.
//! * **Content** ([`glb`]): one feature per object with `EXT_mesh_features` ids and an
//!   `EXT_structural_metadata` property table (`gml_id`, `building`, `class`, `lod`,
//!   `level`, and `irradiance` where a model comes with `skylodAnnualIrradiation` per
//!   surface); materials by class.
//! * **Memory**: the source is read once, a chunk at a time; each building's (or other
//!   object's) meshes go to a temporary spill file with its box, the tree is planned from
//!   the boxes, and the tiles are written from the spill: memory follows the chunk and the
//!   largest tile, not the model.
//! * **Atomic**: the tiles and `tileset.json` are written into a temporary folder inside
//!   `DIR` and moved into place at the end (`tileset.json` last); a failed or cancelled run
//!   leaves `DIR` as it was.

mod feature;
mod georef;
mod glb;
mod plan;
mod viewer;

use super::chunks::{Chunks, Part};
use super::ExportSummary;
use crate::io::citygml::read::StreamSummary;
use crate::io::citygml::write::{check_target, WriteOptions};
use crate::io::citygml::WriteError;
use crate::model::crs::{Crs, Enu};
use crate::model::{Bbox, CityModel};
use feature::{opening_error, Feature};
use georef::Georef;
use glam::{DMat4, DVec3};
use plan::{Node, Tree, Unit};
use rayon::prelude::*;
use serde_json::{json, Value};
use std::fs::File;
use std::io::Write;
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};

/// A parent shows the rough form of an object whose extent is at least its square's side
/// divided by this.
const PARENT_DETAIL: f64 = 32.0;

/// The file name that asks for a tileset.
pub const TILESET_NAME: &str = "tileset.json";

/// Write `chunks` as a 3D Tiles tileset at `out` (`DIR/tileset.json`; see the module docs).
/// With what was written, the source's summary.
///
/// # Errors
/// [`WriteError`]: the target exists (without `overwrite`) or is an input, checked before
/// any work; the model cannot be placed on the globe ([`WriteError::NotOnGlobe`],
/// [`WriteError::Crs`]); I/O; [`WriteError::Declined`] where the stream declines.
pub(crate) fn write(
    chunks: &Chunks<'_>,
    out: &Path,
    opts: &WriteOptions,
) -> Result<(ExportSummary, StreamSummary), WriteError> {
    let input = chunks.check()?;
    let dir = out
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    check_target(out, opts, input)?;
    for other in [dir.join("tiles"), dir.join("index.html")] {
        if other.exists() && !opts.overwrite && (opts.viewer || other.ends_with("tiles")) {
            return Err(WriteError::Exists(other));
        }
    }
    let io = |file: &Path| {
        let file = file.to_path_buf();
        move |source| WriteError::Io { file, source }
    };
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let stage = tempfile::Builder::new()
        .prefix(".skylod-tileset-")
        .tempdir_in(dir)
        .map_err(io(dir))?;
    // one pass: every object's meshes spilled by building, the buildings' boxes kept
    let label = PathBuf::from(chunks.label());
    let (spill, summary) = spill_features(chunks, opts, &label)?;
    let Some(georef) = spill.georef.as_ref() else {
        let crs = opts.source_crs.as_ref().map(|c| c.name.clone());
        let crs = crs.or(summary.srs_name.clone()).unwrap_or_default();
        let file = label.clone();
        return Err(match crs.is_empty() {
            true => WriteError::NotOnGlobe { file, crs },
            false => WriteError::Invalid(format!(
                "{}: no geometry to write as a tileset",
                crate::model::shown(&file)
            )),
        });
    };
    let units: Vec<Unit> = (spill.units.iter())
        .map(|u| Unit {
            at: u.bbox.center().truncate(),
            weight: u.weight,
        })
        .collect();
    let tree = plan::plan(&units, plan::LEAF_VERTICES);
    let mut units_of_leaf = vec![Vec::new(); tree.nodes.len()];
    for (u, &leaf) in tree.leaf_of_unit.iter().enumerate() {
        units_of_leaf[leaf as usize].push(u as u32);
    }
    // the tiles, leaves first, then each level of parents from the deepest
    let generator = format!("skylod {}", env!("CARGO_PKG_VERSION"));
    let model_to_ecef = georef.frame.to_ecef_matrix();
    let frames: Vec<(Enu, DMat4)> = (0..tree.nodes.len())
        .map(|n| {
            let mut b = Bbox::EMPTY;
            for l in tree.leaves_below(n) {
                for &u in &units_of_leaf[l] {
                    b.union(&spill.units[u as usize].bbox);
                }
            }
            let at = if b.is_empty() {
                DVec3::ZERO
            } else {
                b.center()
            };
            let frame = georef.frame_at(at);
            let to_tile = frame.to_ecef_matrix().inverse() * model_to_ecef;
            (frame, to_tile)
        })
        .collect();
    let mut done: Vec<Option<Tile>> = vec![None; tree.nodes.len()];
    let deepest = tree.nodes.iter().map(|n| n.level).max().unwrap_or(0);
    let ctx = Ctx {
        tree: &tree,
        spill: &spill,
        units_of_leaf: &units_of_leaf,
        frames: &frames,
        stage: stage.path(),
        generator: &generator,
    };
    for level in (0..=deepest).rev() {
        let at_level: Vec<usize> = (0..tree.nodes.len())
            .filter(|&n| tree.nodes[n].level == level)
            .collect();
        let tiles: Vec<Result<Tile, WriteError>> =
            at_level.par_iter().map(|&n| ctx.tile(n, &done)).collect();
        for (n, t) in at_level.into_iter().zip(tiles) {
            done[n] = Some(t?);
        }
    }
    let tiles: Vec<Tile> = done.into_iter().map(Option::unwrap_or_default).collect();
    // tileset.json, the viewer, and everything moved into place
    let mut all = Bbox::EMPTY;
    spill.units.iter().for_each(|u| all.union(&u.bbox));
    let extent = if all.is_empty() {
        0.0
    } else {
        (all.max - all.min).length()
    };
    let root = tile_json(&tree, &tiles, &frames, 0, None);
    let tileset = json!({
        "asset": {"version": "1.1", "generator": generator},
        "geometricError": extent.max(tiles[0].error),
        "root": root,
    });
    let json = serde_json::to_vec_pretty(&tileset).unwrap_or_default();
    let staged_json = stage.path().join(TILESET_NAME);
    std::fs::write(&staged_json, &json).map_err(io(&staged_json))?;
    let mut s = ExportSummary {
        tiles: tiles.iter().filter(|t| t.bytes > 0).count(),
        largest_tile: tiles.iter().map(|t| t.bytes).max().unwrap_or(0),
        skipped: spill.degenerate,
        ..ExportSummary::default()
    };
    s.bytes = json.len() as u64 + tiles.iter().map(|t| t.bytes).sum::<u64>();
    for n in tree.leaves() {
        s.objects += tiles[n].features;
        s.triangles += tiles[n].triangles;
        s.vertices += tiles[n].vertices;
    }
    if opts.viewer {
        let page = viewer::page(&chunks.label());
        let staged = stage.path().join("index.html");
        std::fs::write(&staged, page.as_bytes()).map_err(io(&staged))?;
        s.bytes += page.len() as u64;
    }
    move_into_place(stage.path(), dir, opts.viewer)?;
    Ok((s, summary))
}

/// The assets of a part in document order, each with its index in the part's model and in
/// the whole document (a streamed chunk's bodies, which come apart, after the others).
fn part_assets<'p>(p: &'p Part<'_>) -> impl Iterator<Item = (usize, usize)> + 'p {
    (p.in_order(false, 0).chain(p.in_order(true, 0))).map(|(i, _, g)| (i, g))
}

/// A unit of the tree (a building with its parts, or an object outside buildings) as spilled.
#[derive(Debug, Clone)]
struct SpilledUnit {
    /// The box of its meshes in the model's frame.
    bbox: Bbox,
    /// Vertices of its leaf meshes.
    weight: u64,
    /// Its features' bytes in the spill file.
    at: u64,
    len: usize,
}

/// The features in a temporary file, by unit.
struct Spill {
    file: File,
    units: Vec<SpilledUnit>,
    /// Polygons skipped as degenerate.
    degenerate: usize,
    /// The model's frame, set at the first object (none: the model has no geometry).
    georef: Option<Georef>,
}

impl Spill {
    /// The features of unit `u`, with their leaf meshes (`leaf`) and rough meshes (`rough`).
    fn features(&self, u: u32, leaf: bool, rough: bool) -> Result<Vec<Feature>, WriteError> {
        let Some(unit) = self.units.get(u as usize) else {
            return Ok(Vec::new());
        };
        let mut bytes = vec![0u8; unit.len];
        let io = |source| WriteError::Io {
            file: std::env::temp_dir(),
            source,
        };
        self.file.read_exact_at(&mut bytes, unit.at).map_err(io)?;
        Feature::decode_all(&bytes, leaf, rough)
            .ok_or_else(|| WriteError::Invalid("the tileset's spill file is damaged".into()))
    }
}

/// The one pass: every asset as a feature, spilled by unit; the model's frame is set at the
/// first chunk with geometry, in `opts.source_crs` or the CRS the source names. `None` for
/// the spill where the stream declines ([`WriteError::Declined`]).
fn spill_features(
    chunks: &Chunks<'_>,
    opts: &WriteOptions,
    label: &Path,
) -> Result<(Spill, StreamSummary), WriteError> {
    let tmp = std::env::temp_dir();
    let io = |source| WriteError::Io {
        file: tmp.clone(),
        source,
    };
    let mut spill = Spill {
        file: tempfile::tempfile().map_err(io)?,
        units: Vec::new(),
        degenerate: 0,
        georef: None,
    };
    let mut spill_at = 0u64;
    // per-surface results given with a model (the cadastre's `skylodAnnualIrradiation`)
    let attributes = match *chunks {
        Chunks::Model {
            surface_attributes, ..
        } => surface_attributes,
        Chunks::Stream { .. } => None,
    };
    let done = chunks.pass(0, |p: &Part<'_>| -> Result<(), WriteError> {
        let m = p.model;
        let order: Vec<(usize, usize)> = part_assets(p).collect();
        if spill.georef.is_none() {
            let mut b = Bbox::EMPTY;
            order
                .iter()
                .for_each(|&(i, _)| b.union(&m.assets[i].bbox()));
            if b.is_empty() {
                return Ok(());
            }
            let named = m.files.get(p.file).and_then(|f| f.srs_name.as_deref());
            let crs = match &opts.source_crs {
                Some(c) => c.clone(),
                None => Crs::parse(named.unwrap_or("")),
            };
            spill.georef = Some(Georef::new(&crs, b.center(), label)?);
        }
        let Some(georef) = spill.georef.as_ref() else {
            return Ok(());
        };
        let made: Vec<Result<Option<Feature>, WriteError>> = order
            .par_iter()
            .map(|&(i, g)| {
                let mut f = feature::feature(m, (i, g), &p.content, georef)?;
                if let (Some(f), Some(a)) = (&mut f, attributes.and_then(|a| a.get(&i))) {
                    f.irradiance = a
                        .get(super::IRRADIATION_ATTRIBUTE)
                        .and_then(Value::as_f64)
                        .map(|v| v as f32);
                }
                Ok(f)
            })
            .collect();
        let mut features = Vec::with_capacity(made.len());
        for f in made {
            features.push(f?);
        }
        fix_openings(m, &order, &mut features);
        // each building (with its parts) or object outside buildings is a unit
        let mut unit_of_building = foldhash::HashMap::<usize, usize>::default();
        let mut buffers: Vec<(usize, Vec<u8>)> = Vec::new();
        for (&(i, _), f) in order.iter().zip(features) {
            let Some(f) = f else { continue };
            let new = |units: &mut Vec<SpilledUnit>, buffers: &mut Vec<(usize, Vec<u8>)>| {
                units.push(SpilledUnit {
                    bbox: Bbox::EMPTY,
                    weight: 0,
                    at: 0,
                    len: 0,
                });
                buffers.push((units.len() - 1, Vec::new()));
                buffers.len() - 1
            };
            let k = match m.assets[i].building.map(|b| m.root_building(b)) {
                Some(root) => match unit_of_building.get(&root) {
                    Some(&k) => k,
                    None => {
                        let k = new(&mut spill.units, &mut buffers);
                        unit_of_building.insert(root, k);
                        k
                    }
                },
                None => new(&mut spill.units, &mut buffers),
            };
            let unit = &mut spill.units[buffers[k].0];
            unit.bbox.union(&f.leaf.bbox());
            unit.bbox.union(&f.rough.bbox());
            unit.weight += f.leaf.positions.len() as u64;
            spill.degenerate += f.degenerate;
            f.encode(&mut buffers[k].1);
        }
        for (u, bytes) in buffers {
            spill.file.write_all(&bytes).map_err(io)?;
            (spill.units[u].at, spill.units[u].len) = (spill_at, bytes.len());
            spill_at += bytes.len() as u64;
        }
        Ok(())
    })?;
    match done {
        Some(summary) => Ok((spill, summary)),
        None => Err(WriteError::Declined(chunks.label().into())),
    }
}

/// Each opening's deviation where the parents show its wall's rough form (its wall in the
/// same chunk: a chunk holds whole top-level members).
fn fix_openings(model: &CityModel, order: &[(usize, usize)], features: &mut [Option<Feature>]) {
    let at: foldhash::HashMap<usize, usize> = order
        .iter()
        .enumerate()
        .map(|(k, &(i, _))| (i, k))
        .collect();
    for k in 0..features.len() {
        let i = order[k].0;
        let Some(wall) = model.assets[i].parent.and_then(|w| at.get(&w)).copied() else {
            continue;
        };
        if features[k]
            .as_ref()
            .is_none_or(|f| f.opening_points.is_empty())
        {
            continue;
        }
        let error = match (&features[k], &features[wall]) {
            (Some(o), Some(w)) => opening_error(o, &w.rough),
            _ => continue,
        };
        if let Some(o) = features[k].as_mut() {
            o.rough_error = error;
            o.opening_points = Vec::new();
        }
    }
}

/// A tile as written.
#[derive(Debug, Clone, Default)]
struct Tile {
    /// Its bounding box in its own frame.
    min: DVec3,
    max: DVec3,
    /// Its geometric error.
    error: f64,
    /// Bytes of its content (0: none).
    bytes: u64,
    features: usize,
    triangles: usize,
    vertices: usize,
}

/// What every tile is written from.
struct Ctx<'a> {
    tree: &'a Tree,
    spill: &'a Spill,
    units_of_leaf: &'a [Vec<u32>],
    frames: &'a [(Enu, DMat4)],
    stage: &'a Path,
    generator: &'a str,
}

impl Ctx<'_> {
    /// Write node `n`'s content (its children are in `done`).
    fn tile(&self, n: usize, done: &[Option<Tile>]) -> Result<Tile, WriteError> {
        let node = &self.tree.nodes[n];
        let leaf = node.children.is_empty();
        let mut error = 0.0f64;
        let mut shown_features = Vec::new();
        let threshold = node.side / PARENT_DETAIL;
        let units = (self.tree.leaves_below(n).into_iter())
            .flat_map(|l| self.units_of_leaf[l].iter().copied());
        for u in units {
            for f in self.spill.features(u, leaf, !leaf)? {
                let show = if leaf {
                    error = error.max(f.leaf_error);
                    f.level >= 1
                } else {
                    let show = f.level >= 1 && !f.rough.is_empty() && f.extent >= threshold;
                    let opening = f.kind.is_some_and(|k| k.is_opening());
                    error = error.max(match (show, f.level) {
                        (true, _) => f.rough_error,
                        (false, 1..) if opening && f.extent >= threshold => f.rough_error,
                        _ => f.extent,
                    });
                    show
                };
                if show {
                    shown_features.push(f);
                }
            }
        }
        let shown: Vec<glb::Shown<'_>> = shown_features
            .iter()
            .map(|f| glb::Shown {
                feature: f,
                mesh: if leaf { &f.leaf } else { &f.rough },
                level: if leaf { f.level } else { 1 },
                lod: if leaf { f.lod } else { f.rough_lod },
            })
            .collect();
        let (frame_to_ecef, to_tile) = (self.frames[n].0.to_ecef_matrix(), self.frames[n].1);
        let mut t = Tile {
            min: DVec3::INFINITY,
            max: DVec3::NEG_INFINITY,
            ..Tile::default()
        };
        if let Some(g) = glb::glb(&shown, &to_tile, self.generator) {
            let path = self.stage.join(node.content_uri());
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent).map_err(|source| WriteError::Io {
                    file: parent.to_path_buf(),
                    source,
                })?;
            }
            std::fs::write(&path, &g.bytes).map_err(|source| WriteError::Io {
                file: path.clone(),
                source,
            })?;
            (t.min, t.max) = (g.min, g.max);
            t.bytes = g.bytes.len() as u64;
            (t.features, t.triangles) = (g.features, g.triangles);
            t.vertices = shown.iter().map(|s| s.mesh.positions.len()).sum();
        }
        // the children's boxes, in this tile's frame
        let from_ecef = frame_to_ecef.inverse();
        for &c in &node.children {
            let Some(ct) = done[c].as_ref() else { continue };
            error = error.max(ct.error);
            if ct.min.x > ct.max.x {
                continue;
            }
            let child_to_ecef = self.frames[c].0.to_ecef_matrix();
            for k in 0..8 {
                let corner = DVec3::new(
                    if k & 1 == 0 { ct.min.x } else { ct.max.x },
                    if k & 2 == 0 { ct.min.y } else { ct.max.y },
                    if k & 4 == 0 { ct.min.z } else { ct.max.z },
                );
                let q = from_ecef.transform_point3(child_to_ecef.transform_point3(corner));
                t.min = t.min.min(q);
                t.max = t.max.max(q);
            }
        }
        t.error = error;
        Ok(t)
    }
}

/// The JSON of node `n` and its subtree; `parent`: the parent's frame matrix.
fn tile_json(
    tree: &Tree,
    tiles: &[Tile],
    frames: &[(Enu, DMat4)],
    n: usize,
    parent: Option<&DMat4>,
) -> Value {
    let node: &Node = &tree.nodes[n];
    let t = &tiles[n];
    let me = frames[n].0.to_ecef_matrix();
    let transform = match parent {
        Some(p) => p.inverse() * me,
        None => me,
    };
    let (c, h) = if t.min.x <= t.max.x {
        (
            (t.min + t.max) / 2.0,
            ((t.max - t.min) / 2.0).max(DVec3::splat(0.01)),
        )
    } else {
        (DVec3::ZERO, DVec3::splat(0.01))
    };
    let mut j = json!({
        "boundingVolume": {"box": [c.x, c.y, c.z, h.x, 0.0, 0.0, 0.0, h.y, 0.0, 0.0, 0.0, h.z]},
        "geometricError": t.error,
        "refine": "REPLACE",
        "transform": transform.to_cols_array(),
    });
    if t.bytes > 0 {
        j["content"] = json!({"uri": node.content_uri()});
    }
    if !node.children.is_empty() {
        let children: Vec<Value> = (node.children.iter())
            .map(|&c| tile_json(tree, tiles, frames, c, Some(&me)))
            .collect();
        j["children"] = Value::Array(children);
    }
    j
}

/// Move the staged `tiles/`, `index.html` (with the viewer) and `tileset.json` into `dir`,
/// replacing what was there, `tileset.json` last.
fn move_into_place(stage: &Path, dir: &Path, viewer: bool) -> Result<(), WriteError> {
    let io = |file: PathBuf| move |source| WriteError::Io { file, source };
    let tiles = dir.join("tiles");
    if tiles.exists() {
        std::fs::remove_dir_all(&tiles).map_err(io(tiles.clone()))?;
    }
    let staged_tiles = stage.join("tiles");
    if staged_tiles.exists() {
        std::fs::rename(&staged_tiles, &tiles).map_err(io(tiles.clone()))?;
    }
    let mut names = vec![TILESET_NAME];
    if viewer {
        names.insert(0, "index.html");
    }
    for name in names {
        let to = dir.join(name);
        std::fs::rename(stage.join(name), &to).map_err(io(to.clone()))?;
    }
    Ok(())
}
