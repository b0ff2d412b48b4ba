//! The outputs of a `lod` run: laid out and checked before any input is read
//! ([`LodLayout::new`], [`check_report`]), then every file of the model written at its levels
//! and, for a merge, the staged parts merged into the target ([`LodLayout::write`]). Nothing
//! is printed: what to tell the user comes back in order.

use super::{Result, Study};
use crate::export::report::report::Report;
use crate::export::Format;
use crate::io::citygml::write::{atomic_write_bytes, check_target, is_stdout, WriteOptions};
use crate::io::citygml::WriteError;
use crate::model::runtime::progress::Progress;
use crate::model::CityModel;
use crate::pipeline::batch::outputs::Plan;
use crate::pipeline::batch::run::{merge_parts, Batch, Said};
use crate::pipeline::{buildings_without_kept_assets, write_merged_levels, Levels, Written};
use std::path::{Path, PathBuf};

/// Why the outputs of a `lod` run cannot be laid out.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LodLayoutError {
    /// Some targets were refused: one scene needs every input, so nothing is done.
    #[error("{refused} output(s) refused (above): lod writes every input's model, nothing done")]
    Refused {
        /// Targets refused.
        refused: usize,
    },
    /// The model and the report both name standard output.
    #[error("the model and the report cannot both go to standard output")]
    BothStdout,
}

/// Where the model goes, laid out before any input is read.
#[derive(Debug)]
pub struct LodLayout {
    /// The batch of the outputs (plan, format, targets).
    pub batch: Batch,
    /// The output of each input (in input order), `None` when it is not written.
    outputs: Vec<Option<PathBuf>>,
}

/// What happened to one file of the model, in file order.
#[derive(Debug)]
pub enum FileOutcome {
    /// Written: its summary line.
    Written(String),
    /// Not written.
    Failed(WriteError),
}

/// What [`LodLayout::write`] did.
#[derive(Debug, Default)]
pub struct LodWritten {
    /// Per file written or failed, in file order.
    pub files: Vec<FileOutcome>,
    /// What the merge says (nothing without a merge).
    pub merge: Vec<Said>,
    /// Per file of the model: the output's name shown (the merge target for a part) and the
    /// buildings and parts dropped; `None` when not written.
    pub written: Vec<Option<(String, usize)>>,
    /// Whether some output failed.
    pub failed: bool,
}

impl LodLayout {
    /// The layout of `batch` ([`Batch::new`] for every input, its refused targets reported
    /// by the caller): every target must be writable, since a refusal after minutes of
    /// reading and tracing helps nobody and one scene needs every input.
    ///
    /// # Errors
    /// `LodLayoutError::Refused`.
    pub fn new(batch: Batch, inputs: usize) -> std::result::Result<LodLayout, LodLayoutError> {
        if batch.refused > 0 {
            let refused = batch.refused;
            return Err(LodLayoutError::Refused { refused });
        }
        let mut outputs: Vec<Option<PathBuf>> = vec![None; inputs];
        for (k, out) in &batch.targets.todo {
            if let Some(o) = outputs.get_mut(*k) {
                *o = Some(out.clone());
            }
        }
        Ok(LodLayout { batch, outputs })
    }

    /// `(file of model, output)` for every file of `model` whose input (among
    /// `all_inputs`, the inputs laid out) has an output.
    pub fn targets(&self, model: &CityModel, all_inputs: &[PathBuf]) -> Vec<(usize, PathBuf)> {
        (model.files.iter().enumerate())
            .filter_map(|(f, src)| {
                let k = all_inputs.iter().position(|p| p == &src.path)?;
                Some((f, self.outputs.get(k)?.clone()?))
            })
            .collect()
    }

    /// Every file of the study's model written at the levels `lv` to its target (files in
    /// parallel; read hollow, the one document a chunk at a time), then, for a merge, the
    /// staged parts merged into the target (OBJ and CityJSON: merged as they are written,
    /// `write_merged_levels`). A file that fails is reported and the others written.
    ///
    /// # Errors
    /// [`super::Error::Cancelled`], [`super::Error::Io`] (a mirrored folder not made).
    pub fn write(
        &self,
        study: &mut Study,
        all_inputs: &[PathBuf],
        lv: &Levels,
        progress: &dyn Progress,
    ) -> Result<LodWritten> {
        let targets = self.targets(study.source(), all_inputs);
        self.make_folders(&targets)?;
        let batch = &self.batch;
        let (format, wopts) = (batch.format, &batch.targets.write_opts);
        if let (Some(_), Plan::Merge(t)) = (&batch.targets.staging, &batch.plan) {
            if format != Format::CityGml {
                return Ok(merged_export(study.whole()?, &targets, t, lv, batch));
            }
        }
        let results = study.write_targets(&targets, lv, format, wopts, progress)?;
        Ok(self.done(study.source(), &targets, results))
    }

