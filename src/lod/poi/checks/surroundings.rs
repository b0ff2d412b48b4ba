//! What lies around each POI, found once per model: the buildings (a building with its
//! parts, or an asset outside any building) in a grid of [`CELL`]-metre cells, with their
//! boxes and assets. [`super::enclosure::poi_flags_around`] asks it for the lowest surface
//! near a POI (the far-below flag), the polygons a POI lies on (the normal flag) and the
//! full geometry of the buildings whose box holds a POI (the inside-building flag of `lod`,
//! whose own scene is the rough model).
//!
//! # Example
//! ```
//! use glam::DVec3;
//! use skylod::lod::poi::Surroundings;
//! use skylod::model::synth::{BoxBuilding, boxes_citygml};
//! let b = BoxBuilding { id: "B".into(), min: [0.0, 0.0], max: [10.0, 10.0], height: 10.0,
//!     installations: vec![] };
//! let m = skylod::io::citygml::read_bytes(boxes_citygml(&[b], [0.0, 0.0, 0.0]).as_bytes(),
//!     "b.gml").unwrap();
//! let around = Surroundings::new(&m);
//! assert_eq!(around.lowest_near(DVec3::new(20.0, 5.0, 0.0), 100.0), Some(0.0));
//! assert_eq!(around.lowest_near(DVec3::new(500.0, 5.0, 0.0), 100.0), None);
//! ```

use crate::model::{Bbox, CityModel, Polygon};
use crate::solar::trace::{scene_of, TraceScene};
use glam::DVec3;
use std::collections::HashMap;

/// Side of a grid cell (m).
pub const CELL: f64 = 50.0;

/// A building with its parts, or an asset outside any building.
#[derive(Debug, Clone)]
struct Group {
    bbox: Bbox,
    assets: Vec<u32>,
}

/// The buildings of a model in a horizontal grid (model or local frame: the POIs asked about
/// must be in the same one).
#[derive(Debug, Clone, Default)]
pub struct Surroundings {
    groups: Vec<Group>,
    grid: HashMap<(i64, i64), Vec<u32>>,
    /// Groups spanning more than [`MAX_CELLS`] cells (terrain, huge objects): always asked.
    large: Vec<u32>,
}

/// Cells a group may fill before it is kept apart.
const MAX_CELLS: i64 = 4096;

fn cell_of(x: f64) -> i64 {
    (x / CELL).floor() as i64
}

impl Surroundings {
    /// Group the assets of `model` by top-level building and index their boxes.
    pub fn new(model: &CityModel) -> Self {
        let boxes: Vec<Bbox> = model.assets.iter().map(|a| a.bbox()).collect();
        Self::with_boxes(model, &boxes)
    }

    /// [`Surroundings::new`] with each asset's box given (`boxes[i]`: asset `i`'s
    /// [`crate::model::Asset::bbox`], e.g. from a hollow read, `crate::lod::hollow`).
    pub fn with_boxes(model: &CityModel, boxes: &[Bbox]) -> Self {
        let mut groups: Vec<Group> = Vec::new();
        let mut of_root: HashMap<usize, usize> = HashMap::new();
        for ((i, a), &b) in model.assets.iter().enumerate().zip(boxes) {
            if b.is_empty() {
                continue;
            }
            let g = match a.building.map(|x| model.root_building(x)) {
                Some(root) => *of_root.entry(root).or_insert_with(|| {
                    groups.push(Group {
                        bbox: Bbox::EMPTY,
                        assets: Vec::new(),
                    });
                    groups.len() - 1
                }),
                None => {
                    groups.push(Group {
                        bbox: Bbox::EMPTY,
                        assets: Vec::new(),
                    });
                    groups.len() - 1
                }
            };
            groups[g].bbox.union(&b);
            groups[g].assets.push(i as u32);
        }
        let mut grid: HashMap<(i64, i64), Vec<u32>> = HashMap::new();
        let mut large = Vec::new();
        for (k, g) in groups.iter().enumerate() {
            let (x0, x1) = (cell_of(g.bbox.min.x), cell_of(g.bbox.max.x));
            let (y0, y1) = (cell_of(g.bbox.min.y), cell_of(g.bbox.max.y));
            if (x1 - x0 + 1).saturating_mul(y1 - y0 + 1) > MAX_CELLS {
                large.push(k as u32);
                continue;
            }
            for cx in x0..=x1 {
                for cy in y0..=y1 {
                    grid.entry((cx, cy)).or_default().push(k as u32);
                }
            }
        }
        Surroundings {
            groups,
            grid,
            large,
        }
    }

