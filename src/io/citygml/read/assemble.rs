//! Model assembly after the last event: geometry resolved into its owners, body assets,
//! envelopes, the source file's record.

use super::state::{EnvOwner, Owner, Parser};
use super::xlink::{PolyRef, Registry, Walk};
use crate::io::citygml::error::{Location, ReadError};
use crate::model::{Bbox, CityModel, Polygon, SourceFile, Warning};

/// Drop the polygons at the end of the arena that no reference needs any more (`uses` 0),
/// and give the arena's memory back once it is less than half used.
fn release_consumed(polys: &mut Vec<Polygon>, uses: &[u32]) {
    while !polys.is_empty() && uses.get(polys.len() - 1).is_none_or(|&u| u == 0) {
        polys.pop();
    }
    if polys.capacity() > 4096 && polys.len() < polys.capacity() / 2 {
        polys.shrink_to_fit();
    }
}

impl Parser<'_> {
    pub(super) fn finish(mut self, len: u64, gzip: bool) -> Result<CityModel, ReadError> {
        let Some(version) = self.version else {
            return Err(ReadError::NotCityGml {
                loc: Location {
                    file: self.path.clone(),
                    line: 1,
                    column: 1,
                    gml_id: None,
                },
                message: "no element in a CityGML 1.0, 2.0 or 3.0 namespace".into(),
            });
        };
        // the ids that references name, while the id log is there to find them in; then
        // the registry and the log are given back before the model is assembled
        let wanted = self.href_targets();
        let index = (self.registry).index(
            &wanted,
            |pos, hash| self.id_text_at(pos, hash),
            |rec| self.id_log.get(rec as usize).map(|r| (r.hash, r.pos)),
        );
        drop(wanted);
        self.registry = Registry::default();
        self.invalid_id_summary();
        self.duplicate_warnings();
        // resolve geometry: references first, then move or clone the polygons
        let pending = std::mem::take(&mut self.pending);
        let mut refs: Vec<Vec<PolyRef>> = Vec::with_capacity(pending.len());
        let mut uses = vec![0u32; self.polys.len()];
        let mut walk = Walk {
            index,
            budget: self
                .opts
                .max_href_work
                .saturating_add(self.parts.len().saturating_mul(4)),
        };
        // one buffer to resolve into, each geometry's list then allocated at its length
        let mut out = Vec::new();
        for pg in &pending {
            out.clear();
            self.resolve(pg.range, false, 0, None, &mut out, &mut walk)?;
            for r in &out {
                if let Some(u) = uses.get_mut(r.poly as usize) {
                    *u += 1;
                }
            }
            refs.push(out.as_slice().to_vec());
        }
        drop(out);
        let mut polys = std::mem::take(&mut self.polys);
        // Last geometry first: the arena is consumed from its end, and what no reference
        // needs any more is given back as the model's geometry grows (a city's polygons are
        // never held twice: the read's peak is the model's size, not twice it).
        for (pg, rs) in pending.iter().zip(refs).rev() {
            let resolved = self.materialise(&rs, &mut polys, &mut uses);
            release_consumed(&mut polys, &uses);
            let list = match pg.owner {
                Owner::Asset(a) => self.assets.get_mut(a).map(|x| &mut x.geometries),
                Owner::Building(b) => self.buildings.get_mut(b).map(|x| &mut x.geometries),
            };
            if let Some(g) = list.and_then(|l| l.get_mut(pg.index)) {
                g.polygons = resolved;
            }
        }
        // drop empty geometries (curves, points)
        for a in &mut self.assets {
            a.geometries.retain(|g| !g.polygons.is_empty());
        }
        for b in &mut self.buildings {
            b.geometries.retain(|g| !g.polygons.is_empty());
        }
        // Body assets: a building's own geometry when it has no thematic surfaces
        for b in 0..self.buildings.len() {
            if let Some(body) = self.buildings[b].take_body(b, &self.assets) {
                self.buildings[b].assets.push(self.assets.len());
                self.assets.push(body);
            }
        }
        // the model's lists at their size
        self.assets.shrink_to_fit();
        self.buildings.shrink_to_fit();
        // Assets with no geometry left (e.g. a surface with only curves) are dropped from the
        // model but stay verbatim in the output.
        // envelopes
        let envs: Vec<Bbox> = self
            .env_owners
            .iter()
            .map(|o| match o {
                EnvOwner::Root => crate::model::content_bbox(&self.assets, &self.buildings),
                EnvOwner::Building(b) => self.building_bbox(*b),
                EnvOwner::Asset(a) => {
                    let mut b = self.assets.get(*a).map(|x| x.bbox()).unwrap_or_default();
                    for x in &self.assets {
                        if x.parent == Some(*a) {
                            b.union(&x.bbox());
                        }
                    }
                    b
                }
            })
            .collect();
        for (e, b) in self.envelopes.iter_mut().zip(envs) {
            if e.dimension == 0 {
                e.dimension = 3;
                e.bbox = Bbox::EMPTY;
            } else {
                e.bbox = b;
            }
        }
        let mut has_root_env = false;
        for o in &self.env_owners {
            if matches!(o, EnvOwner::Root) {
                has_root_env = true;
            }
        }
        if !has_root_env && self.root_is_model && !self.streamed {
            self.warnings.push(Warning {
                file: self.shared_path.clone(),
                line: 1,
                column: 1,
                gml_id: None,
                message: "CityModel has no gml:boundedBy envelope".into(),
            });
        }
        let file = SourceFile {
            path: self.path.clone(),
            source: crate::model::Source::File(self.path.clone()),
            version,
            srs_name: self.srs_name.clone(),
            gzip,
            len,
            gml_prefix: self.gml_prefix.clone().unwrap_or_else(|| "gml:".into()),
            envelopes: std::mem::take(&mut self.envelopes),
            implicit_geometries: self.implicit_count,
            library_objects: std::mem::take(&mut self.library_objects),
            objects_without_geometry: self.objects_without_geometry,
            polygon_elements: self.polygon_elements,
            features: self
                .feature_counts
                .iter()
                .map(|(name, n)| (String::from_utf8_lossy(name).into_owned(), *n))
                .collect(),
            cityjson: None,
        };
        Ok(CityModel {
            files: vec![file],
            buildings: self.buildings,
            assets: self.assets,
            warnings: self.warnings,
        })
    }

    pub(super) fn building_bbox(&self, b: usize) -> Bbox {
        let mut bb = Bbox::EMPTY;
        for (i, x) in self.buildings.iter().enumerate() {
            // the building itself and its parts (transitively)
            let mut cur = Some(i);
            let mut inside = false;
            while let Some(c) = cur {
                if c == b {
                    inside = true;
                    break;
                }
                cur = self.buildings.get(c).and_then(|y| y.parent);
            }
            if !inside {
                continue;
            }
            for &a in &x.assets {
                if let Some(asset) = self.assets.get(a) {
                    bb.union(&asset.bbox());
                }
            }
            for g in &x.geometries {
                for p in &g.polygons {
                    for q in p.points() {
                        bb.add(*q);
                    }
                }
            }
        }
        bb
    }
}
