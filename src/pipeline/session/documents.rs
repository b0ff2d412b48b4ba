//! The documents of the tracing commands from a [`Study`]: each call traces (or evaluates)
//! the study's POIs and returns the typed document of `skylod svf`, `sun-hours`, `horizon`,
//! `irradiance` or `evaluate` ([`crate::export::report`]) with each POI's trust flags
//! ([`Analysed`]). What a caller gives are plain options; what it does with the document
//! (print the JSON or the table, write a file) is its own. The command line and the Python
//! package both call these.

use super::weather::WeatherYear;
use super::{Result, Study, SunOptions};
use crate::export::report::evaluate::{EvaluateOutput, EvaluateTimings, EvaluateWeather};
use crate::export::report::horizon::{profile_summary, HorizonOutput, HorizonPoi};
use crate::export::report::irradiance::{write_hourly_csv, IrradianceOutput, IrradiancePoi};
use crate::export::report::sun_hours::{SunHoursOutput, SunHoursPoi, SunHoursTimings, SunSetting};
use crate::export::report::svf::{SvfOutput, SvfPoi, TraceTimings};
use crate::export::report::text::TextContext;
use crate::lod::evaluation::{EvalOptions, PoiEval};
use crate::lod::poi::checks::PoiFlag;
use crate::lod::LodOptions;
use crate::model::runtime::progress::Progress;
use crate::pipeline::{EvaluateOptions, PoiIrradiance, Traced};
use crate::solar::irradiance::{IrradianceOptions, IrradianceTable, SkyModel};
use crate::solar::weather::Weather;
use crate::solar::{HorizonOptions, Site, SkyBundles, SunTable};
use std::time::Instant;

/// A document with each POI's trust flags (to tell the user), and the lines a caller may
/// add to its summary.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct Analysed<D> {
    /// The typed document.
    pub doc: D,
    /// Each POI's flags, in POI order.
    pub flags: Vec<Vec<PoiFlag>>,
    /// Summary lines beyond the document's own (e.g. `horizon`'s per-POI profile line,
    /// `evaluate`'s totals).
    pub summary: Vec<String>,
}

/// Milliseconds since `t`, rounded to 0.1, as the documents give them.
pub fn ms_since(t: Instant) -> f64 {
    round_ms(t.elapsed().as_secs_f64())
}

/// `s` seconds in milliseconds rounded to 0.1.
pub(super) fn round_ms(s: f64) -> f64 {
    (s * 1e4).round() / 10.0
}

impl Study {
    /// The inputs read, as the documents name them.
    pub fn input_names(&self) -> Vec<String> {
        let names = self.inputs().iter().map(|i| i.path.display().to_string());
        names.collect()
    }

    /// Milliseconds spent reading, rounded to 0.1.
    pub fn read_ms(&self) -> f64 {
        round_ms(self.read_s())
    }

    /// What a document's text says beyond its JSON: the polygons traced, the decimals of
    /// the model's CRS, and whether a table has its header (`header`).
    pub fn text_context(&self, header: bool) -> TextContext {
        let decimals = self.crs().plan_decimals();
        TextContext::new(self.source().traced_polygon_count(), decimals, header)
    }

    /// The read, BVH and trace milliseconds of `traced`.
    pub fn trace_timings<T>(&self, traced: &Traced<T>) -> TraceTimings {
        TraceTimings::new(self.read_ms(), traced.bvh_s, traced.trace_s)
    }

    /// `skylod svf`: SVF and sky exposure of every POI with `bundles` (`rays` rays per
    /// bundle, seed `seed`, as the document says them).
    ///
    /// # Errors
    /// As [`Study::svf`].
    pub fn svf_output(
        &self,
        bundles: &SkyBundles,
        (rays, seed): (usize, u64),
        progress: &dyn Progress,
    ) -> Result<Analysed<SvfOutput>> {
        let t = self.svf(bundles, progress)?;
        let rows = t.rows(self.pois(), SvfPoi::new);
        let polygons = self.source().polygon_count();
        let timings = self.trace_timings(&t);
        let doc = SvfOutput::new(rows, rays, seed, self.input_names(), polygons, timings);
        Ok(analysed(doc, t.flags))
    }