    /// Groups whose box comes within `radius` of `p` horizontally (each once).
    fn near(&self, p: DVec3, radius: f64) -> Vec<&Group> {
        self.near_ids(p, radius)
            .into_iter()
            .map(|k| &self.groups[k as usize])
            .collect()
    }

    /// Indices of [`Surroundings::near`].
    fn near_ids(&self, p: DVec3, radius: f64) -> Vec<u32> {
        let (x0, x1) = (cell_of(p.x - radius), cell_of(p.x + radius));
        let (y0, y1) = (cell_of(p.y - radius), cell_of(p.y + radius));
        let mut ids: Vec<u32> = self.large.clone();
        for cx in x0..=x1 {
            for cy in y0..=y1 {
                if let Some(v) = self.grid.get(&(cx, cy)) {
                    ids.extend_from_slice(v);
                }
            }
        }
        ids.sort_unstable();
        ids.dedup();
        ids.into_iter()
            .filter(|&k| {
                let g = &self.groups[k as usize];
                let dx = (g.bbox.min.x - p.x).max(p.x - g.bbox.max.x).max(0.0);
                let dy = (g.bbox.min.y - p.y).max(p.y - g.bbox.max.y).max(0.0);
                dx * dx + dy * dy <= radius * radius
            })
            .collect()
    }

    /// The lowest height of any building (or other object) whose box comes within `radius`
    /// of `p` horizontally; `None` when there is none.
    pub fn lowest_near(&self, p: DVec3, radius: f64) -> Option<f64> {
        self.near(p, radius)
            .iter()
            .map(|g| g.bbox.min.z)
            .min_by(f64::total_cmp)
    }

    /// The assets of the buildings whose box, grown by `margin`, holds `p`: those whose full
    /// geometry [`Surroundings::polygons_at`] and [`Surroundings::scene_holding`] look at.
    pub fn assets_holding(&self, p: DVec3, margin: f64) -> impl Iterator<Item = u32> + '_ {
        (self.holding(p, margin).into_iter())
            .flat_map(|k| self.groups[k as usize].assets.iter().copied())
    }

    /// Indices of the groups whose box, grown by `margin`, holds `p`.
    fn holding(&self, p: DVec3, margin: f64) -> Vec<u32> {
        let m = DVec3::splat(margin);
        self.near_ids(p, margin)
            .into_iter()
            .filter(|&k| {
                let b = &self.groups[k as usize].bbox;
                p.cmpge(b.min - m).all() && p.cmple(b.max + m).all()
            })
            .collect()
    }

    /// Full-detail polygons ([`crate::model::Asset::detail_polygons`]) of the buildings
    /// whose box, grown by `margin`, holds `p`, with their asset index.
    pub fn polygons_at<'m>(
        &self,
        model: &'m CityModel,
        p: DVec3,
        margin: f64,
    ) -> Vec<(u32, &'m Polygon)> {
        self.assets_holding(p, margin)
            .filter_map(|i| model.assets.get(i as usize).map(|a| (i, a)))
            .flat_map(|(i, a)| a.detail_polygons().iter().map(move |q| (i, q)))
            .collect()
    }

    /// A full-detail scene (tags: asset indices) of every building whose box, grown by
    /// `margin`, holds one of `points`: what the inside-building probe needs to judge the
    /// full geometry when the traced scene is another (the rough model of `lod`).
    pub fn scene_holding(&self, model: &CityModel, points: &[DVec3], margin: f64) -> TraceScene {
        let mut keep = vec![false; self.groups.len()];
        for p in points {
            for k in self.holding(*p, margin) {
                if let Some(x) = keep.get_mut(k as usize) {
                    *x = true;
                }
            }
        }
        scene_of(
            self.groups
                .iter()
                .zip(&keep)
                .filter(|(_, k)| **k)
                .flat_map(|(g, _)| g.assets.iter())
                .filter_map(|&i| model.assets.get(i as usize).map(|a| (i, a)))
                .flat_map(|(i, a)| a.detail_polygons().iter().map(move |q| (i, q))),
        )
    }
}