    fn make_folders(&self, targets: &[(usize, PathBuf)]) -> Result<()> {
        if self.batch.targets.mirror {
            for (_, out) in targets {
                crate::pipeline::batch::outputs::create_parent(out)?;
            }
        }
        Ok(())
    }

    /// What writing `targets` of `model` gave (`results`, in their order), with the merge
    /// when the layout says so.
    fn done(
        &self,
        model: &CityModel,
        targets: &[(usize, PathBuf)],
        results: Vec<std::result::Result<Written, WriteError>>,
    ) -> LodWritten {
        let batch = &self.batch;
        let shown = |out: &Path| batch.shown(out).display().to_string();
        let format = batch.format;
        let mut done = LodWritten {
            written: vec![None; model.files.len()],
            ..LodWritten::default()
        };
        for ((f, out), r) in targets.iter().zip(results) {
            let s = match r {
                Ok(s) => s,
                Err(e) => {
                    done.files.push(FileOutcome::Failed(e));
                    done.failed = true;
                    continue;
                }
            };
            let input = &model.files[*f].path;
            let line = match &s.export {
                Some(e) => e.describe(format, input, out),
                None => format!(
                    "{} -> {}: assets at level 0/1/2 = {}/{}/{}, polygons {} -> {}, {} building(s) and {} part(s) dropped",
                    crate::model::shown(input),
                    shown(out),
                    s.levels[0],
                    s.levels[1],
                    s.levels[2],
                    s.polygons_in,
                    s.polygons_out,
                    s.buildings_dropped,
                    s.parts_dropped
                ),
            };
            done.files.push(FileOutcome::Written(line));
            if let Some(w) = done.written.get_mut(*f) {
                *w = Some((shown(out), s.buildings_dropped + s.parts_dropped));
            }
        }
        if let (Some(st), Plan::Merge(t)) = (&batch.targets.staging, &batch.plan) {
            let (parts, names): (Vec<PathBuf>, Vec<PathBuf>) = targets
                .iter()
                .filter(|(f, _)| done.written.get(*f).is_some_and(Option::is_some))
                .map(|(f, out)| (out.clone(), model.files[*f].path.clone()))
                .unzip();
            let to = (t.as_path(), batch.format);
            let (merged, said) = merge_parts(&parts, &names, to, st, &batch.wopts, targets.len());
            done.merge = said;
            if !merged {
                done.failed = true;
                done.written.iter_mut().for_each(|w| *w = None);
            }
        }
        done
    }
}

/// Several inputs merged into one OBJ / CityJSON / CityJSONSeq file `target`, written from
/// the model in memory ([`crate::pipeline::write_merged_levels`]): one line for the merged
/// file, every input's buildings dropped counted under the target's name.
fn merged_export(
    model: &CityModel,
    targets: &[(usize, PathBuf)],
    target: &Path,
    lv: &Levels,
    batch: &Batch,
) -> LodWritten {
    let files: Vec<usize> = targets.iter().map(|(f, _)| *f).collect();
    let mut done = LodWritten {
        written: vec![None; model.files.len()],
        ..LodWritten::default()
    };
    match write_merged_levels(model, &files, lv, target, batch.format, &batch.wopts) {
        Ok(s) => {
            if let Some(e) = &s.export {
                let label = crate::export::merge::model_label(model, &files);
                let line = e.describe(batch.format, Path::new(&label), target);
                done.files.push(FileOutcome::Written(line));
            }
            for &f in &files {
                let (b, p) = buildings_without_kept_assets(model, f, lv.levels());
                if let Some(w) = done.written.get_mut(f) {
                    *w = Some((target.display().to_string(), b + p));
                }
            }
        }
        Err(e) => {
            done.files.push(FileOutcome::Failed(e));
            done.failed = true;
        }
    }
    done
}

/// Check the report's target `report` before any work: not standard output when the model
/// `model_out` goes there too, never over an input, never over an existing file without
/// `overwrite`.
///
/// # Errors
/// [`ReportTargetError`].
pub fn check_report(
    report: &Path,
    model_out: &Path,
    overwrite: bool,
    inputs: &[PathBuf],
) -> std::result::Result<(), ReportTargetError> {
    if is_stdout(report) && is_stdout(model_out) {
        return Err(ReportTargetError::Layout(LodLayoutError::BothStdout));
    }
    let opts = WriteOptions {
        overwrite,
        ..Default::default()
    };
    check_target(report, &opts, inputs.iter().map(PathBuf::as_path))
        .map_err(ReportTargetError::Target)
}

