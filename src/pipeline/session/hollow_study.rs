//! The `lod` side of a [`super::Study`] on a document read hollow (`lod` keeps only what the
//! selection needs): [`HollowStudy::read`] reads one plain CityGML document hollow
//! ([`read_hollow`], the POIs' surroundings kept: [`near_pois`]), checks it as
//! [`super::Scene::check`] checks the whole read (heights) and frames the POIs as
//! [`super::Scene::frame`] does ([`crate::pipeline::frame`] on the hollow model with the box the read gave:
//! no point is walked); [`HollowStudy::levels`] selects and bounds on it
//! ([`levels`]), and [`HollowStudy::lod_report`] makes its report (the polygon counts
//! from the hollow read's). What [`lod_read`](super::lod_read::lod_read) chose the hollow
//! read for: the levels, the bound, the report and the frame's warnings are the whole read's.
//!
//! [`HollowStudy::sun_site`] is the sun's site of the bound as the whole read's.
//!
//! [`HollowStudy::write_levels`] writes its CityGML ([`write_levels`]: the polygons the
//! writer needs read back), the whole read's bytes; OBJ and CityJSON outputs, which take the
//! polygons of every level-2 asset, are written from the whole read ([`super::lod_read`]).

use super::lod::report_of;
#[cfg(doc)]
use super::lod_write::LodLayout;
use super::report::{finished, timings_of, RunMs};
use super::{Result, SceneOptions};
use crate::export::report::report::{Guarantee, Report};
use crate::export::Format;
use crate::io::citygml::read::{Passes, Reread};
use crate::io::citygml::write::WriteOptions;
use crate::io::citygml::ReadOptions;
use crate::io::citygml::WriteError;
use crate::lod::hollow::{near_pois, read_hollow, Hollow};
use crate::lod::mixed::MixedSource;
use crate::lod::poi::check_poi_list;
use crate::lod::rough::RoughOptions;
use crate::lod::select::SelectOptions;
use crate::lod::LodOptions;
use crate::model::crs::{Crs, FrameWarning};
use crate::model::runtime::progress::{check, Progress, Stage};
use crate::model::{Bbox, Poi};
use crate::pipeline::{
    check_model_in, frame_in, levels, write_levels, BoundSpec, Levels, LevelsInput, LevelsOptions,
    Written,
};
use glam::DVec3;
use std::path::Path;
use std::time::Instant;

/// One document read hollow, checked, with its POIs framed (module docs).
#[derive(Debug)]
pub struct HollowStudy {
    hollow: Hollow,
    reread: Reread,
    rough: RoughOptions,
    bbox: Bbox,
    crs: Crs,
    pois: Vec<Poi>,
    warnings: Vec<String>,
    frame_warning: Option<FrameWarning>,
    read_s: f64,
    chunk: u64,
}

impl HollowStudy {
    /// Read the plain CityGML document at `path` hollow in chunks of `chunk` bytes
    /// ([`Stage::Read`]: its bytes), rough forms made with `rough`, the surroundings of
    /// `pois` (in the document's CRS) kept; check it (heights) and frame `pois` with
    /// `options` ([`crate::pipeline::frame`]: POIs checked, refused far outside the scene). `None` where
    /// the read declines ([`read_hollow`]) or the frame is not the identity: the caller reads
    /// whole.
    ///
    /// # Errors
    /// [`super::Error::Poi`], [`super::Error::Trust`], [`super::Error::Cancelled`].
    pub fn read(
        path: &Path,
        chunk: u64,
        pois: Vec<Poi>,
        rough: &RoughOptions,
        options: &SceneOptions,
        progress: &dyn Progress,
    ) -> Result<Option<HollowStudy>> {
        crate::model::runtime::mem::set_give_back(options.trim_memory);
        check_poi_list(&pois)?;
        let t = Instant::now();
        let size = std::fs::metadata(path).map_or(0, |m| m.len());
        check(progress, Stage::Read)?;
        progress.start(Stage::Read, 1, size);
        // a chunk parsed ahead on every thread: the hollow model is far under lod's budget;
        // no polygon ids, but for the kept assets' (read back with them after the read)
        let read = ReadOptions {
            stream_ahead: usize::MAX,
            polygon_ids: false,
            ..ReadOptions::default()
        };
        let passed = |_: usize, n: u64| progress.advance(Stage::Read, 0, n, None);
        let passes = Passes::new(&read, chunk, &passed);
        let points: Vec<DVec3> = pois.iter().map(|p| p.position).collect();
        let hollow = read_hollow(path, &passes, rough, &near_pois(&points));
        let name = crate::model::shown(path).to_string();
        progress.advance(Stage::Read, 1, 0, Some(&name));
        progress.finish(Stage::Read);
        let with_ids = ReadOptions {
            polygon_ids: true,
            ..read
        };
        let (Some(mut hollow), Some(reread)) = (hollow, Reread::open(path, &with_ids)) else {
            return Ok(None);
        };
        if hollow.kept_with_ids(&reread).is_none() {
            return Ok(None);
        }
        let bbox = (hollow.boxes.iter()).fold(Bbox::EMPTY, |mut b, a| {
            b.union(a);
            b
        });
        check_model_in(&hollow.model, &bbox, options.allow_mixed_crs)?;
        let f = frame_in(&mut hollow.model, Some(bbox), pois, &options.frame)?;
        if !f.frame.is_identity() {
            return Ok(None);
        }
        let (crs, pois, warnings, frame_warning) = (f.crs, f.pois, f.warnings, f.frame_warning);
        Ok(Some(HollowStudy {
            hollow,
            reread,
            rough: *rough,
            bbox,
            crs,
            pois,
            warnings,
            frame_warning,
            read_s: t.elapsed().as_secs_f64(),
            chunk,
        }))
    }

