//! The reduce step of a sharded `lod` run: the levels files of every shard
//! ([`crate::pipeline::batch::shard_levels`]) read back, their options taken over, and their levels
//! turned into the [`LodResult`] one serial run would have made, ready to write.
//!
//! ```no_run
//! use skylod::pipeline::batch::{Reduce, lod_result};
//! # fn f(model: &skylod::model::CityModel) -> Result<(), Box<dyn std::error::Error>> {
//! let r = Reduce::read(&["levels-0.jsonl".into(), "levels-1.jsonl".into()])?;
//! let opts = r.options(); // the options every shard ran with
//! let pois = r.pois().to_vec(); // all shards' POIs, in shard order
//! // `model`: read from the inputs the shards read.
//! let combined = r.combine(model)?;
//! let result = lod_result(model, combined, &opts);
//! # Ok(()) }
//! ```

use crate::lod::poi::Poi;
use crate::lod::rough::{rough_model, RoughOptions};
use crate::lod::select::{roof_assets, SelectOptions, Selection};
use crate::lod::{LodOptions, LodResult};
use crate::model::CityModel;
use crate::pipeline::batch::shard_levels::{self, Combined, Header, LevelsError, LevelsFile};
use std::path::PathBuf;
use std::time::Instant;

/// The levels files of every shard, read before the inputs.
#[derive(Debug, Clone)]
pub struct Reduce {
    files: Vec<LevelsFile>,
    /// The header of the lowest shard (the options of the run).
    header: Header,
    /// The POIs of all shards in shard order (model CRS).
    pois: Vec<Poi>,
}

impl Reduce {
    /// Read the levels files at `paths` (in any order).
    ///
    /// # Errors
    /// A file that cannot be read or is not a levels file (`shard_levels::read_levels`);
    /// no file at all.
    pub fn read(paths: &[PathBuf]) -> Result<Reduce, LevelsError> {
        let files = paths
            .iter()
            .map(|p| shard_levels::read_levels(p))
            .collect::<Result<Vec<_>, _>>()?;
        let Some(first) = files.iter().min_by_key(|f| f.header.index) else {
            return Err(LevelsError::Mismatch("no levels file to reduce".into()));
        };
        let header = first.header.clone();
        let mut sorted: Vec<&LevelsFile> = files.iter().collect();
        sorted.sort_by_key(|f| f.header.index);
        let pois = sorted
            .iter()
            .flat_map(|f| &f.pois)
            .map(|p| p.seen.poi())
            .collect();
        Ok(Reduce {
            files,
            header,
            pois,
        })
    }

    /// How many levels files were read.
    pub fn files(&self) -> usize {
        self.files.len()
    }

    /// What the reduce says it does: the levels files and the shards of the run.
    pub fn line(&self) -> String {
        let (files, shards) = (self.files(), self.header.count);
        format!("reducing {files} levels file(s) of a {shards}-shard run")
    }

    /// The header of the lowest shard given.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// The POIs of all shards in shard order (model CRS).
    pub fn pois(&self) -> &[Poi] {
        &self.pois
    }

    /// The options the shards selected with (rays, seed, silhouette threshold, roof
    /// tolerance, rough model): the model is written exactly as they selected it.
    pub fn options(&self) -> LodOptions {
        let h = &self.header;
        LodOptions {
            rough: RoughOptions {
                angle_deg: h.angle_deg,
                thickness_m: h.thickness_m,
                prefer_lod2: h.prefer_lod2,
            },
            select: SelectOptions {
                rays: h.rays,
                seed: h.seed,
                threshold_deg: Some(h.threshold_deg),
                roof_tolerance_m: h.roof_tolerance_m,
            },
        }
    }

    /// Combine the shards' levels for the model read from the inputs (source CRS).
    ///
    /// # Errors
    /// As `shard_levels::combine`.
    pub fn combine(self, model: &CityModel) -> Result<Combined, LevelsError> {
        shard_levels::combine(self.files, model)
    }
}

/// The [`LodResult`] of the combined levels `c` on `model` (the local frame's copy): the
/// rough model as [`crate::lod::lod`] makes it, the levels and figures of the shards.
pub fn lod_result(model: &CityModel, c: Combined, opts: &LodOptions) -> LodResult {
    let t = Instant::now();
    let rough = rough_model(model, &opts.rough);
    let rough_s = t.elapsed().as_secs_f64();
    let roof_asset = roof_assets(model, &rough, opts.select.roof_tolerance_m);
    LodResult {
        selection: Selection {
            levels: c.levels,
            hits: c.hits,
            roof_asset,
            pois: c.selections,
            threshold_deg: c.header.threshold_deg,
            rays: c.header.cells,
        },
        rough,
        rough_s,
        bvh_s: 0.0,
        select_s: 0.0,
        triangles: c.header.triangles,
        flags: c.flags,
    }
}
