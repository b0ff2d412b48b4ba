//! Step 3: rough model, selection scene, selection and error bound.

use super::session::Error;
use super::Framed;
use crate::io::citygml::read::Reread;
use crate::lod::bound::{bound_against_from, full_answers_from, FullSource, HollowSource};
use crate::lod::bound::{BoundOptions, BoundReport, FullAnswers};
use crate::lod::hollow::Hollow;
use crate::lod::rough::RoughGeometry;
use crate::lod::{lod, LodOptions, LodResult};
use crate::model::runtime::mem::GIVE_BACK_MIN_ASSETS;
use crate::model::runtime::progress::{check, Progress, Stage};
use crate::model::CityModel;
use crate::solar::SunTable;
use std::borrow::Cow;
use std::time::Instant;

/// The error bound of `levels`: options and, for a sun-hours bound, the sun table.
#[derive(Debug, Clone)]
pub struct BoundSpec {
    /// Bound options (SVF and sun-hours errors allowed, rays).
    pub options: BoundOptions,
    /// The sun positions of the sun-hours bound.
    pub sun: Option<SunTable>,
    /// The weather year of the irradiance bound.
    pub irradiance: Option<crate::solar::irradiance::IrradianceSetting>,
}

/// Options of `levels`.
#[derive(Debug, Clone, Default)]
pub struct LevelsOptions {
    /// Rough model and selection.
    pub lod: LodOptions,
    /// An error bound to meet by promoting assets, if any.
    pub bound: Option<BoundSpec>,
}

/// The levels chosen, and what writing them needs.
#[derive(Debug, Clone)]
pub struct Levels {
    /// Rough model (local frame), selection and timings; after a bound, its levels are the
    /// promoted ones.
    pub lod: LodResult,
    /// The rough geometry in the input's CRS when the frame is not the identity (only the
    /// level-1 assets', the others empty); `None` when it is the rough model itself
    /// ([`Levels::rough_source`]).
    pub rough_source: Option<Vec<RoughGeometry>>,
    /// The bound's report, when one was asked for (`met` says whether it holds; when it
    /// does not, nothing should be written).
    pub bound: Option<BoundReport>,
    /// Seconds of the bound check after the selection (its full-model side, when
    /// `levels` traced it beside the selection, not counted).
    pub bound_s: f64,
}

impl Levels {
    /// The level of each asset.
    pub fn levels(&self) -> &[u8] {
        &self.lod.selection.levels
    }

    /// The rough geometry in the input's CRS, what is written: [`LodResult::rough`] itself
    /// when the frame is the identity (no copy), the level-1 assets' converted otherwise.
    pub fn rough_source(&self) -> &[RoughGeometry] {
        self.rough_source.as_deref().unwrap_or(&self.lod.rough)
    }

    /// Whether the bound holds (true without a bound).
    pub fn bound_met(&self) -> bool {
        self.bound.as_ref().is_none_or(|b| b.met)
    }
}

/// What `levels` runs on: the inputs read whole and framed, or one document read hollow
/// ([`crate::lod::hollow::read_hollow`]) whose frame is the identity, with the same document
/// to read its full polygons back from and the POIs in its coordinates.
#[derive(Debug, Clone, Copy)]
pub enum LevelsInput<'a> {
    /// Read whole.
    Framed(&'a Framed<'a>),
    /// Read hollow.
    Hollow {
        /// The hollow read.
        hollow: &'a Hollow,
        /// The document, to read back what the bound needs.
        reread: &'a Reread,
        /// The POIs.
        pois: &'a [crate::model::Poi],
    },
}

impl<'a> From<&'a Framed<'a>> for LevelsInput<'a> {
    fn from(f: &'a Framed<'a>) -> Self {
        LevelsInput::Framed(f)
    }
}

