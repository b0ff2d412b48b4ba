//! `--lat`, `--lon`: the site of the sun, given or from the model's CRS
//! ([`skylod::pipeline::session::site`]); the messages name the flags.

use crate::flags::site_text;
use anyhow::anyhow;
use skylod::model::CityModel;
use skylod::pipeline::session::{given_site, site_of};

/// The site of the sun position: `--lat`/`--lon`, both or neither (then from the model's CRS).
#[derive(clap::Args, Debug)]
pub struct SiteArgs {
    /// Site latitude in degrees (WGS84, north positive). Default: the centre of the model,
    /// from its CRS (geographic, or UTM zones of WGS 84, ETRS89, JGD2011, NAD83, GDA).
    #[arg(long, allow_hyphen_values = true)]
    pub lat: Option<f64>,
    /// Site longitude in degrees (WGS84, east positive). Default: as --lat.
    #[arg(long, allow_hyphen_values = true)]
    pub lon: Option<f64>,
}

impl SiteArgs {
    /// Both flags, when given.
    pub fn given(&self) -> Option<(f64, f64)> {
        self.lat.zip(self.lon)
    }

    /// Usage check before any input is read: both flags or neither (with `range`: in range).
    pub fn check(&self, cmd: &str, range: bool) -> anyhow::Result<()> {
        let given = given_site(self.lat, self.lon, range);
        given.map(drop).map_err(|e| anyhow!(site_text(&e, cmd)))
    }

    /// The site, from the flags or from `model`'s centre (said on stderr, prefixed by `cmd`).
    pub fn resolve(&self, model: &CityModel, cmd: &str) -> anyhow::Result<(f64, f64)> {
        let s = site_of(self.lat, self.lon, model).map_err(|e| anyhow!(site_text(&e, cmd)))?;
        if let Some(n) = s.note("") {
            crate::log::summary!("{cmd}: {n}");
        }
        Ok(s.lat_lon())
    }
}
