//! Helpers shared by the integration tests: test data, the binary, xmllint, the Python oracle.
//!
//! Rule for external resources (shared data, xmllint, python3): when missing, the test FAILS if
//! the environment variable `CI` is `true`, and otherwise prints why it skips.
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Mutex;

/// Path of the `skylod` binary built for the tests.
pub const BIN: &str = env!("CARGO_BIN_EXE_skylod");

/// Repository root.
pub fn manifest_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// True when running under CI (`CI=true`).
pub fn is_ci() -> bool {
    std::env::var("CI").map(|v| v == "true").unwrap_or(false)
}

/// A required resource is missing: fail under CI, print a skip reason otherwise.
pub fn missing(what: &str) {
    if is_ci() {
        panic!("CI=true but {what} is missing");
    }
    eprintln!("SKIP: {what} is missing (set CI=true to make this a failure)");
}

/// `../shared/data` relative to the repository root, when present.
pub fn shared_data() -> Option<PathBuf> {
    let p = manifest_dir().join("../shared/data");
    if p.is_dir() {
        Some(p)
    } else {
        missing(&format!("shared test data {}", p.display()));
        None
    }
}

/// `../shared/schemas` relative to the repository root, when present.
pub fn shared_schemas() -> Option<PathBuf> {
    let p = manifest_dir().join("../shared/schemas");
    if p.join("catalog.xml").is_file() {
        Some(p)
    } else {
        missing(&format!("shared schemas {}", p.display()));
        None
    }
}

/// True for names of CityGML documents: *.gml, *.xml, *.gml.gz, *.xml.gz, *.citygml.
pub fn is_citygml_name(name: &str) -> bool {
    let n = name.to_ascii_lowercase();
    [".gml", ".xml", ".gml.gz", ".xml.gz", ".citygml"]
        .iter()
        .any(|e| n.ends_with(e))
}

/// Every CityGML document under `root` (recursively, sorted), excluding `codelists/` folders
/// and schemas.
pub fn citygml_files(root: &Path) -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(rd) = std::fs::read_dir(dir) else {
            return;
        };
        for e in rd.flatten() {
            let p = e.path();
            let name = e.file_name().to_string_lossy().to_string();
            if p.is_dir() {
                if name != "codelists" {
                    walk(&p, out);
                }
            } else if is_citygml_name(&name) && !name.ends_with(".xsd") {
                out.push(p);
            }
        }
    }
    let mut v = Vec::new();
    walk(root, &mut v);
    v.sort();
    v
}

/// The hand-made fixtures in `fixtures/` (not the bad-input corpus `fixtures/bad/`).
pub fn fixture_files() -> Vec<PathBuf> {
    let bad = manifest_dir().join("fixtures").join("bad");
    citygml_files(&manifest_dir().join("fixtures"))
        .into_iter()
        .filter(|p| !p.starts_with(&bad))
        .collect()
}

/// One fixture by file name.
pub fn fixture(name: &str) -> PathBuf {
    manifest_dir().join("fixtures").join(name)
}

/// Every shared file plus every fixture (fixtures only when the shared data is missing).
pub fn all_inputs() -> Vec<PathBuf> {
    let mut v = fixture_files();
    if let Some(d) = shared_data() {
        v.extend(citygml_files(&d));
    }
    v
}

/// Name of a file relative to the shared data or the repository, for messages.
pub fn short(p: &Path) -> String {
    let s = p.display().to_string();
    match s.find("shared/data/") {
        Some(i) => s[i + "shared/data/".len()..].to_string(),
        None => match s.find("fixtures/") {
            Some(i) => s[i..].to_string(),
            None => s,
        },
    }
}

/// Run the binary with arguments.
pub fn run(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(BIN)
        .args(args)
        .output()
        .expect("cannot start the skylod binary")
}

/// XSD entry point for a CityGML version ("1.0", "2.0", "3.0").
pub fn xsd(schemas: &Path, version: &str) -> PathBuf {
    match version {
        "1.0" => schemas.join("citygml-1.0/citygml/profiles/base/1.0/CityGML.xsd"),
        "2.0" => schemas.join("citygml-2.0/citygml/profiles/base/2.0/CityGML.xsd"),
        "3.0" => schemas.join("citygml-3.0/citygml/3.0/CityGML.xsd"),
        other => panic!("unknown CityGML version {other}"),
    }
}

