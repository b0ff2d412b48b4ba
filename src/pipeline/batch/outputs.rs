//! Where a batch that writes one output per input puts its outputs (`convert`, `rough`,
//! `lod`, `reproject` of the `skylod` program), decided once before any work:
//!
//! * an output directory (an existing directory, a name ending in `/`, or, for several
//!   inputs, a name with no output ending) mirrors the input tree: each input goes to
//!   `DIR/<relative>` ([`Input::relative`]), with the format's ending for formats other than
//!   CityGML. Two inputs that map to one output are refused.
//! * an output file with one input is that input's output (format from its ending or the
//!   one named).
//! * a file (or `-`, standard output) with several inputs merges them into one document
//!   ([`crate::export::merge`]): each input is written to a [`Staging`] directory beside the
//!   target, then merged into it. An OBJ, CityJSON or CityJSONSeq target holds the merge
//!   converted: one origin, the merge's ids.
//!
//! # Example
//! ```
//! use skylod::pipeline::batch::Input;
//! use skylod::pipeline::batch::{Plan, plan};
//! use skylod::export::Format;
//! use std::path::{Path, PathBuf};
//! let inputs = [
//!     Input { path: "t/a/x.gml".into(), relative: "a/x.gml".into() },
//!     Input { path: "t/b/y.gml".into(), relative: "b/y.gml".into() },
//! ];
//! let (p, format) = plan(&inputs, Path::new("out/"), Some(Format::Obj))?;
//! assert_eq!(format, Format::Obj);
//! assert_eq!(p, Plan::Mirror(vec![PathBuf::from("out/a/x.obj"), PathBuf::from("out/b/y.obj")]));
//! assert_eq!(plan(&inputs, Path::new("all.gml"), None)?.0, Plan::Merge("all.gml".into()));
//! assert_eq!(plan(&inputs, Path::new("all.obj"), None)?, (Plan::Merge("all.obj".into()), Format::Obj));
//! # Ok::<(), skylod::pipeline::batch::PlanError>(())
//! ```

use crate::export::merge::{check_mergeable, MergeError};
use crate::export::{Format, UnknownFormat};
use crate::io::citygml::write::{check_target, is_stdout, WriteOptions};
use crate::io::citygml::WriteError;
use crate::pipeline::batch::inputs::Input;
use crate::pipeline::batch::shard::Shard;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Where the outputs of a batch go.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Plan {
    /// One output per input, in input order.
    PerInput(Vec<PathBuf>),
    /// One output per input below a directory, in input order (parent directories are
    /// created when the input is written: [`create_parent`]).
    Mirror(Vec<PathBuf>),
    /// All inputs merged into one document (a file or `-`): CityGML, or the merge converted.
    Merge(PathBuf),
}

