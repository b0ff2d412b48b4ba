//! Step 5: the POIs traced against the full-detail scene (SVF, sun hours, horizon) and
//! the evaluation of the LoD model.

use super::session::Error;
use super::Framed;
use crate::lod::evaluation::{evaluate_irradiance, EvalOptions, Evaluation};
use crate::lod::poi::checks::{self, PoiFlag};
use crate::lod::scene::full_scene;
use crate::model::runtime::progress::{check, Cancelled, Progress, Stage};
use crate::model::CityModel;
use crate::model::Poi;
use crate::solar::trace::TraceScene;
use crate::solar::{poi_horizon, HorizonOptions, HorizonProfile, SunTable};
use rayon::prelude::*;
use std::time::Instant;

/// What `trace` (and `svf`, `sun_hours`, `horizon`) computed: one result per POI
/// against the full-detail scene, in POI order.
#[derive(Debug, Clone, serde::Serialize)]
#[non_exhaustive]
pub struct Traced<T> {
    /// One result per POI, in the order of [`Framed::local_pois`].
    pub results: Vec<T>,
    /// The trust flags of each POI ([`checks::poi_flags`]: inside a building, no sky).
    pub flags: Vec<Vec<PoiFlag>>,
    /// Seconds building the full-detail scene.
    pub bvh_s: f64,
    /// Seconds tracing the POIs.
    pub trace_s: f64,
}

impl<T> Traced<T> {
    /// One row per POI, in POI order: `row(poi, result, flags)` for each of `pois` (the
    /// framed POIs the results were traced for).
    pub fn rows<R>(&self, pois: &[Poi], row: impl Fn(&Poi, &T, &[PoiFlag]) -> R) -> Vec<R> {
        pois.iter()
            .zip(&self.results)
            .zip(&self.flags)
            .map(|((p, r), flags)| row(p, r, flags))
            .collect()
    }
}

/// `f` for every POI of `framed` (local frame, in parallel) against the full-detail scene of
/// its model ([`Stage::Bvh`], then [`Stage::Trace`]: one item per POI, cancellable before
/// each POI), with each POI's flags; `sky_rays` of a result, when it knows them, adds the
/// no-sky flag.
///
/// # Errors
/// [`Cancelled`] when `progress` asks to stop.
pub fn trace<T: Send>(
    framed: &Framed<'_>,
    f: impl Fn(&TraceScene, &Poi) -> T + Sync,
    sky_rays: impl Fn(&T) -> Option<usize> + Sync,
    progress: &dyn Progress,
) -> Result<Traced<T>, Cancelled> {
    check(progress, Stage::Bvh)?;
    let t = Instant::now();
    let scene = crate::model::runtime::progress::stage(progress, Stage::Bvh, 1, 0, || {
        let s = full_scene(&framed.model);
        progress.advance(Stage::Bvh, 1, 0, None);
        s
    });
    let mut traced = trace_in(framed, &scene, f, sky_rays, progress)?;
    traced.bvh_s = t.elapsed().as_secs_f64() - traced.trace_s;
    Ok(traced)
}

/// [`trace`] against a full-detail `scene` already built (of `framed.model`): no
/// [`Stage::Bvh`], `bvh_s` 0.
///
/// # Errors
/// [`Cancelled`] when `progress` asks to stop.
pub(crate) fn trace_in<T: Send>(
    framed: &Framed<'_>,
    scene: &TraceScene,
    f: impl Fn(&TraceScene, &Poi) -> T + Sync,
    sky_rays: impl Fn(&T) -> Option<usize> + Sync,
    progress: &dyn Progress,
) -> Result<Traced<T>, Cancelled> {
    let model: &CityModel = &framed.model;
    let pois = &framed.local_pois;
    let around = checks::Surroundings::new(model);
    let t = Instant::now();
    let traced: Result<Vec<(T, Vec<PoiFlag>)>, Cancelled> = crate::model::runtime::progress::stage(
        progress,
        Stage::Trace,
        pois.len() as u64,
        0,
        || {
            pois.par_iter()
                .map(|p| {
                    check(progress, Stage::Trace)?;
                    let r = f(scene, p);
                    let flags = checks::poi_flags_around(scene, model, &around, p, sky_rays(&r));
                    // No name: many cheap POIs in parallel (a log line each would drown the log).
                    progress.advance(Stage::Trace, 1, 0, None);
                    Ok((r, flags))
                })
                .collect()
        },
    );
    let (results, flags) = traced?.into_iter().unzip();
    Ok(Traced {
        results,
        flags,
        bvh_s: 0.0,
        trace_s: t.elapsed().as_secs_f64(),
    })
}

