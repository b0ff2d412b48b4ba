//! The inputs of a command, as users give them: files, directories (searched recursively for
//! CityGML: `.gml`, `.xml`, `.citygml`, and CityJSON: `.city.json`, `.city.jsonl`, other
//! `.json`/`.jsonl` that are CityJSON by content; each optionally `.gz`), glob patterns expanded by
//! skylod itself (`'tiles/**/*.gml'`, quoted so that the shell leaves them alone), and `-` for
//! standard input (read whole into memory when it is first read, [`crate::io::files::stdin_bytes`]:
//! the writer copies from its source again, and a pipe can be read only once; its relative
//! path is `stdin.gml`, messages name it `<stdin>`, JSON outputs `-`).
//!
//! Directories and patterns yield CityGML and CityJSON names only (a `README.md` or an `.xsd` beside the
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
//! let found = skylod::pipeline::batch::expand(&[dir.path().join("a")]).unwrap();
//! let rel: Vec<_> = found.iter().map(|i| i.relative.display().to_string()).collect();
//! assert_eq!(rel, ["b/two.xml.gz", "one.gml"]);
//! ```

use crate::model::STDIN_NAME;
use std::path::{Path, PathBuf};

/// One input file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Input {
    /// The path to read (`-`: standard input), and the input's name in JSON outputs and in
    /// the model ([`crate::model::SourceFile::path`]; messages show it with
    /// [`crate::model::shown`]: `<stdin>`).
    pub path: PathBuf,
    /// The path below the directory or the fixed part of the pattern it was found in (its
    /// file name for a file given directly): where `-o DIR` puts its output.
    pub relative: PathBuf,
}

/// A file a directory or a pattern found that is XML but not CityGML (a `metadata.xml`
/// sidecar): left out of the inputs, said as a warning by the caller.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Skipped {
    /// The file.
    pub path: PathBuf,
    /// The local name of its root element (`MD_Metadata`).
    pub root: String,
}

impl std::fmt::Display for Skipped {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: skipped: XML but not CityGML (root element {}, no CityGML namespace)",
            self.path.display(),
            self.root
        )
    }
}

/// The inputs found, and the files found but skipped.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Expanded {
    /// The files to read.
    pub inputs: Vec<Input>,
    /// XML files of a directory or a pattern that are not CityGML, in the order found.
    pub skipped: Vec<Skipped>,
}

/// How many bytes of a file (decompressed) [`sniff_other_xml`] looks at.
pub const SNIFF_BYTES: usize = 4096;

/// The root element's local name when the start of the file shows XML that is not CityGML:
/// the root's start tag complete within the first [`SNIFF_BYTES`] bytes (gzip decompressed),
/// its local name not `CityModel`, and no CityGML namespace (`http://www.opengis.net/citygml/`)
/// anywhere in those bytes. `None` for CityGML, and whenever the start cannot tell (not XML,
/// a root tag longer than the window, a file that cannot be read): reading the file reports
/// what is wrong with it.
pub fn sniff_other_xml(path: &Path) -> Option<String> {
    other_xml_root(&head_of(path)?)
}

/// [`sniff_other_xml`] on the first bytes of a document.
fn other_xml_root(head: &[u8]) -> Option<String> {
    let name = root_name(head)?;
    let local = name.rsplit(':').next().unwrap_or(&name).to_owned();
    let citygml = memchr::memmem::find(head, b"opengis.net/citygml").is_some();
    (local != "CityModel" && !citygml).then_some(local)
}