/// Rough model ([`Stage::Rough`]) → selection scene ([`Stage::Bvh`]) → selection
/// ([`Stage::Select`], per POI, cancellable) → error bound ([`Stage::Trace`]) when asked.
///
/// On a hollow read the selection runs on its rough forms and the bound against its full
/// model read back by span ([`HollowSource`]), after the selection: the same levels, bound
/// and flags as on the whole read.
///
/// The bound's full-model side (`crate::lod::bound::full_answers`: the reference trace, which needs no
/// levels) runs beside the rough model and the selection, each filling the other's
/// one-core stretches, for models under `GIVE_BACK_MIN_ASSETS` assets (a larger model's
/// peak memory keeps them one after the other); the answers are the same either way.
///
/// # Errors
/// [`Error::Select`], [`Error::Bound`], [`Error::Cancelled`].
pub fn levels<'a>(
    input: impl Into<LevelsInput<'a>>,
    opts: &LevelsOptions,
    progress: &dyn Progress,
) -> Result<Levels, Error> {
    let framed = match input.into() {
        LevelsInput::Framed(f) => f,
        LevelsInput::Hollow {
            hollow,
            reread,
            pois,
        } => {
            let mut lod = lod(hollow, pois, &opts.lod, progress)?;
            let src = HollowSource::new(hollow, reread);
            let (bound, bound_s) = bounded(&src, pois, opts, &mut lod, None, progress)?;
            return Ok(Levels {
                lod,
                rough_source: None,
                bound,
                bound_s,
            });
        }
    };
    let (model, pois) = (&*framed.model, &framed.local_pois[..]);
    let beside = opts
        .bound
        .as_ref()
        .filter(|_| model.assets.len() < GIVE_BACK_MIN_ASSETS);
    let Some(spec) = beside else {
        let lod = lod(model, pois, &opts.lod, progress)?;
        return levels_of(framed, opts, lod, progress);
    };
    let (lod, full) = rayon::join(
        || lod(model, pois, &opts.lod, progress),
        || full_of(model, pois, spec),
    );
    let lod = lod?;
    finish(framed, opts, lod, Some(full?), progress)
}

/// [`crate::lod::bound::full_answers`] of `spec` at `pois`, of the full model `src`.
fn full_of<'a>(
    src: &dyn FullSource,
    pois: &'a [crate::model::Poi],
    spec: &'a BoundSpec,
) -> Result<FullAnswers<'a>, crate::lod::bound::BoundError> {
    let (sun, irr) = (spec.sun.as_ref(), spec.irradiance.as_ref());
    full_answers_from(src, pois, &spec.options, sun, irr)
}

/// The rest of [`levels`] for a selection made elsewhere (e.g. the levels of every shard of
/// an array job combined): the error bound when asked, the rough model back to the source CRS.
///
/// # Errors
/// [`Error::Bound`], [`Error::Cancelled`].
pub fn levels_of(
    framed: &Framed<'_>,
    opts: &LevelsOptions,
    lod: LodResult,
    progress: &dyn Progress,
) -> Result<Levels, Error> {
    finish(framed, opts, lod, None, progress)
}

/// [`levels_of`] with the bound's full-model side `full` when it was made already.
fn finish(
    framed: &Framed<'_>,
    opts: &LevelsOptions,
    mut lod: LodResult,
    full: Option<FullAnswers<'_>>,
    progress: &dyn Progress,
) -> Result<Levels, Error> {
    let model: &CityModel = &framed.model;
    let (bound_report, bound_s) =
        bounded(model, &framed.local_pois, opts, &mut lod, full, progress)?;
    let rough_source = match crate::lod::rough::rough_to_source(
        &framed.frame,
        model,
        framed.source,
        &lod.rough,
        Some(&lod.selection.levels),
    ) {
        Cow::Borrowed(_) => None,
        Cow::Owned(v) => Some(v),
    };
    Ok(Levels {
        lod,
        rough_source,
        bound: bound_report,
        bound_s,
    })
}

