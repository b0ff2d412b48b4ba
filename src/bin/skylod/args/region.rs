//! `--facade ID` / `--region WKT --height Z` with `--spacing M`: POIs sampled over a surface
//! or an area ([`skylod::lod::poi::region`]), on `lod`, `svf`, `sun-hours` and `evaluate`. They are
//! added after the `--poi`/`--pois` points, in the model's CRS.

use crate::args::poi::PoiArgs;
use crate::args::positive;
use anyhow::bail;
use skylod::lod::poi::Poi;
use skylod::lod::poi::RegionSpec;
use skylod::model::CityModel;

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
    /// Height (model CRS) of the --region grid.
    #[arg(long, value_name = "Z", allow_hyphen_values = true)]
    height: Option<f64>,
    /// Grid spacing (m) of --facade and --region.
    #[arg(long, value_name = "M", default_value_t = 1.0, value_parser = positive)]
    spacing: f64,
}

impl RegionArgs {
    /// Whether `--facade` or `--region` is given.
    pub fn active(&self) -> bool {
        !self.facade.is_empty() || self.region.is_some()
    }

    /// The `--poi`/`--pois` points; none needed when a region is given.
    pub fn points(&self, pois: &PoiArgs) -> anyhow::Result<Vec<Poi>> {
        if self.active() && pois.poi.is_empty() && pois.pois.is_none() {
            if pois.crs.poi_crs.is_some() {
                bail!("--facade and --region POIs are in the model's CRS: --poi-crs does not apply to them");
            }
            return Ok(Vec::new());
        }
        if self.active() && pois.crs.poi_crs.is_some() {
            bail!("--facade and --region POIs are in the model's CRS: give --poi-crs only with --poi/--pois alone");
        }
        pois.points()
    }

    /// `pois` followed by the region's POIs sampled on `model` (as read:
    /// [`RegionSpec::extend`]).
    pub fn extend(&self, pois: Vec<Poi>, model: &CityModel) -> anyhow::Result<Vec<Poi>> {
        let spec = RegionSpec {
            facades: self.facade.clone(),
            area: self.region.clone().zip(self.height),
            spacing: self.spacing,
        };
        let pois = spec.extend(pois, model)?;
        if self.active() {
            crate::log::summary!("{} POI(s) in all", pois.len());
        }
        Ok(pois)
    }
}
