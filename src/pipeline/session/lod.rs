//! The LoD side of a [`Study`] beyond [`Study::levels`]: the selection alone (a shard of an
//! array job), levels from the shards' combined selections (the reduce step) and the
//! `lod` report.

use super::{Result, Study};
use crate::export::report::report::{Parameters, Report, Timings};
use crate::lod::select::FullFacts;
use crate::lod::{lod, LodOptions, LodResult};
use crate::model::runtime::progress::Progress;
use crate::model::{CityModel, Poi};
use crate::pipeline::batch::shard_levels::Combined;
use crate::pipeline::{levels_of, Levels, LevelsOptions};

impl Study {
    /// The selection of every asset at the POIs, without an error bound and in the local
    /// frame ([`crate::lod::lod`]): what a shard of an array job records.
    ///
    /// # Errors
    /// [`super::Error::Select`], [`super::Error::Cancelled`].
    pub fn lod(&self, opts: &LodOptions, progress: &dyn Progress) -> Result<LodResult> {
        self.whole()?;
        let framed = self.framed();
        Ok(lod(&*framed.model, &framed.local_pois, opts, progress)?)
    }

    /// [`Study::levels`] for the selections of every shard combined
    /// ([`crate::pipeline::batch::reduce::Reduce::combine`] on [`super::Scene::model`]): the rough
    /// model rebuilt with `opts.lod`, the error bound checked when asked.
    ///
    /// # Errors
    /// [`super::Error::Bound`], [`super::Error::Cancelled`].
    pub fn levels_combined(
        &self,
        combined: Combined,
        opts: &LevelsOptions,
        progress: &dyn Progress,
    ) -> Result<Levels> {
        self.whole()?;
        let framed = self.framed();
        let lod = crate::pipeline::batch::reduce::lod_result(&framed.model, combined, &opts.lod);
        levels_of(&framed, opts, lod, progress)
    }

    /// The report of `lv` made with `opts` (schemas/report.schema.json): parameters, POIs
    /// with their flags, assets, totals in the input's CRS, the bound; the outputs are
    /// added with [`Report::record_output`] as they are written.
    pub fn report(&self, lv: &Levels, opts: &LodOptions, timings: Timings) -> Report {
        let (source, opts) = (self.source(), &self.lod_options(opts));
        let facts: &dyn FullFacts = match self.hollow() {
            Some(h) => h,
            None => source,
        };
        report_of(source, facts, self.pois(), lv, opts, timings)
    }

    /// The buildings and building parts of input `file` (what [`Report::record_output`]
    /// counts against).
    pub fn buildings_in(&self, file: usize) -> usize {
        buildings_in(self.source(), file)
    }
}

/// The buildings and building parts of input `file` of `model`.
pub(super) fn buildings_in(model: &CityModel, file: usize) -> usize {
    model.buildings.iter().filter(|b| b.file == file).count()
}

/// The report of `lv` made with `opts` on `model` as read (its polygon counts from `facts`:
/// the model, or its hollow read), at `pois` in its CRS ([`Study::report`]).
fn report_of(
    model: &CityModel,
    facts: &dyn FullFacts,
    pois: &[Poi],
    lv: &Levels,
    opts: &LodOptions,
    timings: Timings,
) -> Report {
    let result = &lv.lod;
    let params = Parameters::of(
        &result.selection,
        opts.select.seed,
        opts.select.roof_tolerance_m,
        &opts.rough,
    );
    let (rough, sel) = (lv.rough_source(), &result.selection);
    let mut report = Report::new_from(model, facts, rough, sel, pois, params, timings);
    report.set_flags(&result.flags);
    report.bound = lv.bound.clone();
    report
}

#[cfg(test)]
mod tests {
    use super::super::{Scene, SceneOptions};
    use crate::model::runtime::progress::Silent;
    use crate::pipeline::batch::reduce::Reduce;
    use crate::pipeline::batch::shard::Shard;
    use crate::pipeline::batch::shard_levels::{header, write_levels_file};
    use crate::pipeline::test_support::*;

    #[test]
    fn two_shards_reduced_give_the_levels_of_one_run() {
        let load = || Scene::load(&[fixture()], &SceneOptions::default(), &Silent).unwrap();
        let scene = load();
        let pois = grid_pois(scene.model(), 4);
        let whole = scene.frame(pois.clone()).unwrap();
        let opts = crate::pipeline::LevelsOptions::default();
        let one = whole.levels(&opts, &Silent).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let mut files = Vec::new();
        for s in 0..2 {
            let shard = Shard::new(s, 2, "test").unwrap();
            let at: Vec<glam::DVec3> = pois.iter().map(|p| p.position).collect();
            let mine = pois[shard.pois(&at)].to_vec();
            let study = load().frame(mine).unwrap();
            let r = study.lod(&opts.lod, &Silent).unwrap();
            let h = header(shard, study.source(), &opts.lod, &r.selection, r.triangles);
            let out = dir.path().join(format!("levels-{s}.jsonl"));
            let (src, p) = (study.source(), study.pois());
            write_levels_file(&out, &h, src, p, &r.selection, &r.flags).unwrap();
            files.push(out);
        }
        let reduce = Reduce::read(&files).unwrap();
        let scene = load();
        let combined = reduce.combine(scene.model()).unwrap();
        let study = scene.frame(pois).unwrap();
        let lv = study.levels_combined(combined, &opts, &Silent).unwrap();
        assert_eq!(lv.levels(), one.levels());
        let report = study.report(&lv, &opts.lod, Default::default());
        assert_eq!(report.pois.len(), 4);
        assert_eq!(report.totals.assets, lv.levels().len());
        assert_eq!(report.parameters.seed, opts.lod.select.seed);
        assert!(study.buildings_in(0) > 0);
    }
}