/// The error bound of `opts` ([`Stage::Trace`]) against the full model `src` when asked
/// (its full-model side `full` when made already), `lod`'s levels promoted; its report and
/// seconds.
fn bounded(
    src: &dyn FullSource,
    pois: &[crate::model::Poi],
    opts: &LevelsOptions,
    lod: &mut LodResult,
    full: Option<FullAnswers<'_>>,
    progress: &dyn Progress,
) -> Result<(Option<BoundReport>, f64), Error> {
    let mut bound_report = None;
    let t = Instant::now();
    if let Some(spec) = &opts.bound {
        check(progress, Stage::Trace)?;
        let b = crate::model::runtime::progress::stage(
            progress,
            Stage::Trace,
            pois.len() as u64,
            0,
            || {
                let full = match full {
                    Some(f) => f,
                    None => full_of(src, pois, spec)?,
                };
                bound_against_from(src, &lod.rough, &lod.selection.levels, &full)
            },
        )?;
        bound_report = Some(BoundReport::new(&b, &spec.options));
        lod.selection.levels = b.levels;
    }
    Ok((bound_report, t.elapsed().as_secs_f64()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::test_support::*;
    use crate::pipeline::{read_inputs, FrameOptions};
    use std::sync::atomic::Ordering;

    /// The bound's full-model side traced beside the selection ([`levels`]) gives the
    /// levels and report of the same bound after it ([`levels_of`]).
    #[test]
    fn the_bound_beside_the_selection_gives_the_bound_after_it() {
        let mut inputs =
            read_inputs(&[fixture()], &crate::model::runtime::progress::Silent).unwrap();
        let pois = grid_pois(&inputs.model, 4);
        let framed = frame(&mut inputs.model, pois, &FrameOptions::default()).unwrap();
        let site = crate::solar::Site::new(41.39, 2.17);
        let opts = LevelsOptions {
            lod: LodOptions::default(),
            bound: Some(BoundSpec {
                options: BoundOptions {
                    max_svf_error: Some(0.001),
                    max_sun_error: Some(0.001),
                    svf_rays: 2000,
                    ..Default::default()
                },
                sun: Some(SunTable::year(2025, 180, &site).unwrap()),
                irradiance: None,
            }),
        };
        let silent = &crate::model::runtime::progress::Silent;
        let beside = levels(&framed, &opts, silent).unwrap();
        let lod = lod(&*framed.model, &framed.local_pois, &opts.lod, silent).unwrap();
        let after = levels_of(&framed, &opts, lod, silent).unwrap();
        assert_eq!(beside.levels(), after.levels());
        assert_eq!(beside.bound, after.bound);
        let b = beside.bound.as_ref().unwrap();
        assert_eq!(b.pois.len(), 4);
        assert!(b.pois.iter().all(|p| p.sun_hours_error.is_some()));
    }

    #[test]
    fn selection_stops_when_cancelled() {
        let mut inputs =
            read_inputs(&[fixture()], &crate::model::runtime::progress::Silent).unwrap();
        assert!(inputs.failures.is_empty());
        let pois = grid_pois(&inputs.model, 64);
        let framed = frame(&mut inputs.model, pois, &FrameOptions::default()).unwrap();
        let opts = LevelsOptions {
            lod: LodOptions {
                select: crate::lod::select::SelectOptions {
                    rays: 500,
                    ..Default::default()
                },
                ..Default::default()
            },
            bound: None,
        };
        let stop = Stopper::new(Stage::Select, 2);
        let r = levels(&framed, &opts, &stop);
        assert_cancelled(&r, Stage::Select);
        // Without cancellation the same call selects every POI.
        let all = Stopper {
            stop_after: u64::MAX,
            ..stop
        };
        all.stopped.store(false, Ordering::SeqCst);
        all.selected.store(0, Ordering::SeqCst);
        let lv = levels(&framed, &opts, &all).unwrap();
        assert_eq!(all.selected.load(Ordering::SeqCst), 64);
        assert_eq!(lv.lod.selection.pois.len(), 64);
    }
}
