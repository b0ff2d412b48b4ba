//! Inputs and points of interest (`--poi`, `--pois`, `--poi-margin`, `--allow-mixed-crs`,
//! with `--source-crs`, `--poi-crs` and `--jobs`), for the commands that trace POIs.

use super::crs::CrsArgs;
use super::jobs::JobsArgs;
use super::non_negative;
use crate::args::tracing::Session;
use crate::flags::frame_said;
use crate::inputs::Spool;
use crate::log::{error, summary, warning};
use anyhow::bail;
use skylod::lod::poi::DEFAULT_POI_MARGIN;
use skylod::lod::poi::{check_pois, parse_poi_at, read_pois_csv, Located, Poi};
use skylod::pipeline::batch::Input;
use skylod::pipeline::batch::Shard;
use skylod::pipeline::session::{Scene, SceneOptions};
use std::path::PathBuf;

/// Inputs and points of interest.
#[derive(clap::Args, Debug)]
pub struct PoiArgs {
    /// CityGML or CityJSON files (.gml, .xml, .city.json, .city.jsonl, .gz; gzip is recognised by content), directories (searched
    /// recursively), glob patterns ('tiles/**/*.gml', quoted), or - for standard input; all
    /// are merged into one scene.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Point of interest X,Y,Z or X,Y,Z,NX,NY,NZ (model CRS; the normal is the outward
    /// normal of the surface the point lies on). Repeatable.
    #[arg(
        long = "poi",
        value_name = "X,Y,Z[,NX,NY,NZ]",
        allow_hyphen_values = true
    )]
    pub poi: Vec<String>,
    /// CSV file of POIs (header `id,x,y,z[,nx,ny,nz]`, columns in any order; quoted
    /// fields, a UTF-8 BOM and `#` comment lines are fine), read after the --poi points.
    #[arg(long, value_name = "FILE.csv")]
    pub pois: Option<PathBuf>,
    /// Refuse POIs farther than this (m) outside the scene's bounding box: they are almost
    /// always in another CRS or have x and y swapped.
    #[arg(long, value_name = "M", default_value_t = DEFAULT_POI_MARGIN, value_parser = non_negative, allow_hyphen_values = true)]
    pub poi_margin: f64,
    /// Merge inputs whose srsName denote different CRSs into one scene anyway (only when
    /// the names differ but the coordinates really are in one CRS).
    #[arg(long)]
    pub allow_mixed_crs: bool,
    /// `--source-crs`, `--poi-crs`: applied by [`Scene::frame`] after reading.
    #[command(flatten)]
    pub crs: CrsArgs,
    /// `--jobs`: threads reading the inputs and tracing the POIs.
    #[command(flatten)]
    pub jobs: JobsArgs,
}

impl PoiArgs {
    /// The POIs in order (--poi first, then the CSV). No POI at all, or two with the same
    /// id, is a usage error.
    pub fn points(&self) -> anyhow::Result<Vec<Poi>> {
        let mut out = Vec::new();
        for (i, t) in self.poi.iter().enumerate() {
            let at = format!("--poi {t}");
            out.push(Located {
                poi: parse_poi_at(t, i, &at)?,
                at,
            });
        }
        if let Some(f) = &self.pois {
            out.extend(read_pois_csv(f)?);
        }
        if out.is_empty() {
            bail!("no point of interest: give --poi X,Y,Z[,NX,NY,NZ] or --pois FILE.csv");
        }
        check_pois(&out)?;
        Ok(out.into_iter().map(|l| l.poi).collect())
    }

    /// Size the thread pool (`--jobs`) and read the inputs into a [`Scene`] (with progress),
    /// each failure said on stderr; `None` when nothing could be read, else the scene checked
    /// ([`Scene::check`]: inputs in different CRSs unless --allow-mixed-crs, no heights).
    pub fn scene(&self) -> anyhow::Result<Option<Scene>> {
        self.jobs.global()?;
        let inputs = self.inputs.iter().map(|p| Input {
            path: p.clone(),
            relative: p.clone(),
        });
        let frame = self.crs.frame_options(self.poi_margin);
        let options = SceneOptions::new(frame, self.allow_mixed_crs);
        let scene = Scene::read(inputs.collect(), &options, &crate::log::reporter())?;
        for e in scene.failures() {
            error!("{e}");
        }
        if scene.inputs().is_empty() {
            return Ok(None);
        }
        scene.check()?;
        Ok(Some(scene))
    }

    /// Frame `pois` in `scene` ([`Scene::frame`]: `--source-crs`, `--poi-crs`, POIs farther
    /// than `--poi-margin` metres outside the scene refused), the frame's warnings and note
    /// said on stderr, prefixed by `cmd`.
    pub fn study(
        &self,
        scene: Scene,
        pois: Vec<Poi>,
        shard: Option<Shard>,
        spool: Spool,
        cmd: &str,
    ) -> anyhow::Result<Session> {
        let failed = !scene.failures().is_empty();
        let study = scene.frame(pois)?;
        for w in frame_said(study.warnings(), study.frame_warning()) {
            warning!("{cmd}: warning: {w}");
        }
        study.note().iter().for_each(|n| summary!("{cmd}: {n}"));
        Ok(Session {
            read_ms: study.read_ms(),
            study,
            shard,
            failed,
            _spool: spool,
        })
    }
}
