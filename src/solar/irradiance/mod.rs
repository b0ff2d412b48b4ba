//! Annual irradiation (kWh/m²) on the plane of a point from an hourly weather year, with
//! the city model's occlusion (DESIGN.md "Irradiance").
//!
//! For each hour of the [`Weather`] the sun is put at the middle of the hour
//! ([`IrradianceTable::new`]) and the plane of normal `n` (horizontal when none) receives:
//!
//! * **direct**: DNI × cos θ when the sun is above the horizon, in front of the plane
//!   (cos θ = n·s > 0) and the ray towards it is not blocked: one ray per such hour;
//! * **diffuse**, [`SkyModel::AllWeather`] (default): daylight coefficients. Every ray of
//!   the plane's bundle that reaches the sky counts for the patch of [`Patches::reinhart`]
//!   it passes through ([`PlaneView::patches`]); each hour's sky is the Perez all-weather
//!   distribution of `all_weather` (the model of Radiance's `gendaymtx`), and the table keeps
//!   each patch's radiance summed over the hours, so the year's diffuse part is one sum over
//!   the patches the plane sees: `π / N × Σ rays(p) × L(p)`. A facade gets the brightness of
//!   the part of the sky it faces; the sun stays a ray per hour (below), so the direct part is
//!   exact rather than spread over patches.
//! * **diffuse**, [`SkyModel::Perez`]: the Perez 1990 transposition
//!   (`perez`) with each of its three parts occluded by what blocks it:
//!   the isotropic part `DHI (1 − F1) × SVF` (the point's cosine-weighted sky view factor of
//!   `crate::solar::svf`, which is `(1 + cos β)/2` for an unobstructed plane), the
//!   circumsolar part `DHI F1 a/b` only when the sun's own ray is free, the horizon band
//!   `DHI F2 sin β × H` with `H` the share of the bundle's rays between 0 and 6.5° of
//!   elevation (Perez's band) that reach the sky; the hour's sum is clamped at 0 as pvlib
//!   does. With the sun below the horizon the Perez model is not defined and the hour's DHI
//!   is treated as isotropic. It is the transposition pvlib, SAM and PVGIS-style tools use
//!   and validate, so an unobstructed plane gives exactly their numbers; obstructed or
//!   facing away from the sun, it treats the plane's sky as a scaled open one.
//! * **diffuse**, [`SkyModel::Isotropic`]: `DHI × SVF`.
//! * **reflected**: `albedo × GHI × (1 − SVF)`: whatever the plane sees that is not sky
//!   (ground and obstructions) is taken as a Lambertian surface lit like open ground. For an
//!   unobstructed plane this is pvlib's `albedo GHI (1 − cos β)/2`; in a street canyon it
//!   overestimates what shaded walls reflect (the simplest defensible model; `--albedo 0`
//!   turns it off).
//!
//! Sums over the hours are in Wh/m² (hourly values are Wh/m²), reported in kWh/m².
//!
//! # Example
//! ```
//! use glam::DVec3;
//! use skylod::solar::irradiance::{irradiance, plane_view, IrradianceOptions, IrradianceTable};
//! use skylod::solar::{Weather, WeatherFormat, WeatherHour, WeatherSite};
//! use skylod::solar::{Site, SkyBundles};
//! use chrono::{TimeZone, Utc};
//! let site = WeatherSite { name: "x".into(), latitude: 41.39, longitude: 2.17,
//!     utc_offset_hours: 1.0, elevation_m: 0.0 };
//! let noon = WeatherHour { mid_utc: Utc.with_ymd_and_hms(2020, 6, 21, 11, 30, 0).unwrap(),
//!     ghi: 900.0, dni: 800.0, dhi: 150.0 };
//! let weather = Weather { format: WeatherFormat::Epw, site, hours: vec![noon] };
//! let opts = IrradianceOptions::default();
//! let table = IrradianceTable::new(&weather, &Site::new(41.39, 2.17), opts.sky).unwrap();
//! let bundles = SkyBundles::new(1000, 1).unwrap();
//! // an unobstructed roof: direct + diffuse = GHI
//! let view = plane_view(None, &bundles, |_| false);
//! let r = irradiance(&table, None, view, |_| false, &opts);
//! assert!((r.global_kwh_m2 - 0.9).abs() < 0.01, "{r:?}");
//! ```

