//! The inputs of a command, as users give them: files, directories (searched recursively for
//! CityGML: `.gml`, `.xml`, `.citygml`, each optionally `.gz`), glob patterns expanded by
//! skylod itself (`'tiles/**/*.gml'`, quoted so that the shell leaves them alone), and `-` for
//! standard input (spooled to a temporary file by [`expand_spooled`]: the writer re-reads
//! its source, and a pipe can be read only once).
//!
//! Directories and patterns yield CityGML names only (a `README.md` or an `.xsd` beside the
//! tiles is not an input); a file named directly is read whatever its name.
//!
//! Every input keeps the path relative to the argument it came from, so that `-o DIR` can
//! mirror the input tree. The order is deterministic: arguments in order, the files of a
//! directory or a pattern sorted by path; a file named twice is kept once.
//!
//! # Example
//! ```
//! use std::path::Path;
//! let dir = tempfile::tempdir().unwrap();
//! std::fs::create_dir_all(dir.path().join("a/b")).unwrap();
//! for f in ["a/one.gml", "a/b/two.xml.gz", "a/notes.txt"] {
//!     std::fs::write(dir.path().join(f), "").unwrap();
//! }
//! let found = skylod::batch::inputs::expand(&[dir.path().join("a")]).unwrap();
//! let rel: Vec<_> = found.iter().map(|i| i.relative.display().to_string()).collect();
//! assert_eq!(rel, ["b/two.xml.gz", "one.gml"]);
//! ```

use std::path::{Path, PathBuf};

/// One input file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Input {
    /// The path to read (`-`: standard input).
    pub path: PathBuf,
    /// The path below the directory or the fixed part of the pattern it was found in (its
    /// file name for a file given directly): where `-o DIR` puts its output.
    pub relative: PathBuf,
}