/// Horizon profile of every POI ([`poi_horizon`]; azimuths from north of the local frame),
/// through [`trace`].
///
/// # Errors
/// [`Error::Solar`] for invalid options (checked before any work),
/// [`Error::Cancelled`].
pub fn horizon(
    framed: &Framed<'_>,
    opts: &HorizonOptions,
    progress: &dyn Progress,
) -> Result<Traced<HorizonProfile>, Error> {
    opts.validate()?;
    let t = trace(framed, |s, p| poi_horizon(s, p, opts), |_| None, progress)?;
    Ok(Traced {
        results: t.results.into_iter().collect::<Result<_, _>>()?,
        flags: t.flags,
        bvh_s: t.bvh_s,
        trace_s: t.trace_s,
    })
}

/// Options of `evaluate`.
#[derive(Debug, Clone, Default)]
pub struct EvaluateOptions {
    /// Rough model, selection and SVF bundle.
    pub eval: EvalOptions,
    /// The sun positions of the sun hours; `None` skips sun hours.
    pub sun: Option<SunTable>,
    /// A weather year for each model's annual irradiation; `None` skips it.
    pub irradiance: Option<crate::solar::irradiance::IrradianceSetting>,
}

/// Full vs LoD vs all-boxes model at every POI of `framed` (`evaluation::evaluate_irradiance`): rough
/// model ([`Stage::Rough`]), scenes ([`Stage::Bvh`]), then each POI selected and traced
/// ([`Stage::Trace`], cancellable before each POI).
///
/// # Errors
/// [`Error::Eval`], [`Error::Cancelled`].
pub fn evaluate(
    framed: &Framed<'_>,
    opts: &EvaluateOptions,
    progress: &dyn Progress,
) -> Result<Evaluation, Error> {
    evaluate_irradiance(
        &framed.model,
        &framed.local_pois,
        &opts.eval,
        opts.sun.as_ref(),
        opts.irradiance.as_ref(),
        progress,
    )
    .map_err(Error::from)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lod::LodOptions;
    use crate::pipeline::test_support::*;
    use crate::solar::{poi_sky_view, poi_sun_hours, SkyBundles};
    use std::sync::atomic::Ordering;

    #[test]
    fn solar_entry_points_trace_every_poi_and_stop_when_cancelled() {
        let mut inputs = fixture_inputs();
        let framed = framed_with(&mut inputs, 24);
        let scene = full_scene(&framed.model);
        let bundles = SkyBundles::new(400, 3).unwrap();
        let site = crate::solar::Site::new(48.76, 11.42);
        let table = SunTable::year(2025, 120, &site).unwrap();
        let hopts = HorizonOptions::default().with_step(10.0);

        // Each entry point: every POI announced and advanced once, results in POI order
        // (against the per-POI functions on the full scene), one flag list per POI.
        let tally = Tally::default();
        let v = svf(&framed, &bundles, &tally).unwrap();
        let h = sun_hours(&framed, &table, &tally).unwrap();
        let z = horizon(&framed, &hopts, &tally).unwrap();
        assert_eq!(tally.sum(Stage::Trace, "start").0, 3 * 24);
        assert_eq!(tally.sum(Stage::Trace, "advance").0, 3 * 24);
        assert_eq!(tally.sum(Stage::Bvh, "start").0, 3);
        // The scene stage advances as far as it announced.
        assert_eq!(tally.sum(Stage::Bvh, "advance").0, 3);
        for (k, p) in framed.local_pois.iter().enumerate() {
            assert_eq!(v.results[k], poi_sky_view(&scene, p, &bundles), "{}", p.id);
            assert_eq!(h.results[k], poi_sun_hours(&scene, p, &table), "{}", p.id);
            assert_eq!(z.results[k], poi_horizon(&scene, p, &hopts).unwrap());
        }
        // Streets and courtyards (some sky, some flags) as well as inside buildings.
        assert!(v.results.iter().any(|r| r.svf > 0.0 && r.svf < 1.0));
        assert!(v.flags.iter().any(Vec::is_empty));
        assert_eq!((v.flags.len(), h.flags.len(), z.flags.len()), (24, 24, 24));

        // Cancelled after 2 POIs: no results, the trace stage named.
        let stop = Stopper::new(Stage::Trace, 2);
        let r = svf(&framed, &bundles, &stop);
        assert_eq!(
            r.unwrap_err(),
            Cancelled {
                stage: Stage::Trace
            }
        );
        assert!(stop.selected.load(Ordering::SeqCst) < 24);
        let stop = Stopper::new(Stage::Trace, 2);
        assert!(sun_hours(&framed, &table, &stop).is_err());
        let stop = Stopper::new(Stage::Trace, 2);
        assert_cancelled(&horizon(&framed, &hopts, &stop), Stage::Trace);
        // Invalid options are refused before any work.
        let tally = Tally::default();
        let bad = HorizonOptions::default().with_step(0.0);
        assert!(matches!(
            horizon(&framed, &bad, &tally),
            Err(Error::Solar(_))
        ));
        assert_eq!(tally.sum(Stage::Bvh, "start").0, 0);
    }
    #[test]
    fn evaluate_reports_each_poi_and_stops_when_cancelled() {
        let mut inputs = fixture_inputs();
        let framed = framed_with(&mut inputs, 6);
        let site = crate::solar::Site::new(48.76, 11.42);
        let opts = EvaluateOptions {
            eval: EvalOptions {
                lod: LodOptions {
                    select: crate::lod::select::SelectOptions {
                        rays: 500,
                        ..Default::default()
                    },
                    ..Default::default()
                },
                svf_rays: 500,
                ..Default::default()
            },
            sun: Some(SunTable::year(2025, 120, &site).unwrap()),
            irradiance: None,
        };
        let tally = Tally::default();
        let e = evaluate(&framed, &opts, &tally).unwrap();
        assert_eq!(tally.sum(Stage::Trace, "start").0, 6);
        assert_eq!(tally.sum(Stage::Trace, "advance").0, 6);
        assert_eq!(tally.sum(Stage::Bvh, "advance").0, 3);
        let n = framed.source.assets.len() as u64;
        assert_eq!(tally.sum(Stage::Rough, "advance").0, n);
        // The same figures as the evaluation called directly (timings aside).
        let direct = crate::lod::evaluation::evaluate(
            &framed.model,
            &framed.local_pois,
            &opts.eval,
            opts.sun.as_ref(),
        )
        .unwrap();
        assert_eq!(e.pois.len(), 6);
        for (a, b) in e.pois.iter().zip(&direct.pois) {
            assert_eq!(a.id, b.id);
            assert_eq!(
                (a.full.svf, a.lod.svf, a.boxes.svf),
                (b.full.svf, b.lod.svf, b.boxes.svf)
            );
            assert_eq!(a.lod.sun_hours, b.lod.sun_hours);
            assert_eq!(a.levels, b.levels);
            assert!(a.full.sun_hours.is_some());
        }
        let stop = Stopper::new(Stage::Trace, 2);
        let r = evaluate(&framed, &opts, &stop);
        assert_cancelled(&r, Stage::Trace);
        assert_eq!(stop.selected.load(Ordering::SeqCst), 2);
    }
}