pub(crate) mod all_weather;
pub(crate) mod perez;
pub use all_weather::{HourSky, Patches, SUBDIVISION};
pub use perez::{brightening, extraterrestrial, relative_airmass};

use super::sky::Frame;
use super::sun::{sun_position, Site};
use super::svf::SkyBundles;
use super::weather::Weather;
use super::SolarError;
use chrono::Datelike;
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Perez's horizon band: elevations from 0 to 6.5°.
pub const HORIZON_BAND_DEG: f64 = 6.5;

/// The sky's diffuse radiance distribution.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum SkyModel {
    /// The Perez all-weather sky on Reinhart's patches, by daylight coefficients (the
    /// model of Radiance's `gendaymtx`; `all_weather`): right for any plane, seen sky
    /// and obstruction.
    #[default]
    #[serde(rename = "all-weather")]
    #[cfg_attr(feature = "cli", value(name = "all-weather"))]
    AllWeather,
    /// The Perez 1990 transposition (isotropic, circumsolar and horizon parts scaled by
    /// what blocks them): pvlib's, SAM's and PVGIS's numbers on unobstructed planes.
    Perez,
    /// Uniform radiance.
    Isotropic,
}

impl SkyModel {
    /// Its name: `all-weather`, `perez` or `isotropic`.
    pub fn name(self) -> &'static str {
        match self {
            SkyModel::AllWeather => "all-weather",
            SkyModel::Perez => "perez",
            SkyModel::Isotropic => "isotropic",
        }
    }
}

/// Options of [`irradiance`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IrradianceOptions {
    /// The sky model of the diffuse part.
    pub sky: SkyModel,
    /// Ground (and obstruction) reflectance; 0 turns the reflected part off.
    pub albedo: f64,
}

impl Default for IrradianceOptions {
    /// Perez, albedo 0.2.
    fn default() -> Self {
        IrradianceOptions {
            sky: SkyModel::Perez,
            albedo: 0.2,
        }
    }
}

/// A weather year ready to trace: its [`IrradianceTable`] and the [`IrradianceOptions`] to
/// use with it (what `evaluate --weather` and the irradiance bound of `lod` take).
#[derive(Debug, Clone, PartialEq)]
pub struct IrradianceSetting {
    /// The weather's hours with the sun placed.
    pub table: IrradianceTable,
    /// Sky model and albedo.
    pub opts: IrradianceOptions,
}

/// One hour of a [`IrradianceTable`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SkyHour {
    /// Unit direction to the sun at the middle of the hour (x east, y north, z up).
    pub sun: DVec3,
    /// Apparent zenith angle of the sun, degrees.
    pub zenith_deg: f64,
    /// Global horizontal, direct normal and diffuse horizontal irradiation (Wh/m²).
    pub ghi: f64,
    /// Direct normal irradiation (Wh/m²).
    pub dni: f64,
    /// Diffuse horizontal irradiation (Wh/m²).
    pub dhi: f64,
    /// Perez circumsolar coefficient (0 for an isotropic sky or the sun down).
    pub f1: f64,
    /// Perez horizon coefficient (0 for an isotropic sky or the sun down).
    pub f2: f64,
    /// The all-weather sky of the hour ([`SkyModel::AllWeather`]; `None` otherwise or
    /// without diffuse light).
    pub sky: Option<HourSky>,
    /// The month of the hour in the weather's local standard time, 0 (January) to 11.
    pub month: u8,
}

impl SkyHour {
    fn sun_up(&self) -> bool {
        self.zenith_deg < 90.0
    }
}

/// The weather's hours with the sun placed and the sky model's coefficients, computed once
/// for every point.
#[derive(Debug, Clone, PartialEq)]
pub struct IrradianceTable {
    hours: Vec<SkyHour>,
    /// Per patch of [`Patches::reinhart`], its radiance summed over the hours
    /// ([`SkyModel::AllWeather`]; empty otherwise).
    patch_sums: Vec<f64>,
    /// The same per month: month `m`'s sums at `m * patches ..`.
    patch_months: Vec<f64>,
}