    /// `skylod sun-hours`: hours of direct sun of every POI at `(lat, lon)` over `year` in
    /// steps of `step_min` minutes, months counted in `time_zone` (IANA name, `UTC` or an
    /// offset).
    ///
    /// # Errors
    /// [`super::Error::Solar`] for a time zone not known or an invalid year or step; as
    /// [`Study::sun_hours`].
    pub fn sun_hours_output(
        &self,
        (lat, lon): (f64, f64),
        (year, step_min): (i32, u32),
        time_zone: &str,
        progress: &dyn Progress,
    ) -> Result<Analysed<SunHoursOutput>> {
        let site = Site::new(lat, lon).with_time_zone(time_zone)?;
        let sun = SunOptions::new(Some(site), year, step_min);
        let t0 = Instant::now();
        let steps = self.sun_table_with(&sun, progress)?.len();
        let sun_ms = ms_since(t0);
        let t = self.sun_hours(&sun, progress)?;
        let timings = SunHoursTimings::new(self.trace_timings(&t), sun_ms);
        let doc = SunHoursOutput::new(
            t.rows(self.pois(), SunHoursPoi::new),
            SunSetting::new(lat, lon, year, step_min),
            time_zone.to_string(),
            steps,
            self.input_names(),
            self.source().polygon_count(),
            timings,
        );
        Ok(analysed(doc, t.flags))
    }

    /// `skylod horizon`: the horizon profile of every POI (azimuths from north in the
    /// local metric frame), with one summary line per POI (`profile_summary`).
    ///
    /// # Errors
    /// As [`Study::horizon`].
    pub fn horizon_output(
        &self,
        opts: &HorizonOptions,
        progress: &dyn Progress,
    ) -> Result<Analysed<HorizonOutput>> {
        let t = self.horizon(opts, progress)?;
        let doc = HorizonOutput::new(
            t.rows(self.pois(), HorizonPoi::from_profile),
            opts.step_deg,
            opts.tolerance_deg,
            self.input_names(),
            self.source().polygon_count(),
            self.trace_timings(&t),
        );
        let lines = self.pois().iter().zip(&t.results);
        let summary = lines.map(|(p, h)| profile_summary(&p.id, h)).collect();
        Ok(Analysed {
            summary,
            ..analysed(doc, t.flags)
        })
    }

    /// `skylod irradiance`: the annual irradiation of every POI under `weather`
    /// ([`IrradianceRequest`]), and what was traced (the hourly series, with
    /// [`IrradianceRequest::hourly`]).
    ///
    /// # Errors
    /// [`super::Error::Solar`] when the sun cannot be placed; as [`Study::irradiance`].
    pub fn irradiance_output(
        &self,
        req: &IrradianceRequest<'_>,
        progress: &dyn Progress,
    ) -> Result<IrradianceRun> {
        let (sky, albedo) = (req.sky, req.albedo);
        let t0 = Instant::now();
        let table = IrradianceTable::new(req.weather, &Site::new(req.site[0], req.site[1]), sky)?;
        let sun_ms = req.weather_ms + ms_since(t0);
        let opts = IrradianceOptions { sky, albedo };
        let scenes = match req.cadastre {
            true => crate::pipeline::Scenes::CADASTRE,
            false => crate::pipeline::Scenes::Whole,
        };
        let t = self.irradiance(req.bundles, &table, &opts, req.hourly, scenes, progress)?;
        let rows = match req.rows {
            true => t.rows(self.pois(), |p, r, f| IrradiancePoi::new(p, &r.annual, f)),
            false => Vec::new(),
        };
        let summary = super::weather::weather_summary(req.path, req.weather);
        let timings = SunHoursTimings::new(self.trace_timings(&t), sun_ms);
        let mut doc = IrradianceOutput::new(
            rows,
            summary,
            req.site,
            sky,
            albedo,
            req.rays,
            self.input_names(),
            self.source().polygon_count(),
            timings,
        );
        doc.points = t.results.len();
        Ok(IrradianceRun {
            doc: analysed(doc, t.flags.clone()),
            traced: t,
        })
    }

