//! The error bound a caller asks of `lod` ([`BoundRequest`]: errors allowed, rays, the sun's
//! year) made into what [`crate::pipeline::levels`] runs and what the report guarantees:
//! [`BoundRequest::plan`] decides which figures are bounded (SVF always; sun hours where the
//! sun has a site; the irradiation with a weather year), [`BoundPlan::sun_table`] places the
//! sun and [`BoundPlan::finish`] gives the [`BoundSpec`] and its [`Guarantee`]. The command
//! line and the Python package both decide through it.

use super::site::{site_hint, SiteError};
use super::weather::{SunSite, WeatherYear};
use crate::export::report::report::Guarantee;
use crate::lod::bound::BoundOptions;
use crate::model::runtime::progress::Progress;
use crate::pipeline::BoundSpec;
use crate::solar::ephemeris::SunEphemeris;
use crate::solar::{Site, SolarError, SunTable, DEFAULT_STEP_MIN, DEFAULT_YEAR};
use std::path::Path;

/// The relative error bounded by default (SVF, sun hours where the site is known, the
/// irradiation with a weather year): 1 %.
pub const DEFAULT_MAX_ERROR: f64 = 0.01;

/// The error bound asked for. `None` errors take `DEFAULT_MAX_ERROR`.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct BoundRequest {
    /// Bound at all (`false`: the selection alone decides; nothing guaranteed).
    pub bound: bool,
    /// Largest relative SVF error at any POI.
    pub max_svf_error: Option<f64>,
    /// Largest relative error of yearly sun hours; given, the sun must have a site.
    pub max_sun_hours_error: Option<f64>,
    /// Largest relative error of the annual irradiation (with a weather year).
    pub max_irradiance_error: Option<f64>,
    /// Rays of the SVF bundle of the check.
    pub rays: usize,
    /// Seed of that bundle.
    pub seed: u64,
    /// Calendar year of the sun-hours bound.
    pub year: i32,
    /// Minutes per step of the sun-hours bound.
    pub step_min: u32,
    /// How the caller names its option that turns the bound off, in the report's lines
    /// (a command line's flag, a keyword argument).
    pub no_bound_option: String,
    /// How the caller names its option that gives the site, in the report's lines.
    pub site_option: String,
}

impl BoundRequest {
    /// The default bound (1 % everywhere it can be checked), `rays` and `seed` for its SVF
    /// bundle, the default year and step; `(no_bound_option, site_option)` as the caller
    /// names the options that turn the bound off and give the site.
    pub fn new(rays: usize, seed: u64, (no_bound_option, site_option): (&str, &str)) -> Self {
        BoundRequest {
            bound: true,
            max_svf_error: None,
            max_sun_hours_error: None,
            max_irradiance_error: None,
            rays,
            seed,
            year: DEFAULT_YEAR,
            step_min: DEFAULT_STEP_MIN,
            no_bound_option: no_bound_option.into(),
            site_option: site_option.into(),
        }
    }

    /// SPA's site-independent half of the sun-hours bound's table, started in the
    /// background before the model (which gives the site) is read, for
    /// `BoundPlan::sun_table_ahead`; `None` without a bound (or for a year or step the table
    /// refuses: the table says so). The steps deep in the night of a site near the sun's are
    /// not computed ([`SunEphemeris::year_near`]): the `lat`, `lon` given, else the centre of
    /// the first city objects of `first` (the first input), found in the background
    /// (`super::site::site_hint`).
    pub fn ephemeris(
        &self,
        lat: Option<f64>,
        lon: Option<f64>,
        first: Option<&Path>,
    ) -> Option<SunEphemeris> {
        let delta_t_s = Site::new(0.0, 0.0).delta_t_s;
        let first = first.map(Path::to_path_buf);
        let near = move || site_hint(lat, lon, first.as_deref()).map(|(a, o)| Site::new(a, o));
        (self.bound)
            .then(|| SunEphemeris::year_near(self.year, self.step_min, delta_t_s, near).ok())
            .flatten()
    }

