//! Every input of a `convert` batch: [`convert_file`] on each target to do, in parallel on
//! the current rayon pool, with [`Stage::Read`] counting the inputs and their bytes. A merge
//! into another format than CityGML converts to CityGML parts first
//! ([`Batch::finish`] converts the merge).

use super::convert::{chunk_for, convert_file, ConvertError, ConvertOptions};
use super::run::{Batch, Done};
use crate::export::citygml_from_cityjson::TargetVersion;
use crate::export::Format;
use crate::model::runtime::progress::{Progress, Stage};
use rayon::prelude::*;
use std::path::PathBuf;

/// One input's result in a batch: `(input, output, result)`.
pub type Result1 = (PathBuf, PathBuf, Result<Done, ConvertError>);

/// [`convert_file`] on every target of `batch` (`paths`: its inputs), CityJSON inputs written
/// as CityGML `version`, large files streamed by `chunk` ([`chunk_for`]); `note` hears why a
/// file meant to be streamed was read whole, `written` the line of each OBJ or CityJSON
/// output as soon as it is written (a CityGML output's line is its [`Done`]'s). The results in
/// input order, for [`Batch::finish`].
pub fn convert_all(
    batch: &Batch,
    paths: &[PathBuf],
    (version, chunk): (TargetVersion, u64),
    progress: &dyn Progress,
    note: &(dyn Fn(String) + Sync),
    written: &(dyn Fn(String) + Sync),
) -> Vec<Result1> {
    let t = &batch.targets;
    let format = t.staging.as_ref().map_or(batch.format, |_| Format::CityGml);
    let size = |k: usize| paths[k].metadata().map_or(0, |m| m.len());
    let bytes: u64 = t.todo.iter().map(|(k, _)| size(*k)).sum();
    progress.start(Stage::Read, t.todo.len() as u64, bytes);
    let results = (t.todo.par_iter())
        .map(|(k, out)| {
            let o = ConvertOptions {
                format,
                version,
                write: &t.write_opts,
                mirror: t.mirror,
                chunk: chunk_for(&paths[*k], chunk),
            };
            let r = convert_file(&paths[*k], out, &o, progress, note);
            if let Ok(Some(line)) = r.as_ref().map(|c| &c.written) {
                written(line.clone());
            }
            progress.advance(Stage::Read, 1, 0, None);
            (paths[*k].clone(), out.clone(), r.map(|c| c.done))
        })
        .collect();
    progress.finish(Stage::Read);
    results
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::runtime::progress::Silent;
    use crate::pipeline::batch::inputs::Input;
    use std::path::Path;
    use std::sync::Mutex;

    fn inputs() -> Vec<Input> {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
        ["rough/courtyard-lod1.gml", "rough/l-shape-lod1.gml"]
            .iter()
            .map(|n| Input {
                path: dir.join(n),
                relative: PathBuf::from(n),
            })
            .collect()
    }

    /// The results and the lines said; the batch too, whose staging directory lives as long.
    fn run(to: &Path, format: Format) -> (Vec<Result1>, Vec<String>, Batch) {
        let inputs = inputs();
        let paths: Vec<PathBuf> = inputs.iter().map(|i| i.path.clone()).collect();
        let batch = Batch::new(&inputs, (to, Some(format), false), false, None).unwrap();
        let said = Mutex::new(Vec::new());
        let written = |l: String| said.lock().unwrap().push(l);
        let v = (TargetVersion::V2_0, 0);
        let r = convert_all(&batch, &paths, v, &Silent, &|_| {}, &written);
        (r, said.into_inner().unwrap(), batch)
    }

    #[test]
    fn obj_lines_are_said_as_written_citygml_lines_are_the_batch_s() {
        let dir = tempfile::tempdir().unwrap();
        let (r, said, _) = run(&dir.path().join("obj"), Format::Obj);
        assert_eq!(r.len(), 2);
        assert_eq!(said.len(), 2, "{said:?}");
        for (input, out, done) in &r {
            assert!(done.as_ref().unwrap().line.is_none());
            assert!(out.exists() && out.extension().unwrap() == "obj");
            let name = input.file_stem().unwrap().to_string_lossy();
            assert!(said.iter().any(|l| l.contains(&*name)));
        }
        let (r, said, _) = run(&dir.path().join("gml"), Format::CityGml);
        assert!(said.is_empty());
        assert!(r
            .iter()
            .all(|(_, o, d)| o.exists() && d.as_ref().unwrap().line.is_some()));
    }

    #[test]
    fn a_merge_into_obj_writes_citygml_parts() {
        let dir = tempfile::tempdir().unwrap();
        let (r, said, batch) = run(&dir.path().join("all.obj"), Format::Obj);
        assert!(batch.targets.staging.is_some());
        assert!(said.is_empty(), "{said:?}");
        for (_, part, d) in &r {
            assert!(d.is_ok());
            assert!(std::fs::read_to_string(part).unwrap().contains("CityModel"));
        }
    }
}
