//! Step 4: each input file written with its assets at their levels.

use super::Levels;
use crate::export::citygml_via_cityjson::{
    is_cityjson_source, write_citygml_levels, write_citygml_levels_to,
};
use crate::export::{Content, Format};
use crate::io::citygml::write::WriteOptions;
use crate::io::citygml::WriteError;
use crate::lod::mixed::{write_mixed, write_mixed_to, MixedSource};
use crate::model::runtime::progress::{check, Cancelled, Progress, Stage};
use crate::model::CityModel;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// What `write_levels` wrote.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
#[non_exhaustive]
pub struct Written {
    /// Bytes written (before compression).
    pub bytes: u64,
    /// Assets of the file per level (CityGML only; zeros for other formats).
    pub levels: [usize; 3],
    /// Asset polygons of the file in the input (CityGML only).
    pub polygons_in: usize,
    /// Asset polygons written (CityGML only).
    pub polygons_out: usize,
    /// Buildings (top-level) left out because nothing of them was kept.
    pub buildings_dropped: usize,
    /// Building parts left out because nothing of them was kept (CityGML: a part removed
    /// with its dropped building is not counted; other formats: every such part).
    pub parts_dropped: usize,
    /// What the OBJ / CityJSON writer wrote (formats other than CityGML).
    pub export: Option<crate::export::ExportSummary>,
}

/// Write `src` to `out` in `format` with every asset at its level; `out`'s missing parent
/// folders are created. `src` is a file of the model as read, e.g.
/// `(framed.source, 0)` ([`Framed::source`](super::Framed::source)), or a document read
/// hollow (`MixedSource::Hollow`: CityGML only, the polygons the writer needs read back,
/// the bytes of the whole read's).
///
/// # Errors
/// [`WriteError`] (the target is checked first; nothing partial is left behind).
pub fn write_levels<'a>(
    src: impl Into<MixedSource<'a>>,
    levels: &Levels,
    out: &Path,
    format: Format,
    wopts: &WriteOptions,
) -> Result<Written, WriteError> {
    make_parent(out)?;
    let (model, file) = match src.into() {
        MixedSource::Whole(model, file) => (model, file),
        _ if format != Format::CityGml => {
            return Err(WriteError::Invalid(format!(
                "{format:?} is written from the whole read, not a hollow one"
            )))
        }
        hollow => {
            let s = write_mixed(hollow, levels.rough_source(), levels.levels(), out, wopts)?;
            return Ok(mixed_written(s));
        }
    };
    if format == Format::CityGml && is_cityjson_source(model, file) {
        let s = write_citygml_levels(model, file, content(levels), out, wopts)?;
        return Ok(via_cityjson_written(model, file, levels, &s));
    }
    if format == Format::CityGml {
        let s = write_mixed(
            (model, file),
            levels.rough_source(),
            levels.levels(),
            out,
            wopts,
        )?;
        return Ok(mixed_written(s));
    }
    let chunks = crate::export::Chunks::model(model, file, content(levels));
    let (s, _) = crate::export::write(format, &chunks, out, wopts)?;
    Ok(export_written(model, file, levels, s))
}

/// Make `out`'s missing parent folders (a missing folder is made, not reported as a failed
/// temporary file inside it).
fn make_parent(out: &Path) -> Result<(), WriteError> {
    if let Some(dir) = out
        .parent()
        .filter(|d| !d.as_os_str().is_empty() && !d.exists())
    {
        if !crate::io::files::is_stdout(out) {
            std::fs::create_dir_all(dir).map_err(|source| WriteError::Io {
                file: dir.to_path_buf(),
                source,
            })?;
        }
    }
    Ok(())
}

