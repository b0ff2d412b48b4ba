//! Where the commands that write per input (`convert`, `rough`, `lod`, `reproject`) put their
//! outputs, decided once before any work:
//!
//! * `-o DIR` (an existing directory, a name ending in `/`, or, for several inputs, a name with
//!   no output ending) mirrors the input tree: each input goes to `DIR/<relative>`, its path
//!   below the directory or pattern it was found in (its file name when named directly),
//!   with the format's ending for formats other than CityGML. Two inputs that map to one
//!   output are refused.
//! * `-o FILE` with one input writes that file (format from its ending or `--format`).
//! * `-o FILE` (CityGML) or `-o -` with several inputs merges them into one document
//!   ([`skylod::citygml::merge`]): each input is written to a staging directory beside the
//!   target, then merged into it.

use anyhow::{bail, Context};
use skylod::batch::inputs::Input;
use skylod::batch::shard::Shard;
use skylod::citygml::merge::{check_mergeable, merge_named, MergeSummary};
use skylod::citygml::write::{check_target, is_stdout, WriteOptions};
use skylod::export::Format;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// What `-o` means for these inputs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Plan {
    /// One output per input, in input order.
    PerInput(Vec<PathBuf>),
    /// One output per input below a directory, in input order (parent directories are
    /// created when the input is written: [`create_parent`]).
    Mirror(Vec<PathBuf>),
    /// All inputs merged into one CityGML document (a file or `-`).
    Merge(PathBuf),
}

fn names_directory(out: &Path) -> bool {
    out.is_dir() || out.as_os_str().to_string_lossy().ends_with('/')
}

/// The outputs of `inputs` for `-o out` and the format written (see the module docs). Usage
/// errors (an unknown ending for one file, a merge into a format other than CityGML,
/// colliding outputs) are returned before any input is read.
pub fn plan(
    inputs: &[Input],
    out: &Path,
    explicit: Option<Format>,
) -> anyhow::Result<(Plan, Format)> {
    let several = inputs.len() > 1;
    if is_stdout(out) {
        let format = explicit.unwrap_or(Format::CityGml);
        if several {
            refuse_merge(format, inputs.len())?;
            return Ok((Plan::Merge(out.to_path_buf()), format));
        }
        return Ok((Plan::PerInput(vec![out.to_path_buf()]), format));
    }
    if !names_directory(out) {
        match Format::resolve(out, explicit) {
            Ok(format) if !several => {
                return Ok((Plan::PerInput(vec![out.to_path_buf()]), format));
            }
            Ok(format) if Format::from_path(out).is_some() => {
                refuse_merge(format, inputs.len())?;
                return Ok((Plan::Merge(out.to_path_buf()), format));
            }
            Err(e) if !several => return Err(e.into()),
            // Several inputs and a name without an output ending: a directory.
            _ => {}
        }
        if out.exists() {
            bail!(
                "{}: is a file; {} inputs are written to a directory (-o DIR) or merged into \
                 one CityGML file (-o FILE.gml)",
                out.display(),
                inputs.len()
            );
        }
    }
    let format = explicit.unwrap_or(Format::CityGml);
    Ok((Plan::Mirror(mirror(inputs, out, format)?), format))
}

fn refuse_merge(format: Format, n: usize) -> anyhow::Result<()> {
    if format != Format::CityGml {
        bail!(
            "{n} inputs cannot be merged into one {format} file: give -o DIR for one output per \
             input, or a CityGML name (.gml, .xml, .gz) to merge"
        );
    }
    Ok(())
}

/// `dir/<relative>` per input, with the format's ending; colliding outputs are refused.
pub fn mirror(inputs: &[Input], dir: &Path, format: Format) -> anyhow::Result<Vec<PathBuf>> {
    let mut seen: HashMap<PathBuf, &Path> = HashMap::new();
    let mut out = Vec::with_capacity(inputs.len());
    for i in inputs {
        let rel = if i.relative.as_os_str().is_empty() || i.relative.as_os_str() == "-" {
            PathBuf::from("stdin.gml")
        } else {
            i.relative.clone()
        };
        let Some(name) = rel.file_name() else {
            bail!("{}: not a file name", i.path.display());
        };
        let p = dir
            .join(&rel)
            .with_file_name(format.output_name(&name.to_string_lossy()));
        if let Some(other) = seen.insert(p.clone(), &i.path) {
            bail!(
                "{} and {} would both be written to {}",
                other.display(),
                i.path.display(),
                p.display()
            );
        }
        out.push(p);
    }
    Ok(out)
}