    /// What is bounded, with `site` the sun's site (given, or the model's:
    /// [`super::site::site_of`]); without one, sun hours are not bounded (said in the
    /// guarantee) unless [`BoundRequest::max_sun_hours_error`] asks for them.
    ///
    /// # Errors
    /// `site`'s error when sun hours must be bounded and it has none (and any error of a site
    /// given: [`SiteError::Half`], [`SiteError::OutOfRange`]).
    pub fn plan(&self, site: Result<SunSite, SiteError>) -> Result<BoundPlan, SiteError> {
        let mut guarantee = Guarantee::default();
        if !self.bound {
            let why = format!(
                "SVF and sun hours: no error bound ({})",
                self.no_bound_option
            );
            guarantee.not_bounded.push(why);
            return Ok(BoundPlan {
                guarantee,
                site: None,
                options: None,
                year: self.year,
                step_min: self.step_min,
                max_irradiance_error: None,
            });
        }
        let svf = self.max_svf_error.unwrap_or(DEFAULT_MAX_ERROR);
        guarantee.svf_error = Some(svf);
        let site = match site {
            Ok(s) => Some(s),
            Err(SiteError::NoSite(why)) if self.max_sun_hours_error.is_none() => {
                let line = format!("sun hours: no site ({why}; give {})", self.site_option);
                guarantee.not_bounded.push(line);
                None
            }
            Err(e) => return Err(e),
        };
        let sun_error =
            (site.as_ref()).map(|_| self.max_sun_hours_error.unwrap_or(DEFAULT_MAX_ERROR));
        guarantee.sun_hours_error = sun_error;
        let options = BoundOptions {
            max_svf_error: Some(svf),
            max_sun_error: sun_error,
            svf_rays: self.rays,
            svf_seed: self.seed,
            ..Default::default()
        };
        Ok(BoundPlan {
            guarantee,
            site,
            options: Some(options),
            year: self.year,
            step_min: self.step_min,
            max_irradiance_error: Some(self.max_irradiance_error.unwrap_or(DEFAULT_MAX_ERROR)),
        })
    }
}

/// What a [`BoundRequest`] bounds ([`BoundRequest::plan`]).
#[derive(Debug, Clone)]
pub struct BoundPlan {
    /// What the report says the model guarantees (so far: the irradiation is added by
    /// [`BoundPlan::finish`]).
    pub guarantee: Guarantee,
    /// The sun's site of the sun-hours bound (`None`: sun hours not bounded).
    pub site: Option<SunSite>,
    options: Option<BoundOptions>,
    year: i32,
    step_min: u32,
    max_irradiance_error: Option<f64>,
}

impl BoundPlan {
    /// Whether anything is bounded.
    pub fn bounded(&self) -> bool {
        self.options.is_some()
    }

    /// The sun positions of the sun-hours bound (`None` without one), built as the progress
    /// stage `Sun`.
    ///
    /// # Errors
    /// [`SolarError`] for an invalid year or step.
    pub fn sun_table(&self, progress: &dyn Progress) -> Result<Option<SunTable>, SolarError> {
        self.sun_table_ahead(None, progress)
    }

    /// [`BoundPlan::sun_table`] with SPA's site-independent half taken from `ahead` where it
    /// is ready ([`BoundRequest::ephemeris`], started before the model was read): the same
    /// table.
    ///
    /// # Errors
    /// As [`BoundPlan::sun_table`].
    pub fn sun_table_ahead(
        &self,
        ahead: Option<&SunEphemeris>,
        progress: &dyn Progress,
    ) -> Result<Option<SunTable>, SolarError> {
        let Some((lat, lon)) = self.site.as_ref().map(SunSite::lat_lon) else {
            ahead.inspect(|a| a.stop());
            return Ok(None);
        };
        let site = Site::new(lat, lon);
        SunTable::year_ahead(self.year, self.step_min, &site, ahead, progress).map(Some)
    }

