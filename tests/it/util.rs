//! Helpers shared by the integration tests: test data, the binary, xmllint, the Python oracle.
//!
//! Rule for external resources (shared data, xmllint, python3): when missing, the test FAILS if
//! the environment variable `CI` is `true`, and otherwise prints why it skips.

use std::collections::{BTreeMap, HashSet};
use std::ffi::OsStr;
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

/// The file at `path` gzipped into `dir` as its name with `.gz` added: the new file's path.
pub fn gzip_copy(path: &Path, dir: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap().to_os_string();
    name.push(".gz");
    let gz = dir.join(name);
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    std::io::Write::write_all(&mut enc, &std::fs::read(path).unwrap()).unwrap();
    std::fs::write(&gz, enc.finish().unwrap()).unwrap();
    gz
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
/// True when python3 imports every module of `modules` (e.g. `"pyproj, numpy"`); otherwise
/// the oracle is `missing` (a failure under `CI=true`, a printed skip elsewhere); `install`
/// says how to get it.
pub fn python_has(modules: &str, install: &str) -> bool {
    let ok = Command::new("python3")
        .args(["-c", &format!("import {modules}")])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        missing(&format!("python3 with {modules} ({install})"));
    }
    ok
}

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

/// Local references of a CityGML document that do not resolve: every `xlink:href="#id"` and
/// every appearance target (`<app:target>#id</app:target>`, `<app:target uri="#id">`) whose
/// `id` is not the `gml:id` of an element of the same document. References to other documents
/// (no leading `#`) are not checked. Reads `.gz` too. `Err` when the XML does not parse.
pub fn unresolved_refs(path: &Path) -> Result<Vec<String>, String> {
    use quick_xml::events::Event;
    use quick_xml::name::ResolveResult;
    let (reader, _) = skylod::io::citygml::open(path).map_err(|e| e.to_string())?;
    let mut r = quick_xml::NsReader::from_reader(reader);
    let mut buf = Vec::new();
    let mut ids = std::collections::HashSet::new();
    let mut refs: Vec<String> = Vec::new();
    let mut in_target = false;
    let mut text = String::new();
    loop {
        let ev = r.read_event_into(&mut buf).map_err(|e| e.to_string())?;
        match &ev {
            Event::Start(e) | Event::Empty(e) => {
                let is_target = e.local_name().as_ref() == b"target"
                    && matches!(r.resolve_element(e.name()).0,
                        ResolveResult::Bound(n) if n.0.starts_with(b"http://www.opengis.net/citygml/appearance/"));
                let mut had_uri = false;
                for a in e.attributes().with_checks(false).flatten() {
                    let v = a.unescape_value().map_err(|e| e.to_string())?.to_string();
                    let local = a.key.local_name();
                    let ns = match r.resolve_attribute(a.key).0 {
                        ResolveResult::Bound(n) => n.0.to_vec(),
                        _ => Vec::new(),
                    };
                    match local.as_ref() {
                        b"id" if ns.starts_with(b"http://www.opengis.net/gml") => {
                            ids.insert(v);
                        }
                        b"href" if ns == b"http://www.w3.org/1999/xlink" => refs.push(v),
                        b"uri" if is_target && a.key.prefix().is_none() => {
                            had_uri = true;
                            refs.push(v)
                        }
                        _ => {}
                    }
                }
                if is_target && !had_uri && matches!(ev, Event::Start(_)) {
                    in_target = true;
                    text.clear();
                }
            }
            Event::Text(t) if in_target => {
                text.push_str(&String::from_utf8_lossy(t));
            }
            Event::End(_) if in_target => {
                in_target = false;
                refs.push(text.trim().to_string());
            }
            Event::Eof => break,
            _ => {}
        }
        buf.clear();
    }
    Ok(refs
        .into_iter()
        .filter_map(|h| {
            let h = h.trim().to_string();
            let id = h.strip_prefix('#')?;
            (!ids.contains(id)).then_some(h)
        })
        .collect())
}

/// Threads for xmllint batches.
pub fn threads() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get().min(2))
        .unwrap_or(2)
}

