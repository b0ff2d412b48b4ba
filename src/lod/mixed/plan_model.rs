//! The model a plan reads ([`PlanModel`]): a model read whole ([`Whole`]: every polygon
//! there), or a document read hollow ([`Filled`], [`super::MixedSource::Hollow`]), whose
//! polygons the rules of a chunk's plan look at are read back for the chunk
//! ([`PlanModel::fill`]) and dropped again after it: the assets kept (level 1 or 2: properties
//! copied, rebuilt or compared with the rough form, the boxes of the envelopes) and the
//! buildings' own geometry (the envelopes, a building's kept geometry). A level-0 asset's
//! geometry goes whole, so its polygons are not needed; the polygon counts of the summary are
//! the hollow read's ([`FullFacts::polygons`]). The bytes written are those of the whole read.

use crate::io::citygml::read::Reread;
use crate::lod::hollow::{drop_polygons, Hollow};
use crate::lod::select::FullFacts;
use crate::model::CityModel;

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

/// The whole read: nothing to fill.
pub(super) struct Whole<'a>(pub(super) &'a CityModel);

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
pub(super) struct Filled<'a> {
    pub(super) hollow: &'a mut Hollow,
    pub(super) rr: &'a Reread,
    /// Assets and buildings given polygons (assets the read kept are not).
    pub(super) assets: Vec<usize>,
    pub(super) buildings: Vec<usize>,
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
