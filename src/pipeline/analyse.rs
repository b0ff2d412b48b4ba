//! Step 5: the POIs traced against the full-detail scene (SVF, sun hours, horizon) and
//! the evaluation of the LoD model.

use super::session::Error;
use super::Framed;
use crate::lod::evaluation::{evaluate_irradiance, EvalOptions, Evaluation};
use crate::lod::poi::checks::{self, PoiFlag};
use crate::lod::rough::{rough_model, RoughOptions};
use crate::lod::scene::{detail_boxes, full_scene, mixed_scene};
use crate::model::runtime::progress::{check, Cancelled, Progress, Stage};
use crate::model::Poi;
use crate::model::{Bbox, CityModel};
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

/// How the POIs' scene is built for tracing: the one decision between a few POIs and every
/// surface of a city.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Scenes {
    /// One scene: the whole model at full detail.
    #[default]
    Whole,
    /// The POIs in squares of `size` metres (x, y) on a grid anchored at the corner of the
    /// model's box, so that a POI's square never depends on the other POIs (a shard's
    /// answers are the serial run's); each square traced against its own scene: full detail
    /// for the assets whose box comes within `margin` metres of the square, skylod's rough
    /// forms (level 1) beyond. The largest scene follows a square's surroundings, not the
    /// city's size.
    Tiled {
        /// Side of a square (m).
        size: f64,
        /// Reach of full detail around a square (m).
        margin: f64,
    },
}

