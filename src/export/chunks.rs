//! What an export is written from ([`Chunks`]): the writers go over their source in passes,
//! a chunk at a time, so that one writer serves a document read in chunks (memory follows
//! the chunk) and a model in memory (one chunk, each pass a walk over it, never a second
//! read).

use super::cityjson_source::FromSource;
use super::Content;
use crate::io::citygml::read::{Chunk, Passes, StreamSummary};
use crate::io::citygml::WriteError;
use crate::model::{Asset, AssetKind, Building, CityModel};
use serde_json::{Map, Value};
use std::collections::BTreeMap;
use std::path::Path;

/// The source of an export, handed to its writer one chunk at a time.
#[derive(Debug, Clone, Copy)]
pub enum Chunks<'a> {
    /// File `file` of a model in memory: one chunk, every asset written as `content` says.
    Model {
        /// The model.
        model: &'a CityModel,
        /// The file written (its assets and buildings).
        file: usize,
        /// What each asset contributes.
        content: Content<'a>,
        /// CityJSON only: extra members of the semantic surface objects of some assets (asset
        /// index → members: the per-surface results of `crate::pipeline::attributes`).
        surface_attributes: Option<&'a BTreeMap<usize, Map<String, Value>>>,
    },
    /// The document at `path` read in streamed passes ([`Passes`]; [`Content::Full`]), named
    /// `label` (where given) instead of its path in what the output says of its source (the
    /// OBJ's comment line: a merge's staged document is named by its inputs).
    Stream {
        /// The document.
        path: &'a Path,
        /// Its name in the output, when not its path's.
        label: Option<&'a str>,
        /// The settings of the passes.
        passes: &'a Passes<'a>,
    },
}

/// One chunk of [`Chunks`] as a writer's pass sees it: a model, the file of it written, and
/// where the chunk stands in the whole document.
pub(super) struct Part<'a> {
    pub(super) model: &'a CityModel,
    pub(super) file: usize,
    pub(super) content: Content<'a>,
    /// Position of the chunk (0 for the first; a model's one chunk is 0).
    pub(super) index: usize,
    /// Buildings (and parts) in earlier chunks.
    pub(super) buildings_before: usize,
    /// Assets other than bodies in earlier chunks.
    pub(super) assets_before: usize,
    /// Body assets in earlier chunks.
    pub(super) bodies_before: usize,
    /// A streamed chunk's bodies come after every other asset of the whole document
    /// ([`Chunk`]); a model's assets are in document order already.
    bodies_apart: bool,
    /// A CityJSON chunk's attributes and semantic surface members, copied to its output.
    pub(super) from_source: Option<&'a FromSource>,
}

impl<'a> Chunks<'a> {
    /// File `file` of `model`, every asset as `content` says.
    pub fn model(model: &'a CityModel, file: usize, content: Content<'a>) -> Self {
        Chunks::Model {
            model,
            file,
            content,
            surface_attributes: None,
        }
    }