impl IrradianceTable {
    /// Sun positions (SPA, at each hour's middle) at `site` and the sky coefficients of
    /// `sky` for every hour of `weather`.
    ///
    /// # Errors
    /// [`SolarError`] when SPA rejects the site or a date.
    pub fn new(weather: &Weather, site: &Site, sky: SkyModel) -> Result<Self, SolarError> {
        let mut hours = weather
            .hours
            .par_iter()
            .map(|h| {
                let p = sun_position(h.mid_utc, site)?;
                let (f1, f2) = match sky {
                    SkyModel::Perez => perez::relative_airmass(p.zenith_deg)
                        .map(|am| {
                            let extra = perez::extraterrestrial(h.mid_utc.ordinal());
                            perez::brightening(h.dhi, h.dni, p.zenith_deg, am, extra)
                        })
                        .unwrap_or((0.0, 0.0)),
                    SkyModel::Isotropic | SkyModel::AllWeather => (0.0, 0.0),
                };
                let local = h.mid_utc
                    + chrono::Duration::seconds((weather.site.utc_offset_hours * 3600.0) as i64);
                Ok(SkyHour {
                    month: local.month0() as u8,
                    sun: p.direction,
                    zenith_deg: p.zenith_deg,
                    ghi: h.ghi,
                    dni: h.dni,
                    dhi: h.dhi,
                    f1,
                    f2,
                    sky: None,
                })
            })
            .collect::<Result<Vec<_>, SolarError>>()?;
        let (patch_sums, patch_months) = if sky == SkyModel::AllWeather {
            // fixed runs of hours summed in order: the same sums on every run and machine
            const RUN: usize = 168;
            let n = Patches::reinhart().len();
            let runs: Vec<Vec<f64>> = (hours.par_chunks_mut(RUN))
                .zip(weather.hours.par_chunks(RUN))
                .map(|(hs, ws)| {
                    let mut acc = vec![0.0; 12 * n];
                    for (h, w) in hs.iter_mut().zip(ws) {
                        let m = usize::from(h.month.min(11)) * n;
                        let month = &mut acc[m..m + n];
                        h.sky = HourSky::adding(h.sun, h.dni, h.dhi, w.mid_utc.ordinal(), month);
                    }
                    acc
                })
                .collect();
            let mut months = vec![0.0; 12 * n];
            for r in runs {
                months.iter_mut().zip(r).for_each(|(x, y)| *x += y);
            }
            let mut sums = vec![0.0; n];
            for m in months.chunks(n) {
                sums.iter_mut().zip(m).for_each(|(x, y)| *x += y);
            }
            (sums, months)
        } else {
            (Vec::new(), Vec::new())
        };
        Ok(IrradianceTable {
            hours,
            patch_sums,
            patch_months,
        })
    }

    /// The diffuse irradiation (Wh/m²) over all hours of a plane whose free sky rays fall
    /// in the patches of `view` ([`SkyModel::AllWeather`]).
    fn all_weather_sum(&self, view: &PlaneView) -> f64 {
        sum_over(&self.patch_sums, view)
    }

    /// [`IrradianceTable::all_weather_sum`] per month.
    fn all_weather_months(&self, view: &PlaneView) -> [f64; 12] {
        let n = Patches::reinhart().len();
        let mut out = [0.0; 12];
        for (m, o) in out.iter_mut().enumerate() {
            *o = sum_over(
                self.patch_months.get(m * n..(m + 1) * n).unwrap_or(&[]),
                view,
            );
        }
        out
    }

    /// The hours, in weather order.
    pub fn hours(&self) -> &[SkyHour] {
        &self.hours
    }

    /// Number of hours.
    pub fn len(&self) -> usize {
        self.hours.len()
    }

    /// Whether there are no hours.
    pub fn is_empty(&self) -> bool {
        self.hours.is_empty()
    }
}

/// `π / N × Σ rays(p) × sums(p)` over the patches `view` sees.
fn sum_over(sums: &[f64], view: &PlaneView) -> f64 {
    let rays = view.rays.max(1) as f64;
    (view.patches.iter())
        .map(|&(p, k)| sums.get(p as usize).copied().unwrap_or(0.0) * f64::from(k))
        .sum::<f64>()
        * PI
        / rays
}

