//! The study the `lod` command runs on ([`LodStudy`]): the whole read's ([`Study`]) or,
//! where [`super::lod_read`] chose it and the read does not decline, a hollow read's
//! ([`HollowStudy`]): one command for both, each stage the same answer.

use super::hollow_study::HollowStudy;
use super::lod_read::LodRead;
use super::lod_write::{LodLayout, LodWritten};
use super::report::RunMs;
use super::{Result, SceneOptions, Study};
use crate::export::report::report::{Guarantee, Report};
use crate::lod::rough::RoughOptions;
use crate::lod::LodOptions;
use crate::model::runtime::progress::Progress;
use crate::model::{CityModel, Poi};
use crate::pipeline::batch::shard_levels::Combined;
use crate::pipeline::{Levels, LevelsOptions};
use std::path::PathBuf;

/// The study of a `lod` run (module docs).
#[derive(Debug)]
pub enum LodStudy {
    /// The inputs read whole.
    Whole(Box<Study>),
    /// One document read hollow.
    Hollow(Box<HollowStudy>),
}

impl LodRead {
    /// The document of `inputs` read hollow ([`HollowStudy::read`], POIs `pois`, rough forms
    /// made with `rough`) where this read is [`LodRead::Hollow`]; `None` where it is not, or
    /// where the hollow read declines (the caller reads whole).
    ///
    /// # Errors
    /// As [`HollowStudy::read`].
    pub fn read_hollow(
        &self,
        inputs: &[PathBuf],
        pois: &[Poi],
        rough: &RoughOptions,
        options: &SceneOptions,
        progress: &dyn Progress,
    ) -> Result<Option<Box<HollowStudy>>> {
        let (LodRead::Hollow { chunk }, [path]) = (self, inputs) else {
            return Ok(None);
        };
        let h = HollowStudy::read(path, *chunk, pois.to_vec(), rough, options, progress)?;
        Ok(h.map(Box::new))
    }
}

impl LodStudy {
    /// The model as read (a hollow read's has the polygons of a few assets only).
    pub fn source(&self) -> &CityModel {
        match self {
            LodStudy::Whole(s) => s.source(),
            LodStudy::Hollow(h) => &h.hollow().model,
        }
    }

    /// The POIs in the model's CRS.
    pub fn pois(&self) -> &[Poi] {
        match self {
            LodStudy::Whole(s) => s.pois(),
            LodStudy::Hollow(h) => h.pois(),
        }
    }

    /// Milliseconds reading ([`Study::read_ms`]).
    pub fn read_ms(&self) -> f64 {
        match self {
            LodStudy::Whole(s) => s.read_ms(),
            LodStudy::Hollow(h) => super::documents::round_ms(h.read_s()),
        }
    }

    /// The sun's site ([`Study::sun_site`]).
    ///
    /// # Errors
    /// As [`Study::sun_site`].
    pub fn sun_site(
        &self,
        lat: Option<f64>,
        lon: Option<f64>,
    ) -> std::result::Result<super::weather::SunSite, super::site::SiteError> {
        match self {
            LodStudy::Whole(s) => s.sun_site(lat, lon),
            LodStudy::Hollow(h) => h.sun_site(lat, lon),
        }
    }

    /// The levels ([`Study::levels`], or [`Study::levels_combined`] of the shards'
    /// `combined` selections; a hollow read is never combined: the reduce step reads whole).
    ///
    /// # Errors
    /// As [`Study::levels`].
    pub fn levels(
        &self,
        combined: Option<Combined>,
        opts: &LevelsOptions,
        progress: &dyn Progress,
    ) -> Result<Levels> {
        match (self, combined) {
            (LodStudy::Whole(s), Some(c)) => s.levels_combined(c, opts, progress),
            (LodStudy::Whole(s), None) => s.levels(opts, progress),
            (LodStudy::Hollow(h), _) => h.levels(&opts.lod.select, opts.bound.as_ref(), progress),
        }
    }

    /// Every output of `layout` written at the levels `lv` ([`LodLayout::write`],
    /// [`LodLayout::write_hollow`]).
    ///
    /// # Errors
    /// As [`LodLayout::write`].
    pub fn write(
        &mut self,
        layout: &LodLayout,
        all_inputs: &[PathBuf],
        lv: &Levels,
        progress: &dyn Progress,
    ) -> Result<LodWritten> {
        match self {
            LodStudy::Whole(s) => layout.write(s.source(), all_inputs, lv, progress),
            LodStudy::Hollow(h) => layout.write_hollow(h.writer(), all_inputs, lv, progress),
        }
    }

    /// The `lod` report of `lv` made with `opts` ([`Study::lod_report`],
    /// [`HollowStudy::lod_report`]), the run's times and guarantee given, the outputs
    /// `written`.
    pub fn lod_report(
        &self,
        (lv, opts): (&Levels, &LodOptions),
        (ms, guarantee): (RunMs, Guarantee),
        written: impl IntoIterator<Item = (usize, String, usize)>,
    ) -> Report {
        match self {
            LodStudy::Whole(s) => s.lod_report(lv, opts, ms, guarantee, written),
            LodStudy::Hollow(h) => h.lod_report(lv, &opts.select, ms, guarantee, written),
        }
    }
}
