//! A batch that writes per input (`convert`, `rough`, `subset`, `filter-lods`, `lod`,
//! `reproject`): its outputs planned before any work ([`Batch::new`]: [`plan`], then
//! [`Plan::targets`]), the results of the inputs gathered and several inputs merged into
//! one file ([`Batch::finish`], [`merge_parts`]). Nothing is printed: each step returns what
//! to tell the user ([`Said`]), in order.

use super::inputs::Input;
use super::outputs::{create_parent, plan, Plan, PlanError, Staging, Targets};
use super::shard::Shard;
use crate::export::merge::{label, merge_cityjson, merge_named, MergeSummary};
use crate::export::Format;
use crate::io::citygml::write::{is_stdout, WriteOptions};
use crate::io::files::Protected;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// A line for the user, at its level (an error is shown even when the others are not).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Said {
    /// What was done (an output written, a closing line).
    Summary(String),
    /// Something the user should know; the work went on.
    Warning(String),
    /// Something failed.
    Error(String),
}

/// The outputs of a batch that writes per input, laid out for an output name and a format,
/// every target checked before any work (a refused target's input fails without being
/// read: [`Targets::refused`]).
#[derive(Debug)]
pub struct Batch {
    /// Per input, mirrored or merged.
    pub plan: Plan,
    /// The format written.
    pub format: Format,
    /// The options the caller gave (a merge is written with them).
    pub wopts: WriteOptions,
    /// What to do, and where.
    pub targets: Targets,
    /// Inputs whose target was refused.
    pub refused: usize,
    /// Whether the closing line counts polygons.
    pub counts_polygons: bool,
}

/// What one input gave: its line (said in input order unless merged), its warnings and
/// polygons in and out.
#[derive(Debug, Clone, Default)]
pub struct Done {
    /// The input's summary line.
    pub line: Option<String>,
    /// Warnings of the input.
    pub warnings: usize,
    /// Polygons read and written.
    pub polygons: (usize, usize),
}

impl Done {
    /// An input done with its line (no warnings, no polygons counted).
    pub fn with_line(line: String) -> Done {
        Done {
            line: Some(line),
            ..Done::default()
        }
    }
}

/// What [`Batch::run_each`] runs on one input: `(input, output, shown, options)` to what it
/// gave (e.g. [`Done::with_line`]).
pub type Each<'a, E> = dyn Fn(&Path, &Path, &Path, &WriteOptions) -> Result<Done, E> + Sync + 'a;

/// The end of a batch: what to say, and how many inputs failed.
#[derive(Debug, Clone, Default)]
pub struct Finished {
    /// The lines to show, in order (the closing line last).
    pub said: Vec<Said>,
    /// Inputs that failed (refused, not done, or lost in a failed merge).
    pub failed: usize,
}

impl Batch {
    /// Plan the outputs of `inputs` to `out` in `format` (`None`: from `out`'s ending),
    /// replacing existing files with `overwrite`; `shard`'s part of the inputs. The
    /// refused targets stay in [`Targets::refused`] for the caller to report.
    ///
    /// # Errors
    /// As [`plan`] and [`Plan::targets`].
    pub fn new(
        inputs: &[Input],
        out: (&Path, Option<Format>, bool),
        keep_envelopes: bool,
        shard: Option<Shard>,
    ) -> Result<Batch, PlanError> {
        Batch::make(inputs, out, keep_envelopes, shard, false)
    }

    /// [`Batch::new`] for an edit that writes each input in its own format (`subset`,
    /// `filter-lods`, `upgrade`): CityJSON inputs merged into one file are merged as CityJSON
    /// ([`Plan::targets`], [`merge_parts`]).
    ///
    /// # Errors
    /// As [`Batch::new`], and [`PlanError::MixedMerge`].
    pub fn for_edits(
        inputs: &[Input],
        out: (&Path, Option<Format>, bool),
        keep_envelopes: bool,
        shard: Option<Shard>,
    ) -> Result<Batch, PlanError> {
        Batch::make(inputs, out, keep_envelopes, shard, true)
    }