/// What a plane sees of the sky, from one bundle of rays: see [`plane_view`].
#[derive(Debug, Clone, PartialEq)]
pub struct PlaneView {
    /// Cosine-weighted sky view factor (the isotropic share).
    pub svf: f64,
    /// Share of the bundle's rays in the horizon band (0–6.5° elevation) that reach the sky;
    /// 1 when the bundle has none there.
    pub horizon: f64,
    /// The plane's daylight coefficients: per patch of [`Patches::reinhart`] the bundle's
    /// rays that reach the sky through it, ascending by patch; a patch's coefficient is
    /// `π × rays / `[`PlaneView::rays`] (the cosine-weighted solid angle of it the plane
    /// sees).
    pub patches: Vec<(u32, u32)>,
    /// Rays of the bundle.
    pub rays: usize,
}

impl PlaneView {
    /// The view of `rays` rays of which those in `free` (patch indices of
    /// [`Patches::reinhart`], in any order) reach the sky, `band` of `in_band` in the
    /// horizon band.
    fn of_free(rays: usize, mut free: Vec<u32>, band: usize, in_band: usize) -> PlaneView {
        let svf = free.len() as f64 / rays.max(1) as f64;
        free.sort_unstable();
        let mut patches: Vec<(u32, u32)> = Vec::new();
        for p in free {
            match patches.last_mut() {
                Some((q, k)) if *q == p => *k += 1,
                _ => patches.push((p, 1)),
            }
        }
        PlaneView {
            svf,
            horizon: if in_band == 0 {
                1.0
            } else {
                band as f64 / in_band as f64
            },
            patches,
            rays,
        }
    }
}

/// The [`PlaneView`] of a plane with `normal` (horizontal when `None`, zero or not finite):
/// the projected-area bundle of `bundles` turned to the normal, `blocked(dir)` telling
/// whether a ray is obstructed (as [`crate::solar::svf::sky_view`]).
pub fn plane_view(
    normal: Option<DVec3>,
    bundles: &SkyBundles,
    blocked: impl Fn(DVec3) -> bool + Sync,
) -> PlaneView {
    let n = normal.and_then(|n| n.try_normalize()).unwrap_or(DVec3::Z);
    let frame = Frame::from_normal(n);
    let band = HORIZON_BAND_DEG.to_radians().sin();
    let patches = Patches::reinhart();
    // per ray above the horizon: its patch when free, and whether it is in the band
    let rays: Vec<(Option<u32>, bool)> = bundles
        .projected_dirs()
        .par_iter()
        .with_min_len(1024)
        .filter_map(|&local| {
            let d = frame.to_world(local);
            (d.z > 0.0).then_some(d)
        })
        .map(|d| {
            let free = (!blocked(d)).then(|| patch_index(patches, d));
            (free, d.z <= band)
        })
        .collect();
    let in_band = rays.iter().filter(|r| r.1).count();
    let band_sky = rays.iter().filter(|r| r.1 && r.0.is_some()).count();
    let free = rays.iter().filter_map(|r| r.0).collect();
    PlaneView::of_free(bundles.len(), free, band_sky, in_band)
}

/// The patch of a direction above the horizon, as stored in a [`PlaneView`].
fn patch_index(patches: &Patches, d: DVec3) -> u32 {
    patches
        .patch_of(d)
        .map_or(u32::MAX, |p| u32::try_from(p).unwrap_or(u32::MAX))
}

/// Annual irradiation of a plane (kWh/m²), see the module docs.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct Irradiance {
    /// Direct + diffuse + reflected.
    pub global_kwh_m2: f64,
    /// From the sun's disc.
    pub direct_kwh_m2: f64,
    /// From the sky.
    pub diffuse_kwh_m2: f64,
    /// From the ground and obstructions.
    pub reflected_kwh_m2: f64,
    /// Cosine-weighted sky view factor used for the diffuse and reflected parts.
    pub svf: f64,
    /// Hours the sun was above the horizon and in front of the plane.
    pub sun_hours_possible: u32,
    /// Of those, hours with the sun's ray free.
    pub sun_hours: u32,
    /// Global irradiation per month of the weather's local time, January first (kWh/m²);
    /// they sum to [`Irradiance::global_kwh_m2`].
    #[serde(skip)]
    pub monthly_global_kwh_m2: [f64; 12],
}

