//! The house rules of `ARCHITECTURE.md` ("Import rules"), checked on the source tree. The
//! library is six groups, layered `model < io < solar < lod < export < pipeline`:
//!
//! - each group imports only the groups before it (so no cycle between groups), and the
//!   folders inside a group (`model/crs`, `io/citygml`, ...: [`GROUPS`]) import each other
//!   without a cycle;
//! - plain data (`model/`) imports no other group, tracing (`solar/trace/`) knows no levels,
//!   the reader (`io/citygml/read/`) imports neither the writer nor `lod`;
//! - the library never prints; no source file outside `src/model/synth/` passes 1,000 lines;
//!   at most six folders or files at the top of `src/` besides `lib.rs` and `bin/`; each
//!   command of the binary at most 200 lines (the binary owns the words of the command line,
//!   however many: no cap on the binary as a whole).
//!
//! Imports are read from the text: every `crate::path` (and each part of `crate::{a, b}`)
//! outside comments, outside the `#[cfg(test)] mod tests` block at the end of a file and
//! outside files of unit tests only (`tests.rs`: tests may use anything). Paths of before the groups (`crate::crs::`, `crate::citygml::`,
//! ..., kept working by the crate root for one release) are read as the folder they name
//! now, so code merged with the old paths is checked as well. Each rule is a function
//! returning its violations; `each_rule_can_fail` runs them on a fake tree that breaks
//! every one of them.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The six groups in layering order, with the folders (or files) inside each that the
/// cycle check treats as units of their own; the rest of a group is its core.
const GROUPS: &[(&str, &[&str])] = &[
    ("model", &["crs", "synth", "runtime"]),
    ("io", &["files", "citygml", "cityjson"]),
    ("solar", &["trace"]),
    ("lod", &["poi", "evaluation"]),
    ("export", &["report", "transform"]),
    ("pipeline", &["session", "batch"]),
];