    /// `skylod evaluate`: full vs LoD vs all-boxes model at every POI ([`Study::evaluate`])
    /// as its document, with the run's summary lines; `started` is when the command began
    /// (the document's total).
    ///
    /// # Errors
    /// As [`Study::evaluate`].
    pub fn evaluate_output(
        &self,
        req: EvaluateRequest,
        started: Instant,
        progress: &dyn Progress,
    ) -> Result<Analysed<EvaluateOutput>> {
        let EvaluateRequest {
            lod,
            svf_rays,
            sun,
            weather,
        } = req;
        let (rays, seed) = (lod.select.rays, lod.select.seed);
        let (setting, sun) = sun.unzip();
        let opts = EvaluateOptions {
            eval: EvalOptions {
                lod,
                svf_rays,
                ..Default::default()
            },
            sun,
            irradiance: weather.as_ref().map(|y| y.setting.clone()),
        };
        let e = self.evaluate(&opts, progress)?;
        let flags = e.pois.iter().map(|p| p.flags.clone()).collect();
        let total = ms_since(started);
        let timings = EvaluateTimings {
            read: self.read_ms(),
            rough: e.rough_ms,
            selection_bvh: e.selection_bvh_ms,
            total,
        };
        let mut summary = vec![format!(
            "{} POI(s); selection {rays} rays, SVF {svf_rays} rays; read {:.0} ms, rough {:.0} ms (shared), selection BVH {:.0} ms (shared), total {:.0} ms",
            e.pois.len(),
            timings.read,
            e.rough_ms,
            e.selection_bvh_ms,
            total
        )];
        let pois = e.pois;
        let doc = EvaluateOutput::new(
            self.input_names(),
            rays,
            svf_rays,
            seed,
            setting,
            pois,
            timings,
        );
        let doc = match weather {
            Some(y) => {
                summary.push(irradiance_line(&y, &doc.pois));
                doc.with_weather(EvaluateWeather {
                    sky: y.sky(),
                    albedo: y.setting.opts.albedo,
                    site: y.site,
                    weather: y.summary,
                })
            }
            None => doc,
        };
        Ok(Analysed {
            doc,
            flags,
            summary,
        })
    }
}

/// `doc` with `flags` and no summary lines of its own.
fn analysed<D>(doc: D, flags: Vec<Vec<PoiFlag>>) -> Analysed<D> {
    Analysed {
        doc,
        flags,
        summary: Vec::new(),
    }
}

/// `evaluate`'s line on its weather year, with the largest relative irradiance error of the
/// LoD model over `pois` as a percentage.
fn irradiance_line(y: &WeatherYear, pois: &[PoiEval]) -> String {
    let e = pois
        .iter()
        .filter_map(|p| p.lod_irradiance_error)
        .fold(0.0, f64::max);
    format!(
        "irradiance: {} hours of {} (GHI {:.0} kWh/m²) at ({:.4}, {:.4}), {} sky, albedo {}; largest LoD error {:.3}%",
        y.setting.table.len(),
        y.summary.station,
        y.summary.ghi_kwh_m2,
        y.site[0],
        y.site[1],
        y.setting.opts.sky.name(),
        y.setting.opts.albedo,
        100.0 * e
    )
}

/// What [`Study::evaluate_output`] compares.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct EvaluateRequest {
    /// Rough model and selection of the LoD model.
    pub lod: LodOptions,
    /// Rays of each SVF bundle (the same bundle for the three models).
    pub svf_rays: usize,
    /// The sun of the sun hours and where and when it was placed (`None`: no sun hours).
    pub sun: Option<(SunSetting, SunTable)>,
    /// A weather year for each model's annual irradiation (`None`: none).
    pub weather: Option<WeatherYear>,
}

impl EvaluateRequest {
    /// The models of `lod` compared with `svf_rays` SVF rays, without sun or weather.
    pub fn new(lod: LodOptions, svf_rays: usize) -> Self {
        EvaluateRequest {
            lod,
            svf_rays,
            sun: None,
            weather: None,
        }
    }
}

/// What [`Study::irradiance_output`] traces: a weather year read from `path` with its sun at
/// `site`, the diffuse sky and albedo, the sky bundles.
#[derive(Debug, Clone, Copy)]
pub struct IrradianceRequest<'a> {
    /// The file the weather was read from (as the document names it).
    pub path: &'a std::path::Path,
    /// The weather year.
    pub weather: &'a Weather,
    /// Milliseconds spent reading it (counted in the sun's time).
    pub weather_ms: f64,
    /// Where the sun stands (latitude, longitude).
    pub site: [f64; 2],
    /// Diffuse sky model.
    pub sky: SkyModel,
    /// Reflectance of the ground and obstructions.
    pub albedo: f64,
    /// The sky bundles, and their rays as the document says them.
    pub bundles: &'a SkyBundles,
    /// Rays per bundle.
    pub rays: usize,
    /// Keep every hour's value (`IrradianceRun::write_hourly`).
    pub hourly: bool,
    /// The POIs are a cadastre's, every roof or wall of a city: they are traced square by
    /// square ([`crate::pipeline::Scenes::CADASTRE`]), not against one scene of the whole
    /// model.
    pub cadastre: bool,
    /// Every POI's row in the document (its `pois`). Without them (a
    /// cadastre whose answer is its tables: millions of rows) the summary still counts the
    /// POIs.
    pub rows: bool,
}