/// Write the `lod` report `report` to `path` (checked by [`check_report`]) as pretty JSON and
/// a newline, atomically (`-`: standard output); the bytes written.
///
/// # Errors
/// [`WriteError`] of the target or of writing.
pub fn write_report(path: &Path, report: &Report) -> std::result::Result<u64, WriteError> {
    let json = serde_json::to_vec_pretty(report).map_err(|e| WriteError::Invalid(e.to_string()));
    let mut json = json?;
    json.push(b'\n');
    atomic_write_bytes(path, &json)
}

/// Why the report's target is refused ([`check_report`]).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReportTargetError {
    /// As the layout refuses it.
    #[error(transparent)]
    Layout(LodLayoutError),
    /// The target itself (an input, an existing file).
    #[error(transparent)]
    Target(WriteError),
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::runtime::progress::Silent;
    use crate::pipeline::batch::inputs::Input;
    use crate::pipeline::session::{Scene, SceneOptions};
    use crate::pipeline::test_support::*;
    use crate::pipeline::LevelsOptions;

    fn inputs(dir: &Path, names: &[&str]) -> Vec<Input> {
        names
            .iter()
            .map(|n| {
                let p = dir.join(n);
                std::fs::copy(fixture(), &p).unwrap();
                Input {
                    path: p,
                    relative: PathBuf::from(n),
                }
            })
            .collect()
    }

    #[test]
    fn every_file_is_written_then_merged_and_refusals_stop_everything() {
        let dir = tempfile::tempdir().unwrap();
        let ins = inputs(dir.path(), &["a.gml", "b.gml"]);
        let paths: Vec<PathBuf> = ins.iter().map(|i| i.path.clone()).collect();
        let target = dir.path().join("merged.gml");
        let batch = Batch::new(&ins, (&target, None, false), false, None).unwrap();
        let layout = LodLayout::new(batch, ins.len()).unwrap();
        let scene = Scene::load_inputs(ins.clone(), &SceneOptions::default(), &Silent).unwrap();
        let pois = grid_pois(scene.model(), 2);
        let mut study = scene.frame(pois).unwrap();
        let lv = study.levels(&LevelsOptions::default(), &Silent).unwrap();
        // Only the second input read: only it is written, to the second input's output.
        let b = Scene::load_inputs(ins[1..].to_vec(), &SceneOptions::default(), &Silent).unwrap();
        let t = layout.targets(b.model(), &paths);
        assert_eq!(t, vec![(0, layout.batch.targets.todo[1].1.clone())]);
        assert_eq!(layout.targets(study.source(), &paths).len(), 2);
        let w = layout.write(&mut study, &paths, &lv, &Silent).unwrap();
        assert!(!w.failed);
        assert_eq!(w.files.len(), 2);
        let shown = target.display().to_string();
        for (f, o) in w.files.iter().enumerate() {
            let FileOutcome::Written(line) = o else {
                panic!("{o:?}")
            };
            assert!(line.contains(&format!("-> {shown}: assets at level 0/1/2 = ")));
            assert_eq!(w.written[f].as_ref().unwrap().0, shown);
        }
        assert!(matches!(&w.merge[..], [Said::Summary(l)] if l.starts_with("merged 2 file(s)")));
        assert!(target.exists());
        // Mirrored below a folder where one output exists: refused, so nothing is done.
        let out = dir.path().join("out");
        std::fs::create_dir(&out).unwrap();
        std::fs::write(out.join("b.gml"), "x").unwrap();
        let batch = Batch::new(&ins, (&out, None, false), false, None).unwrap();
        let e = LodLayout::new(batch, ins.len()).unwrap_err();
        assert!(matches!(e, LodLayoutError::Refused { refused: 1 }), "{e}");
        assert!(e.to_string().starts_with("1 output(s) refused"));
    }

    #[test]
    fn a_report_is_refused_beside_a_model_on_stdout_or_over_an_input() {
        let dir = tempfile::tempdir().unwrap();
        let ins = [dir.path().join("in.gml")];
        std::fs::write(&ins[0], "x").unwrap();
        let dash = Path::new("-");
        let e = check_report(dash, dash, false, &ins).unwrap_err();
        assert!(matches!(
            e,
            ReportTargetError::Layout(LodLayoutError::BothStdout)
        ));
        assert!(check_report(dash, Path::new("out.gml"), false, &ins).is_ok());
        let e = check_report(&ins[0], Path::new("out.gml"), true, &ins).unwrap_err();
        assert!(matches!(e, ReportTargetError::Target(_)));
        let r = dir.path().join("r.json");
        assert!(check_report(&r, dash, false, &ins).is_ok());
        std::fs::write(&r, "{}").unwrap();
        let e = check_report(&r, dash, false, &ins).unwrap_err();
        assert!(matches!(
            e,
            ReportTargetError::Target(WriteError::Exists(_))
        ));
        assert!(check_report(&r, dash, true, &ins).is_ok());
    }
}