/// Root paths of before the six groups (the hidden re-exports of `lib.rs`) and where they
/// point now.
const OLD: &[(&str, &str)] = &[
    ("crs", "model::crs"),
    ("synth", "model::synth"),
    ("runtime", "model::runtime"),
    ("progress", "model::runtime::progress"),
    ("mem", "model::runtime::mem"),
    ("citygml", "io::citygml"),
    ("cityjson", "io::cityjson"),
    ("trace", "solar::trace"),
    ("sky", "solar::sky"),
    ("poi", "lod::poi"),
    ("checks", "lod::poi::checks"),
    ("region", "lod::poi::region"),
    ("evaluate", "lod::evaluation"),
    ("bound", "lod::bound"),
    ("level", "lod::level"),
    ("rough", "lod::rough"),
    ("scene", "lod::scene"),
    ("select", "lod::select"),
    ("output", "export::report"),
    ("report", "export::report::report"),
    ("stats", "export::report::stats"),
    ("session", "pipeline::session"),
    ("batch", "pipeline::batch"),
    ("inputs", "pipeline::batch::inputs"),
    ("scene_radius", "pipeline::batch::scene_radius"),
    ("shard", "pipeline::batch::shard"),
    ("shard_levels", "pipeline::batch::shard_levels"),
];

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// Every `.rs` file below `dir`, sorted.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap_or_else(|e| panic!("{}: {e}", d.display())) {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The library's code of a file: comments and the trailing unit-test module removed.
fn code(text: &str) -> String {
    let text = match text.find("#[cfg(test)]\nmod tests") {
        Some(i) => &text[..i],
        None => text,
    };
    text.lines()
        .map(|l| match l.find("//") {
            Some(i) if !l[..i].contains('"') => &l[..i],
            _ => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

fn ident(s: &str) -> &str {
    let n = s
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(s.len());
    &s[..n]
}

/// The identifiers of the path at the start of `s` (`a::b::c` → [a, b, c]).
fn path_at(mut s: &str) -> Vec<String> {
    let mut out = Vec::new();
    loop {
        let id = ident(s);
        if id.is_empty() {
            return out;
        }
        out.push(id.to_string());
        match s[id.len()..].strip_prefix("::") {
            Some(rest) => s = rest,
            None => return out,
        }
    }
}

/// The `crate::` paths in `code`, each as its identifiers after `crate` (the parts of a
/// `crate::{a::X, b}` group each as a path of their own).
fn crate_paths(code: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    for (i, _) in code.match_indices("crate::") {
        if i > 0
            && code[..i]
                .ends_with(|c: char| c.is_ascii_alphanumeric() || c == '_' || c == ':' || c == '$')
        {
            continue; // `$crate::`, `other::crate::`
        }
        let rest = &code[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let (mut depth, mut start) = (0usize, 0usize);
            for (j, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => {
                        out.push(path_at(group[start..].trim_start()));
                        break;
                    }
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        out.push(path_at(group[start..].trim_start()));
                        start = j + 1;
                    }
                    _ => {}
                }
            }
        } else {
            out.push(path_at(rest));
        }
    }
    out.retain(|p| !p.is_empty());
    out
}

/// A path as of the six groups: an old root path (`crs::CrsName`) rewritten to the folder
/// it names now (`model::crs::CrsName`).
fn canonical(path: &[String]) -> Vec<String> {
    let Some(first) = path.first() else {
        return Vec::new();
    };
    let mut out: Vec<String> = match OLD.iter().find(|(old, _)| old == first) {
        Some((_, new)) => new.split("::").map(String::from).collect(),
        None => vec![first.clone()],
    };
    if out[0] == "pipeline" && path.get(1).is_some_and(|s| s == "evaluation") {
        out = vec!["lod".into(), "evaluation".into()];
        out.extend(path[2..].iter().cloned());
        return out;
    }
    out.extend(path[1..].iter().cloned());
    out
}

/// The unit of a canonical path: `group/member` for a folder of [`GROUPS`], else the group
/// (or the root name, for the facade: `Error`, `glam`, ...).
fn unit(path: &[String]) -> String {
    let group = path[0].as_str();
    match GROUPS.iter().find(|(g, _)| *g == group) {
        Some((_, members)) => match path.get(1) {
            Some(m) if members.contains(&m.as_str()) => format!("{group}/{m}"),
            _ => group.to_string(),
        },
        None => group.to_string(),
    }
}

/// The unit of a source file (`model/crs/frame.rs` → `model/crs`, `io/files.rs` →
/// `io/files`, `lod/select.rs` → `lod`).
fn file_unit(rel: &str) -> String {
    let parts: Vec<&str> = rel.split('/').collect();
    let group = parts[0].trim_end_matches(".rs");
    let member = parts.get(1).map(|m| m.trim_end_matches(".rs"));
    match (GROUPS.iter().find(|(g, _)| *g == group), member) {
        (Some((_, members)), Some(m)) if members.contains(&m) => format!("{group}/{m}"),
        _ => group.to_string(),
    }
}

fn group_of(unit: &str) -> &str {
    unit.split('/').next().unwrap()
}

fn rank(group: &str) -> Option<usize> {
    GROUPS.iter().position(|(g, _)| *g == group)
}

/// The library's files: (path below `src/`, library code), `lib.rs` and `bin/` left out.
struct Library {
    files: Vec<(String, String)>,
}

/// A file of unit tests only (`tests.rs`, `*_tests.rs`, `test_support.rs`): tests may use
/// anything.
fn is_unit_test_file(rel: &str) -> bool {
    let name = rel.rsplit('/').next().unwrap_or(rel);
    name == "tests.rs" || name.ends_with("_tests.rs") || name == "test_support.rs"
}

/// Every file of the library (outside `bin/`): its path below `src/` and its code ([`code`]).
fn library_sources() -> Vec<(String, String)> {
    let root = src();
    let mut files = Vec::new();
    for p in rust_files(&root) {
        let rel = p
            .strip_prefix(&root)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        if !rel.starts_with("bin/") {
            let text = std::fs::read_to_string(&p).unwrap();
            files.push((rel, code(&text)));
        }
    }
    files
}

fn library() -> Library {
    let files = (library_sources().into_iter())
        .filter(|(rel, _)| rel != "lib.rs" && !is_unit_test_file(rel))
        .collect();
    Library { files }
}

impl Library {
    /// Every import: (file, canonical path).
    fn imports(&self) -> Vec<(&str, Vec<String>)> {
        let mut out = Vec::new();
        for (rel, code) in &self.files {
            for p in crate_paths(code) {
                out.push((rel.as_str(), canonical(&p)));
            }
        }
        out
    }

    /// Which units each unit imports, with one place per edge.
    fn unit_edges(&self) -> BTreeMap<String, BTreeMap<String, String>> {
        let mut e: BTreeMap<String, BTreeMap<String, String>> = BTreeMap::new();
        for (rel, _) in &self.files {
            e.entry(file_unit(rel)).or_default();
        }
        for (rel, path) in self.imports() {
            let (from, to) = (file_unit(rel), unit(&path));
            if from != to {
                e.entry(from)
                    .or_default()
                    .entry(to)
                    .or_insert_with(|| rel.to_string());
            }
        }
        e
    }
}

/// A cycle of `edges`, each step with the file that makes it.
fn find_cycle(edges: &BTreeMap<String, BTreeMap<String, String>>) -> Option<String> {
    // Depth-first search for a back edge.
    fn visit(
        v: &str,
        edges: &BTreeMap<String, BTreeMap<String, String>>,
        state: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(v.to_string(), 1);
        path.push(v.to_string());
        for w in edges
            .get(v)
            .map(|m| m.keys().cloned().collect::<Vec<_>>())
            .unwrap_or_default()
        {
            match state.get(&w).copied().unwrap_or(0) {
                0 => {
                    if let Some(c) = visit(&w, edges, state, path) {
                        return Some(c);
                    }
                }
                1 => {
                    let start = path.iter().position(|x| *x == w).unwrap();
                    let mut c = path[start..].to_vec();
                    c.push(w);
                    return Some(c);
                }
                _ => {}
            }
        }
        path.pop();
        state.insert(v.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for v in edges.keys() {
        if state.get(v).copied().unwrap_or(0) == 0 {
            if let Some(c) = visit(v, edges, &mut state, &mut Vec::new()) {
                let why: Vec<String> = c
                    .windows(2)
                    .map(|w| format!("{} -> {} ({})", w[0], w[1], edges[&w[0]][&w[1]]))
                    .collect();
                return Some(why.join(", "));
            }
        }
    }
    None
}

/// Rule: each group imports only the groups before it (`model < io < solar < lod < export
/// < pipeline`), which leaves no cycle between groups.
fn layering(lib: &Library) -> Vec<String> {
    let mut bad = BTreeSet::new();
    for (rel, path) in lib.imports() {
        let (from, to) = (file_unit(rel), unit(&path));
        let (gf, gt) = (group_of(&from), group_of(&to));
        if let (Some(rf), Some(rt)) = (rank(gf), rank(gt)) {
            if rt > rf {
                bad.insert(format!(
                    "{rel}: crate::{} ({gf} may not import {gt}, a later group)",
                    path.join("::")
                ));
            }
        }
    }
    bad.into_iter().collect()
}

/// Rule: no import cycle between units (the folders inside a group, the groups' cores).
fn cycles(lib: &Library) -> Vec<String> {
    find_cycle(&lib.unit_edges())
        .map(|c| format!("import cycle: {c}"))
        .into_iter()
        .collect()
}

/// Rules of the form "files under `from` never import `to`" (`to` a canonical path prefix;
/// empty = any other group).
fn forbidden(lib: &Library) -> Vec<String> {
    let rules: &[(&str, &str, &str)] = &[
        (
            "model/",
            "",
            "data knows no stage: model imports no other group",
        ),
        ("solar/trace/", "lod", "tracing knows no levels"),
        ("model/crs/", "lod", "the frame knows no rough model"),
        ("solar/", "lod", "solar analysis takes a scene, not levels"),
        (
            "io/citygml/read/",
            "lod",
            "the reader never depends on the writer (lod::mixed)",
        ),
        (
            "io/citygml/read/",
            "io::citygml::write",
            "the reader never depends on the writer",
        ),
    ];
    let mut bad = Vec::new();
    for (rel, path) in lib.imports() {
        for (from, to, why) in rules {
            if !rel.starts_with(from) {
                continue;
            }
            let own = from.split('/').next().unwrap();
            let hit = if to.is_empty() {
                rank(&path[0]).is_some() && path[0] != own
            } else {
                let to: Vec<&str> = to.split("::").collect();
                path.len() >= to.len() && path.iter().zip(&to).all(|(a, b)| a == b)
            };
            if hit {
                bad.push(format!("{rel}: crate::{} ({why})", path.join("::")));
            }
        }
    }
    bad
}

/// Rule: the library never prints.
fn prints(lib: &Library) -> Vec<String> {
    let mut bad = BTreeSet::new();
    for (rel, code) in &lib.files {
        for m in ["println!", "eprintln!", "print!(", "eprint!(", "dbg!("] {
            if code.contains(m) {
                bad.insert(format!("{rel}: {m}"));
            }
        }
    }
    bad.into_iter().collect()
}

/// Rule: at most 1,000 lines per file outside `model/synth/` (`files`: path below `src/`,
/// line count).
fn long_files(files: &[(String, usize)]) -> Vec<String> {
    files
        .iter()
        .filter(|(rel, n)| *n > 1000 && !rel.starts_with("model/synth/"))
        .map(|(rel, n)| format!("{rel}: {n} lines (split by concern)"))
        .collect()
}

/// Rule: at most six folders or files at the top of `src/` besides `lib.rs` and `bin/`.
fn crowded_top(names: &[String]) -> Vec<String> {
    let top: Vec<&String> = names
        .iter()
        .filter(|n| *n != "lib.rs" && *n != "bin")
        .collect();
    if top.len() > 6 {
        vec![format!(
            "{} modules at the top of src/ besides lib.rs and bin/ (at most 6): {top:?}",
            top.len()
        )]
    } else {
        Vec::new()
    }
}

#[test]
fn groups_import_only_the_groups_before_them() {
    let lib = library();
    let units = lib.unit_edges();
    for (g, members) in GROUPS {
        assert!(
            units.contains_key(*g),
            "no files of the group {g}/: {units:?}"
        );
        for m in *members {
            let u = format!("{g}/{m}");
            assert!(units.contains_key(&u), "no files of {u}: {units:?}");
        }
    }
    let bad = layering(&lib);
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

#[test]
fn folders_import_each_other_without_a_cycle() {
    let bad = cycles(&library());
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// Rules of the form "`from` never imports `to`" (ARCHITECTURE.md, "Import rules").
#[test]
fn stages_import_only_what_they_may() {
    let bad = forbidden(&library());
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

#[test]
fn the_library_never_prints() {
    let bad = prints(&library());
    assert!(bad.is_empty(), "{bad:?}");
}

#[test]
fn source_files_stay_short_and_the_top_stays_small() {
    let root = src();
    let files: Vec<(String, usize)> = rust_files(&root)
        .into_iter()
        .map(|p| {
            let rel = p
                .strip_prefix(&root)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/");
            (rel, std::fs::read_to_string(&p).unwrap().lines().count())
        })
        .collect();
    let long = long_files(&files);
    assert!(long.is_empty(), "{long:?}");
    let names: Vec<String> = std::fs::read_dir(&root)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().any(|n| n == "lib.rs"), "{names:?}");
    let crowded = crowded_top(&names);
    assert!(crowded.is_empty(), "{crowded:?}");
}

/// The library's public modules: `pub mod` (not `pub(crate)`) outside the binary.
fn public_modules() -> Vec<String> {
    let mut out = Vec::new();
    for (rel, code) in library_sources() {
        for l in code.lines() {
            if let Some(rest) = l.trim_start().strip_prefix("pub mod ") {
                out.push(format!("{rel}: {}", ident(rest)));
            }
        }
    }
    out
}

#[test]
fn the_library_shows_few_modules() {
    // The groups and the namespaces a program names; every other module is `pub(crate)`,
    // its items re-exported by the nearest public parent.
    let public = public_modules();
    assert!(
        public.len() <= 30,
        "{} public modules: {public:#?}",
        public.len()
    );
    assert!(
        public.iter().any(|m| m.ends_with(": pipeline")),
        "{public:?}"
    );
}

#[test]
fn the_path_reader_sees_imports() {
    // The checks above are only as good as the reader of imports: it must see these.
    let code = code("use crate::lod::rough; // crate::solar in a comment\nfn f() { crate::trace::TraceScene::new(); $crate::x::y(); }\nuse crate::{io::citygml::write, model};\n#[cfg(test)]\nmod tests { use crate::synth; }\n");
    let found: Vec<String> = crate_paths(&code)
        .iter()
        .map(|p| canonical(p).join("::"))
        .collect();
    assert_eq!(
        found,
        [
            "lod::rough",
            "solar::trace::TraceScene::new",
            "io::citygml::write",
            "model"
        ]
    );
    let units: Vec<String> = crate_paths(&code)
        .iter()
        .map(|p| unit(&canonical(p)))
        .collect();
    assert_eq!(units, ["lod", "solar/trace", "io/citygml", "model"]);
    assert_eq!(file_unit("model/crs/frame.rs"), "model/crs");
    assert_eq!(file_unit("io/files.rs"), "io/files");
    assert_eq!(file_unit("lod/rough/mod.rs"), "lod");
    assert_eq!(file_unit("pipeline/evaluation.rs"), "pipeline");
    assert_eq!(
        canonical(&path_at("pipeline::evaluation::PoiEval")).join("::"),
        "lod::evaluation::PoiEval"
    );
}

/// Every rule above fires on a tree made to break it (and the real tree passes them all,
/// in the tests above): a rule that cannot fail checks nothing.
#[test]
fn each_rule_can_fail() {
    let fake = |files: &[(&str, &str)]| Library {
        files: files
            .iter()
            .map(|(rel, text)| (rel.to_string(), code(text)))
            .collect(),
    };
    // A good fake tree passes every rule.
    let good = fake(&[
        ("model/poi.rs", "use crate::model::CityModel;"),
        ("model/crs/mod.rs", "use crate::model::Poi;"),
        ("io/citygml/read/mod.rs", "use crate::io::files::is_gzip;"),
        ("solar/trace/mod.rs", "use crate::model::CityModel;"),
        (
            "lod/mod.rs",
            "use crate::{solar::trace::TraceScene, io::citygml};",
        ),
        ("pipeline/mod.rs", "use crate::export::report::LodReport;"),
    ]);
    assert!(layering(&good).is_empty(), "{:?}", layering(&good));
    assert!(cycles(&good).is_empty(), "{:?}", cycles(&good));
    assert!(forbidden(&good).is_empty(), "{:?}", forbidden(&good));
    assert!(prints(&good).is_empty());
    // An upward import (the old `output` -> `pipeline::evaluation`, written the old way).
    let up = fake(&[(
        "export/report/evaluate.rs",
        "use crate::pipeline::frame::Framed;",
    )]);
    assert_eq!(layering(&up).len(), 1, "{:?}", layering(&up));
    // ... but the evaluation's old path names `lod`: no violation.
    let old = fake(&[(
        "export/report/evaluate.rs",
        "use crate::lod::evaluation::PoiEval;",
    )]);
    assert!(layering(&old).is_empty(), "{:?}", layering(&old));
    // A cycle inside a group (no layering rule sees it).
    let cyc = fake(&[
        ("io/citygml/mod.rs", "use crate::io::cityjson::Doc;"),
        ("io/cityjson/mod.rs", "use crate::citygml::ReadError;"),
    ]);
    assert!(layering(&cyc).is_empty());
    let c = cycles(&cyc);
    assert_eq!(c.len(), 1, "{c:?}");
    assert!(c[0].contains("io/citygml -> io/cityjson"), "{c:?}");
    // The forbidden edges, each once.
    for (rel, text, expect) in [
        (
            "model/poi.rs",
            "use crate::io::files::FileError;",
            "data knows no stage",
        ),
        (
            "model/synth/gml.rs",
            "use crate::citygml::write;",
            "data knows no stage",
        ),
        (
            "solar/trace/scene.rs",
            "use crate::lod::level::Level;",
            "tracing knows no levels",
        ),
        (
            "model/crs/frame.rs",
            "fn f() { crate::rough::x(); }",
            "the frame knows no rough model",
        ),
        (
            "io/citygml/read/mod.rs",
            "use crate::io::citygml::write::Span;",
            "the reader never depends on the writer",
        ),
        (
            "io/citygml/read/ids.rs",
            "use crate::lod::mixed;",
            "the reader never depends on the writer (lod::mixed)",
        ),
    ] {
        let bad = forbidden(&fake(&[(rel, text)]));
        assert!(
            bad.iter().any(|b| b.contains(expect)),
            "{rel}: {text}: {bad:?}"
        );
    }
    // Printing, in code but not in a comment.
    assert!(!prints(&fake(&[("lod/x.rs", "fn f() { eprintln!(\"x\"); }")])).is_empty());
    assert!(prints(&fake(&[("lod/x.rs", "// println!(\"x\")")])).is_empty());
    // Long files, except generated districts.
    assert_eq!(
        long_files(&[("lod/x.rs".into(), 1001), ("model/synth/b.rs".into(), 5000)]).len(),
        1
    );
    // Seven modules at the top; six pass.
    let mut names: Vec<String> = ["lib.rs", "bin", "model", "io", "solar", "lod", "export"]
        .map(String::from)
        .to_vec();
    names.push("pipeline".into());
    assert!(crowded_top(&names).is_empty());
    names.push("extra.rs".into());
    assert_eq!(crowded_top(&names).len(), 1);
}

#[test]
fn each_command_of_the_binary_stays_short() {
    let commands = src().join("bin/skylod/commands");
    let mut long = Vec::new();
    for p in rust_files(&commands) {
        let lines = std::fs::read_to_string(&p).unwrap().lines().count();
        if lines > 200 {
            long.push(format!("{}: {lines} lines", p.display()));
        }
    }
    assert!(!rust_files(&commands).is_empty(), "no commands found");
    assert!(
        long.is_empty(),
        "a command maps flags to library calls: {long:?}"
    );
}