/// Why the outputs cannot be laid out.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlanError {
    /// One input and an output name that tells no format.
    #[error(transparent)]
    Format(#[from] UnknownFormat),
    /// Several inputs and an existing file that is not a merge target.
    #[error(
        "{}: is a file; {inputs} inputs are written to a directory or merged into one CityGML \
         file",
        .output.display()
    )]
    NotADirectory {
        /// The output named.
        output: PathBuf,
        /// How many inputs.
        inputs: usize,
    },
    /// Several inputs to merge into a format that cannot hold them (none today: every
    /// output format merges).
    #[error("{inputs} inputs cannot be merged into one {format} file")]
    NotMergeable {
        /// The format asked for.
        format: Format,
        /// How many inputs.
        inputs: usize,
    },
    /// An input whose path has no file name to mirror.
    #[error("{}: not a file name", .0.display())]
    NotAFileName(PathBuf),
    /// Two inputs that would be written to one output.
    #[error("{} and {} would both be written to {}", .first.display(), .second.display(), .output.display())]
    Collision {
        /// The earlier input.
        first: PathBuf,
        /// The later input.
        second: PathBuf,
        /// Their common output.
        output: PathBuf,
    },
    /// A merge asked of one shard (a merge needs every input).
    #[error("shard {shard} cannot merge into {}: a merge needs every input", .target.display())]
    ShardedMerge {
        /// The shard.
        shard: Shard,
        /// The merge target.
        target: PathBuf,
    },
    /// An edit (`subset`, `filter-lods`, `upgrade`, `reproject`) asked to merge CityJSON
    /// inputs with CityGML ones (`other`), or CityJSON inputs into a CityGML name (`None`).
    #[error("{}", mixed_text(.target, .json, .other.as_deref()))]
    MixedMerge {
        /// The merge target.
        target: PathBuf,
        /// A CityJSON input.
        json: PathBuf,
        /// A CityGML input.
        other: Option<PathBuf>,
    },
    /// The merge target is refused.
    #[error(transparent)]
    Target(#[from] WriteError),
    /// The inputs cannot be merged (CityGML versions, CRSs).
    #[error(transparent)]
    Merge(#[from] MergeError),
    /// The staging directory of a merge cannot be made.
    #[error("creating a staging directory for {}", .target.display())]
    Staging {
        /// The merge target.
        target: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// The parent directory of an output cannot be made.
    #[error("creating {}", .dir.display())]
    CreateDir {
        /// The directory.
        dir: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
}

fn mixed_text(target: &Path, json: &Path, other: Option<&Path>) -> String {
    let (t, j) = (target.display(), crate::model::shown(json));
    match other {
        Some(o) => format!(
            "{t}: an edit writes CityJSON as CityJSON and CityGML as CityGML, so the CityJSON \
             {j} and the CityGML {} cannot be merged into one file (merge each format apart, \
             or `skylod convert` one into the other first)",
            crate::model::shown(o)
        ),
        None => format!(
            "{t}: CityJSON inputs ({j}, ...) are merged into CityJSON: name the target \
             .city.json or .city.jsonl (`skylod convert` writes CityGML from them)"
        ),
    }
}

fn names_directory(out: &Path) -> bool {
    out.is_dir() || out.as_os_str().to_string_lossy().ends_with('/')
}

/// The outputs of `inputs` for the output name `out` and the format written (see the module
/// docs; `explicit`: the format named, if any).
///
/// # Errors
/// An unknown ending for one file, colliding outputs: before any input is read.
pub fn plan(
    inputs: &[Input],
    out: &Path,
    explicit: Option<Format>,
) -> Result<(Plan, Format), PlanError> {
    let several = inputs.len() > 1;
    if is_stdout(out) {
        let format = explicit.unwrap_or(Format::CityGml);
        if several {
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
                return Ok((Plan::Merge(out.to_path_buf()), format));
            }
            Err(e) if !several => return Err(e.into()),
            // Several inputs and a name without an output ending: a directory.
            _ => {}
        }
        if out.exists() {
            return Err(PlanError::NotADirectory {
                output: out.to_path_buf(),
                inputs: inputs.len(),
            });
        }
    }
    let format = explicit.unwrap_or(Format::CityGml);
    Ok((Plan::Mirror(mirror(inputs, out, format)?), format))
}

/// `dir/<relative>` per input, with the format's ending.
///
/// # Errors
/// Colliding outputs, an input without a file name.
pub fn mirror(inputs: &[Input], dir: &Path, format: Format) -> Result<Vec<PathBuf>, PlanError> {
    let mut seen: HashMap<PathBuf, &Path> = HashMap::new();
    let mut out = Vec::with_capacity(inputs.len());
    for i in inputs {
        let rel = if i.relative.as_os_str().is_empty() || i.relative.as_os_str() == "-" {
            PathBuf::from("stdin.gml")
        } else {
            i.relative.clone()
        };
        let Some(name) = rel.file_name() else {
            return Err(PlanError::NotAFileName(i.path.clone()));
        };
        let p = dir
            .join(&rel)
            .with_file_name(format.output_name(&name.to_string_lossy()));
        if let Some(other) = seen.insert(p.clone(), &i.path) {
            return Err(PlanError::Collision {
                first: other.to_path_buf(),
                second: i.path.clone(),
                output: p,
            });
        }
        out.push(p);
    }
    Ok(out)
}

/// The work of a batch that writes per input, laid out before any input is read: which
/// inputs to do and where each goes (every target checked; a shard's part), the options to
/// write them with, and the staging directory of a merge.
#[derive(Debug)]
pub struct Targets {
    /// `(input index, output)` to do, in input order.
    pub todo: Vec<(usize, PathBuf)>,
    /// Targets refused, in input order: those inputs failed without being read.
    pub refused: Vec<WriteError>,
    /// The merge's staging directory (per-input documents go there), for [`Plan::Merge`].
    pub staging: Option<Staging>,
    /// Whether outputs mirror a tree (their parent directories are created as written).
    pub mirror: bool,
    /// How each output is written: the given options, or for a merge's staged parts the
    /// same with `overwrite` (the merge target was checked instead).
    pub write_opts: WriteOptions,
}

impl Plan {
    /// Lay out the work for `inputs` (paths in input order) with the options `wopts`:
    /// `shard`'s part of the per-input targets is kept ([`Shard::files`]: each file goes
    /// where the serial run writes it), then each is checked (a refused one lands in
    /// [`Targets::refused`]). A merge checks its target, refuses inputs that cannot be
    /// merged (CityGML versions; CRSs when the outputs keep their input's, `keeps_crs`) from
    /// their heads before any work, and makes its staging directory. The parts are CityGML
    /// (CityJSON inputs written as CityGML first), but for an edit that writes each input in
    /// its own format (`own_format`: `subset`, `filter-lods`, `upgrade`, `reproject`), whose
    /// CityJSON inputs stage CityJSON parts (`Staging::json_part`) to be merged as CityJSON
    /// ([`crate::pipeline::batch::run::merge_parts`]); there, CityJSON and CityGML inputs
    /// together, or CityJSON inputs into a CityGML name, are refused
    /// ([`PlanError::MixedMerge`]).
    ///
    /// # Errors
    /// [`PlanError::MixedMerge`], a merge under a shard (it needs every input), a refused
    /// merge target, inputs that cannot be merged, a staging directory that cannot be made.
    pub fn targets(
        &self,
        inputs: &[PathBuf],
        wopts: &WriteOptions,
        shard: Option<Shard>,
        (keeps_crs, own_format): (bool, bool),
    ) -> Result<Targets, PlanError> {
        // every input resolved once: each target then costs one resolution of its own
        let wopts = &WriteOptions {
            protect: wopts.protect.and(inputs),
            ..wopts.clone()
        };
        let protect = std::iter::empty;
        match self {
            Plan::PerInput(outs) | Plan::Mirror(outs) => {
                // Laid out for all inputs, then this shard's part; only that part is
                // checked: other shards may have written theirs already.
                let mine = shard.map_or(0..outs.len(), |s| s.files(outs.len()));
                let mut todo = Vec::with_capacity(mine.len());
                let mut refused = Vec::new();
                for (k, out) in outs.iter().enumerate().skip(mine.start).take(mine.len()) {
                    match check_target(out, wopts, protect()) {
                        Ok(()) => todo.push((k, out.clone())),
                        Err(e) => refused.push(e),
                    }
                }
                Ok(Targets {
                    todo,
                    refused,
                    staging: None,
                    mirror: matches!(self, Plan::Mirror(_)),
                    write_opts: wopts.clone(),
                })
            }
            Plan::Merge(target) => {
                let (json, xml): (Vec<PathBuf>, Vec<PathBuf>) = inputs
                    .iter()
                    .cloned()
                    .partition(|p| crate::export::citygml_from_cityjson::is_json_file(p));
                if let (true, Some(j)) = (own_format, json.first()) {
                    let gml_name = !is_stdout(target)
                        && Format::from_path(target).is_none_or(|f| f == Format::CityGml);
                    if gml_name || !xml.is_empty() {
                        return Err(PlanError::MixedMerge {
                            target: target.clone(),
                            json: j.clone(),
                            other: xml.first().cloned(),
                        });
                    }
                }
                if let Some(shard) = shard {
                    return Err(PlanError::ShardedMerge {
                        shard,
                        target: target.clone(),
                    });
                }
                check_target(target, wopts, protect())?;
                // The parts of CityJSON inputs are checked when merged.
                check_mergeable(&xml, keeps_crs)?;
                let staging = Staging::new(target)?;
                let json_parts = own_format && !json.is_empty();
                let part = |k| match json_parts {
                    true => (k, staging.json_part(k)),
                    false => (k, staging.part(k)),
                };
                Ok(Targets {
                    todo: (0..inputs.len()).map(part).collect(),
                    refused: Vec::new(),
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
///
/// # Errors
/// [`PlanError::CreateDir`].
pub fn create_parent(out: &Path) -> Result<(), PlanError> {
    if is_stdout(out) {
        return Ok(());
    }
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| PlanError::CreateDir {
            dir: dir.to_path_buf(),
            source,
        })?;
    }
    Ok(())
}

/// A temporary directory for the per-input documents of a merge, beside the target (system
/// temporary directory for `-`); removed when dropped.
#[derive(Debug)]
pub struct Staging {
    dir: tempfile::TempDir,
}

impl Staging {
    /// A staging directory for a merge into `target`.
    ///
    /// # Errors
    /// [`PlanError::Staging`].
    pub fn new(target: &Path) -> Result<Staging, PlanError> {
        let mut b = tempfile::Builder::new();
        b.prefix(".skylod-merge-");
        let dir = match target.parent().filter(|d| !d.as_os_str().is_empty()) {
            _ if is_stdout(target) => b.tempdir(),
            // the target's folder is made first (a tileset's, `-o new/tileset.json`)
            Some(parent) => std::fs::create_dir_all(parent).and_then(|()| b.tempdir_in(parent)),
            None => b.tempdir_in("."),
        }
        .map_err(|source| PlanError::Staging {
            target: target.to_path_buf(),
            source,
        })?;
        Ok(Staging { dir })
    }

    /// Where the `k`-th input's document is written.
    pub fn part(&self, k: usize) -> PathBuf {
        self.dir.path().join(format!("{k:06}.gml"))
    }

    /// Where the `k`-th CityJSON input's edited document is written (a merge of CityJSON
    /// inputs by an edit).
    pub fn json_part(&self, k: usize) -> PathBuf {
        self.dir.path().join(format!("{k:06}.city.json"))
    }

    /// Where the merged CityGML document is staged when the target is another format.
    pub fn merged(&self) -> PathBuf {
        self.dir.path().join("merged.gml")
    }
}

/// The name of the `k`-th of `n` per-POI outputs from the output name `base`: `base` itself
/// for one, else `<stem>-<id>.svg` beside it (the id's characters other than ASCII letters,
/// digits, `-` and `_` replaced by `_`).
pub fn per_poi(base: &Path, id: &str, many: bool) -> PathBuf {
    if !many {
        return base.to_path_buf();
    }
    let stem = base
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "sky".into());
    let id: String = id
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    base.with_file_name(format!("{stem}-{id}.svg"))
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
        // several inputs and a file (or `-`): a merge, in the format named or asked for
        let merges = [
            ("m.gml.gz", None, Format::CityGml),
            ("-", None, Format::CityGml),
            ("m.obj", None, Format::Obj),
            ("-", Some(Format::CityJson), Format::CityJson),
            ("m.city.jsonl", None, Format::CityJsonSeq),
        ];
        for (o, asked, format) in merges {
            assert_eq!(p(&two, o, asked), (Plan::Merge(o.into()), format), "{o}");
        }
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