/// [`write_levels`] into any writer `w` (uncompressed, no target checks: of `wopts` only
/// `keep_envelopes` matters). A model read from memory or standard input is written as one
/// read from a file.
///
/// # Errors
/// [`WriteError`].
pub fn write_levels_to(
    model: &CityModel,
    file: usize,
    levels: &Levels,
    w: &mut dyn std::io::Write,
    format: Format,
    wopts: &WriteOptions,
) -> Result<Written, WriteError> {
    if format == Format::CityGml && is_cityjson_source(model, file) {
        let s = write_citygml_levels_to(model, file, content(levels), w)?;
        return Ok(via_cityjson_written(model, file, levels, &s));
    }
    if format == Format::CityGml {
        let (rough, lv) = (levels.rough_source(), levels.levels());
        let s = write_mixed_to(model, file, rough, lv, w, wopts)?;
        return Ok(mixed_written(s));
    }
    let chunks = crate::export::Chunks::model(model, file, content(levels));
    let (s, _) = crate::export::write_to(format, &chunks, w)?;
    Ok(export_written(model, file, levels, s))
}

fn content(levels: &Levels) -> Content<'_> {
    Content::Levels {
        rough: levels.rough_source(),
        levels: levels.levels(),
    }
}

/// What CityGML written from a CityJSON source ([`crate::export::citygml_via_cityjson`])
/// reports: the file's assets per level, their detail polygons, the polygons written.
fn via_cityjson_written(
    model: &CityModel,
    file: usize,
    levels: &Levels,
    s: &crate::export::citygml_from_cityjson::FromCityJsonSummary,
) -> Written {
    let mut per_level = [0usize; 3];
    let mut polygons_in = 0;
    for (i, a) in model
        .assets
        .iter()
        .enumerate()
        .filter(|(_, a)| a.file == file)
    {
        let l = levels.levels().get(i).copied().unwrap_or(2).min(2);
        per_level[usize::from(l)] += 1;
        polygons_in += a.detail_polygons().len();
    }
    let (buildings_dropped, parts_dropped) =
        buildings_without_kept_assets(model, file, levels.levels());
    Written {
        bytes: s.bytes_out,
        levels: per_level,
        polygons_in,
        polygons_out: s.polygons,
        buildings_dropped,
        parts_dropped,
        export: None,
    }
}

fn mixed_written(s: crate::lod::mixed::MixedSummary) -> Written {
    Written {
        bytes: s.bytes,
        levels: s.levels,
        polygons_in: s.polygons_in,
        polygons_out: s.polygons_out,
        buildings_dropped: s.buildings_dropped,
        parts_dropped: s.parts_dropped,
        export: None,
    }
}

fn export_written(
    model: &CityModel,
    file: usize,
    levels: &Levels,
    s: crate::export::ExportSummary,
) -> Written {
    let (buildings_dropped, parts_dropped) =
        buildings_without_kept_assets(model, file, levels.levels());
    Written {
        bytes: s.bytes,
        buildings_dropped,
        parts_dropped,
        export: Some(s),
        ..Written::default()
    }
}

/// [`write_levels`] for each `(file, output)` pair, files in parallel ([`Stage::Write`],
/// cancellable between files); one result per pair, in the order of `targets`.
///
/// # Errors
/// [`Cancelled`] when `progress` asks to stop (files already written stay).
pub fn write_all(
    model: &CityModel,
    targets: &[(usize, PathBuf)],
    levels: &Levels,
    format: Format,
    wopts: &WriteOptions,
    progress: &dyn Progress,
) -> Result<Vec<Result<Written, WriteError>>, Cancelled> {
    progress.start(Stage::Write, targets.len() as u64, 0);
    // Files in parallel (the caller's rayon pool); results in the order of `targets`.
    let out: Result<Vec<_>, Cancelled> = targets
        .par_iter()
        .map(|(f, path)| {
            check(progress, Stage::Write)?;
            let r = write_levels((model, *f), levels, path, format, wopts);
            progress.advance(Stage::Write, 1, 0, Some(&path.display().to_string()));
            Ok(r)
        })
        .collect();
    progress.finish(Stage::Write);
    out
}

