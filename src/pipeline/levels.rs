//! Step 3: rough model, selection scene, selection and error bound.

use super::{Framed, PipelineError};
use crate::lod::bound::{bound_with, BoundOptions, BoundReport};
use crate::lod::rough::RoughGeometry;
use crate::lod::{lod_with, LodOptions, LodResult};
use crate::model::runtime::progress::{check, Progress, Stage};
use crate::model::CityModel;
use crate::solar::SunTable;
use std::borrow::Cow;
use std::time::Instant;

/// The error bound of [`levels`]: options and, for a sun-hours bound, the sun table.
#[derive(Debug, Clone)]
pub struct BoundSpec {
    /// Bound options (SVF and sun-hours errors allowed, rays).
    pub options: BoundOptions,
    /// The sun positions of the sun-hours bound.
    pub sun: Option<SunTable>,
    /// The weather year of the irradiance bound.
    pub irradiance: Option<crate::solar::irradiance::IrradianceSetting>,
}

/// Options of [`levels`].
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
    /// Seconds of the bound check.
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

/// Rough model ([`Stage::Rough`]) → selection scene ([`Stage::Bvh`]) → selection
/// ([`Stage::Select`], per POI, cancellable) → error bound ([`Stage::Trace`]) when asked.
///
/// # Errors
/// [`PipelineError::Select`], [`PipelineError::Bound`], [`PipelineError::Cancelled`].
pub fn levels(
    framed: &Framed<'_>,
    opts: &LevelsOptions,
    progress: &dyn Progress,
) -> Result<Levels, PipelineError> {
    let lod = lod_with(&framed.model, &framed.local_pois, &opts.lod, progress)?;
    levels_of(framed, opts, lod, progress)
}

/// The rest of [`levels`] for a selection made elsewhere (e.g. the levels of every shard of
/// an array job combined): the error bound when asked, the rough model back to the source CRS.
///
/// # Errors
/// [`PipelineError::Bound`], [`PipelineError::Cancelled`].
pub fn levels_of(
    framed: &Framed<'_>,
    opts: &LevelsOptions,
    mut lod: LodResult,
    progress: &dyn Progress,
) -> Result<Levels, PipelineError> {
    let model: &CityModel = &framed.model;
    let pois = &framed.local_pois;
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
                bound_with(
                    model,
                    &lod.rough,
                    &lod.selection.levels,
                    pois,
                    &spec.options,
                    spec.sun.as_ref(),
                    spec.irradiance.as_ref(),
                )
            },
        )?;
        bound_report = Some(BoundReport::new(&b, &spec.options));
        lod.selection.levels = b.levels;
    }
    let bound_s = t.elapsed().as_secs_f64();
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lod::select::SelectError;
    use crate::model::runtime::progress::Cancelled;
    use crate::pipeline::test_support::*;
    use crate::pipeline::{frame, read_inputs, FrameOptions};
    use std::sync::atomic::Ordering;

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
        assert!(
            matches!(
                r,
                Err(PipelineError::Select(SelectError::Cancelled(Cancelled {
                    stage: Stage::Select
                })))
            ),
            "{r:?}"
        );
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