    fn make(
        inputs: &[Input],
        (out, format, overwrite): (&Path, Option<Format>, bool),
        keep_envelopes: bool,
        shard: Option<Shard>,
        edits: bool,
    ) -> Result<Batch, PlanError> {
        let (plan, format) = plan(inputs, out, format)?;
        let paths: Vec<PathBuf> = inputs.iter().map(|i| i.path.clone()).collect();
        let wopts = WriteOptions {
            overwrite,
            protect: Protected::new(&paths),
            keep_envelopes,
            ..WriteOptions::default()
        };
        let targets = plan.targets(&paths, &wopts, shard, (true, edits))?;
        Ok(Batch {
            counts_polygons: format == Format::CityGml,
            refused: targets.refused.len(),
            plan,
            format,
            wopts,
            targets,
        })
    }

    /// The name an output is shown by: the merge target for a staged part of a merge.
    pub fn shown<'a>(&'a self, out: &'a Path) -> &'a Path {
        match (&self.targets.staging, &self.plan) {
            (Some(_), Plan::Merge(target)) => target,
            _ => out,
        }
    }

    /// Run `each(input, output, shown, options)` on every input to do (shown: the name the
    /// output is said by, [`Batch::shown`]), what it gave its result: in parallel on the current
    /// rayon pool when `parallel`, else one after the other; a mirrored output's directory
    /// made first (its error the input's). The results in input order, for
    /// [`Batch::finish`].
    pub fn run_each<E: From<PlanError> + Send>(
        &self,
        inputs: &[Input],
        parallel: bool,
        each: &Each<'_, E>,
    ) -> Vec<(PathBuf, PathBuf, Result<Done, E>)> {
        use rayon::prelude::*;
        let t = &self.targets;
        let work = |(k, out): &(usize, PathBuf)| {
            let input = inputs[*k].path.clone();
            let parent = if t.mirror { create_parent(out) } else { Ok(()) };
            let r = parent
                .map_err(E::from)
                .and_then(|()| each(&input, out, self.shown(out), &t.write_opts));
            (input, out.clone(), r)
        };
        match parallel {
            true => t.todo.par_iter().map(work).collect(),
            false => t.todo.iter().map(work).collect(),
        }
    }

    /// The results of the inputs done (`(input, output, result)` in input order, each
    /// failure as its message): each line (none when merged), each failure, the merge, then
    /// `cmd`'s closing line (polygons when [`Batch::counts_polygons`]), of `inputs` inputs
    /// and the time since `started`.
    pub fn finish(
        &self,
        cmd: &str,
        results: Vec<(PathBuf, PathBuf, Result<Done, String>)>,
        inputs: usize,
        started: Instant,
    ) -> Finished {
        let staged = self.targets.staging.is_some();
        let mut said = Vec::new();
        let (mut ok, mut failed, mut warnings, mut polys) = (0, self.refused, 0, (0, 0));
        let (mut parts, mut names) = (Vec::new(), Vec::new());
        for (input, out, r) in results {
            match r {
                Ok(d) => {
                    if let Some(line) = d.line.filter(|_| !staged) {
                        said.push(Said::Summary(line));
                    }
                    ok += 1;
                    warnings += d.warnings;
                    polys.0 += d.polygons.0;
                    polys.1 += d.polygons.1;
                    parts.push(out);
                    names.push(input);
                }
                Err(e) => {
                    said.push(Said::Error(e));
                    failed += 1;
                }
            }
        }
        if let (Some(st), Plan::Merge(target)) = (&self.targets.staging, &self.plan) {
            let to = (target.as_path(), self.format);
            let (merged, s) = merge_parts(&parts, &names, to, st, &self.wopts, inputs);
            said.extend(s);
            if !merged {
                failed += ok;
                ok = 0;
            }
        }
        let polys = self.counts_polygons.then_some(polys);
        let line = summary_line(cmd, ok, failed, warnings, polys, started.elapsed());
        said.push(Said::Summary(line));
        Finished { said, failed }
    }
}