    /// Pass `k` over the chunks (told to [`Passes::passed`] as pass `k`'s bytes): `each` sees
    /// every chunk in document order. The document's summary (a model's: of its file as one
    /// chunk), or `None` where the stream declines (what the pass did is to be dropped).
    ///
    /// # Errors
    /// Errors of `each`.
    pub(super) fn pass<E>(
        &self,
        k: usize,
        mut each: impl FnMut(&Part<'_>) -> Result<(), E>,
    ) -> Result<Option<StreamSummary>, E> {
        match *self {
            Chunks::Model {
                model,
                file,
                content,
                ..
            } => {
                each(&Part {
                    model,
                    file,
                    content,
                    index: 0,
                    buildings_before: 0,
                    assets_before: 0,
                    bodies_before: 0,
                    bodies_apart: false,
                    from_source: None,
                })?;
                Ok(Some(summary(model, file)))
            }
            Chunks::Stream { path, passes, .. } => passes.pass(path, k, |c: Chunk| {
                each(&Part {
                    model: &c.model,
                    file: 0,
                    content: Content::Full,
                    index: c.index,
                    buildings_before: c.buildings_before,
                    assets_before: c.assets_before,
                    bodies_before: c.bodies_before,
                    bodies_apart: true,
                    from_source: c.source.as_ref(),
                })
            }),
        }
    }

    /// The source's checks before anything is written: a model's file exists and its
    /// `content` has one entry per asset. The input file not to write over, if any.
    pub(super) fn check(&self) -> Result<Option<&'a Path>, WriteError> {
        let (model, file, content) = match *self {
            Chunks::Stream { path, .. } => return Ok(Some(path)),
            Chunks::Model {
                model,
                file,
                content,
                ..
            } => (model, file, content),
        };
        if let Content::Levels { rough, levels } = content {
            crate::lod::mixed::check_per_asset(model, rough, levels)?;
        }
        let src = crate::io::citygml::write::source_file(model, file)?;
        Ok(src.source.path())
    }

    /// How the output names its source: the label, or the file's name.
    pub(super) fn label(&self) -> String {
        match *self {
            Chunks::Model { model, file, .. } => model
                .files
                .get(file)
                .map(|f| crate::model::shown(&f.path).to_string())
                .unwrap_or_default(),
            Chunks::Stream { path, label, .. } => {
                label.map_or_else(|| crate::model::shown(path).to_string(), str::to_string)
            }
        }
    }
}

/// A model's file as the summary of a stream of one chunk (its warnings: the model's).
fn summary(model: &CityModel, file: usize) -> StreamSummary {
    let f = model.files.get(file);
    let assets = model.assets.iter().filter(|a| a.file == file);
    let bodies = assets.clone().filter(|a| a.kind == AssetKind::Body).count();
    StreamSummary {
        chunks: 1,
        version: f.map(|f| f.version),
        srs_name: f.and_then(|f| f.srs_name.clone()),
        buildings: model.buildings.iter().filter(|b| b.file == file).count(),
        assets: assets.count() - bodies,
        bodies,
        warnings: model.warnings.len(),
        ..StreamSummary::default()
    }
}

impl<'a> Part<'a> {
    /// The assets of the file, with their indices in the part's model.
    pub(super) fn assets(&self) -> impl Iterator<Item = (usize, &'a Asset)> {
        let (f, all) = (self.file, self.model.assets.iter());
        all.enumerate().filter(move |(_, a)| a.file == f)
    }

    /// The buildings (and parts) of the file, with their indices in the part's model.
    pub(super) fn buildings(&self) -> impl Iterator<Item = (usize, &'a Building)> {
        let (f, all) = (self.file, self.model.buildings.iter());
        all.enumerate().filter(move |(_, b)| b.file == f)
    }

    /// The assets a pass in document order writes of this part: in the pass over the
    /// document's assets (`bodies` false), or in the one over the bodies that come apart after
    /// them (a streamed chunk's); each with its index in the part's model and in the whole
    /// document's (`assets`: the document's assets other than bodies).
    pub(super) fn in_order(
        &self,
        bodies: bool,
        assets: usize,
    ) -> impl Iterator<Item = (usize, &'a Asset, usize)> + '_ {
        let apart = self.bodies_apart;
        // a streamed chunk's bodies come after its other assets
        let first_body = if apart {
            self.assets()
                .filter(|(_, a)| a.kind != AssetKind::Body)
                .count()
        } else {
            usize::MAX
        };
        self.assets()
            .filter(move |(_, a)| match apart {
                true => (a.kind == AssetKind::Body) == bodies,
                false => !bodies,
            })
            .map(move |(i, a)| {
                let global = match i.checked_sub(first_body) {
                    Some(k) => assets + self.bodies_before + k,
                    None => self.assets_before + i,
                };
                (i, a, global)
            })
    }
}