/// Why the inputs cannot be listed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum InputError {
    /// A glob pattern that does not parse.
    #[error("{pattern}: not a valid pattern: {message}")]
    Pattern {
        /// The pattern.
        pattern: String,
        /// What is wrong.
        message: String,
    },
    /// A pattern or directory that names no CityGML file.
    #[error("{0}: no CityGML file (.gml, .xml, .citygml, optionally .gz) found")]
    Empty(String),
    /// A directory that cannot be listed.
    #[error("{}: cannot list: {source}", .path.display())]
    Io {
        /// The directory or entry.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// `-` given more than once.
    #[error("standard input (-) can be read only once")]
    StdinTwice,
    /// The temporary directory of the spooled standard input cannot be made.
    #[error(transparent)]
    SpoolDir(std::io::Error),
    /// The spool file cannot be created.
    #[error("spooling standard input to {}", .path.display())]
    SpoolFile {
        /// The spool file.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// Standard input cannot be read.
    #[error("reading standard input")]
    Stdin(#[source] std::io::Error),
}

/// Whether a file name is a CityGML document skylod reads from a directory.
///
/// ```
/// use skylod::batch::inputs::is_citygml_name;
/// assert!(is_citygml_name("4018215.XML.gz") && is_citygml_name("b.citygml"));
/// assert!(!is_citygml_name("README.md") && !is_citygml_name("schema.xsd"));
/// ```
pub fn is_citygml_name(name: &str) -> bool {
    let n = name.to_ascii_lowercase();
    let n = n.strip_suffix(".gz").unwrap_or(&n);
    [".gml", ".xml", ".citygml"].iter().any(|e| n.ends_with(e))
}

fn has_glob_chars(s: &str) -> bool {
    s.contains(['*', '?', '['])
}

/// The fixed leading directories of a pattern (`tiles/2024/**/*.gml` → `tiles/2024`).
fn fixed_prefix(pattern: &str) -> PathBuf {
    let mut out = PathBuf::new();
    for c in Path::new(pattern).components() {
        if has_glob_chars(&c.as_os_str().to_string_lossy()) {
            break;
        }
        out.push(c);
    }
    out
}

fn relative_to(path: &Path, base: &Path) -> PathBuf {
    path.strip_prefix(base)
        .map(Path::to_path_buf)
        .unwrap_or_else(|_| path.file_name().map(PathBuf::from).unwrap_or_default())
}

fn walk(dir: &Path, base: &Path, out: &mut Vec<Input>) -> Result<(), InputError> {
    let mut found = Vec::new();
    for entry in walkdir::WalkDir::new(dir)
        .follow_links(true)
        .sort_by_file_name()
    {
        let entry = entry.map_err(|e| InputError::Io {
            path: e.path().unwrap_or(dir).to_path_buf(),
            source: e
                .into_io_error()
                .unwrap_or_else(|| std::io::Error::other("loop")),
        })?;
        if entry.file_type().is_file() && is_citygml_name(&entry.file_name().to_string_lossy()) {
            found.push(Input {
                path: entry.path().to_path_buf(),
                relative: relative_to(entry.path(), base),
            });
        }
    }
    out.extend(found);
    Ok(())
}

/// Expand the arguments of a command into input files (see the module docs). A path that
/// does not exist and holds no pattern is kept: reading it reports the error per file.
pub fn expand(args: &[PathBuf]) -> Result<Vec<Input>, InputError> {
    let mut out: Vec<Input> = Vec::new();
    for a in args {
        let text = a.to_string_lossy();
        if a.as_os_str() == "-" || a.is_file() || (!a.exists() && !has_glob_chars(&text)) {
            out.push(Input {
                path: a.clone(),
                relative: a
                    .file_name()
                    .map(PathBuf::from)
                    .unwrap_or_else(|| a.clone()),
            });
        } else if a.is_dir() {
            let before = out.len();
            walk(a, a, &mut out)?;
            if out.len() == before {
                return Err(InputError::Empty(text.to_string()));
            }
        } else {
            let paths = glob::glob(&text).map_err(|e| InputError::Pattern {
                pattern: text.to_string(),
                message: e.msg.to_string(),
            })?;
            let base = fixed_prefix(&text);
            let mut found = Vec::new();
            for p in paths {
                let p = p.map_err(|e| InputError::Io {
                    path: e.path().to_path_buf(),
                    source: e.into(),
                })?;
                if p.is_file() {
                    if is_citygml_name(&p.file_name().unwrap_or_default().to_string_lossy()) {
                        found.push(Input {
                            relative: relative_to(&p, &base),
                            path: p,
                        });
                    }
                } else if p.is_dir() {
                    walk(&p, &base, &mut found)?;
                }
            }
            if found.is_empty() {
                return Err(InputError::Empty(text.to_string()));
            }
            found.sort_by(|x, y| x.path.cmp(&y.path));
            out.extend(found);
        }
    }
    let mut seen = std::collections::HashSet::new();
    out.retain(|i| i.path.as_os_str() == "-" || seen.insert(i.path.clone()));
    Ok(out)
}

/// Standard input spooled to a temporary file (removed when this is dropped).
#[derive(Debug, Default)]
pub struct Spool(Option<tempfile::TempDir>);

impl Spool {
    /// Whether standard input was spooled.
    pub fn is_used(&self) -> bool {
        self.0.is_some()
    }
}

/// [`expand`], with `-` read from `stdin` into a temporary file (the input is that file,
/// its relative path `stdin.gml`). Keep the returned [`Spool`] alive while the inputs are
/// read and written.
///
/// # Errors
/// As [`expand`]; `-` given twice; the spool file cannot be made or written.
pub fn expand_spooled(
    args: &[PathBuf],
    stdin: &mut dyn std::io::Read,
) -> Result<(Vec<Input>, Spool), InputError> {
    let expanded = expand(args)?;
    let mut spool = None;
    let mut out = Vec::with_capacity(expanded.len());
    for i in expanded {
        if i.path.as_os_str() != "-" {
            out.push(i);
            continue;
        }
        if spool.is_some() {
            return Err(InputError::StdinTwice);
        }
        let dir = tempfile::Builder::new()
            .prefix("skylod-stdin-")
            .tempdir()
            .map_err(InputError::SpoolDir)?;
        let path = dir.path().join("stdin");
        let mut f = std::fs::File::create(&path).map_err(|source| InputError::SpoolFile {
            path: path.clone(),
            source,
        })?;
        std::io::copy(stdin, &mut f).map_err(InputError::Stdin)?;
        out.push(Input {
            path,
            relative: PathBuf::from("stdin.gml"),
        });
        spool = Some(dir);
    }
    Ok((out, Spool(spool)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tree() -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        for f in [
            "t/2024/a.gml",
            "t/2024/sub/b.GML.gz",
            "t/2025/c.xml",
            "t/2025/x.xsd",
            "t/readme.txt",
        ] {
            let p = dir.path().join(f);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, "").unwrap();
        }
        dir
    }

    #[test]
    fn globs_keep_paths_below_their_fixed_part() {
        let d = tree();
        let pat = d.path().join("t/**/*.gml");
        let got = expand(&[pat]).unwrap();
        let rel: Vec<_> = got
            .iter()
            .map(|i| i.relative.display().to_string())
            .collect();
        assert_eq!(rel, ["2024/a.gml"]);
        let pat = d.path().join("t/*");
        let got = expand(&[pat]).unwrap();
        let rel: Vec<_> = got
            .iter()
            .map(|i| i.relative.display().to_string())
            .collect();
        assert_eq!(rel, ["2024/a.gml", "2024/sub/b.GML.gz", "2025/c.xml"]);
    }

    #[test]
    fn files_dash_missing_and_duplicates() {
        let d = tree();
        let a = d.path().join("t/2024/a.gml");
        let missing = d.path().join("nope.gml");
        let got = expand(&[a.clone(), PathBuf::from("-"), missing.clone(), a.clone()]).unwrap();
        let paths: Vec<_> = got.iter().map(|i| i.path.clone()).collect();
        assert_eq!(paths, [a, PathBuf::from("-"), missing]);
        assert_eq!(got[0].relative, PathBuf::from("a.gml"));
    }

    #[test]
    fn empty_matches_are_errors() {
        let d = tree();
        let e = expand(&[d.path().join("t/**/*.citygml")]).unwrap_err();
        assert!(e.to_string().contains("no CityGML file"), "{e}");
        std::fs::create_dir(d.path().join("empty")).unwrap();
        assert!(expand(&[d.path().join("empty")]).is_err());
        assert!(expand(&[d.path().join("t/[")]).is_err());
    }
}