impl AsRef<Irradiance> for Irradiance {
    fn as_ref(&self) -> &Irradiance {
        self
    }
}

/// The irradiation of a plane with `normal` over `table`, given its [`PlaneView`] and
/// `blocked(sun_dir)` for the sun's rays; `hourly`, when given, receives each hour's global
/// irradiation (Wh/m²) in table order.
pub fn irradiance_hourly(
    table: &IrradianceTable,
    normal: Option<DVec3>,
    view: PlaneView,
    blocked: impl Fn(DVec3) -> bool,
    opts: &IrradianceOptions,
    hourly: Option<&mut Vec<f64>>,
) -> Irradiance {
    let hours = &table.hours;
    let blocked_hour = |i: usize| hours.get(i).is_none_or(|h| blocked(h.sun));
    irradiance_of_hours(table, normal, view, blocked_hour, opts, hourly)
}

/// [`irradiance_hourly`] with `blocked_hour(i)` telling whether the sun's ray of hour `i`
/// of `table` is blocked (asked only for the hours the sun is up in front of the plane).
fn irradiance_of_hours(
    table: &IrradianceTable,
    normal: Option<DVec3>,
    view: PlaneView,
    blocked_hour: impl Fn(usize) -> bool,
    opts: &IrradianceOptions,
    mut hourly: Option<&mut Vec<f64>>,
) -> Irradiance {
    let n = normal.and_then(|n| n.try_normalize()).unwrap_or(DVec3::Z);
    let sin_tilt = (1.0 - n.z * n.z).max(0.0).sqrt();
    let cos85 = 85f64.to_radians().cos();
    let (mut direct, mut diffuse, mut reflected) = (0.0, 0.0, 0.0);
    let (mut possible, mut seen) = (0u32, 0u32);
    let mut months = [0.0f64; 12];
    let hour_by_hour = hourly.is_some();
    for (i, h) in table.hours.iter().enumerate() {
        let cos_inc = n.dot(h.sun);
        let facing = h.sun_up() && cos_inc > 0.0;
        let free = facing && !blocked_hour(i);
        possible += u32::from(facing);
        seen += u32::from(free);
        let dir = if free { h.dni * cos_inc } else { 0.0 };
        let dif = match opts.sky {
            SkyModel::Isotropic => h.dhi * view.svf,
            SkyModel::Perez => {
                let circ = if free {
                    h.f1 * cos_inc / h.zenith_deg.to_radians().cos().max(cos85)
                } else {
                    0.0
                };
                let iso = (1.0 - h.f1) * view.svf;
                (h.dhi * (iso + circ + h.f2 * sin_tilt * view.horizon)).max(0.0)
            }
            // the year's sum at once below, unless the hours are asked for
            SkyModel::AllWeather if hour_by_hour => h.sky.map_or(0.0, |s| {
                let k: f64 = (view.patches.iter())
                    .map(|&(p, k)| s.patch(p as usize) * f64::from(k))
                    .sum();
                k * PI / view.rays.max(1) as f64
            }),
            SkyModel::AllWeather => 0.0,
        };
        let refl = opts.albedo * h.ghi * (1.0 - view.svf);
        direct += dir;
        diffuse += dif;
        reflected += refl;
        months[usize::from(h.month.min(11))] += dir + dif + refl;
        if let Some(v) = hourly.as_deref_mut() {
            v.push(dir + dif + refl);
        }
    }
    if opts.sky == SkyModel::AllWeather && !hour_by_hour {
        diffuse = table.all_weather_sum(&view);
        for (m, d) in months.iter_mut().zip(table.all_weather_months(&view)) {
            *m += d;
        }
    }
    Irradiance {
        global_kwh_m2: (direct + diffuse + reflected) / 1000.0,
        direct_kwh_m2: direct / 1000.0,
        diffuse_kwh_m2: diffuse / 1000.0,
        reflected_kwh_m2: reflected / 1000.0,
        svf: view.svf,
        sun_hours_possible: possible,
        sun_hours: seen,
        monthly_global_kwh_m2: months.map(|m| m / 1000.0),
    }
}