/// The closing line of a batch: files ok / failed, warnings, polygons in / out, wall time.
pub fn summary_line(
    cmd: &str,
    ok: usize,
    failed: usize,
    warnings: usize,
    polygons: Option<(usize, usize)>,
    elapsed: Duration,
) -> String {
    let polys = polygons.map_or(String::new(), |(i, o)| format!(", polygons {i} -> {o}"));
    format!(
        "{cmd}: {ok} file(s) ok, {failed} failed, {warnings} warning(s){polys}, {:.2} s",
        elapsed.as_secs_f64()
    )
}

/// Merge `parts` (in input order; written from the inputs `names`) into `target` in
/// `format`, the last step of every batch that merges: CityJSON parts (an edit's,
/// [`super::outputs::Plan::targets`], named so) as CityJSON ([`merge_cityjson`]),
/// CityJSONSeq for a `.jsonl` target or for `-` when the first input is named so; CityGML
/// parts as CityGML ([`merge_named`]), into another format through a CityGML merge staged in
/// `staging` (`Staging::merged`) then converted from a streamed read (read whole where the
/// stream declines), named by the inputs it holds (`label`). Whether `target` was written,
/// and what to say: the merge's lines, with a warning when some of the `inputs` failed and
/// the target holds only the others, or why nothing was written (then every input counts as
/// failed).
pub fn merge_parts(
    parts: &[PathBuf],
    names: &[PathBuf],
    (target, format): (&Path, Format),
    staging: &Staging,
    opts: &WriteOptions,
    inputs: usize,
) -> (bool, Vec<Said>) {
    if parts.is_empty() {
        let e = format!(
            "nothing to merge (every input failed); {} not written",
            target.display()
        );
        return (false, vec![Said::Error(e)]);
    }
    let json = |p: &PathBuf| crate::pipeline::batch::inputs::is_cityjson_name(&p.to_string_lossy());
    let lines = match format {
        _ if parts.iter().all(json) => {
            let seq_name = |p: &Path| {
                let n = p.to_string_lossy().to_ascii_lowercase();
                n.strip_suffix(".gz").unwrap_or(&n).ends_with(".jsonl")
            };
            let seq = match is_stdout(target) {
                true => names.first().is_some_and(|n| seq_name(n)),
                false => seq_name(target),
            };
            let s = merge_cityjson(parts, names, target, seq, opts);
            s.map(|s| vec![merge_line(&s, target, true)])
                .map_err(|e| format!("{e:#}"))
        }
        Format::CityGml => merge_named(parts, names, target, opts)
            .map(|s| vec![merge_line(&s, target, false)])
            .map_err(|e| format!("{e:#}")),
        _ => merge_converted(parts, names, (target, format), staging, opts),
    };
    match lines {
        Ok(lines) => {
            let partial = (parts.len() < inputs).then(|| {
                Said::Warning(format!(
                    "warning: {} holds {} of the {inputs} inputs (the others failed)",
                    target.display(),
                    parts.len()
                ))
            });
            let lines = lines.into_iter().map(Said::Summary);
            (true, partial.into_iter().chain(lines).collect())
        }
        Err(e) => (false, vec![Said::Error(e)]),
    }
}

/// The lines of a merge of CityGML `parts` into `target` in another format than CityGML
/// ([`merge_parts`]), or the error's message.
fn merge_converted(
    parts: &[PathBuf],
    names: &[PathBuf],
    (target, format): (&Path, Format),
    staging: &Staging,
    opts: &WriteOptions,
) -> Result<Vec<String>, String> {
    let protect = parts.iter().map(PathBuf::as_path);
    crate::io::citygml::write::check_target(target, opts, protect).map_err(|e| format!("{e:#}"))?;
    let staged = staging.merged();
    let sopts = WriteOptions {
        overwrite: true,
        ..opts.clone()
    };
    let m = merge_named(parts, names, &staged, &sopts).map_err(|e| format!("{e:#}"))?;
    let label = label(names.first().map(PathBuf::as_path), names.len());
    let r = convert_staged(&staged, &label, target, format, opts);
    let _ = std::fs::remove_file(&staged);
    let e = r.map_err(|e| format!("{e:#}"))?;
    Ok(vec![
        format!(
            "merged {} file(s) into {} ({format}): {} member(s), {} gml:id(s) renamed",
            m.files,
            target.display(),
            m.members,
            m.ids_renamed
        ),
        e.describe(format, Path::new(&label), target),
    ])
}

