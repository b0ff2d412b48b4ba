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
//!   `level`); materials by class.
//! * **Memory**: the source is read in passes a chunk at a time (a plan of the units, then
//!   the features); the features go to a temporary spill file by leaf, and the tiles are
//!   written from it: memory follows the chunk and the largest tile, not the model.
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
    // pass 0: the units and the model's box
    let Some(survey) = survey(chunks)? else {
        return Err(WriteError::Declined(chunks.label().into()));
    };
    let crs = match &opts.source_crs {
        Some(c) => c.clone(),
        None => Crs::parse(survey.summary.srs_name.as_deref().unwrap_or("")),
    };
    let label = PathBuf::from(chunks.label());
    let centre = if survey.bbox.is_empty() {
        DVec3::ZERO
    } else {
        survey.bbox.center()
    };
    let georef = Georef::new(&crs, centre, &label)?;
    let units: Vec<Unit> = (survey.units.iter())
        .map(|(b, w)| {
            let at = georef.enu(b.center()).map_err(|source| WriteError::Crs {
                file: label.clone(),
                line: 0,
                id: format!("an object at {}", b.center()),
                source: Box::new(source),
            })?;
            Ok(Unit {
                at: at.truncate(),
                weight: *w,
            })
        })
        .collect::<Result<_, WriteError>>()?;
    let tree = plan::plan(&units, plan::LEAF_VERTICES);
    // pass 1: the features, spilled by leaf
    let stage = tempfile::Builder::new()
        .prefix(".skylod-tileset-")
        .tempdir_in(dir)
        .map_err(io(dir))?;
    let spill = spill_features(chunks, &survey, &tree, &georef, survey.summary.assets)?;
    // the tiles, leaves first, then each level of parents from the deepest
    let generator = format!("skylod {}", env!("CARGO_PKG_VERSION"));
    let model_to_ecef = georef.frame.to_ecef_matrix();
    let frames: Vec<(Enu, DMat4)> = (0..tree.nodes.len())
        .map(|n| {
            let mut b = Bbox::EMPTY;
            for l in tree.leaves_below(n) {
                b.union(&spill.leaf_boxes[l]);
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
    let extent = if survey.bbox.is_empty() {
        0.0
    } else {
        let (lo, hi) = (georef.enu(survey.bbox.min), georef.enu(survey.bbox.max));
        match (lo, hi) {
            (Ok(lo), Ok(hi)) => (hi - lo).length(),
            _ => 0.0,
        }
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
        ..ExportSummary::default()
    };
    s.bytes = json.len() as u64 + tiles.iter().map(|t| t.bytes).sum::<u64>();
    for n in tree.leaves() {
        s.objects += tiles[n].features;
        s.triangles += tiles[n].triangles;
        s.vertices += tiles[n].vertices;
    }
    s.skipped = spill.degenerate;
    if opts.viewer {
        let page = viewer::page(&chunks.label());
        let staged = stage.path().join("index.html");
        std::fs::write(&staged, page.as_bytes()).map_err(io(&staged))?;
        s.bytes += page.len() as u64;
    }
    move_into_place(stage.path(), dir, opts.viewer)?;
    Ok((s, survey.summary))
}

/// What pass 0 found: units (a box and full-detail vertices each), each asset's unit in
/// pass order, the model's box and the source's summary.
struct Survey {
    units: Vec<(Bbox, u64)>,
    unit_of_asset: Vec<u32>,
    bbox: Bbox,
    summary: StreamSummary,
}

/// The assets of a part in the order of both passes, each with its index in the part's
/// model and in the whole document (`assets`: the document's assets other than bodies).
fn part_assets<'p>(p: &'p Part<'_>, assets: usize) -> impl Iterator<Item = (usize, usize)> + 'p {
    (p.in_order(false, assets).chain(p.in_order(true, assets))).map(|(i, _, g)| (i, g))
}

/// Pass 0: the units; `None` where the stream declines.
fn survey(chunks: &Chunks<'_>) -> Result<Option<Survey>, WriteError> {
    let mut units: Vec<(Bbox, u64)> = Vec::new();
    let mut unit_of_asset = Vec::new();
    let mut bbox = Bbox::EMPTY;
    let sum = chunks.pass(0, |p: &Part<'_>| -> Result<(), WriteError> {
        let m = p.model;
        let mut unit_of_building = foldhash::HashMap::<usize, u32>::default();
        for (i, _) in part_assets(p, 0) {
            let a = &m.assets[i];
            let polys = crate::lod::level::traced(a, p.content.rough(i), 2);
            let b = Bbox::of_points(polys.iter().flat_map(|q| q.points()));
            let weight: u64 = polys.iter().map(|q| q.points().count() as u64).sum();
            let u = match a.building.map(|b| m.root_building(b)) {
                Some(root) => *unit_of_building.entry(root).or_insert_with(|| {
                    units.push((Bbox::EMPTY, 0));
                    (units.len() - 1) as u32
                }),
                None => {
                    units.push((Bbox::EMPTY, 0));
                    (units.len() - 1) as u32
                }
            };
            let unit = &mut units[u as usize];
            unit.0.union(&b);
            unit.1 += weight;
            bbox.union(&b);
            unit_of_asset.push(u);
        }
        Ok(())
    })?;
    // a unit without geometry sits at the model's centre
    let centre = if bbox.is_empty() {
        DVec3::ZERO
    } else {
        bbox.center()
    };
    for u in &mut units {
        if u.0.is_empty() {
            u.0 = Bbox {
                min: centre,
                max: centre,
            };
        }
    }
    Ok(sum.map(|summary| Survey {
        units,
        unit_of_asset,
        bbox,
        summary,
    }))
}

/// The features in a temporary file, by leaf.
struct Spill {
    file: File,
    /// Per leaf (node index): the byte ranges of its features, in document order.
    segments: Vec<Vec<(u64, usize)>>,
    /// Per node: the box (model frame) of its leaves' features (leaf and rough meshes).
    leaf_boxes: Vec<Bbox>,
    /// Polygons skipped as degenerate.
    degenerate: usize,
}

impl Spill {
    /// The features of leaf `n`, with their leaf meshes (`leaf`) and rough meshes (`rough`).
    fn features(&self, n: usize, leaf: bool, rough: bool) -> Result<Vec<Feature>, WriteError> {
        let mut all = Vec::new();
        for &(at, len) in &self.segments[n] {
            let mut bytes = vec![0u8; len];
            self.file
                .read_exact_at(&mut bytes, at)
                .map_err(|source| WriteError::Io {
                    file: std::env::temp_dir(),
                    source,
                })?;
            let more = Feature::decode_all(&bytes, leaf, rough)
                .ok_or_else(|| WriteError::Invalid("the tileset's spill file is damaged".into()))?;
            all.extend(more);
        }
        Ok(all)
    }
}

/// Pass 1: every asset as a feature, appended to its leaf's segments.
fn spill_features(
    chunks: &Chunks<'_>,
    survey: &Survey,
    tree: &Tree,
    georef: &Georef,
    assets: usize,
) -> Result<Spill, WriteError> {
    let tmp = std::env::temp_dir();
    let mut file = tempfile::tempfile().map_err(|source| WriteError::Io {
        file: tmp.clone(),
        source,
    })?;
    let n = tree.nodes.len();
    let mut spill_at = 0u64;
    let mut segments = vec![Vec::new(); n];
    let mut leaf_boxes = vec![Bbox::EMPTY; n];
    let mut degenerate = 0;
    let mut next = 0usize;
    let done = chunks.pass(1, |p: &Part<'_>| -> Result<(), WriteError> {
        let order: Vec<(usize, usize)> = part_assets(p, assets).collect();
        let made: Vec<Result<Option<Feature>, WriteError>> = order
            .par_iter()
            .map(|&(i, g)| feature::feature(p.model, (i, g), &p.content, georef))
            .collect();
        let mut features = Vec::with_capacity(made.len());
        for f in made {
            features.push(f?);
        }
        fix_openings(p.model, &order, &mut features);
        let mut buffers: Vec<(usize, Vec<u8>)> = Vec::new();
        let mut buffer_of = foldhash::HashMap::<usize, usize>::default();
        for f in features {
            let unit = survey.unit_of_asset.get(next).copied().unwrap_or(0);
            next += 1;
            let Some(f) = f else { continue };
            let leaf = tree.leaf_of_unit.get(unit as usize).copied().unwrap_or(0) as usize;
            leaf_boxes[leaf].union(&f.leaf.bbox());
            leaf_boxes[leaf].union(&f.rough.bbox());
            degenerate += f.degenerate;
            let k = *buffer_of.entry(leaf).or_insert_with(|| {
                buffers.push((leaf, Vec::new()));
                buffers.len() - 1
            });
            f.encode(&mut buffers[k].1);
        }
        for (leaf, bytes) in buffers {
            file.write_all(&bytes).map_err(|source| WriteError::Io {
                file: tmp.clone(),
                source,
            })?;
            segments[leaf].push((spill_at, bytes.len()));
            spill_at += bytes.len() as u64;
        }
        Ok(())
    })?;
    if done.is_none() {
        return Err(WriteError::Declined(chunks.label().into()));
    }
    Ok(Spill {
        file,
        segments,
        leaf_boxes,
        degenerate,
    })
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
        for l in self.tree.leaves_below(n) {
            for f in self.spill.features(l, leaf, !leaf)? {
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