    /// The levels at the POIs ([`levels`]) selected with `select` (the rough forms are
    /// the read's), the error bound checked when `bound` asks.
    ///
    /// # Errors
    /// [`super::Error::Select`], [`super::Error::Bound`], [`super::Error::Cancelled`].
    pub fn levels(
        &self,
        select: &SelectOptions,
        bound: Option<&BoundSpec>,
        progress: &dyn Progress,
    ) -> Result<Levels> {
        let opts = LevelsOptions {
            lod: LodOptions {
                rough: self.rough,
                select: *select,
            },
            bound: bound.cloned(),
        };
        let (h, rr) = (&self.hollow, &self.reread);
        let input = LevelsInput::Hollow {
            hollow: h,
            reread: rr,
            pois: &self.pois,
        };
        levels(input, &opts, progress)
    }

    /// The `lod` report of `lv` (from [`HollowStudy::levels`] with `select`) as
    /// [`super::Study::lod_report`] makes it of the whole read: its polygon counts from the
    /// hollow read's.
    pub fn lod_report(
        &self,
        lv: &Levels,
        select: &SelectOptions,
        ms: RunMs,
        guarantee: Guarantee,
        written: impl IntoIterator<Item = (usize, String, usize)>,
    ) -> Report {
        let opts = LodOptions {
            rough: self.rough,
            select: *select,
        };
        let (model, t) = (&self.hollow.model, timings_of(lv, ms));
        let report = report_of(model, &self.hollow, &self.pois, lv, &opts, t);
        finished(report, model, guarantee, written)
    }

    /// Write the document at the levels `lv` (from [`HollowStudy::levels`]) in CityGML to
    /// `out` ([`write_levels`]: the polygons the writer needs read back, planned a
    /// chunk of the read at a time): the bytes the whole read's
    /// [`crate::pipeline::write_levels`] writes.
    ///
    /// # Errors
    /// As [`crate::pipeline::write_levels`].
    pub fn write_levels(
        &mut self,
        lv: &Levels,
        out: &Path,
        wopts: &WriteOptions,
    ) -> std::result::Result<Written, WriteError> {
        let src = MixedSource::Hollow(&mut self.hollow, &self.reread, self.chunk);
        write_levels(src, lv, out, Format::CityGml, wopts)
    }

    /// What [`LodLayout::write_hollow`] writes with: the document read hollow, its reread and
    /// the chunk of the read.
    pub fn writer(&mut self) -> (&mut Hollow, &Reread, u64) {
        (&mut self.hollow, &self.reread, self.chunk)
    }

    /// The sun's site ([`super::Study::sun_site`]): `lat` and `lon` given, else the centre of
    /// the model from its CRS.
    ///
    /// # Errors
    /// As [`super::site::site_of`].
    pub fn sun_site(
        &self,
        lat: Option<f64>,
        lon: Option<f64>,
    ) -> std::result::Result<super::weather::SunSite, super::site::SiteError> {
        super::site::site_in(lat, lon, &self.hollow.model, &self.bbox)
    }

    /// The document read hollow.
    pub fn hollow(&self) -> &Hollow {
        &self.hollow
    }

    /// The POIs (the document's CRS, the tracing frame's too).
    pub fn pois(&self) -> &[Poi] {
        &self.pois
    }

    /// The box of every asset ([`crate::model::CityModel::bbox`] of the whole read).
    pub fn bbox(&self) -> Bbox {
        self.bbox
    }

    /// The document's CRS.
    pub fn crs(&self) -> &Crs {
        &self.crs
    }