/// [`irradiance_hourly`] without the hourly values.
pub fn irradiance(
    table: &IrradianceTable,
    normal: Option<DVec3>,
    view: PlaneView,
    blocked: impl Fn(DVec3) -> bool,
    opts: &IrradianceOptions,
) -> Irradiance {
    irradiance_hourly(table, normal, view, blocked, opts, None)
}

/// The rays that decide a plane's irradiation, for computing it from ray answers traced
/// elsewhere (the irradiance bound of [`crate::lod::bound`]): the plane's sky rays (the
/// directions of [`plane_view`], in its order, those above the horizon) and the sun's rays
/// of the hours the sun is up in front of the plane ([`PlaneRays::sun_dirs`]).
/// [`PlaneRays::irradiance`] with the answers of the rays traced in a scene equals
/// [`irradiance`] on that scene.
#[derive(Debug, Clone, PartialEq)]
pub struct PlaneRays {
    normal: Option<DVec3>,
    /// Rays of the bundle (the SVF's denominator).
    bundle_len: usize,
    /// Per sky ray: whether it is in Perez's horizon band.
    band: Vec<bool>,
    /// Per sky ray: its patch of [`Patches::reinhart`].
    patch: Vec<u32>,
    /// Hours (indices into the table) the sun is up in front of the plane, ascending.
    hours: Vec<usize>,
}

impl PlaneRays {
    /// The rays of a plane with `normal` (horizontal when `None`) whose sky rays are
    /// `sky_dirs` (world frame, above the horizon, from a bundle of `bundle_len` rays).
    pub fn new(
        table: &IrradianceTable,
        normal: Option<DVec3>,
        sky_dirs: &[DVec3],
        bundle_len: usize,
    ) -> Self {
        let n = normal.and_then(|n| n.try_normalize()).unwrap_or(DVec3::Z);
        let band = HORIZON_BAND_DEG.to_radians().sin();
        let hours = (table.hours.iter().enumerate())
            .filter(|(_, h)| h.sun_up() && n.dot(h.sun) > 0.0)
            .map(|(i, _)| i)
            .collect();
        let patches = Patches::reinhart();
        PlaneRays {
            normal,
            bundle_len,
            band: sky_dirs.iter().map(|d| d.z <= band).collect(),
            patch: sky_dirs.iter().map(|&d| patch_index(patches, d)).collect(),
            hours,
        }
    }

    /// Directions to the sun of the hours it shines on the plane (when nothing blocks it).
    pub fn sun_dirs(&self, table: &IrradianceTable) -> Vec<DVec3> {
        self.hours.iter().map(|&i| table.hours[i].sun).collect()
    }

    /// The irradiation with `sky_free(j)` telling whether sky ray `j` reaches the sky and
    /// `sun_free(k)` whether the `k`-th ray of [`PlaneRays::sun_dirs`] does.
    pub fn irradiance(
        &self,
        table: &IrradianceTable,
        opts: &IrradianceOptions,
        sky_free: impl Fn(usize) -> bool,
        sun_free: impl Fn(usize) -> bool,
    ) -> Irradiance {
        let (mut free, mut in_band, mut band_sky) = (Vec::new(), 0usize, 0usize);
        for (j, (&b, &p)) in self.band.iter().zip(&self.patch).enumerate() {
            let f = sky_free(j);
            if f {
                free.push(p);
            }
            in_band += usize::from(b);
            band_sky += usize::from(f && b);
        }
        let view = PlaneView::of_free(self.bundle_len, free, band_sky, in_band);
        let blocked_hour = |i: usize| self.hours.binary_search(&i).map_or(true, |k| !sun_free(k));
        irradiance_of_hours(table, self.normal, view, blocked_hour, opts, None)
    }