/// True when `xmllint` and the shared schemas are usable (skip/fail rule otherwise).
pub fn have_xmllint() -> bool {
    if shared_schemas().is_none() {
        return false;
    }
    match Command::new("xmllint").arg("--version").output() {
        Ok(o) if o.status.success() => true,
        _ => {
            missing("xmllint (apt-get install libxml2-utils)");
            false
        }
    }
}

/// Validate one file against the official XSD of `version`, offline through the shared catalog.
/// `Err` holds xmllint's messages. Call [`have_xmllint`] first.
pub fn xmllint_validate(path: &Path, version: &str) -> Result<(), String> {
    xmllint_validate_many(&[path.to_path_buf()], version)
        .pop()
        .expect("one result per file")
}

/// Validate many files with one xmllint process (the schema is parsed once). One result per
/// file, in order. Call [`have_xmllint`] first.
pub fn xmllint_validate_many(paths: &[PathBuf], version: &str) -> Vec<Result<(), String>> {
    if paths.is_empty() {
        return Vec::new();
    }
    let schemas = shared_schemas().expect("shared schemas");
    let out = Command::new("xmllint")
        .env("XML_CATALOG_FILES", schemas.join("catalog.xml"))
        .arg("--nonet")
        .arg("--noout")
        .arg("--schema")
        .arg(xsd(&schemas, version))
        .args(paths)
        .output()
        .expect("cannot run xmllint");
    let stderr = String::from_utf8_lossy(&out.stderr);
    paths
        .iter()
        .map(|p| {
            let name = p.display().to_string();
            let ok = stderr.lines().any(|l| l == format!("{name} validates"));
            if ok {
                Ok(())
            } else {
                let msgs: Vec<&str> = stderr
                    .lines()
                    .filter(|l| l.starts_with(&name) && !l.contains("Skipping import"))
                    .take(5)
                    .collect();
                Err(if msgs.is_empty() {
                    format!("xmllint gave no verdict for {name}: {stderr}")
                } else {
                    msgs.join("\n")
                })
            }
        })
        .collect()
}

/// Validate files of possibly different versions: groups by version, runs the groups on up to
/// `threads` threads in chunks. Results keyed by path.
pub fn xmllint_validate_all(
    files: &[(PathBuf, String)],
    threads: usize,
) -> BTreeMap<PathBuf, Result<(), String>> {
    let mut jobs: Vec<(String, Vec<PathBuf>)> = Vec::new();
    let mut by_version: BTreeMap<&str, Vec<PathBuf>> = BTreeMap::new();
    for (p, v) in files {
        by_version.entry(v.as_str()).or_default().push(p.clone());
    }
    for (v, ps) in by_version {
        for chunk in ps.chunks(25) {
            jobs.push((v.to_string(), chunk.to_vec()));
        }
    }
    let results = Mutex::new(BTreeMap::new());
    let next = Mutex::new(jobs.into_iter());
    std::thread::scope(|s| {
        for _ in 0..threads.max(1) {
            s.spawn(|| loop {
                let job = next.lock().unwrap().next();
                let Some((v, ps)) = job else { break };
                let rs = xmllint_validate_many(&ps, &v);
                let mut map = results.lock().unwrap();
                for (p, r) in ps.into_iter().zip(rs) {
                    map.insert(p, r);
                }
            });
        }
    });
    results.into_inner().unwrap()
}

/// Run the independent Python oracle on files; `None` when python3 is missing (skip rule).
pub fn oracle_counts(files: &[PathBuf]) -> Option<serde_json::Map<String, serde_json::Value>> {
    let script = manifest_dir().join("tests/oracle/count_citygml.py");
    let out = match Command::new("python3").arg(&script).args(files).output() {
        Ok(o) => o,
        Err(_) => {
            missing("python3");
            return None;
        }
    };
    assert!(
        out.status.success(),
        "oracle failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("oracle JSON");
    match v {
        serde_json::Value::Object(m) => Some(m),
        _ => panic!("oracle output is not an object"),
    }
}
