//! `--lat`, `--lon`: the site of the sun, given or from the model's CRS
//! ([`skylod::pipeline::session::site`]); the messages name the flags.

use anyhow::anyhow;
use skylod::model::CityModel;
use skylod::pipeline::session::site::{given_site, site_of, SiteError};

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
        given.map(drop).map_err(|e| flags(e, cmd))
    }

    /// The site, from the flags or from `model`'s centre (said on stderr, prefixed by `cmd`).
    pub fn resolve(&self, model: &CityModel, cmd: &str) -> anyhow::Result<(f64, f64)> {
        let s = site_of(self.lat, self.lon, model).map_err(|e| flags(e, cmd))?;
        if let Some(n) = s.note("") {
            crate::log::summary!("{cmd}: {n}");
        }
        Ok(s.lat_lon())
    }
}

/// `e` in the words of the flags that fix it.
pub fn flags(e: SiteError, cmd: &str) -> anyhow::Error {
    match e {
        SiteError::OutOfRange { lat, lon } => {
            anyhow!("--lat must be in -90..90 and --lon in -180..180 (got {lat}, {lon})")
        }
        SiteError::Half => {
            anyhow!("{cmd} needs both --lat and --lon of the site, in degrees (WGS84)")
        }
        e => anyhow!("{cmd} needs the site's --lat and --lon (WGS84 degrees): {e}"),
    }
}
