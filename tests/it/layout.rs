//! The house rules of `ARCHITECTURE.md` ("Import rules"), checked on the source tree: the folders of `src/`
//! import each other without a cycle (so they could become crates), plain data imports no
//! stage, tracing knows no levels, the reader never depends on the writer, the library never
//! prints, and no source file outside `src/synth/` passes 1,000 lines.
//!
//! Imports are read from the text: every `crate::name` outside comments and outside the
//! `#[cfg(test)] mod tests` block at the end of a file (tests may use anything).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

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

/// `crate::a::b` paths in `code`, as (a, b) (b empty when the path stops at a).
fn crate_paths(code: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect()
    };
    for (i, _) in code.match_indices("crate::") {
        if i > 0 && code[..i].ends_with(|c: char| c.is_ascii_alphanumeric() || c == '_' || c == ':')
        {
            continue; // `$crate::` or `other::crate::`
        }
        let rest = &code[i + "crate::".len()..];
        let a = ident(rest);
        let b = rest[a.len()..]
            .strip_prefix("::")
            .map(ident)
            .unwrap_or_default();
        out.push((a, b));
    }
    out
}

struct Library {
    /// (top-level module, path below `src/`, library code of the file)
    files: Vec<(String, String, String)>,
}

fn library() -> Library {
    let root = src();
    let mut files = Vec::new();
    for p in rust_files(&root) {
        let rel = p
            .strip_prefix(&root)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        if rel.starts_with("bin/") || rel == "lib.rs" {
            continue;
        }
        let top = rel
            .split('/')
            .next()
            .unwrap()
            .trim_end_matches(".rs")
            .to_string();
        let text = std::fs::read_to_string(&p).unwrap();
        files.push((top, rel, code(&text)));
    }
    Library { files }
}

impl Library {
    /// Which top-level modules each imports, with one place per edge.
    fn edges(&self) -> BTreeMap<String, BTreeMap<String, String>> {
        let mut e: BTreeMap<String, BTreeMap<String, String>> = BTreeMap::new();
        for (top, rel, code) in &self.files {
            e.entry(top.clone()).or_default();
            for (a, _) in crate_paths(code) {
                if &a != top {
                    e.get_mut(top)
                        .unwrap()
                        .entry(a)
                        .or_insert_with(|| rel.clone());
                }
            }
        }
        e
    }
}

#[test]
fn folders_import_each_other_without_a_cycle() {
    let edges = library().edges();
    // Depth-first search for a back edge; the cycle is printed with one file per edge.
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
            if let Some(c) = visit(v, &edges, &mut state, &mut Vec::new()) {
                let why: Vec<String> = c
                    .windows(2)
                    .map(|w| format!("{} -> {} ({})", w[0], w[1], edges[&w[0]][&w[1]]))
                    .collect();
                panic!("import cycle between folders of src/: {}", why.join(", "));
            }
        }
    }
    assert!(
        edges.len() >= 10,
        "the library's folders were not found: {edges:?}"
    );
}

/// Rules of the form "`from` never imports `to`" (ARCHITECTURE.md, "Import rules").
#[test]
fn stages_import_only_what_they_may() {
    let lib = library();
    let forbidden: &[(&str, &str, &str)] = &[
        (
            "model/",
            "",
            "data knows no stage: model imports nothing of the crate but itself",
        ),
        ("trace/", "lod", "tracing knows no levels"),
        (
            "citygml/read/",
            "lod",
            "the reader never depends on the writer (lod::mixed)",
        ),
        (
            "citygml/read/",
            "citygml::write",
            "the reader never depends on the writer",
        ),
        ("crs/", "lod", "the frame knows no rough model"),
        ("solar/", "lod", "solar analysis takes a scene, not levels"),
    ];
    let mut bad = Vec::new();
    for (_, rel, code) in &lib.files {
        for (a, b) in crate_paths(code) {
            for (from, to, why) in forbidden {
                if !rel.starts_with(from) {
                    continue;
                }
                let own = from.trim_end_matches('/').split('/').next().unwrap();
                let hit = if to.is_empty() {
                    a != own
                } else if let Some((ta, tb)) = to.split_once("::") {
                    a == ta && b == tb
                } else {
                    a == *to
                };
                if hit {
                    bad.push(format!("{rel}: crate::{a}::{b} ({why})"));
                }
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

#[test]
fn the_library_never_prints() {
    let mut bad = BTreeSet::new();
    for (_, rel, code) in &library().files {
        for m in ["println!", "eprintln!", "print!(", "eprint!(", "dbg!("] {
            if code.contains(m) {
                bad.insert(format!("{rel}: {m}"));
            }
        }
    }
    assert!(bad.is_empty(), "{bad:?}");
}

#[test]
fn source_files_stay_short_and_the_top_stays_small() {
    let root = src();
    let mut long = Vec::new();
    for p in rust_files(&root) {
        let rel = p
            .strip_prefix(&root)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        let lines = std::fs::read_to_string(&p).unwrap().lines().count();
        if lines > 1000 && !rel.starts_with("synth/") {
            long.push(format!("{rel}: {lines} lines"));
        }
    }
    assert!(long.is_empty(), "split by concern: {long:?}");
    let top: Vec<String> = std::fs::read_dir(&root)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file() && p.extension().is_some_and(|x| x == "rs"))
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .filter(|n| n != "lib.rs")
        .collect();
    assert!(
        top.len() <= 6,
        "modules at the top of src/ besides lib.rs: {top:?}"
    );
}

#[test]
fn the_path_reader_sees_imports() {
    // The checks above are only as good as the reader of imports: it must see these.
    let code = code("use crate::lod::rough; // crate::solar in a comment\nfn f() { crate::trace::Scene::new(); }\n#[cfg(test)]\nmod tests { use crate::synth; }\n");
    let found: Vec<String> = crate_paths(&code)
        .into_iter()
        .map(|(a, b)| format!("{a}::{b}"))
        .collect();
    assert_eq!(found, ["lod::rough", "trace::Scene"]);
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