/// The staged merge at `staged` written to `target` in `format`, streamed (or read whole
/// where the stream declines), named `label`.
fn convert_staged(
    staged: &Path,
    label: &str,
    target: &Path,
    format: Format,
    opts: &WriteOptions,
) -> Result<crate::export::ExportSummary, crate::io::citygml::WriteError> {
    use crate::export::{Chunks, Content};
    use crate::io::citygml::read::{Passes, ReadOptions, CHUNK_BYTES};
    use crate::io::citygml::WriteError;
    let read = ReadOptions::default();
    let passes = Passes::new(&read, CHUNK_BYTES, &|_, _| {});
    let stream = Chunks::Stream {
        path: staged,
        label: Some(label),
        passes: &passes,
    };
    match crate::export::write(format, &stream, target, opts) {
        Err(WriteError::Declined(_)) => {}
        r => return r.map(|(e, _)| e),
    }
    let mut model = crate::io::citygml::read_file(staged)?;
    if let Some(f) = model.files.first_mut() {
        f.path = label.into();
    }
    let chunks = Chunks::model(&model, 0, Content::Full);
    crate::export::write(format, &chunks, target, opts).map(|(e, _)| e)
}

/// The line said after a merge (of CityJSON documents when `cityjson`: their ids are not
/// `gml:id`s).
pub fn merge_line(s: &MergeSummary, target: &Path, cityjson: bool) -> String {
    format!(
        "merged {} file(s) into {}: {} member(s), {} {}id(s) renamed, {} reference(s) \
         rewritten, {}",
        s.files,
        target.display(),
        s.members,
        s.ids_renamed,
        if cityjson { "" } else { "gml:" },
        s.refs_rewritten,
        size_note(target, s.bytes)
    )
}