impl Scenes {
    /// A city's solar cadastre: 250 m squares with full detail 150 m around them. Beyond
    /// 150 m, a rough form differs from its detail by under a degree as seen from the
    /// square (a metre's overhang or recess subtends 0.4°).
    pub const CADASTRE: Scenes = Scenes::Tiled {
        size: 250.0,
        margin: 150.0,
    };
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

/// [`trace`] with the scene built as `scenes` says: [`Scenes::Whole`] is [`trace`];
/// [`Scenes::Tiled`] reports the boxes and rough forms as one [`Stage::Bvh`] item, then the
/// POIs as [`Stage::Trace`] items, square after square (each square's scene built in that
/// stage), `bvh_s` the time of every scene together. The results are made in place
/// (`T::default()` until its POI is traced), so that a city's millions of points are held
/// once.
///
/// # Errors
/// [`Cancelled`] when `progress` asks to stop.
pub fn trace_with<T: Send + Default>(
    framed: &Framed<'_>,
    scenes: Scenes,
    f: impl Fn(&TraceScene, &Poi) -> T + Sync,
    sky_rays: impl Fn(&T) -> Option<usize> + Sync,
    progress: &dyn Progress,
) -> Result<Traced<T>, Cancelled> {
    let Scenes::Tiled { size, margin } = scenes else {
        return trace(framed, f, sky_rays, progress);
    };
    let model: &CityModel = &framed.model;
    let pois = &framed.local_pois;
    let t = Instant::now();
    check(progress, Stage::Bvh)?;
    let (boxes, rough, squares) =
        crate::model::runtime::progress::stage(progress, Stage::Bvh, 1, 0, || {
            let (boxes, all) = detail_boxes(model);
            let rough = rough_model(model, &RoughOptions::default());
            progress.advance(Stage::Bvh, 1, 0, None);
            (boxes, rough, squares_of(pois, all, size))
        });
    let around = checks::Surroundings::new(model);
    let mut bvh_s = t.elapsed().as_secs_f64();
    let mut results: Vec<T> = std::iter::repeat_with(T::default)
        .take(pois.len())
        .collect();
    let mut flags: Vec<Vec<PoiFlag>> = vec![Vec::new(); pois.len()];
    progress.start(Stage::Trace, pois.len() as u64, 0);
    for (square, members) in squares {
        check(progress, Stage::Trace)?;
        let t = Instant::now();
        let levels = square_levels(&boxes, &square, margin);
        let scene = mixed_scene(model, &rough, &levels);
        drop(levels);
        bvh_s += t.elapsed().as_secs_f64();
        let done: Result<Vec<(T, Vec<PoiFlag>)>, Cancelled> = members
            .par_iter()
            .map(|&i| one_poi(&scene, model, &around, &pois[i], &f, &sky_rays, progress))
            .collect();
        for (i, (r, f)) in members.into_iter().zip(done?) {
            (results[i], flags[i]) = (r, f);
        }
    }
    progress.finish(Stage::Trace);
    let total = t.elapsed().as_secs_f64();
    Ok(Traced {
        results,
        flags,
        bvh_s,
        trace_s: total - bvh_s,
    })
}

/// The POIs (indices into `pois`) of each square of side `size` of the grid anchored at
/// `all`'s lower corner ([`crate::model::squares`]).
fn squares_of(pois: &[Poi], all: Bbox, size: f64) -> Vec<(Bbox, Vec<usize>)> {
    let origin = if all.is_empty() {
        glam::DVec3::ZERO
    } else {
        all.min
    };
    let points: Vec<glam::DVec3> = pois.iter().map(|p| p.position).collect();
    crate::model::squares(&points, origin, size)
}

/// Each asset's level in the scene of `square`: 2 (full detail) where its box `boxes[i]`
/// comes within `margin` of the square in x and y, else 1 (its rough form).
fn square_levels(boxes: &[Bbox], square: &Bbox, margin: f64) -> Vec<u8> {
    boxes
        .iter()
        .map(|b| {
            let near = !b.is_empty()
                && b.min.x <= square.max.x + margin
                && b.max.x >= square.min.x - margin
                && b.min.y <= square.max.y + margin
                && b.max.y >= square.min.y - margin;
            if near {
                2
            } else {
                1
            }
        })
        .collect()
}

/// One POI traced against `scene` (see [`trace_in`]).
fn one_poi<T>(
    scene: &TraceScene,
    model: &CityModel,
    around: &checks::Surroundings,
    p: &Poi,
    f: &(impl Fn(&TraceScene, &Poi) -> T + Sync),
    sky_rays: &(impl Fn(&T) -> Option<usize> + Sync),
    progress: &dyn Progress,
) -> Result<(T, Vec<PoiFlag>), Cancelled> {
    check(progress, Stage::Trace)?;
    let r = f(scene, p);
    let flags = checks::poi_flags_around(scene, model, around, p, sky_rays(&r));
    // No name: many cheap POIs in parallel (a log line each would drown the log).
    progress.advance(Stage::Trace, 1, 0, None);
    Ok((r, flags))
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
                .map(|p| one_poi(scene, model, &around, p, &f, &sky_rays, progress))
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
    use crate::model::runtime::progress::Silent;
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
    fn tiled_scenes_keep_the_pois_order_and_the_whole_scenes_answers() {
        let mut inputs = fixture_inputs();
        let framed = framed_with(&mut inputs, 24);
        let bundles = SkyBundles::new(400, 3).unwrap();
        let f = |s: &TraceScene, p: &Poi| (p.id.clone(), poi_sky_view(s, p, &bundles));
        let whole = trace(&framed, f, |_| None, &Silent).unwrap();
        // one square holding the model, full detail everywhere: the whole scene's answers
        let wide = Scenes::Tiled {
            size: 1e6,
            margin: 1e6,
        };
        let one = trace_with(&framed, wide, f, |_| None, &Silent).unwrap();
        assert_eq!((&one.results, &one.flags), (&whole.results, &whole.flags));
        // squares of 6 m with 2 m of full detail: several scenes, the POIs in their order, rough
        // forms beyond 2 m changing some answers a little
        let tally = Tally::default();
        let small = Scenes::Tiled {
            size: 6.0,
            margin: 2.0,
        };
        let t = trace_with(&framed, small, f, |_| None, &tally).unwrap();
        assert_eq!(tally.sum(Stage::Trace, "advance").0, 24);
        assert_eq!(tally.sum(Stage::Bvh, "advance").0, 1);
        let (boxes, all) = detail_boxes(&framed.model);
        let squares = squares_of(&framed.local_pois, all, 6.0);
        assert!(squares.len() > 2, "{} squares", squares.len());
        // some squares' scenes have assets at full detail and others rough
        let mixed = squares.iter().filter(|(square, _)| {
            let levels = square_levels(&boxes, square, 2.0);
            levels.contains(&1) && levels.contains(&2)
        });
        assert!(mixed.count() > 1);
        for ((a, b), p) in t
            .results
            .iter()
            .zip(&whole.results)
            .zip(framed.local_pois.iter())
        {
            assert_eq!((&a.0, &b.0), (&p.id, &p.id));
            assert!((a.1.svf - b.1.svf).abs() < 0.05, "{}: {a:?} {b:?}", p.id);
        }
        // cancelled in the second square
        let stop = Stopper::new(Stage::Trace, squares[0].1.len() as u64 + 1);
        assert!(trace_with(&framed, small, f, |_| None, &stop).is_err());
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
