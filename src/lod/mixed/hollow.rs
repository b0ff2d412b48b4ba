//! The mixed writer on a document read hollow ([`super::MixedSource::Hollow`]): the plan
//! of each chunk is made on the hollow model with the polygons its rules look at read back
//! for the chunk ([`PlanModel::fill`]) and dropped again after it: the assets kept (level 1
//! or 2: properties copied, rebuilt or compared with the rough form, the boxes of the
//! envelopes) and the buildings' own geometry (the envelopes, a building's kept geometry).
//! A level-0 asset's geometry goes whole, so its polygons are not needed; the polygon counts
//! of the summary are the hollow read's ([`FullFacts::polygons`]). The bytes written are
//! those of [`super::write_mixed`] on the whole read. Where the chunked plan declines, every such polygon of the file is read back and the whole
//! index planned (the memory of the whole read).

use super::chunked::plan_chunked_with;
use super::{check_per_asset, plan_file_with, MixedSummary};
use crate::io::citygml::error::WriteError;
use crate::io::citygml::read::Reread;
use crate::io::citygml::write::{check_target, write_document, WriteOptions};
use crate::lod::hollow::{drop_polygons, Hollow};
use crate::lod::rough::RoughGeometry;
use crate::lod::select::FullFacts;
use crate::model::CityModel;
use std::path::Path;

/// The model a plan reads (`super::chunked`): the whole read, every polygon there, or a
/// hollow read whose polygons a chunk's plan needs are read back for it.
pub(super) trait PlanModel {
    /// The model.
    fn model(&self) -> &CityModel;
    /// The polygons of each asset in the full model.
    fn facts(&self) -> &dyn FullFacts;
    /// Give the assets of `assets` kept at `levels` and the buildings of `buildings` their
    /// polygons; false where they cannot be read back.
    fn fill(&mut self, assets: &[u32], buildings: &[u32], levels: &[u8]) -> bool;
    /// Drop the polygons [`PlanModel::fill`] gave.
    fn empty(&mut self);
}

/// The whole read: nothing to fill (for tests: the writer plans a model read whole in one
/// chunk).
#[cfg(test)]
pub(super) struct Whole<'a>(pub(super) &'a CityModel);

#[cfg(test)]
impl PlanModel for Whole<'_> {
    fn model(&self) -> &CityModel {
        self.0
    }

    fn facts(&self) -> &dyn FullFacts {
        self.0
    }

    fn fill(&mut self, _: &[u32], _: &[u32], _: &[u8]) -> bool {
        true
    }

    fn empty(&mut self) {}
}

/// A hollow read, its polygons read back through `rr` as a plan needs them.
struct Filled<'a> {
    hollow: &'a mut Hollow,
    rr: &'a Reread,
    /// Assets and buildings given polygons (assets the read kept are not).
    assets: Vec<usize>,
    buildings: Vec<usize>,
}

impl PlanModel for Filled<'_> {
    fn model(&self) -> &CityModel {
        &self.hollow.model
    }

    fn facts(&self) -> &dyn FullFacts {
        &*self.hollow
    }

    fn fill(&mut self, assets: &[u32], buildings: &[u32], levels: &[u8]) -> bool {
        let h = &*self.hollow;
        let assets: Vec<usize> = (assets.iter().map(|&a| a as usize))
            .filter(|&a| levels.get(a).is_some_and(|&l| l > 0))
            .filter(|&a| !h.kept.get(a).copied().unwrap_or(false))
            .collect();
        let buildings: Vec<usize> = (buildings.iter().map(|&b| b as usize))
            .filter(|&b| {
                h.model
                    .buildings
                    .get(b)
                    .is_some_and(|b| !b.geometries.is_empty())
            })
            .collect();
        if assets.is_empty() && buildings.is_empty() {
            return true;
        }
        let Some((ga, gb)) = h.read_back_geometries(self.rr, &assets, &buildings) else {
            return false;
        };
        let m = &mut self.hollow.model;
        for (&a, g) in assets.iter().zip(ga) {
            m.assets[a].geometries = g;
        }
        for (&b, g) in buildings.iter().zip(gb) {
            m.buildings[b].geometries = g;
        }
        self.assets.extend(assets);
        self.buildings.extend(buildings);
        true
    }

    fn empty(&mut self) {
        let m = &mut self.hollow.model;
        for a in std::mem::take(&mut self.assets) {
            drop_polygons(&mut m.assets[a].geometries);
        }
        for b in std::mem::take(&mut self.buildings) {
            drop_polygons(&mut m.buildings[b].geometries);
        }
    }
}

/// [`super::write_mixed`] of the document read hollow as `hollow` (its one file) to `out`,
/// the polygons the plan needs read back through `rr` (the document's [`Reread`]), planned in
/// chunks of about `chunk_bytes` (see the module docs): the bytes and the summary of the
/// whole read's. `hollow` is left as it was given.
pub(super) fn write_hollow(
    hollow: &mut Hollow,
    rr: &Reread,
    (rough, levels): (&[RoughGeometry], &[u8]),
    out: &Path,
    opts: &WriteOptions,
    chunk_bytes: u64,
) -> Result<MixedSummary, WriteError> {
    let model = &hollow.model;
    check_per_asset(model, rough, levels)?;
    let src = crate::io::citygml::write::source_file(model, 0)?;
    check_target(out, opts, src.source.path())?;
    let keep = opts.keep_envelopes;
    let mut m = Filled {
        hollow,
        rr,
        assets: Vec::new(),
        buildings: Vec::new(),
    };
    let planned = plan_chunked_with(&mut m, (0, rough, levels), keep, chunk_bytes);
    m.empty();
    let (edits, mut summary) = match planned {
        Some(p) => p,
        None => {
            let (n, b) = (m.hollow.model.assets.len(), m.hollow.model.buildings.len());
            let all = |n: usize| (0..n).map(|i| u32::try_from(i).unwrap_or(u32::MAX));
            let (assets, buildings): (Vec<u32>, Vec<u32>) = (all(n).collect(), all(b).collect());
            if !m.fill(&assets, &buildings, levels) {
                return Err(WriteError::Invalid(format!(
                    "{}: the polygons to write could not be read again",
                    m.hollow.model.files[0].path.display()
                )));
            }
            let h = &*m.hollow;
            let p = plan_file_with(&h.model, h, (0, rough, levels), keep, true);
            m.empty();
            p?
        }
    };
    let wopts = WriteOptions {
        keep_envelopes: true,
        ..opts.clone()
    };
    summary.bytes = write_document(&m.hollow.model, 0, edits, out, &wopts)?.bytes;
    Ok(summary)
}