/// `N bytes` of a written file `out`: its size on disk, so the compressed size of a `.gz`,
/// with the `written` (uncompressed) bytes in brackets when they differ; `written` alone for
/// standard output or a file that cannot be read back.
pub fn size_note(out: &Path, written: u64) -> String {
    match std::fs::metadata(out).map(|m| m.len()) {
        Ok(n) if n != written && !is_stdout(out) => {
            format!("{n} bytes ({written} uncompressed)")
        }
        _ => format!("{written} bytes"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn input(p: &Path) -> Input {
        Input {
            path: p.to_path_buf(),
            relative: p.file_name().map(PathBuf::from).unwrap_or_default(),
        }
    }

    #[test]
    fn a_merge_of_two_inputs_is_said_and_counted() {
        let fix = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/synth-small.gml");
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("merged.gml");
        let ins = [dir.path().join("a.gml"), dir.path().join("b.gml")];
        for i in &ins {
            std::fs::copy(&fix, i).unwrap();
        }
        let inputs: Vec<Input> = ins.iter().map(|p| input(p)).collect();
        let b = Batch::new(&inputs, (&target, None, false), false, None).unwrap();
        assert!(matches!(b.plan, Plan::Merge(_)) && b.targets.staging.is_some());
        assert_eq!(b.shown(Path::new("part")), target.as_path());
        let results = b
            .targets
            .todo
            .iter()
            .map(|(k, out)| {
                std::fs::copy(&ins[*k], out).unwrap();
                let done = Done {
                    line: Some("not said: merged".into()),
                    ..Done::default()
                };
                (ins[*k].clone(), out.clone(), Ok(done))
            })
            .collect();
        let f = b.finish("convert", results, 2, Instant::now());
        assert_eq!(f.failed, 0);
        assert_eq!(f.said.len(), 2, "{:?}", f.said);
        assert!(matches!(&f.said[0], Said::Summary(l) if l.starts_with("merged 2 file(s) into")));
        let end = "convert: 2 file(s) ok, 0 failed, 0 warning(s), polygons 0 -> 0, ";
        assert!(matches!(&f.said[1], Said::Summary(l) if l.starts_with(end)));
        let line = summary_line("rough", 1, 2, 3, None, Duration::from_millis(1234));
        assert_eq!(line, "rough: 1 file(s) ok, 2 failed, 3 warning(s), 1.23 s");
        assert!(target.exists());
        // Nothing to merge: every input failed, the target is not written.
        let (x, st) = (
            dir.path().join("x.gml"),
            b.targets.staging.as_ref().unwrap(),
        );
        let (ok, said) = merge_parts(&[], &[], (&x, Format::CityGml), st, &b.wopts, 2);
        assert!(!ok && matches!(&said[0], Said::Error(e) if e.starts_with("nothing to merge")));
    }

    #[test]
    fn each_input_run_in_order_mirrored_its_error_its_own() {
        let fix = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/synth-small.gml");
        let dir = tempfile::tempdir().unwrap();
        let ins = [dir.path().join("a.gml"), dir.path().join("b.gml")];
        for i in &ins {
            std::fs::copy(&fix, i).unwrap();
        }
        let inputs: Vec<Input> = ins.iter().map(|p| input(p)).collect();
        let out = dir.path().join("out/deep");
        let b = Batch::new(&inputs, (&out, None, false), false, None).unwrap();
        assert!(b.targets.mirror);
        let each = |i: &Path, o: &Path, shown: &Path, _: &WriteOptions| {
            if i.ends_with("b.gml") {
                return Err(PlanError::Format(crate::export::UnknownFormat("b".into())));
            }
            std::fs::copy(i, o).map_err(|e| {
                PlanError::Format(crate::export::UnknownFormat(e.to_string().into()))
            })?;
            Ok(Done::with_line(format!(
                "{} -> {}",
                i.display(),
                shown.display()
            )))
        };
        for parallel in [false, true] {
            let r = b.run_each(&inputs, parallel, &each);
            assert_eq!(r.len(), 2);
            assert_eq!((&r[0].0, &r[1].0), (&ins[0], &ins[1]), "input order");
            let done = r[0].2.as_ref().unwrap();
            assert_eq!(
                done.line.as_deref(),
                Some(format!("{} -> {}", ins[0].display(), r[0].1.display()).as_str())
            );
            assert!(
                r[0].1.starts_with(&out) && r[0].1.exists(),
                "mirrored, made"
            );
            assert!(r[1].2.is_err());
            std::fs::remove_file(&r[0].1).unwrap();
        }
    }

    #[test]
    fn every_merge_says_the_same_when_inputs_fail() {
        let dir = tempfile::tempdir().unwrap();
        let fix = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/synth-small.gml");
        let part = dir.path().join("a.gml");
        std::fs::copy(&fix, &part).unwrap();
        let o = WriteOptions::default();
        for (name, format) in [("m.gml", Format::CityGml), ("m.obj", Format::Obj)] {
            let t = dir.path().join(name);
            let staging = Staging::new(&t).unwrap();
            let (ok, said) = merge_parts(&[], &[], (&t, format), &staging, &o, 2);
            let e = format!(
                "nothing to merge (every input failed); {} not written",
                t.display()
            );
            assert!(!ok && matches!(&said[..], [Said::Error(l)] if *l == e));
            assert!(!t.exists());
            let parts = [part.clone()];
            let (ok, said) = merge_parts(&parts, &parts, (&t, format), &staging, &o, 3);
            let w = format!(
                "warning: {} holds 1 of the 3 inputs (the others failed)",
                t.display()
            );
            assert!(
                ok && matches!(&said[0], Said::Warning(l) if *l == w),
                "{said:?}"
            );
            std::fs::remove_file(&t).unwrap();
            let (ok, said) = merge_parts(&parts, &parts, (&t, format), &staging, &o, 1);
            assert!(ok && matches!(&said[0], Said::Summary(_)), "{said:?}");
        }
    }

    #[test]
    fn sizes_say_the_compressed_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("a.gml.gz");
        std::fs::write(&f, [0u8; 10]).unwrap();
        assert_eq!(size_note(&f, 30), "10 bytes (30 uncompressed)");
        assert_eq!(size_note(&f, 10), "10 bytes");
        assert_eq!(size_note(Path::new("-"), 7), "7 bytes");
    }
}