/// `files` of `model` (in input order) merged into one OBJ, CityJSON or CityJSONSeq file at
/// `out` with every asset at its level (`crate::export::merge::write_merged`: one origin,
/// the CityGML merge's ids); `out`'s missing parent folders are created. What was written,
/// counted over all of `files` (buildings and parts dropped summed).
///
/// # Errors
/// [`WriteError`]; [`WriteError::Invalid`] for [`Format::CityGml`] (merged by
/// `crate::export::merge` from the per-file documents).
pub fn write_merged_levels(
    model: &CityModel,
    files: &[usize],
    levels: &Levels,
    out: &Path,
    format: Format,
    wopts: &WriteOptions,
) -> Result<Written, WriteError> {
    if format == Format::CityGml {
        return Err(WriteError::Invalid(
            "a CityGML merge is merged from the per-file documents".into(),
        ));
    }
    if let Some(dir) = out
        .parent()
        .filter(|d| !d.as_os_str().is_empty() && !d.exists() && !crate::io::files::is_stdout(out))
    {
        std::fs::create_dir_all(dir).map_err(|source| WriteError::Io {
            file: dir.to_path_buf(),
            source,
        })?;
    }
    let s = crate::export::merge::write_merged(format, model, files, content(levels), out, wopts)?;
    let (mut buildings_dropped, mut parts_dropped) = (0, 0);
    for &f in files {
        let (b, p) = buildings_without_kept_assets(model, f, levels.levels());
        buildings_dropped += b;
        parts_dropped += p;
    }
    Ok(Written {
        bytes: s.bytes,
        buildings_dropped,
        parts_dropped,
        export: Some(s),
        ..Written::default()
    })
}

/// Buildings and parts of file `f` that keep no asset (through any part below them): what
/// the OBJ and CityJSON writers leave out, as `(buildings, parts)` (top-level buildings, then
/// building parts).
pub fn buildings_without_kept_assets(model: &CityModel, f: usize, levels: &[u8]) -> (usize, usize) {
    let mut kept = vec![false; model.buildings.len()];
    for (a, l) in model.assets.iter().zip(levels) {
        if *l == 0 {
            continue;
        }
        let mut b = a.building;
        let mut steps = 0;
        while let Some(k) = b {
            if let Some(x) = kept.get_mut(k) {
                *x = true;
            }
            b = model.buildings.get(k).and_then(|x| x.parent);
            steps += 1;
            if steps > model.buildings.len() {
                break;
            }
        }
    }
    let dropped = |part: bool| {
        model
            .buildings
            .iter()
            .zip(&kept)
            .filter(|(b, k)| b.file == f && !**k && b.is_part == part)
            .count()
    };
    (dropped(false), dropped(true))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::test_support::*;
    use crate::pipeline::{levels, read_inputs, FrameOptions, LevelsOptions};

    #[test]
    fn every_stage_advances_as_far_as_it_announced() {
        let tally = Tally::default();
        let size = std::fs::metadata(fixture()).unwrap().len();
        let mut inputs = read_inputs(&[fixture()], &tally).unwrap();
        assert_eq!(tally.sum(Stage::Read, "start"), (1, size));
        assert_eq!(tally.sum(Stage::Read, "advance"), (1, size));
        let pois = grid_pois(&inputs.model, 5);
        let framed = frame(&mut inputs.model, pois, &FrameOptions::default()).unwrap();
        let lv = levels(&framed, &LevelsOptions::default(), &tally).unwrap();
        assert_eq!(tally.sum(Stage::Select, "start").0, 5);
        assert_eq!(tally.sum(Stage::Select, "advance").0, 5);
        let n = framed.source.assets.len() as u64;
        assert_eq!(tally.sum(Stage::Rough, "advance").0, n);
        let dir = tempfile::tempdir().unwrap();
        let targets = vec![(0, dir.path().join("a.gml")), (0, dir.path().join("b.gml"))];
        let w = write_all(
            framed.source,
            &targets,
            &lv,
            Format::CityGml,
            &WriteOptions::default(),
            &tally,
        )
        .unwrap();
        assert!(w.iter().all(Result::is_ok));
        // A missing folder is created (it used to fail naming a temporary file in it).
        let deep = dir.path().join("x/y/c.gml");
        write_levels(
            (framed.source, 0),
            &lv,
            &deep,
            Format::CityGml,
            &WriteOptions::default(),
        )
        .unwrap();
        assert!(deep.is_file());
        assert_eq!(tally.sum(Stage::Write, "start").0, 2);
        assert_eq!(tally.sum(Stage::Write, "advance").0, 2);
    }
}