/// The qualified name of the root element, when its start tag is complete in `head`.
fn root_name(head: &[u8]) -> Option<String> {
    let mut rest = head.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(head);
    loop {
        let skip = rest.iter().take_while(|b| b.is_ascii_whitespace()).count();
        rest = &rest[skip..];
        let end_of =
            |rest: &[u8], close: &[u8]| memchr::memmem::find(rest, close).map(|i| i + close.len());
        if rest.starts_with(b"<?") {
            rest = &rest[end_of(rest, b"?>")?..];
        } else if rest.starts_with(b"<!--") {
            rest = &rest[end_of(rest, b"-->")?..];
        } else if rest.starts_with(b"<!") {
            // DOCTYPE, with or without an internal subset
            let gt = memchr::memchr(b'>', rest)?;
            let bracket = memchr::memchr(b'[', &rest[..gt]);
            rest = match bracket {
                Some(_) => &rest[end_of(rest, b"]>")?..],
                None => &rest[gt + 1..],
            };
        } else if rest.first() == Some(&b'<') {
            let name_len = rest[1..]
                .iter()
                .take_while(|b| !b.is_ascii_whitespace() && **b != b'>' && **b != b'/')
                .count();
            if name_len == 0 {
                return None;
            }
            let name = std::str::from_utf8(&rest[1..1 + name_len]).ok()?.to_owned();
            memchr::memchr(b'>', rest)?;
            return Some(name);
        } else {
            return None;
        }
    }
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
    /// A pattern or directory that names no CityGML or CityJSON file.
    #[error("{0}: no CityGML file (.gml, .xml, .citygml, optionally .gz) or CityJSON file (.city.json, .city.jsonl, CityJSON .json) found")]
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
    /// Standard input cannot be read.
    #[error("reading standard input")]
    Stdin(#[source] std::io::Error),
}

/// Whether a file name is a CityGML document skylod reads from a directory.
///
/// ```
/// use skylod::pipeline::batch::is_citygml_name;
/// assert!(is_citygml_name("4018215.XML.gz") && is_citygml_name("b.citygml"));
/// assert!(!is_citygml_name("README.md") && !is_citygml_name("schema.xsd"));
/// ```
pub fn is_citygml_name(name: &str) -> bool {
    let n = name.to_ascii_lowercase();
    let n = n.strip_suffix(".gz").unwrap_or(&n);
    [".gml", ".xml", ".citygml"].iter().any(|e| n.ends_with(e))
}

/// Whether a file name is CityJSON skylod reads from a directory whatever its content:
/// `.city.json` and `.city.jsonl` (CityJSONSeq), each optionally `.gz`.
///
/// ```
/// use skylod::pipeline::batch::is_cityjson_name;
/// assert!(is_cityjson_name("t/a.city.json") && is_cityjson_name("b.CITY.JSONL.gz"));
/// assert!(!is_cityjson_name("package.json"));
/// ```
pub fn is_cityjson_name(name: &str) -> bool {
    let n = name.to_ascii_lowercase();
    let n = n.strip_suffix(".gz").unwrap_or(&n);
    [".city.json", ".city.jsonl"].iter().any(|e| n.ends_with(e))
}

/// Whether a directory or a pattern takes this file: a CityGML name ([`is_citygml_name`]),
/// a CityJSON name ([`is_cityjson_name`]), or another `.json` / `.jsonl` (optionally `.gz`)
/// whose start shows CityJSON ([`sniff_cityjson`]).
pub fn is_input_file(path: &Path) -> bool {
    let name = path.file_name().unwrap_or_default().to_string_lossy();
    if is_citygml_name(&name) || is_cityjson_name(&name) {
        return true;
    }
    let n = name.to_ascii_lowercase();
    let n = n.strip_suffix(".gz").unwrap_or(&n);
    (n.ends_with(".json") || n.ends_with(".jsonl")) && sniff_cityjson(path)
}

/// True when the first [`SNIFF_BYTES`] bytes of a file (gzip decompressed) are a JSON object
/// naming `CityJSON` (`"type": "CityJSON"`, `CityJSONFeature`) or holding `"CityObjects"`.
pub fn sniff_cityjson(path: &Path) -> bool {
    let Some(head) = head_of(path) else {
        return false;
    };
    let json = crate::io::cityjson::sniff(&head) == crate::io::cityjson::Sniffed::Json;
    json && (memchr::memmem::find(&head, b"\"CityJSON").is_some()
        || memchr::memmem::find(&head, b"\"CityObjects\"").is_some())
}

/// The first [`SNIFF_BYTES`] bytes of a file, gzip decompressed.
fn head_of(path: &Path) -> Option<Vec<u8>> {
    use std::io::Read;
    if path.as_os_str() == crate::model::STDIN_NAME {
        return None; // not a file: standard input is told by its reader
    }
    let (r, _) = crate::io::files::open_decoded(path).ok()?;
    let mut head = Vec::with_capacity(SNIFF_BYTES);
    r.take(SNIFF_BYTES as u64).read_to_end(&mut head).ok()?;
    Some(head)
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

fn walk(dir: &Path, base: &Path, out: &mut Expanded) -> Result<(), InputError> {
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
        if entry.file_type().is_file() && is_input_file(entry.path()) {
            found.push(Input {
                path: entry.path().to_path_buf(),
                relative: relative_to(entry.path(), base),
            });
        }
    }
    keep_citygml(found, out);
    Ok(())
}

/// Append the files of a walk or a pattern to `out`, those that are XML but not CityGML to
/// its skipped files.
fn keep_citygml(found: Vec<Input>, out: &mut Expanded) {
    for i in found {
        match sniff_other_xml(&i.path) {
            Some(root) => out.skipped.push(Skipped { path: i.path, root }),
            None => out.inputs.push(i),
        }
    }
}

/// Expand the arguments of a command into input files (see the module docs). A path that
/// does not exist and holds no pattern is kept: reading it reports the error per file. Files
/// found in a directory or by a pattern that are XML but not CityGML (`sniff_other_xml`)
/// are left out: `expand_all` lists them.
pub fn expand(args: &[PathBuf]) -> Result<Vec<Input>, InputError> {
    expand_all(args).map(|e| e.inputs)
}

/// [`expand`], with the files it skipped. A directory or a pattern whose every CityGML-named
/// file was skipped is an error ([`InputError::Empty`]), as one that named none.
pub fn expand_all(args: &[PathBuf]) -> Result<Expanded, InputError> {
    let mut out = Expanded::default();
    for a in args {
        let text = a.to_string_lossy();
        if a.as_os_str() == STDIN_NAME {
            if out.inputs.iter().any(|i| i.path.as_os_str() == STDIN_NAME) {
                return Err(InputError::StdinTwice);
            }
            out.inputs.push(Input {
                path: a.clone(),
                relative: PathBuf::from(STDIN_RELATIVE),
            });
        } else if a.is_file() || (!a.exists() && !has_glob_chars(&text)) {
            out.inputs.push(Input {
                path: a.clone(),
                relative: a
                    .file_name()
                    .map(PathBuf::from)
                    .unwrap_or_else(|| a.clone()),
            });
        } else if a.is_dir() {
            let before = out.inputs.len();
            walk(a, a, &mut out)?;
            if out.inputs.len() == before {
                return Err(InputError::Empty(text.to_string()));
            }
        } else {
            let paths = glob::glob(&text).map_err(|e| InputError::Pattern {
                pattern: text.to_string(),
                message: e.msg.to_string(),
            })?;
            let base = fixed_prefix(&text);
            let mut found = Expanded::default();
            for p in paths {
                let p = p.map_err(|e| InputError::Io {
                    path: e.path().to_path_buf(),
                    source: e.into(),
                })?;
                if p.is_file() {
                    if is_input_file(&p) {
                        let i = Input {
                            relative: relative_to(&p, &base),
                            path: p,
                        };
                        keep_citygml(vec![i], &mut found);
                    }
                } else if p.is_dir() {
                    walk(&p, &base, &mut found)?;
                }
            }
            if found.inputs.is_empty() {
                return Err(InputError::Empty(text.to_string()));
            }
            found.inputs.sort_by(|x, y| x.path.cmp(&y.path));
            out.inputs.extend(found.inputs);
            out.skipped.extend(found.skipped);
        }
    }
    let mut seen = std::collections::HashSet::new();
    out.inputs
        .retain(|i| i.path.as_os_str() == STDIN_NAME || seen.insert(i.path.clone()));
    Ok(out)
}

/// Where `-o DIR` puts the output of standard input: `DIR/stdin.gml` (its relative path).
pub const STDIN_RELATIVE: &str = "stdin.gml";

/// What [`expand_spooled`] returns beside the inputs. Standard input is no longer spooled to
/// a temporary file (it is held in memory, [`crate::io::files::stdin_bytes`]): nothing to keep
/// alive, kept for the callers of 0.2.
#[derive(Debug, Default)]
pub struct Spool(bool);

impl Spool {
    /// Whether standard input is among the inputs.
    pub fn is_used(&self) -> bool {
        self.0
    }
}

/// `expand_all`, with `-` read now from `stdin` into memory (it becomes the bytes of the
/// input `-`, [`crate::io::files::set_stdin_bytes`]; its relative path is `stdin.gml`).
///
/// # Errors
/// As [`expand`]; `-` given twice; `stdin` cannot be read.
pub fn expand_spooled(
    args: &[PathBuf],
    stdin: &mut dyn std::io::Read,
) -> Result<(Expanded, Spool), InputError> {
    let expanded = expand_all(args)?;
    let used = expanded
        .inputs
        .iter()
        .any(|i| i.path.as_os_str() == STDIN_NAME);
    if used {
        crate::io::files::set_stdin_bytes(stdin).map_err(InputError::Stdin)?;
    }
    Ok((expanded, Spool(used)))
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
        let cases: [(&str, &[&str]); 2] = [
            ("t/**/*.gml", &["2024/a.gml"]),
            ("t/*", &["2024/a.gml", "2024/sub/b.GML.gz", "2025/c.xml"]),
        ];
        for (pattern, want) in cases {
            let got = expand(&[d.path().join(pattern)]).unwrap();
            let rel: Vec<_> = got
                .iter()
                .map(|i| i.relative.display().to_string())
                .collect();
            assert_eq!(rel, want, "{pattern}");
        }
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

    const CITYGML: &str = "<?xml version=\"1.0\"?>\n<!-- tile -->\n<core:CityModel \
        xmlns:core=\"http://www.opengis.net/citygml/2.0\"></core:CityModel>";
    const METADATA: &str = "\u{feff}<?xml version=\"1.0\"?>\n<!DOCTYPE x [<!ENTITY a \"b\">]>\n\
        <gmd:MD_Metadata xmlns:gmd=\"http://www.isotc211.org/2005/gmd\"><x/></gmd:MD_Metadata>";

    #[test]
    fn the_root_element_tells_citygml_from_other_xml() {
        assert_eq!(other_xml_root(CITYGML.as_bytes()), None);
        assert_eq!(
            other_xml_root(METADATA.as_bytes()).as_deref(),
            Some("MD_Metadata")
        );
        // CityGML declared on the root of a WFS collection, or a CityModel without prefixes.
        let wfs =
            "<wfs:FeatureCollection xmlns:bldg=\"http://www.opengis.net/citygml/building/2.0\">";
        assert_eq!(other_xml_root(wfs.as_bytes()), None);
        assert_eq!(other_xml_root(b"<CityModel>"), None);
        // What the start cannot tell is kept (reading it says what is wrong).
        assert_eq!(other_xml_root(b""), None);
        assert_eq!(other_xml_root(b"not xml"), None);
        assert_eq!(other_xml_root(b"<root a=\"unfinished"), None);
        assert_eq!(other_xml_root(b"<!-- never closed"), None);
    }

    #[test]
    fn walks_skip_xml_that_is_not_citygml_but_named_files_are_kept() {
        use std::io::Write;
        let d = tempfile::tempdir().unwrap();
        let t = d.path().join("t");
        std::fs::create_dir(&t).unwrap();
        std::fs::write(t.join("a.gml"), CITYGML).unwrap();
        std::fs::write(t.join("metadata.xml"), METADATA).unwrap();
        let mut gz = flate2::write::GzEncoder::new(
            std::fs::File::create(t.join("meta2.xml.gz")).unwrap(),
            flate2::Compression::default(),
        );
        gz.write_all(METADATA.as_bytes()).unwrap();
        gz.finish().unwrap();
        for arg in [t.clone(), t.join("*.xml*"), t.join("*")] {
            let got = expand_all(std::slice::from_ref(&arg));
            if arg.ends_with("*.xml*") {
                // Every match skipped: nothing to read.
                assert!(matches!(got, Err(InputError::Empty(_))), "{got:?}");
                continue;
            }
            let got = got.unwrap();
            let paths: Vec<_> = got.inputs.iter().map(|i| i.path.clone()).collect();
            assert_eq!(paths, [t.join("a.gml")], "{arg:?}");
            let skipped: Vec<_> = got.skipped.iter().map(|s| s.path.clone()).collect();
            assert_eq!(skipped, [t.join("meta2.xml.gz"), t.join("metadata.xml")]);
            assert!(got.skipped[1]
                .to_string()
                .contains("root element MD_Metadata"));
        }
        let named = expand_all(&[t.join("metadata.xml")]).unwrap();
        assert_eq!(named.inputs.len(), 1);
        assert!(named.skipped.is_empty());
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
