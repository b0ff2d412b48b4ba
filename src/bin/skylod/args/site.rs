//! `--lat`, `--lon`: the site of the sun, given or from the model's CRS.

use crate::log::summary;
use anyhow::bail;
use skylod::crs::Crs;
use skylod::model::CityModel;

/// Check `--lat`/`--lon` given together, or say that they are needed.
pub fn lat_lon(lat: Option<f64>, lon: Option<f64>, cmd: &str) -> anyhow::Result<(f64, f64)> {
    match (lat, lon) {
        (Some(a), Some(o)) => {
            if !(-90.0..=90.0).contains(&a) || !(-180.0..=180.0).contains(&o) {
                bail!("--lat must be in -90..90 and --lon in -180..180 (got {a}, {o})");
            }
            Ok((a, o))
        }
        _ => bail!("{cmd} needs both --lat and --lon of the site, in degrees (WGS84)"),
    }
}

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

    /// Usage check before any input is read: both flags or neither.
    pub fn check(&self, cmd: &str) -> anyhow::Result<()> {
        if self.lat.is_some() != self.lon.is_some() {
            lat_lon(self.lat, self.lon, cmd)?;
        }
        Ok(())
    }

    /// [`SiteArgs::check`], and the flags' ranges when they are given.
    pub fn check_given(&self, cmd: &str) -> anyhow::Result<()> {
        self.check(cmd)?;
        if let Some((lat, lon)) = self.given() {
            lat_lon(Some(lat), Some(lon), cmd)?;
        }
        Ok(())
    }

    /// The site of the sun paths: the flags, or else the centre of `model` in `crs`
    /// ([`skylod::crs::model_site`], said on stderr, prefixed by `cmd`); `None` when neither
    /// gives one.
    pub fn for_sun_paths(&self, model: &CityModel, crs: &Crs, cmd: &str) -> Option<(f64, f64)> {
        if let Some(s) = self.given() {
            return Some(s);
        }
        match skylod::crs::model_site(model, crs) {
            Ok(s) => {
                summary!(
                    "{cmd}: site lat {:.5}, lon {:.5}: the centre of the model in {crs}",
                    s.lat,
                    s.lon
                );
                Some((s.lat, s.lon))
            }
            Err(_) => {
                summary!("{cmd}: no sun paths: the CRS ({crs}) is not one skylod converts; give --lat/--lon");
                None
            }
        }
    }

    /// The site, from the flags or from `model` ([`site_lat_lon`]).
    pub fn resolve(&self, model: &CityModel, cmd: &str) -> anyhow::Result<(f64, f64)> {
        site_lat_lon(self.lat, self.lon, model, cmd)
    }
}

/// The site for the sun position: `--lat`/`--lon` when given (both), otherwise the centre of
/// the model converted from its CRS when that is a UTM CRS skylod knows ([`skylod::crs`]).
pub fn site_lat_lon(
    lat: Option<f64>,
    lon: Option<f64>,
    model: &CityModel,
    cmd: &str,
) -> anyhow::Result<(f64, f64)> {
    if lat.is_some() || lon.is_some() {
        return lat_lon(lat, lon, cmd);
    }
    match model_site(model) {
        Ok((a, o, srs)) => {
            summary!("{cmd}: site lat {a:.5}, lon {o:.5}: the centre of the model in {srs}");
            Ok((a, o))
        }
        Err(why) => bail!("{cmd} needs the site's --lat and --lon (WGS84 degrees): {why}"),
    }
}

/// The centre of `model` in WGS84 degrees (lat, lon) with the srsName it was converted from,
/// or why there is none ([`skylod::crs::model_site`]).
pub fn model_site(model: &CityModel) -> Result<(f64, f64, String), skylod::crs::NoSite> {
    let s = skylod::crs::model_site(model, &skylod::crs::model_crs(model, None))?;
    Ok((s.lat, s.lon, s.crs.name))
}