/// XSD check of outputs whose input validates; problems appended.
pub fn check_xsd(pairs: &[(PathBuf, PathBuf, String)], problems: &mut Vec<String>) {
    if !have_xmllint() {
        return;
    }
    let ins: Vec<(PathBuf, String)> = pairs
        .iter()
        .map(|(i, _, v)| (i.clone(), v.clone()))
        .collect();
    let valid_in = xmllint_validate_all(&ins, threads());
    let outs: Vec<(PathBuf, String)> = pairs
        .iter()
        .filter(|(i, _, _)| matches!(valid_in.get(i), Some(Ok(()))))
        .map(|(_, o, v)| (o.clone(), v.clone()))
        .collect();
    let valid_out = xmllint_validate_all(&outs, threads());
    for (i, o, _) in pairs {
        if let Some(Err(e)) = valid_out.get(o) {
            problems.push(format!(
                "{}: input validates, output does not:\n{e}",
                short(i)
            ));
        }
    }
    eprintln!(
        "{} of {} outputs checked against the XSD",
        outs.len(),
        pairs.len()
    );
}

/// References: none unresolved in the output unless already unresolved in the input.
pub fn check_refs(input: &Path, out: &Path, problems: &mut Vec<String>) {
    let before: HashSet<String> = unresolved_refs(input)
        .unwrap_or_default()
        .into_iter()
        .collect();
    match unresolved_refs(out) {
        Ok(after) => {
            let new: Vec<&String> = after.iter().filter(|h| !before.contains(*h)).collect();
            if !new.is_empty() {
                problems.push(format!(
                    "{}: {} unresolved reference(s) in the output, e.g. {:?}",
                    short(input),
                    new.len(),
                    &new[..new.len().min(5)]
                ));
            }
        }
        Err(e) => problems.push(format!("{}: output does not parse: {e}", short(input))),
    }
}

/// Validate a JSON document against a schema of `schemas/` with Python's `jsonschema` (an
/// independent validator; skip/fail rule when it is missing).
#[allow(dead_code)]
pub fn check_json_schema(schema: &str, doc: &Path) {
    let schema = manifest_dir().join("schemas").join(schema);
    let script = "import json,sys,jsonschema\n\
        s=json.load(open(sys.argv[1])); d=json.load(open(sys.argv[2]))\n\
        jsonschema.Draft202012Validator.check_schema(s)\n\
        jsonschema.Draft202012Validator(s).validate(d)\n";
    if !python_has("jsonschema", "pip install jsonschema") {
        return;
    }
    let o = Command::new("python3")
        .args(["-c", script])
        .arg(&schema)
        .arg(doc)
        .output()
        .expect("python3");
    assert!(
        o.status.success(),
        "{} does not follow {}: {}",
        doc.display(),
        schema.display(),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Validate a command's standard output, a JSON document, against a schema of `schemas/`
/// ([`check_json_schema`]).
pub fn check_stdout_schema(schema: &str, o: &Output) {
    let dir = tempfile::tempdir().expect("temporary directory");
    let doc = dir.path().join("stdout.json");
    std::fs::write(&doc, &o.stdout).expect("writing stdout.json");
    check_json_schema(schema, &doc);
}

/// An argument as `&OsStr` (mixing `&str` and paths in one argument list).
pub fn os<S: AsRef<OsStr> + ?Sized>(s: &S) -> &OsStr {
    s.as_ref()
}

/// The arguments of `skylod COMMAND INPUT` with a `--poi P` for each of `pois`, then `rest`.
pub fn poi_args<'a, S: AsRef<OsStr> + ?Sized + 'a>(
    command: &'a str,
    input: &'a Path,
    pois: impl IntoIterator<Item = &'a S>,
    rest: &[&'a OsStr],
) -> Vec<&'a OsStr> {
    let mut args = vec![os(command), input.as_os_str()];
    for p in pois {
        args.extend([os("--poi"), p.as_ref()]);
    }
    args.extend(rest);
    args
}

/// The standard error of a finished command, as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).to_string()
}

/// The standard output of a finished command as JSON (panics, showing stderr, when it is not).
pub fn json(o: &Output) -> serde_json::Value {
    serde_json::from_slice(&o.stdout)
        .unwrap_or_else(|e| panic!("stdout is not JSON ({e}): {}", stderr(o)))
}