    /// What the frame tells the user ([`crate::pipeline::Framed::warnings`]), and its
    /// warning structured.
    pub fn warnings(&self) -> (&[String], Option<&FrameWarning>) {
        (&self.warnings, self.frame_warning.as_ref())
    }

    /// The frame's warnings as the command line says them ([`super::flags::frame_said`]).
    pub fn frame_said(&self) -> Vec<String> {
        super::flags::frame_said(&self.warnings, self.frame_warning.as_ref())
    }

    /// Seconds spent reading (the hollow read, the checks and the frame).
    pub fn read_s(&self) -> f64 {
        self.read_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lod::bound::BoundOptions;
    use crate::model::runtime::progress::Silent;
    use crate::pipeline::session::Scene;

    /// On six blocks of the small preset read hollow in small chunks, with a bound that
    /// promotes: the levels, the bound's report, the flags and the rough forms of the whole
    /// read's [`super::super::Study::levels`], and the frame's warnings.
    #[test]
    fn levels_on_a_hollow_read_are_the_whole_reads() {
        let dir = tempfile::tempdir().unwrap();
        let small = crate::model::synth::SynthOptions {
            blocks_x: 3,
            blocks_y: 2,
            ..crate::model::synth::Preset::Small.defaults()
        };
        let path = dir.path().join("six.gml");
        let mut xml = Vec::new();
        crate::model::synth::generate(&small, &mut xml).unwrap();
        std::fs::write(&path, xml).unwrap();
        let pois: Vec<Poi> = (crate::model::synth::pois(&small).into_iter())
            .take(3)
            .map(Into::into)
            .collect();
        let site = crate::solar::Site::new(48.76, 11.42);
        let opts = LevelsOptions {
            bound: Some(BoundSpec {
                options: BoundOptions {
                    max_svf_error: Some(0.0005),
                    max_sun_error: Some(0.0005),
                    svf_rays: 2000,
                    ..Default::default()
                },
                sun: Some(crate::solar::SunTable::year(2025, 120, &site).unwrap()),
                irradiance: None,
            }),
            ..Default::default()
        };
        let so = SceneOptions::default();
        let scene = Scene::load(&[&path], &so, &Silent).unwrap();
        let study = scene.frame(pois.clone()).unwrap();
        let want = study.levels(&opts, &Silent).unwrap();
        let rough = &opts.lod.rough;
        let h = HollowStudy::read(&path, 1 << 16, pois.clone(), rough, &so, &Silent);
        let h = h.unwrap().unwrap();
        assert!(
            h.hollow().summary.chunks > 2,
            "{}",
            h.hollow().summary.chunks
        );
        assert_eq!(h.bbox(), study.source().bbox());
        assert_eq!(h.pois(), study.pois());
        assert_eq!(h.sun_site(None, None), study.sun_site(None, None));
        assert!(h.sun_site(None, None).is_ok());
        let got = h.levels(&opts.lod.select, opts.bound.as_ref(), &Silent);
        let mut got = got.unwrap();
        for (g, w) in (got.lod.selection.pois.iter_mut()).zip(&want.lod.selection.pois) {
            g.seconds = w.seconds;
        }
        let b = want.bound.as_ref().unwrap();
        assert!(!b.promotions.is_empty(), "{b:?}");
        assert_eq!(got.bound, want.bound);
        assert_eq!(got.lod.selection, want.lod.selection);
        assert_eq!(got.lod.flags, want.lod.flags);
        assert_eq!(got.lod.rough, want.lod.rough);
        assert_eq!(got.rough_source(), want.rough_source());
        // the report, its polygon counts from the hollow read's (the stages' times aside)
        let w = &want.lod;
        (got.lod.rough_s, got.lod.bvh_s, got.lod.select_s) = (w.rough_s, w.bvh_s, w.select_s);
        let ms = RunMs::default();
        let written = || [(0, "out.gml".to_string(), 1)];
        let g = Guarantee::default();
        let report = h.lod_report(&got, &opts.lod.select, ms, g.clone(), written());
        let whole = study.lod_report(&want, &opts.lod, ms, g, written());
        assert!(
            whole.totals.polygons_in > whole.totals.polygons_out,
            "{:?}",
            whole.totals
        );
        assert!(whole
            .assets
            .iter()
            .any(|a| a.level == 2 && a.polygons_in > 0));
        assert_eq!(
            serde_json::to_value(&report).unwrap(),
            serde_json::to_value(&whole).unwrap()
        );
        // a POI far outside is refused as by the whole read
        let far = vec![Poi::at("far", (h.bbox().max + 5000.0).to_array())];
        let r = HollowStudy::read(&path, 1 << 16, far, rough, &so, &Silent);
        assert!(
            matches!(r, Err(crate::pipeline::session::Error::Trust(_))),
            "{r:?}"
        );
    }
}
