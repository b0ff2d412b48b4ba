//! `-o` of the commands that write per input (`convert`, `rough`, `lod`, `reproject`):
//! [`skylod::batch::outputs`] lays the outputs out; this module says it in the flags' words,
//! reports refused targets, the merge and the outputs in other formats than CityGML.

use crate::log::{error, summary, warning};
use anyhow::anyhow;
use skylod::batch::inputs::Input;
use skylod::batch::outputs::{Plan, PlanError, Targets};
use skylod::batch::shard::Shard;
use skylod::citygml::merge::{merge_named, MergeSummary};
use skylod::citygml::write::WriteOptions;
use skylod::export::{Content, ExportSummary, Format};
use skylod::model::CityModel;
use std::path::{Path, PathBuf};

/// A layout error in the flags' words (`-o DIR`, `-o FILE`).
pub fn usage(e: PlanError) -> anyhow::Error {
    match e {
        PlanError::NotADirectory { output, inputs } => anyhow!(
            "{}: is a file; {inputs} inputs are written to a directory (-o DIR) or merged into \
             one CityGML file (-o FILE.gml)",
            output.display()
        ),
        PlanError::NotMergeable { format, inputs } => anyhow!(
            "{inputs} inputs cannot be merged into one {format} file: give -o DIR for one output \
             per input, or a CityGML name (.gml, .xml, .gz) to merge"
        ),
        PlanError::ShardedMerge { shard, target } => anyhow!(
            "shard {shard} cannot merge into {}: a merge needs every input (give -o DIR to the \
             shards, then merge their outputs with `skylod convert DIR -o FILE`)",
            target.display()
        ),
        PlanError::Format(e) => e.into(),
        PlanError::Target(e) => e.into(),
        PlanError::Merge(e) => e.into(),
        e => e.into(),
    }
}

/// [`skylod::batch::outputs::plan`] for `-o out` and `--format`.
pub fn plan(
    inputs: &[Input],
    out: &Path,
    format: Option<Format>,
) -> anyhow::Result<(Plan, Format)> {
    skylod::batch::outputs::plan(inputs, out, format).map_err(usage)
}

/// [`Plan::targets`] for `cmd`: this shard's files said on stderr, each refused target
/// reported with `refused` (its input fails without being read); the number refused.
pub fn targets(
    plan: &Plan,
    inputs: &[PathBuf],
    wopts: &WriteOptions,
    shard: Option<Shard>,
    cmd: &str,
    keeps_crs: bool,
    refused: impl Fn(&anyhow::Error),
) -> anyhow::Result<(Targets, usize)> {
    let mut t = plan
        .targets(inputs, wopts, shard, keeps_crs)
        .map_err(usage)?;
    if let Some(s) = shard {
        crate::args::shard::say(s, s.files(inputs.len()), inputs.len(), cmd, "files");
    }
    let n = t.refused.len();
    for e in std::mem::take(&mut t.refused) {
        refused(&anyhow!("{}", crate::errors::cli_text(&e)));
    }
    Ok((t, n))
}

/// Write file `file` of `model` in `format` (not CityGML: [`skylod::export::write`]) and
/// print its summary line.
pub fn export(
    format: Format,
    model: &CityModel,
    file: usize,
    content: Content<'_>,
    out: &Path,
    wopts: &WriteOptions,
) -> anyhow::Result<()> {
    let s = skylod::export::write(format, model, file, content, out, wopts)?;
    summary!("{}", describe(&s, format, model, file, out));
    Ok(())
}

/// [`skylod::export::ExportSummary::describe`] of file `file` of `model`.
pub fn describe(
    s: &ExportSummary,
    format: Format,
    model: &CityModel,
    file: usize,
    out: &Path,
) -> String {
    let input = model
        .files
        .get(file)
        .map_or(Path::new(""), |f| f.path.as_path());
    s.describe(format, input, out)
}

/// Create the parent directory of an output path (nothing for `-`).
pub fn create_parent(out: &Path) -> anyhow::Result<()> {
    Ok(skylod::batch::outputs::create_parent(out)?)
}

/// Merge `parts` (in input order; written from the inputs `names`) into `target`, the last
/// step of every command that merges: prints the merge line — with a warning when some of
/// the `inputs` failed and the target holds only the others — or why nothing was written.
/// False when `target` was not written (no part, or the merge failed): the caller then
/// counts every input as failed (exit 1).
pub fn merge(
    parts: &[PathBuf],
    names: &[PathBuf],
    target: &Path,
    opts: &WriteOptions,
    inputs: usize,
) -> bool {
    if parts.is_empty() {
        error!(
            "nothing to merge (every input failed); {} not written",
            target.display()
        );
        return false;
    }
    match merge_named(parts, names, target, opts) {
        Ok(s) => {
            if parts.len() < inputs {
                warning!(
                    "warning: {} holds {} of the {} inputs (the others failed)",
                    target.display(),
                    parts.len(),
                    inputs
                );
            }
            summary!("{}", merge_line(&s, target));
            true
        }
        Err(e) => {
            error!("{e:#}");
            false
        }
    }
}

/// The line printed after a merge.
fn merge_line(s: &MergeSummary, target: &Path) -> String {
    format!(
        "merged {} file(s) into {}: {} member(s), {} gml:id(s) renamed, {} reference(s) \
         rewritten, {}",
        s.files,
        target.display(),
        s.members,
        s.ids_renamed,
        s.refs_rewritten,
        size_note(target, s.bytes)
    )
}

