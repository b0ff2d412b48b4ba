//! A [`Study`] of one document read hollow ([`Study::read_hollow`]): `lod` on a file larger
//! than its memory keeps only what the selection needs. The plain CityGML document is read in
//! chunks ([`read_hollow`]: every asset's rough form, boxes and polygon counts, the polygons
//! of the POIs' surroundings only, [`near_pois`]), checked as [`super::Scene::check`] checks
//! the whole read (heights) and its POIs framed as [`super::Scene::frame`] frames them
//! ([`crate::pipeline::frame`] on the hollow model with the box the read gave: no point is
//! walked). The study then gives the whole read's levels, bound, report and CityGML bytes:
//! the polygons the bound and the writer need are read back ([`Reread`]).

use super::{Frame, Read, Result, SceneOptions, Study};
use crate::io::citygml::read::{Passes, Reread};
use crate::io::citygml::ReadOptions;
use crate::lod::hollow::{near_pois, read_hollow, Hollow};
use crate::lod::poi::check_poi_list;
use crate::lod::rough::RoughOptions;
use crate::model::runtime::progress::{check, Progress, Stage};
use crate::model::{Bbox, Poi};
use crate::pipeline::batch::inputs::Input;
use crate::pipeline::{check_model_in, frame_in};
use glam::DVec3;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A document read hollow, with what reads its polygons back.
#[derive(Debug)]
pub(super) struct HollowRead {
    /// The read: the model without most polygons, every asset's rough form and boxes.
    pub(super) hollow: Hollow,
    /// The document, to read polygons back from.
    pub(super) reread: Reread,
    /// The options the rough forms were made with.
    pub(super) rough: RoughOptions,
    /// The bytes of a chunk of the read (the writer plans as many at a time).
    pub(super) chunk: u64,
}

impl Study {
    /// Read the plain CityGML document at `path` hollow in chunks of `chunk` bytes
    /// ([`Stage::Read`]: its bytes), rough forms made with `rough`, the surroundings of
    /// `pois` (in the document's CRS) kept; check it (heights) and frame `pois` with
    /// `options` (`crate::pipeline::frame`: POIs checked, refused far outside the scene).
    /// `None` where the read declines ([`read_hollow`]) or the frame is not the identity: the
    /// caller reads whole.
    ///
    /// # Errors
    /// [`super::Error::Poi`], [`super::Error::Trust`], [`super::Error::Cancelled`].
    pub fn read_hollow(
        path: &Path,
        chunk: u64,
        pois: Vec<Poi>,
        rough: &RoughOptions,
        options: &SceneOptions,
        progress: &dyn Progress,
    ) -> Result<Option<Study>> {
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
        let f = Frame::from(frame_in(
            &mut hollow.model,
            Some(bbox),
            pois,
            &options.frame,
        )?);
        if !f.frame.is_identity() {
            return Ok(None);
        }
        let input = Input {
            path: path.to_path_buf(),
            relative: path
                .file_name()
                .map_or_else(|| path.to_path_buf(), PathBuf::from),
        };
        let read = HollowRead {
            hollow,
            reread,
            rough: *rough,
            chunk,
        };
        let read = Read::Hollow(Box::new(read));
        let read_s = t.elapsed().as_secs_f64();
        Ok(Some(Study::new(
            (vec![input], read, bbox),
            f,
            Vec::new(),
            read_s,
        )))
    }

    /// The document read hollow, what reads its polygons back and the bytes of a chunk:
    /// `None` for a study read whole.
    pub(super) fn hollow_mut(&mut self) -> Option<(&mut Hollow, &Reread, u64)> {
        match &mut self.read {
            Read::Whole(_) => None,
            Read::Hollow(h) => Some((&mut h.hollow, &h.reread, h.chunk)),
        }
    }

    /// The document read hollow (`None` for a study read whole).
    pub fn hollow(&self) -> Option<&Hollow> {
        match &self.read {
            Read::Whole(_) => None,
            Read::Hollow(h) => Some(&h.hollow),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::export::report::report::Guarantee;
    use crate::lod::bound::BoundOptions;
    use crate::model::runtime::progress::Silent;
    use crate::pipeline::session::report::RunMs;
    use crate::pipeline::session::Scene;
    use crate::pipeline::{BoundSpec, LevelsOptions};

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
        let h = Study::read_hollow(&path, 1 << 16, pois.clone(), rough, &so, &Silent);
        let h = h.unwrap().unwrap();
        let chunks = h.hollow().map(|h| h.summary.chunks);
        assert!(chunks > Some(2), "{chunks:?}");
        assert_eq!(h.bbox(), study.source().bbox());
        assert_eq!(h.pois(), study.pois());
        assert_eq!(h.sun_site(None, None), study.sun_site(None, None));
        assert!(h.sun_site(None, None).is_ok());
        let got = h.levels(&opts, &Silent);
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
        let report = h.lod_report(&got, &opts.lod, ms, g.clone(), written());
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
        // what needs the whole model is refused, naming the document
        let svf = h.svf(&crate::solar::SkyBundles::new(300, 2).unwrap(), &Silent);
        assert!(
            matches!(&svf, Err(crate::pipeline::session::Error::Hollow { file }) if *file == path),
            "{svf:?}"
        );
        // a POI far outside is refused as by the whole read
        let far = vec![Poi::at("far", (h.bbox().max + 5000.0).to_array())];
        let r = Study::read_hollow(&path, 1 << 16, far, rough, &so, &Silent);
        assert!(
            matches!(r, Err(crate::pipeline::session::Error::Trust(_))),
            "{r:?}"
        );
    }
}