/// What [`Study::irradiance_output`] gives: the document and what was traced.
#[derive(Debug, Clone)]
pub struct IrradianceRun {
    /// The document, with each POI's flags.
    pub doc: Analysed<IrradianceOutput>,
    /// Per POI: annual sums, and the hourly series when asked for.
    pub traced: Traced<PoiIrradiance>,
}

impl IrradianceRun {
    /// Each POI's annual global irradiation (kWh/m²), in order.
    pub fn annual_global(&self) -> Vec<f64> {
        let r = self.traced.results.iter();
        r.map(|r| r.annual.global_kwh_m2).collect()
    }

    /// Every hour's global irradiation (Wh/m²) per POI as CSV (a `time_utc` column of
    /// `weather`'s hours, one column per POI of `pois`, the study's).
    ///
    /// # Errors
    /// The CSV writer's.
    pub fn write_hourly(
        &self,
        out: impl std::io::Write,
        weather: &Weather,
        pois: &[crate::model::Poi],
    ) -> csv::Result<()> {
        let ids: Vec<&str> = pois.iter().map(|p| p.id.as_str()).collect();
        let series: Vec<&[f64]> = self
            .traced
            .results
            .iter()
            .map(|r| r.hourly.as_slice())
            .collect();
        write_hourly_csv(out, weather, &ids, &series)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::export::report::text::Document;
    use crate::model::runtime::progress::Silent;
    use crate::pipeline::session::Error;
    use crate::pipeline::test_support::{fixture, study};

    #[test]
    fn svf_and_sun_hours_documents_hold_the_study_s_figures() {
        let s = study(3);
        let inputs = vec![fixture().display().to_string()];
        let bundles = SkyBundles::new(400, 5).unwrap();
        let a = s.svf_output(&bundles, (400, 5), &Silent).unwrap();
        let direct = s.svf(&bundles, &Silent).unwrap();
        assert_eq!((a.doc.rays, a.doc.seed), (400, 5));
        assert_eq!(a.doc.inputs, inputs);
        assert_eq!(a.doc.polygons, s.source().polygon_count());
        assert_eq!(a.doc.timings_ms.read, s.read_ms());
        assert_eq!(a.flags, direct.flags);
        assert!(a.summary.is_empty());
        for ((row, v), p) in a.doc.pois.iter().zip(&direct.results).zip(s.pois()) {
            assert_eq!(row.id, p.id);
            assert_eq!(row.values.svf, v.svf);
            assert_eq!(row.values.sky_exposure, v.sky_exposure);
        }
        assert_eq!(a.doc.pois.len(), 3);
        // Sun hours at a site, months in a time zone, over a year in 2 h steps.
        let (site, when) = ((41.39, 2.17), (2024, 120));
        let h = s
            .sun_hours_output(site, when, "Europe/Madrid", &Silent)
            .unwrap();
        let tz = Site::new(41.39, 2.17)
            .with_time_zone("Europe/Madrid")
            .unwrap();
        let table = SunTable::year(2024, 120, &tz).unwrap();
        assert_eq!(h.doc.steps, table.len());
        assert_eq!(h.doc.sun, SunSetting::new(41.39, 2.17, 2024, 120));
        assert_eq!(h.doc.timezone, "Europe/Madrid");
        let direct =
            crate::pipeline::test_support::sun_hours(&s.framed(), &table, &Silent).unwrap();
        for (row, v) in h.doc.pois.iter().zip(&direct.results) {
            assert_eq!(row.values.sun_hours, v.hours);
            assert_eq!(row.values.monthly, v.monthly);
        }
        let e = s.sun_hours_output(site, when, "Mars/Olympus", &Silent);
        assert!(matches!(e, Err(Error::Solar(_))), "{e:?}");
    }

    #[test]
    fn horizon_says_one_line_per_poi_and_evaluate_its_totals() {
        let s = study(2);
        let opts = HorizonOptions::default().with_step(30.0);
        let a = s.horizon_output(&opts, &Silent).unwrap();
        let direct = s.horizon(&opts, &Silent).unwrap();
        assert_eq!(a.doc.pois.len(), 2);
        assert_eq!(a.doc.pois[0].values.azimuth.len(), 12);
        let lines: Vec<String> = (s.pois().iter().zip(&direct.results))
            .map(|(p, h)| profile_summary(&p.id, h))
            .collect();
        assert_eq!(a.summary, lines);
        let cx = s.text_context(true);
        assert!(!a.doc.summary(&cx).is_empty());
        // evaluate, without sun and with a weather year
        let mut lod = LodOptions::default();
        (lod.select.rays, lod.select.seed) = (300, 4);
        let req = EvaluateRequest::new(lod, 300);
        let e = s.evaluate_output(req, Instant::now(), &Silent).unwrap();
        assert_eq!((e.doc.rays, e.doc.svf_rays, e.doc.seed), (300, 300, 4));
        assert!(e.doc.sun.is_none() && e.doc.weather.is_none());
        assert_eq!((e.doc.pois.len(), e.flags.len()), (2, 2));
        assert_eq!(e.summary.len(), 1);
        assert!(
            e.summary[0].starts_with("2 POI(s); selection 300 rays, SVF 300 rays; read "),
            "{}",
            e.summary[0]
        );
        let w = crate::pipeline::session::weather::tests::weather();
        let at = (w.site.latitude, w.site.longitude);
        let year = WeatherYear::new("w.epw".as_ref(), &w, at, SkyModel::Isotropic, 0.2).unwrap();
        let mut req = EvaluateRequest::new(lod, 300);
        req.weather = Some(year);
        let e = s.evaluate_output(req, Instant::now(), &Silent).unwrap();
        let ew = e.doc.weather.as_ref().unwrap();
        assert_eq!((ew.site, ew.albedo), ([at.0, at.1], 0.2));
        assert_eq!(e.summary.len(), 2);
        let l = &e.summary[1];
        assert!(l.starts_with("irradiance: 1 hours of Somewhere (GHI 0 kWh/m²) at (41.3900, 2.1700), isotropic sky, albedo 0.2; largest LoD error "), "{l}");
        assert!(l.ends_with('%'), "{l}");
    }

    #[test]
    fn irradiance_gives_its_document_annual_values_and_hours() {
        let s = study(2);
        let w = crate::pipeline::session::weather::tests::weather();
        let bundles = SkyBundles::new(300, 1).unwrap();
        let req = IrradianceRequest {
            path: "w.epw".as_ref(),
            weather: &w,
            weather_ms: 1.5,
            site: [41.39, 2.17],
            sky: SkyModel::Perez,
            albedo: 0.1,
            bundles: &bundles,
            rays: 300,
            hourly: true,
            cadastre: false,
            rows: true,
        };
        let run = s.irradiance_output(&req, &Silent).unwrap();
        let d = &run.doc.doc;
        assert_eq!((d.site, d.albedo, d.rays), ([41.39, 2.17], 0.1, 300));
        assert_eq!(d.weather.file, "w.epw");
        assert!(d.timings_ms.sun >= 1.5);
        let annual = run.annual_global();
        assert_eq!(annual.len(), 2);
        for (row, a) in d.pois.iter().zip(&annual) {
            assert_eq!(row.values.global_kwh_m2, *a);
        }
        let mut csv = Vec::new();
        run.write_hourly(&mut csv, &w, s.pois()).unwrap();
        let csv = String::from_utf8(csv).unwrap();
        let mut lines = csv.lines();
        assert_eq!(lines.next(), Some("time_utc,p0,p1"));
        assert_eq!(lines.count(), w.hours.len());
        // without rows: the same values, the summary still counting the POIs
        let bare = IrradianceRequest { rows: false, ..req };
        let run2 = s.irradiance_output(&bare, &Silent).unwrap();
        assert!(run2.doc.doc.pois.is_empty());
        assert_eq!(run2.annual_global(), annual);
        let cx = s.text_context(true);
        let line = &run2.doc.doc.summary(&cx)[0];
        assert!(line.starts_with("2 POI(s); "), "{line}");
    }
}