    /// What each ray adds to the annual irradiation (Wh/m²) when it is free rather than
    /// blocked, to first order: per sky ray (in the order of `sky_dirs`), then per sun ray.
    /// Sky rays bring the isotropic diffuse part less what they no longer reflect (and, in
    /// the horizon band, Perez's band); sun rays the beam and the circumsolar part. (The
    /// clamp of a negative Perez hour at 0 is left out: the weights rank culprits.)
    pub fn weights(&self, table: &IrradianceTable, opts: &IrradianceOptions) -> Vec<f64> {
        let n = self
            .normal
            .and_then(|n| n.try_normalize())
            .unwrap_or(DVec3::Z);
        let sin_tilt = (1.0 - n.z * n.z).max(0.0).sqrt();
        let cos85 = 85f64.to_radians().cos();
        let perez = opts.sky == SkyModel::Perez;
        let (mut iso, mut band) = (0.0, 0.0);
        for h in &table.hours {
            let f1 = if perez { h.f1 } else { 0.0 };
            iso += h.dhi * (1.0 - f1) - opts.albedo * h.ghi;
            if perez {
                band += h.dhi * h.f2 * sin_tilt;
            }
        }
        let in_band = self.band.iter().filter(|&&b| b).count().max(1) as f64;
        let rays = self.bundle_len.max(1) as f64;
        let all_weather = opts.sky == SkyModel::AllWeather;
        let reflected: f64 = table.hours.iter().map(|h| opts.albedo * h.ghi).sum();
        let sky = self.band.iter().zip(&self.patch).map(|(&b, &p)| {
            if all_weather {
                let sum = table.patch_sums.get(p as usize).copied().unwrap_or(0.0);
                (PI * sum - reflected) / rays
            } else {
                iso / rays + if b { band / in_band } else { 0.0 }
            }
        });
        let sun = self.hours.iter().map(|&i| {
            let h = &table.hours[i];
            let cos_inc = n.dot(h.sun);
            let circ = if perez {
                h.dhi * h.f1 * cos_inc / h.zenith_deg.to_radians().cos().max(cos85)
            } else {
                0.0
            };
            h.dni * cos_inc + circ
        });
        sky.chain(sun).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solar::weather::{WeatherFormat, WeatherHour, WeatherSite};
    use chrono::{Duration, TimeZone, Utc};

    /// A clear-sky-like year: every hour GHI from the sun's height, DNI 700 by day, DHI 100.
    fn year() -> (Weather, Site) {
        let site = Site::new(48.0, 11.0);
        let start = Utc.with_ymd_and_hms(2021, 1, 1, 0, 30, 0).unwrap();
        let hours = (0..8760)
            .map(|k| {
                let t = start + Duration::hours(k);
                let z = sun_position(t, &site).unwrap().zenith_deg;
                let up = z < 90.0;
                let (dni, dhi) = if up { (700.0, 100.0) } else { (0.0, 0.0) };
                WeatherHour {
                    mid_utc: t,
                    ghi: dhi + dni * z.to_radians().cos().max(0.0),
                    dni,
                    dhi,
                }
            })
            .collect();
        let ws = WeatherSite {
            name: "t".into(),
            latitude: 48.0,
            longitude: 11.0,
            utc_offset_hours: 0.0,
            elevation_m: 0.0,
        };
        (
            Weather {
                format: WeatherFormat::Epw,
                site: ws,
                hours,
            },
            site,
        )
    }

    #[test]
    fn unobstructed_horizontal_receives_ghi() {
        let (w, site) = year();
        let (ghi, _, _) = w.totals_kwh_m2();
        let b = SkyBundles::new(2000, 3).unwrap();
        for sky in [SkyModel::AllWeather, SkyModel::Perez, SkyModel::Isotropic] {
            let t = IrradianceTable::new(&w, &site, sky).unwrap();
            // the same table, to the last bit, whatever the threads did
            assert!(t == IrradianceTable::new(&w, &site, sky).unwrap());
            let o = IrradianceOptions { sky, albedo: 0.2 };
            let r = irradiance(&t, None, plane_view(None, &b, |_| false), |_| false, &o);
            assert!(
                (r.global_kwh_m2 / ghi - 1.0).abs() < 1e-3,
                "{sky:?}: {r:?} vs {ghi}"
            );
            // the months sum to the year; each is its own GHI
            let total: f64 = r.monthly_global_kwh_m2.iter().sum();
            assert!((total - r.global_kwh_m2).abs() < 1e-9, "{sky:?}");
            let mut month_ghi = [0.0; 12];
            for (h, sh) in w.hours.iter().zip(t.hours()) {
                month_ghi[usize::from(sh.month)] += h.ghi / 1000.0;
            }
            for (m, (got, want)) in r.monthly_global_kwh_m2.iter().zip(month_ghi).enumerate() {
                assert!(
                    (got / want - 1.0).abs() < 2e-3,
                    "{sky:?} month {m}: {got} vs {want}"
                );
            }
            assert_eq!(r.reflected_kwh_m2, 0.0);
        }
    }

    /// [`year`], its Perez table, `rays` sky rays and the default options.
    fn perez_year(rays: usize) -> (Weather, SkyBundles, IrradianceTable, IrradianceOptions) {
        let (w, site) = year();
        let b = SkyBundles::new(rays, 3).unwrap();
        let t = IrradianceTable::new(&w, &site, SkyModel::Perez).unwrap();
        (w, b, t, IrradianceOptions::default())
    }

    #[test]
    fn a_wall_that_blocks_everything_receives_only_reflection() {
        let (w, b, t, o) = perez_year(500);
        let view = plane_view(Some(DVec3::X), &b, |_| true);
        assert_eq!((view.svf, view.horizon), (0.0, 0.0));
        let r = irradiance(&t, Some(DVec3::X), view, |_| true, &o);
        assert_eq!(
            (r.direct_kwh_m2, r.diffuse_kwh_m2, r.sun_hours),
            (0.0, 0.0, 0)
        );
        let (ghi, _, _) = w.totals_kwh_m2();
        assert!((r.reflected_kwh_m2 - 0.2 * ghi).abs() < 1e-9);
        assert!(r.sun_hours_possible > 1000);
    }

    #[test]
    fn plane_rays_give_what_tracing_gives() {
        // A wall facing south-east with a blocker over a third of its sky rays and every
        // third hour's sun: the same figures from the rays' answers as from `irradiance`.
        let (w, site) = year();
        let b = SkyBundles::new(1500, 5).unwrap();
        let n = DVec3::new(0.6, -0.8, 0.0);
        let blocked = |d: DVec3| d.x > 0.5 * d.z;
        for sky in [SkyModel::AllWeather, SkyModel::Perez, SkyModel::Isotropic] {
            let t = IrradianceTable::new(&w, &site, sky).unwrap();
            let o = IrradianceOptions { sky, albedo: 0.3 };
            let want = irradiance(&t, Some(n), plane_view(Some(n), &b, blocked), blocked, &o);
            let frame = Frame::from_normal(n);
            let dirs: Vec<DVec3> = (b.projected_dirs().iter())
                .map(|&l| frame.to_world(l))
                .filter(|d| d.z > 0.0)
                .collect();
            let rays = PlaneRays::new(&t, Some(n), &dirs, b.len());
            let sun = rays.sun_dirs(&t);
            assert_eq!(sun.len() as u32, want.sun_hours_possible);
            let got = rays.irradiance(&t, &o, |j| !blocked(dirs[j]), |k| !blocked(sun[k]));
            assert_eq!(got, want, "{sky:?}");
            // The weights: all free minus all blocked, to first order.
            let wsum: f64 = rays.weights(&t, &o).iter().sum();
            let free = rays.irradiance(&t, &o, |_| true, |_| true);
            let none = rays.irradiance(&t, &o, |_| false, |_| false);
            let span = (free.global_kwh_m2 - none.global_kwh_m2) * 1000.0;
            assert!(
                (wsum / span - 1.0).abs() < 0.05,
                "{sky:?}: {wsum} vs {span}"
            );
        }
    }

    #[test]
    fn south_wall_gets_more_than_north_wall() {
        let (_, b, t, o) = perez_year(2000);
        let wall = |n: DVec3| {
            irradiance(
                &t,
                Some(n),
                plane_view(Some(n), &b, |_| false),
                |_| false,
                &o,
            )
        };
        let (s, nn) = (wall(-DVec3::Y), wall(DVec3::Y));
        assert!(s.global_kwh_m2 > 2.0 * nn.global_kwh_m2, "{s:?} {nn:?}");
        assert!((s.svf - 0.5).abs() < 0.01 && s.reflected_kwh_m2 > 0.0);
    }
}