/// `N bytes` of a written file `out`: its size on disk, so the compressed size of a `.gz`,
/// with the `written` (uncompressed) bytes in brackets when they differ; `written` alone for
/// stdout or a file that cannot be read back.
pub fn size_note(out: &Path, written: u64) -> String {
    match std::fs::metadata(out).map(|m| m.len()) {
        Ok(n) if n != written && !skylod::citygml::write::is_stdout(out) => {
            format!("{n} bytes ({written} uncompressed)")
        }
        _ => format!("{written} bytes"),
    }
}

/// The outputs of a command that writes per input (`convert`, `rough`): laid out for `-o`
/// and `--format`, every target checked before any work (a refused one reported: its input
/// fails without being read), this shard's files said on stderr.
pub struct Batch {
    pub plan: Plan,
    pub format: Format,
    /// The options the user gave (the merge is written with them).
    pub wopts: WriteOptions,
    pub targets: Targets,
    /// Inputs whose target was refused.
    pub refused: usize,
    /// Whether the closing line counts polygons (CityGML outputs of `convert`, `rough`).
    pub counts_polygons: bool,
}

/// What one input gave: its line (printed in input order unless merged), its warnings and
/// polygons in and out.
pub struct Done {
    pub line: Option<String>,
    pub warnings: usize,
    pub polygons: (usize, usize),
}

impl Batch {
    /// Plan `cmd`'s outputs of `inputs` to `-o out`, `--format`, `--overwrite` ([`plan`],
    /// [`targets`]).
    pub fn new(
        cmd: &str,
        inputs: &[Input],
        (out, format, overwrite): (&Path, Option<Format>, bool),
        keep_envelopes: bool,
        shard: Option<Shard>,
    ) -> anyhow::Result<Batch> {
        let (plan, format) = plan(inputs, out, format)?;
        let paths: Vec<PathBuf> = inputs.iter().map(|i| i.path.clone()).collect();
        let wopts = WriteOptions {
            overwrite,
            protect: paths.clone(),
            keep_envelopes,
        };
        let (targets, refused) =
            self::targets(&plan, &paths, &wopts, shard, cmd, true, |e| error!("{e}"))?;
        Ok(Batch {
            counts_polygons: format == Format::CityGml,
            plan,
            format,
            wopts,
            targets,
            refused,
        })
    }

    /// The results of the inputs done (`(input, output, result)` in input order): each
    /// line printed (none when merged), each failure with `failure`, the merge made, then
    /// `cmd`'s closing line (polygons when the outputs are CityGML). The exit outcome.
    pub fn finish(
        &self,
        cmd: &str,
        results: Vec<(PathBuf, PathBuf, anyhow::Result<Done>)>,
        failure: impl Fn(&anyhow::Error) -> String,
        inputs: usize,
        t0: std::time::Instant,
    ) -> crate::Outcome {
        let staged = self.targets.staging.is_some();
        let (mut ok, mut failed, mut warnings, mut polys) = (0, self.refused, 0, (0, 0));
        let (mut parts, mut names) = (Vec::new(), Vec::new());
        for (input, out, r) in results {
            match r {
                Ok(d) => {
                    if let Some(line) = d.line.filter(|_| !staged) {
                        summary!("{line}");
                    }
                    ok += 1;
                    warnings += d.warnings;
                    polys.0 += d.polygons.0;
                    polys.1 += d.polygons.1;
                    parts.push(out);
                    names.push(input);
                }
                Err(e) => {
                    error!("{}", failure(&e));
                    failed += 1;
                }
            }
        }
        if let (true, Plan::Merge(target)) = (staged, &self.plan) {
            if !merge(&parts, &names, target, &self.wopts, inputs) {
                failed += ok;
                ok = 0;
            }
        }
        let polys = self.counts_polygons.then_some(polys);
        let line = crate::commands::summary_line(cmd, ok, failed, warnings, polys, t0);
        summary!("{line}");
        crate::Outcome::failed_if(failed > 0)
    }
}

/// The summary line of one input written to `out`, named `shown` (the merge target for a
/// staged part of a merge).
pub type Edit<'a> = dyn Fn(&Path, &Path, &Path, &WriteOptions) -> Result<String, skylod::citygml::WriteError>
    + Sync
    + 'a;

/// Run `edit` on every input of `a` as `cmd`, CityGML in and out (`subset`, `filter-lods`):
/// a [`Batch`] (targets checked before any work, an error per input does not stop it,
/// several inputs into one file merged).
pub fn per_input(
    a: &crate::args::citygml_io::CityGmlIoArgs,
    cmd: &str,
    edit: &Edit<'_>,
) -> anyhow::Result<crate::Outcome> {
    let t0 = std::time::Instant::now();
    let shard = a.shard.resolve()?;
    let (inputs, _spool) = crate::inputs::expand_inputs_relative(&a.inputs)?;
    let out = (a.output.as_path(), Some(Format::CityGml), a.overwrite);
    let mut batch = Batch::new(cmd, &inputs, out, true, shard)?;
    batch.counts_polygons = false;
    let t = &batch.targets;
    let results = t
        .todo
        .iter()
        .map(|(k, out)| {
            let input = inputs[*k].path.clone();
            let shown = match (&t.staging, &batch.plan) {
                (Some(_), Plan::Merge(target)) => target.as_path(),
                _ => out.as_path(),
            };
            let parent = if t.mirror { create_parent(out) } else { Ok(()) };
            let r = parent.and_then(|()| {
                let line = edit(&input, out, shown, &t.write_opts)
                    .map_err(|e| anyhow!(crate::errors::cli_text(&e)))?;
                Ok(Done {
                    line: Some(line),
                    warnings: 0,
                    polygons: (0, 0),
                })
            });
            (input, out.clone(), r)
        })
        .collect();
    Ok(batch.finish(cmd, results, |e| e.to_string(), inputs.len(), t0))
}