/// The work of a command that writes per input, laid out before any input is read: which
/// inputs to do and where each goes (every target checked; this shard's part), the options
/// to write them with, and the staging directory of a merge.
pub struct Targets {
    /// `(input index, output)` to do, in input order.
    pub todo: Vec<(usize, PathBuf)>,
    /// Targets refused (each reported): those inputs failed without being read.
    pub refused: usize,
    /// The merge's staging directory (per-input documents go there), for [`Plan::Merge`].
    pub staging: Option<Staging>,
    /// Whether outputs mirror a tree (their parent directories are created as written).
    pub mirror: bool,
    /// How each output is written: the user's options, or for a merge's staged parts the
    /// same with `overwrite` (the merge target was checked instead).
    pub write_opts: WriteOptions,
}

impl Plan {
    /// Lay out the work of `cmd` for `inputs` (paths in input order) with the user's
    /// `wopts`: this `shard`'s part of the per-input targets is kept, then each is checked
    /// (a refused one is reported with `refused` and its input skipped). A merge checks its
    /// target, refuses inputs that cannot be merged (CityGML versions; CRSs when the outputs
    /// keep their input's, `keeps_crs`) from their heads before any work, and makes its
    /// staging directory.
    ///
    /// # Errors
    /// A merge under a shard (it needs every input), a refused merge target, inputs that
    /// cannot be merged, a staging directory that cannot be made.
    pub fn targets(
        &self,
        inputs: &[PathBuf],
        wopts: &WriteOptions,
        shard: Option<Shard>,
        cmd: &str,
        keeps_crs: bool,
        refused: impl Fn(&anyhow::Error),
    ) -> anyhow::Result<Targets> {
        let protect = || inputs.iter().map(PathBuf::as_path);
        match self {
            Plan::PerInput(outs) | Plan::Mirror(outs) => {
                // Laid out for all inputs, then this shard's part (each file goes where the
                // serial run writes it); only that part is checked: other shards may have
                // written theirs already.
                let mine = crate::args::shard::files(
                    shard,
                    outs.iter().cloned().enumerate().collect(),
                    cmd,
                );
                let mut todo = Vec::with_capacity(mine.len());
                let mut n_refused = 0;
                for (k, out) in mine {
                    match check_target(&out, wopts, protect()) {
                        Ok(()) => todo.push((k, out)),
                        Err(e) => {
                            refused(&e.into());
                            n_refused += 1;
                        }
                    }
                }
                Ok(Targets {
                    todo,
                    refused: n_refused,
                    staging: None,
                    mirror: matches!(self, Plan::Mirror(_)),
                    write_opts: wopts.clone(),
                })
            }
            Plan::Merge(target) => {
                if let Some(s) = shard {
                    bail!(
                        "shard {s} cannot merge into {}: a merge needs every input (give -o DIR \
                         to the shards, then merge their outputs with `skylod convert DIR -o \
                         FILE`)",
                        target.display()
                    );
                }
                check_target(target, wopts, protect())?;
                check_mergeable(inputs, keeps_crs)?;
                let staging = Staging::new(target)?;
                Ok(Targets {
                    todo: (0..inputs.len()).map(|k| (k, staging.part(k))).collect(),
                    refused: 0,
                    staging: Some(staging),
                    mirror: false,
                    write_opts: WriteOptions {
                        overwrite: true,
                        ..wopts.clone()
                    },
                })
            }
        }
    }
}

/// Create the parent directory of an output path (nothing for `-`).
pub fn create_parent(out: &Path) -> anyhow::Result<()> {
    if is_stdout(out) {
        return Ok(());
    }
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    Ok(())
}

/// A temporary directory for the per-input documents of a merge, beside the target (system
/// temporary directory for `-`); removed when dropped.
pub struct Staging {
    dir: tempfile::TempDir,
}

impl Staging {
    /// A staging directory for a merge into `target`.
    pub fn new(target: &Path) -> anyhow::Result<Staging> {
        let mut b = tempfile::Builder::new();
        b.prefix(".skylod-merge-");
        let dir = match target.parent().filter(|d| !d.as_os_str().is_empty()) {
            _ if is_stdout(target) => b.tempdir(),
            Some(parent) => b.tempdir_in(parent),
            None => b.tempdir_in("."),
        }
        .with_context(|| format!("creating a staging directory for {}", target.display()))?;
        Ok(Staging { dir })
    }