    /// The bound to run ([`BoundSpec`], `None` when nothing is bounded) with `sun` (from
    /// [`BoundPlan::sun_table`]) and `weather` (its irradiation bounded too), and its
    /// guarantee.
    pub fn finish(
        self,
        sun: Option<SunTable>,
        weather: Option<WeatherYear>,
    ) -> (Option<BoundSpec>, Guarantee) {
        let mut guarantee = self.guarantee;
        let Some(mut options) = self.options else {
            return (None, guarantee);
        };
        let irradiance_error = weather.as_ref().and(self.max_irradiance_error);
        guarantee.irradiance_error = irradiance_error;
        options.max_irradiance_error = irradiance_error;
        let irradiance = weather.map(|y| y.setting);
        let spec = BoundSpec {
            options,
            sun,
            irradiance,
        };
        (Some(spec), guarantee)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::crs::NoSite;
    use crate::model::runtime::progress::Silent;

    fn no_site() -> Result<SunSite, SiteError> {
        Err(SiteError::NoSite(NoSite {
            crs: Some("EPSG:1234".into()),
        }))
    }

    #[test]
    fn off_bounds_nothing_and_says_which_option_turned_it_off() {
        let mut r = BoundRequest::new(500, 3, ("bound=False", "site"));
        r.bound = false;
        let p = r.plan(Ok(SunSite::Given(41.0, 2.0))).unwrap();
        assert!(!p.bounded() && p.site.is_none());
        assert!(p.sun_table(&Silent).unwrap().is_none());
        let (spec, g) = p.finish(None, None);
        assert!(spec.is_none());
        assert_eq!(g.svf_error, None);
        assert_eq!(
            g.not_bounded,
            ["SVF and sun hours: no error bound (bound=False)"]
        );
    }

    #[test]
    fn svf_always_sun_hours_where_the_sun_has_a_site() {
        let mut r = BoundRequest::new(500, 3, ("off", "site"));
        r.step_min = 240;
        let p = r
            .plan(Ok(SunSite::Model(41.4, 2.2, "EPSG:25831".into())))
            .unwrap();
        assert!(p.bounded());
        assert_eq!(p.site.as_ref().map(SunSite::lat_lon), Some((41.4, 2.2)));
        let sun = p.sun_table(&Silent).unwrap().unwrap();
        assert_eq!(
            sun.len(),
            SunTable::year(DEFAULT_YEAR, 240, &Site::new(41.4, 2.2))
                .unwrap()
                .len()
        );
        let (spec, g) = p.finish(Some(sun), None);
        let spec = spec.unwrap();
        assert_eq!(
            (spec.options.max_svf_error, spec.options.max_sun_error),
            (Some(DEFAULT_MAX_ERROR), Some(DEFAULT_MAX_ERROR))
        );
        assert_eq!((spec.options.svf_rays, spec.options.svf_seed), (500, 3));
        assert!(spec.sun.is_some() && spec.irradiance.is_none());
        assert_eq!(spec.options.max_irradiance_error, None);
        assert_eq!(g.irradiance_error, None);
        assert_eq!((g.svf_error, g.sun_hours_error), (Some(0.01), Some(0.01)));
        assert!(g.not_bounded.is_empty());
        // Errors asked for are the ones bounded.
        r.max_svf_error = Some(0.05);
        r.max_sun_hours_error = Some(0.2);
        let (spec, g) = r
            .plan(Ok(SunSite::Given(1.0, 2.0)))
            .unwrap()
            .finish(None, None);
        assert_eq!((g.svf_error, g.sun_hours_error), (Some(0.05), Some(0.2)));
        assert_eq!(spec.unwrap().options.max_sun_error, Some(0.2));
    }

    #[test]
    fn no_site_leaves_sun_hours_unbounded_unless_asked_for() {
        let r = BoundRequest::new(500, 3, ("off", "--lat/--lon"));
        let p = r.plan(no_site()).unwrap();
        assert!(p.site.is_none() && p.bounded());
        let (spec, g) = p.finish(None, None);
        assert_eq!(spec.unwrap().options.max_sun_error, None);
        assert_eq!(g.sun_hours_error, None);
        assert_eq!(g.not_bounded.len(), 1);
        let line = &g.not_bounded[0];
        assert!(
            line.starts_with("sun hours: no site (the input's CRS (EPSG:1234)"),
            "{line}"
        );
        assert!(line.ends_with("; give --lat/--lon)"), "{line}");
        let mut asked = r.clone();
        asked.max_sun_hours_error = Some(0.02);
        assert!(matches!(asked.plan(no_site()), Err(SiteError::NoSite(_))));
        // With a weather year, its irradiation too (1 % unless asked).
        let w = crate::pipeline::session::weather::tests::weather();
        let at = (w.site.latitude, w.site.longitude);
        let year = |_| WeatherYear::new("w.epw".as_ref(), &w, at, Default::default(), 0.2);
        let (spec, g) = r
            .plan(no_site())
            .unwrap()
            .finish(None, Some(year(()).unwrap()));
        let spec = spec.unwrap();
        assert_eq!(spec.options.max_irradiance_error, Some(DEFAULT_MAX_ERROR));
        assert_eq!(g.irradiance_error, Some(DEFAULT_MAX_ERROR));
        assert_eq!(spec.irradiance.unwrap().table.len(), w.hours.len());
        let mut tight = r.clone();
        tight.max_irradiance_error = Some(0.001);
        let (_, g) = tight
            .plan(no_site())
            .unwrap()
            .finish(None, Some(year(()).unwrap()));
        assert_eq!(g.irradiance_error, Some(0.001));
        // A site given wrongly is refused whatever is asked.
        assert_eq!(r.plan(Err(SiteError::Half)).unwrap_err(), SiteError::Half);
    }
}
