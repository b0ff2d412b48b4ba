//! Several files of a model in one OBJ, CityJSON or CityJSONSeq file (`lod tiles/*.gml -o
//! street.obj`): the scene as the CityGML merge ([`super::merge_named`]) would hold it, then
//! written as one file is.
//!
//! * **Ids**: the plan's rule ([`super::rename_ids`] over every `gml:id` of each input): the
//!   first input keeps its ids, an id a later input `k` (1-based) shares with an earlier one
//!   becomes `<id>__<k>`. The objects are named from the renamed ids as one file's are
//!   ([`crate::model::CityModel::asset_name`]).
//! * **One origin**: the OBJ origin and CityJSON's `transform` are picked over the whole
//!   scene as the single-file writers pick them over one file (the centre of all the geometry
//!   written, rounded to whole metres; the floor of its lower corner).
//! * **One CRS**: that of the first input (the inputs were checked before any work, as for
//!   the CityGML merge: [`super::check_mergeable`]).
//!
//! `convert` does not hold the scene: it merges the inputs into a staged CityGML document and
//! streams that ([`crate::export::Chunks::Stream`]), so its output is, by construction, the
//! CityGML merge converted. `lod` holds the scene and writes it through
//! [`write_merged`]: a view of the model with one file ([`view`]).

use super::citygml::document_ids;
use super::rename_ids;
use crate::export::{Content, ExportSummary, Format};
use crate::io::citygml::write::WriteOptions;
use crate::io::citygml::{ReadError, WriteError};
use crate::model::CityModel;
use std::collections::HashMap;
use std::path::Path;

/// The renaming of each of `files` (indices into `model.files`, in merge order): the
/// plan's ([`rename_ids`]) over every `gml:id` of each document; a CityJSON input (no
/// `gml:id`s to scan) gives its buildings' and assets' ids.
fn renames(model: &CityModel, files: &[usize]) -> Result<Vec<HashMap<String, String>>, ReadError> {
    let mut ids: Vec<Vec<String>> = Vec::with_capacity(files.len());
    for &f in files {
        let Some(src) = model.files.get(f) else {
            ids.push(Vec::new());
            continue;
        };
        match src.source.path() {
            Some(p) if src.cityjson.is_none() => ids.push(document_ids(p)?),
            _ => ids.push(model_ids(model, f)),
        }
    }
    let lists: Vec<&[String]> = ids.iter().map(Vec::as_slice).collect();
    Ok(rename_ids(&lists))
}

/// The buildings' then the assets' ids of file `f`, each once, in model order.
fn model_ids(model: &CityModel, f: usize) -> Vec<String> {
    let mut seen = std::collections::HashSet::new();
    let buildings = model
        .buildings
        .iter()
        .filter(|b| b.file == f)
        .filter_map(|b| b.id.clone());
    let assets = model
        .assets
        .iter()
        .filter(|a| a.file == f)
        .filter_map(|a| a.id.as_ref().map(|s| s.to_string()));
    buildings
        .chain(assets)
        .filter(|id| seen.insert(id.clone()))
        .collect()
}

/// How a merge of `files` of `model` is named where one file's name goes ([`super::label`]).
pub(crate) fn model_label(model: &CityModel, files: &[usize]) -> String {
    let first = files.first().and_then(|&f| model.files.get(f));
    super::label(first.map(|f| f.path.as_path()), files.len())
}

/// `model` with `files` (in merge order) as its one file, 0, and their ids renamed by
/// `renames` (one map per file, [`renames`]): what the single-file writers write as the
/// merge. File 0 is the first input's, named [`model_label`], without its CityJSON origin (the
/// attributes a CityJSON source carries beyond the model are not copied into a merge). Every
/// asset and building keeps its index (so [`Content::Levels`] applies unchanged); those of
/// other files belong to no file of the view.
fn view(model: &CityModel, files: &[usize], renames: &[HashMap<String, String>]) -> CityModel {
    let slot = |f: usize| files.iter().position(|&g| g == f);
    let mut v = model.clone();
    let mut first = files
        .first()
        .and_then(|&f| model.files.get(f))
        .cloned()
        .into_iter()
        .collect::<Vec<_>>();
    for f in &mut first {
        f.path = model_label(model, files).into();
        f.cityjson = None;
    }
    v.files = first;
    for b in &mut v.buildings {
        match slot(b.file) {
            Some(k) => {
                b.file = 0;
                if let Some(new) = b.id.as_ref().and_then(|id| renames.get(k)?.get(id)) {
                    b.id = Some(new.clone());
                }
            }
            None => b.file = usize::MAX,
        }
    }
    for a in &mut v.assets {
        match slot(a.file) {
            Some(k) => {
                a.file = 0;
                if let Some(new) =
                    a.id.as_ref()
                        .and_then(|id| renames.get(k)?.get(id.as_str()))
                {
                    a.id = Some(new.as_str().into());
                }
            }
            None => a.file = usize::MAX,
        }
    }
    v
}

/// Write `files` of `model` (in merge order) as one `format` file at `out` (module docs),
/// atomically, refusing to write over any of their sources or, without `overwrite`, over an
/// existing file. The view (the model with the inputs as one file) is a copy of the model
/// while it is written.
///
/// # Errors
/// [`WriteError`] as [`crate::export::write()`]; an input whose ids cannot be scanned.
pub fn write_merged(
    format: Format,
    model: &CityModel,
    files: &[usize],
    content: Content<'_>,
    out: &Path,
    opts: &WriteOptions,
) -> Result<ExportSummary, WriteError> {
    let protect = files
        .iter()
        .filter_map(|&f| model.files.get(f)?.source.path());
    crate::io::citygml::write::check_target(out, opts, protect)?;
    if files.is_empty() {
        return Err(WriteError::Invalid("no file to merge".into()));
    }
    let renames = renames(model, files)?;
    let v = view(model, files, &renames);
    let chunks = crate::export::Chunks::model(&v, 0, content);
    if format == Format::Tiles {
        // a folder of files, staged and moved into place by its writer
        return crate::export::write(format, &chunks, out, opts).map(|(s, _)| s);
    }
    let mut summary = ExportSummary::default();
    let bytes = crate::io::citygml::write::atomic_write(out, |w| {
        summary = crate::export::write_to(format, &chunks, w)?.0;
        Ok(summary.bytes)
    })?;
    summary.bytes = bytes;
    Ok(summary)
}
