//! The finished report of a `lod` run ([`Study::lod_report`]: timings, guarantee, the
//! outputs written).

use super::Study;
use crate::export::report::report::{Guarantee, Report, Timings};
use crate::lod::LodOptions;
use crate::model::CityModel;
use crate::pipeline::Levels;

/// The times of a `lod` run measured outside [`Levels`] (ms).
#[derive(Debug, Clone, Copy, Default)]
pub struct RunMs {
    /// Reading the inputs.
    pub read: f64,
    /// Writing the outputs.
    pub write: f64,
    /// The whole run.
    pub total: f64,
}

impl Study {
    /// [`Study::report`] of `lv` with its timings (the stages of `lv`, and `ms`), the
    /// `guarantee` of the error bound, and each output `written` recorded ((input file,
    /// output path shown, buildings dropped) : [`Report::record_output`]).
    pub fn lod_report(
        &self,
        lv: &Levels,
        opts: &LodOptions,
        ms: RunMs,
        guarantee: Guarantee,
        written: impl IntoIterator<Item = (usize, String, usize)>,
    ) -> Report {
        let report = self.report(lv, opts, timings_of(lv, ms));
        finished(report, self.source(), guarantee, written)
    }
}

/// The timings of a `lod` report: the stages of `lv`, and `ms`.
pub(super) fn timings_of(lv: &Levels, ms: RunMs) -> Timings {
    let r = &lv.lod;
    Timings {
        read: ms.read,
        rough: r.rough_s * 1e3,
        bvh: r.bvh_s * 1e3,
        select: r.select_s * 1e3,
        write: ms.write,
        total: ms.total,
    }
}

/// `report` of `model` with the `guarantee` of the error bound and each output `written`
/// recorded ([`Study::lod_report`]).
pub(super) fn finished(
    mut report: Report,
    model: &CityModel,
    guarantee: Guarantee,
    written: impl IntoIterator<Item = (usize, String, usize)>,
) -> Report {
    report.guarantee = guarantee;
    for (f, path, dropped) in written {
        report.record_output(f, path, super::lod::buildings_in(model, f), dropped);
    }
    report
}

#[cfg(test)]
mod tests {
    use super::super::{Scene, SceneOptions};
    use super::*;
    use crate::model::runtime::progress::Silent;
    use crate::pipeline::test_support::*;

    #[test]
    fn report_timed_outputs_recorded() {
        let scene = Scene::load(&[fixture()], &SceneOptions::default(), &Silent).unwrap();
        let pois = grid_pois(scene.model(), 3);
        let study = scene.frame(pois).unwrap();
        let opts = crate::pipeline::LevelsOptions::default();
        let lv = study.levels(&opts, &Silent).unwrap();
        let ms = RunMs {
            read: 1.0,
            write: 2.0,
            total: 30.0,
        };
        let guarantee = Guarantee::default();
        let out = vec![(0, "out.gml".to_string(), 0)];
        let report = study.lod_report(&lv, &opts.lod, ms, guarantee.clone(), out);
        let t = &report.timings_ms;
        assert_eq!((t.read, t.write, t.total), (1.0, 2.0, 30.0));
        assert_eq!(t.select, lv.lod.select_s * 1e3);
        assert_eq!(report.inputs[0].output.as_deref(), Some("out.gml"));
        assert_eq!(report.inputs[0].buildings_out, study.buildings_in(0));
    }
}