    /// Where the `k`-th input's document is written.
    pub fn part(&self, k: usize) -> PathBuf {
        self.dir.path().join(format!("{k:06}.gml"))
    }

    /// Merge `parts` (in input order; written from the inputs `names`) into `target`, the
    /// last step of every command that merges: prints the merge line — with a warning when
    /// some of the `inputs` failed and the target holds only the others — or why nothing was
    /// written. False when `target` was not written (no part, or the merge failed): the
    /// caller then counts every input as failed (exit 1).
    pub fn finish(
        &self,
        parts: &[PathBuf],
        names: &[PathBuf],
        target: &Path,
        opts: &WriteOptions,
        inputs: usize,
    ) -> bool {
        if parts.is_empty() {
            crate::log::error!(
                "nothing to merge (every input failed); {} not written",
                target.display()
            );
            return false;
        }
        match merge_named(parts, names, target, opts) {
            Ok(s) => {
                if parts.len() < inputs {
                    crate::log::warning!(
                        "warning: {} holds {} of the {} inputs (the others failed)",
                        target.display(),
                        parts.len(),
                        inputs
                    );
                }
                crate::log::summary!("{}", merge_line(&s, target));
                true
            }
            Err(e) => {
                crate::log::error!("{e:#}");
                false
            }
        }
    }
}

/// The line printed after a merge.
pub fn merge_line(s: &MergeSummary, target: &Path) -> String {
    format!(
        "merged {} file(s) into {}: {} member(s), {} gml:id(s) renamed, {} reference(s) \
         rewritten, {} bytes",
        s.files,
        target.display(),
        s.members,
        s.ids_renamed,
        s.refs_rewritten,
        s.bytes
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn input(p: &str, rel: &str) -> Input {
        Input {
            path: PathBuf::from(p),
            relative: PathBuf::from(rel),
        }
    }

    #[test]
    fn plans() {
        let one = [input("a/x.gml", "x.gml")];
        let two = [
            input("t/a/x.gml", "a/x.gml"),
            input("t/b/x.gml.gz", "b/x.gml.gz"),
        ];
        let p = |i: &[Input], o: &str, f| plan(i, Path::new(o), f).unwrap();
        assert_eq!(
            p(&one, "o.gml", None),
            (Plan::PerInput(vec!["o.gml".into()]), Format::CityGml)
        );
        assert_eq!(
            p(&one, "o.obj", None),
            (Plan::PerInput(vec!["o.obj".into()]), Format::Obj)
        );
        assert!(plan(&one, Path::new("o.txt"), None).is_err());
        assert_eq!(
            p(&two, "m.gml.gz", None),
            (Plan::Merge("m.gml.gz".into()), Format::CityGml)
        );
        assert_eq!(
            p(&two, "-", None),
            (Plan::Merge("-".into()), Format::CityGml)
        );
        assert!(plan(&two, Path::new("m.obj"), None).is_err());
        assert_eq!(
            p(&two, "outdir", None),
            (
                Plan::Mirror(vec!["outdir/a/x.gml".into(), "outdir/b/x.gml.gz".into()]),
                Format::CityGml
            )
        );
        assert_eq!(
            p(&two, "outdir/", Some(Format::CityJson)).0,
            Plan::Mirror(vec![
                "outdir/a/x.city.json".into(),
                "outdir/b/x.city.json".into()
            ])
        );
        assert_eq!(
            p(&one, "outdir/", None).0,
            Plan::Mirror(vec!["outdir/x.gml".into()])
        );
    }

    #[test]
    fn colliding_outputs_are_refused() {
        let two = [input("a/x.gml", "x.gml"), input("b/x.gml", "x.gml")];
        let e = plan(&two, Path::new("outdir"), None).unwrap_err();
        assert!(e.to_string().contains("would both be written"), "{e}");
        // Different inputs, same output once the ending is replaced.
        let two = [input("x.gml", "x.gml"), input("x.xml", "x.xml")];
        assert!(plan(&two, Path::new("o/"), Some(Format::Obj)).is_err());
        assert!(plan(&two, Path::new("o/"), None).is_ok());
    }
}
