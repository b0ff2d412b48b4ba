//! `--facade ID` / `--region WKT --height Z` / `--surfaces roof,wall` with `--spacing M`: POIs
//! sampled over a surface, an area or every roof and wall ([`skylod::lod::poi::region`]), on `lod`, `svf`, `sun-hours` and `evaluate`. They are
//! added after the `--poi`/`--pois` points, in the model's CRS.

use crate::args::poi::PoiArgs;
use crate::args::positive;
use anyhow::bail;
use skylod::lod::poi::Poi;
use skylod::lod::poi::{cadastre_surfaces, shard_range, surface_of_poi, RegionSpec, SurfaceClass};
use skylod::model::CityModel;
use skylod::pipeline::batch::Shard;
use std::collections::HashSet;

#[derive(clap::Args, Debug)]
pub struct RegionArgs {
    /// POIs over a wall or roof surface (its gml:id), or over all walls of a building or
    /// building part (its gml:id): a grid of --spacing in the surface's plane, 5 cm out along
    /// the outward normal, not in openings. Repeatable.
    #[arg(long, value_name = "ID")]
    facade: Vec<String>,
    /// POIs on a horizontal grid of --spacing at --height inside a WKT polygon in the model's
    /// CRS, e.g. "POLYGON((x y, x y, x y, x y))" (holes allowed).
    #[arg(long, value_name = "WKT", requires = "height")]
    region: Option<String>,
    /// POIs on every roof and/or wall of the model (roof, wall or roof,wall): a grid of
    /// --spacing in the plane of each polygon, 5 cm out along its outward normal, not in
    /// openings; a body without thematic surfaces split into roof-like and wall-like faces by
    /// their normals. Named <surface>:<k>.
    #[arg(long, value_enum, value_name = "KINDS", value_delimiter = ',', num_args = 1..)]
    surfaces: Vec<SurfaceClass>,
    /// Height (model CRS) of the --region grid.
    #[arg(long, value_name = "Z", allow_hyphen_values = true)]
    height: Option<f64>,
    /// Grid spacing (m) of --facade, --region and --surfaces.
    #[arg(long, value_name = "M", default_value_t = 1.0, value_parser = positive)]
    spacing: f64,
}

impl RegionArgs {
    /// Whether `--facade`, `--region` or `--surfaces` is given.
    pub fn active(&self) -> bool {
        !self.facade.is_empty() || self.region.is_some() || !self.surfaces.is_empty()
    }

    /// The classes of `--surfaces`.
    pub fn surfaces(&self) -> &[SurfaceClass] {
        &self.surfaces
    }

    /// The `--poi`/`--pois` points; none needed when a region is given.
    pub fn points(&self, pois: &PoiArgs) -> anyhow::Result<Vec<Poi>> {
        if !self.surfaces.is_empty() && (!pois.poi.is_empty() || pois.pois.is_some()) {
            bail!("--surfaces makes the POIs: give it without --poi/--pois");
        }
        if self.active() && pois.poi.is_empty() && pois.pois.is_none() {
            if pois.crs.poi_crs.is_some() {
                bail!("--facade, --region and --surfaces POIs are in the model's CRS: --poi-crs does not apply to them");
            }
            return Ok(Vec::new());
        }
        if self.active() && pois.crs.poi_crs.is_some() {
            bail!("--facade, --region and --surfaces POIs are in the model's CRS: give --poi-crs only with --poi/--pois alone");
        }
        pois.points()
    }

    /// With `--surfaces` and a shard: the surfaces of `model` this shard works on
    /// ([`skylod::lod::poi::shard_range`], by index into
    /// [`skylod::lod::poi::cadastre_surfaces`]'s list).
    pub fn surface_shard(
        &self,
        model: &CityModel,
        shard: Option<Shard>,
    ) -> Option<std::ops::Range<usize>> {
        let s = shard.filter(|_| !self.surfaces.is_empty())?;
        let list = cadastre_surfaces(model, &self.surfaces);
        Some(shard_range(&list, s.index(), s.count()))
    }

    /// `pois` (the region's, from [`RegionArgs::extend`]) of this shard: with `--surfaces`
    /// those of the shard's surfaces ([`RegionArgs::surface_shard`]), cut between buildings
    /// so each building's table rows are whole in one shard; else by place.
    pub fn shard_pois(
        &self,
        pois: Vec<Poi>,
        model: &CityModel,
        shard: Option<Shard>,
        cmd: &str,
    ) -> Vec<Poi> {
        let Some(s) = shard.filter(|_| !self.surfaces.is_empty()) else {
            return crate::args::shard::pois(shard, pois, cmd);
        };
        let list = cadastre_surfaces(model, &self.surfaces);
        let range = shard_range(&list, s.index(), s.count());
        let mine: HashSet<&str> = list[range.clone()]
            .iter()
            .map(|c| c.name.as_str())
            .collect();
        let total = list.len();
        crate::args::shard::say(s, range, total, cmd, "surfaces");
        pois.into_iter()
            .filter(|p| mine.contains(surface_of_poi(&p.id)))
            .collect()
    }

    /// `pois` followed by the region's POIs sampled on `model` (as read:
    /// [`RegionSpec::extend`]).
    pub fn extend(&self, pois: Vec<Poi>, model: &CityModel) -> anyhow::Result<Vec<Poi>> {
        let spec = RegionSpec {
            facades: self.facade.clone(),
            area: self.region.clone().zip(self.height),
            surfaces: self.surfaces.clone(),
            spacing: self.spacing,
        };
        let pois = spec.extend(pois, model)?;
        if self.active() {
            crate::log::summary!("{} POI(s) in all", pois.len());
        }
        Ok(pois)
    }
}
