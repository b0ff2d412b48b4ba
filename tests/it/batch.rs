//! Batch inputs as users give them: directories, glob patterns expanded by skylod, and `-`
//! (standard input, gzip recognised by content), on the shared Ingolstadt street.

use crate::util::*;
use serde_json::Value;
use std::ffi::OsStr;
use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Output, Stdio};

fn stats(args: &[&OsStr]) -> Value {
    let mut a = vec![os("stats"), os("--json")];
    a.extend_from_slice(args);
    let o = run(&a);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

fn ingolstadt() -> Option<PathBuf> {
    let d = shared_data()?.join("ingolstadt-lod3");
    if d.is_dir() {
        Some(d)
    } else {
        missing(&d.display().to_string());
        None
    }
}

/// Run the binary with `input` on its standard input.
fn piped(args: &[&OsStr], input: &[u8]) -> Output {
    let mut child = Command::new(BIN)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let data = input.to_vec();
    let writer = std::thread::spawn(move || {
        let _ = stdin.write_all(&data);
    });
    let o = child.wait_with_output().unwrap();
    writer.join().unwrap();
    o
}

#[test]
fn directory_and_glob_give_the_files_they_hold() {
    let Some(dir) = ingolstadt() else {
        return;
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(".xml.gz"))
        .collect();
    files.sort();
    let listed = stats(&files.iter().map(|p| p.as_os_str()).collect::<Vec<_>>());
    let by_dir = stats(&[dir.as_os_str()]);
    let pattern = dir.join("*.xml.gz");
    let by_glob = stats(&[pattern.as_os_str()]);
    assert_eq!(by_dir["files"].as_array().unwrap().len(), files.len());
    assert_eq!(by_dir["total"], listed["total"]);
    assert_eq!(by_glob["total"], listed["total"]);
    // The files come in path order, whatever the directory order.
    let paths: Vec<&str> = by_dir["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["path"].as_str().unwrap())
        .collect();
    let mut sorted = paths.clone();
    sorted.sort();
    assert_eq!(paths, sorted);
    // A pattern that matches nothing is a usage error naming it.
    let none = dir.join("*.citygml");
    let o = run(&[os("stats"), none.as_os_str()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("no CityGML file"), "{}", stderr(&o));
}

#[test]
fn standard_input_in_standard_output_out_is_byte_identical_to_files() {
    let Some(dir) = ingolstadt() else {
        return;
    };
    let gz = dir.join("4018215.xml.gz");
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out.gml");
    let o = run(&[os("convert"), gz.as_os_str(), os("-o"), out.as_os_str()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let want = std::fs::read(&out).unwrap();
    // gzip on standard input is recognised by its magic bytes.
    let o = piped(
        &[os("convert"), os("-"), os("-o"), os("-")],
        &std::fs::read(&gz).unwrap(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        o.stdout == want,
        "stdin -> stdout differs from file -> file"
    );
    // Plain XML on standard input, into stats.
    let o = piped(&[os("stats"), os("--json"), os("-")], &want);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    let file = stats(&[out.as_os_str()]);
    assert_eq!(v["total"]["features"], file["total"]["features"]);
    assert_eq!(v["total"]["polygons"], file["total"]["polygons"]);
}

/// `rough` over a directory: the same bytes whatever `--jobs`; a broken file among them is
/// reported and the others are done (exit 1), and a closing line sums it up.
#[test]
fn rough_over_a_directory_any_jobs_and_a_broken_file() {
    let Some(dir) = ingolstadt() else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let tiles = tmp.path().join("tiles");
    std::fs::create_dir(&tiles).unwrap();
    let mut names: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(".xml.gz"))
        .collect();
    names.sort();
    for p in names.iter().take(8) {
        std::fs::copy(p, tiles.join(p.file_name().unwrap())).unwrap();
    }
    let run_jobs = |jobs: &str, out: &std::path::Path| {
        let o = run(&[
            os("rough"),
            tiles.as_os_str(),
            os("-o"),
            out.as_os_str(),
            os("--jobs"),
            os(jobs),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let err = stderr(&o);
        assert!(err.contains("rough: 8 file(s) ok, 0 failed"), "{err}");
        let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(out)
            .unwrap()
            .map(|e| {
                let p = e.unwrap().path();
                (
                    p.file_name().unwrap().to_string_lossy().to_string(),
                    std::fs::read(&p).unwrap(),
                )
            })
            .collect();
        files.sort();
        files
    };
    let one = run_jobs("1", &tmp.path().join("one"));
    let two = run_jobs("2", &tmp.path().join("two"));
    assert_eq!(one.len(), 8);
    assert!(one == two, "--jobs 1 and --jobs 2 differ");

    // A broken tile among them.
    std::fs::write(tiles.join("broken.gml"), "<CityModel><unclosed>").unwrap();
    let out = tmp.path().join("three");
    let o = run(&[os("rough"), tiles.as_os_str(), os("-o"), out.as_os_str()]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("broken.gml"), "{err}");
    assert!(err.contains("rough: 8 file(s) ok, 1 failed"), "{err}");
    assert_eq!(
        std::fs::read_dir(&out).unwrap().count(),
        8,
        "the others are written, nothing for the broken one"
    );
    // stats: the same closing line.
    let o = run(&[os("stats"), tiles.as_os_str()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("stats: 8 file(s) ok, 1 failed"),
        "{}",
        stderr(&o)
    );
}

/// The first `n` Ingolstadt tiles, copied below `root` into a small tree: `a/` and `b/c/`.
fn tile_tree(src: &std::path::Path, root: &std::path::Path, n: usize) -> Vec<PathBuf> {
    let mut names: Vec<PathBuf> = std::fs::read_dir(src)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(".xml.gz"))
        .collect();
    names.sort();
    let mut rel = Vec::new();
    for (i, p) in names.iter().take(n).enumerate() {
        let sub = if i % 2 == 0 { "a" } else { "b/c" };
        let r = PathBuf::from(sub).join(p.file_name().unwrap());
        std::fs::create_dir_all(root.join(sub)).unwrap();
        std::fs::copy(p, root.join(&r)).unwrap();
        rel.push(r);
    }
    rel
}

/// Every file below `dir`, relative, sorted, with its bytes.
fn tree_files(dir: &std::path::Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = walk(dir)
        .into_iter()
        .map(|p| {
            (
                p.strip_prefix(dir).unwrap().display().to_string(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

fn walk(dir: &std::path::Path) -> Vec<PathBuf> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            v.extend(walk(&p));
        } else {
            v.push(p);
        }
    }
    v
}

/// `convert DIR -o OUT`: the output tree mirrors the input tree; a broken file among them is
/// reported on one line (file, line:column, reason), the others are converted, exit 1, a
/// closing summary, and nothing is left for the broken one (no temporary file either).
#[test]
fn convert_mirrors_a_tree_and_survives_a_broken_file() {
    let Some(src) = ingolstadt() else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let tiles = tmp.path().join("tiles");
    let rel = tile_tree(&src, &tiles, 6);
    std::fs::write(tiles.join("b/broken.gml"), "<CityModel>\n  <unclosed>\n").unwrap();
    let out = tmp.path().join("out");
    let o = run(&[os("convert"), tiles.as_os_str(), os("-o"), out.as_os_str()]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    let broken: Vec<&str> = err.lines().filter(|l| l.contains("broken.gml")).collect();
    assert_eq!(broken.len(), 1, "one line for the broken file:\n{err}");
    assert!(
        broken[0].starts_with("error: ") && broken[0].contains("broken.gml:"),
        "file and position on the line: {}",
        broken[0]
    );
    assert!(err.contains("convert: 6 file(s) ok, 1 failed"), "{err}");
    let got: Vec<String> = tree_files(&out).into_iter().map(|(p, _)| p).collect();
    let mut want: Vec<String> = rel.iter().map(|p| p.display().to_string()).collect();
    want.sort();
    assert_eq!(got, want, "the output tree mirrors the input tree");
    // Each mirrored file is what converting that file alone gives.
    let single = tmp.path().join("single.xml.gz");
    let o = run(&[
        os("convert"),
        tiles.join(&rel[1]).as_os_str(),
        os("-o"),
        single.as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let a = gunzip(&std::fs::read(&single).unwrap());
    let b = gunzip(&std::fs::read(out.join(&rel[1])).unwrap());
    assert!(a == b, "mirrored output differs from a single conversion");
    // Two inputs that would land on one output: refused before any work.
    let other = tmp.path().join("other");
    std::fs::create_dir(&other).unwrap();
    std::fs::copy(tiles.join(&rel[0]), other.join(rel[0].file_name().unwrap())).unwrap();
    let out2 = tmp.path().join("out2");
    let o = run(&[
        os("convert"),
        tiles.join(&rel[0]).as_os_str(),
        other.join(rel[0].file_name().unwrap()).as_os_str(),
        os("-o"),
        out2.as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("would both be written"),
        "{}",
        stderr(&o)
    );
    assert!(!out2.exists(), "nothing written");
}

fn gunzip(b: &[u8]) -> Vec<u8> {
    use std::io::Read;
    let mut v = Vec::new();
    flate2::read::MultiGzDecoder::new(b)
        .read_to_end(&mut v)
        .unwrap();
    v
}

/// Bounds of every `gml:pos` / `gml:posList` coordinate (3-D) of a document, ignoring
/// envelopes; and the corners of its root envelope.
fn coords_and_root_envelope(text: &str) -> ([f64; 3], [f64; 3], Vec<f64>, Vec<f64>) {
    use quick_xml::events::Event;
    let mut r = quick_xml::Reader::from_str(text);
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    let (mut lower, mut upper) = (Vec::new(), Vec::new());
    let mut open: Vec<Vec<u8>> = Vec::new();
    loop {
        match r.read_event().unwrap() {
            Event::Eof => break,
            Event::Start(e) => open.push(e.local_name().as_ref().to_vec()),
            Event::End(_) => {
                open.pop();
            }
            Event::Text(t) => {
                let Some(name) = open.last() else { continue };
                let vals = || -> Vec<f64> {
                    t.decode()
                        .unwrap()
                        .split_ascii_whitespace()
                        .map(|v| v.parse().unwrap())
                        .collect()
                };
                match name.as_slice() {
                    b"pos" | b"posList" => {
                        for p in vals().chunks_exact(3) {
                            for i in 0..3 {
                                lo[i] = lo[i].min(p[i]);
                                hi[i] = hi[i].max(p[i]);
                            }
                        }
                    }
                    b"lowerCorner" if open.len() == 4 => lower = vals(),
                    b"upperCorner" if open.len() == 4 => upper = vals(),
                    _ => {}
                }
            }
            _ => {}
        }
    }
    (lo, hi, lower, upper)
}

/// Every `gml:id` of a document is unique.
fn ids_unique(text: &str) -> usize {
    let ids: Vec<&str> = text
        .split("gml:id=\"")
        .skip(1)
        .map(|s| &s[..s.find('"').unwrap()])
        .collect();
    let set: std::collections::HashSet<&&str> = ids.iter().collect();
    assert_eq!(
        set.len(),
        ids.len(),
        "duplicate gml:id in the merged document"
    );
    ids.len()
}

/// `-o FILE` with several inputs: one document, XSD-valid when the inputs are (the FZK-Haus
/// variants, whose ids collide, in CityGML 2.0 and 3.0), unique ids, every reference resolved,
/// the envelope over all coordinates; the same for `lod` and `rough`, and `-o -` writes the
/// same bytes to standard output.
#[test]
fn merged_output_is_valid_with_unique_ids_and_the_envelope_of_all() {
    let Some(data) = shared_data() else {
        return;
    };
    if !have_xmllint() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    for (version, dir, pattern) in [
        ("2.0", "kit-fzk-haus/citygml2", "fzk_haus_lod*_v2.gml"),
        ("3.0", "kit-fzk-haus/citygml3", "*.gml"),
    ] {
        let pat = data.join(dir).join(pattern);
        let inputs = glob::glob(&pat.to_string_lossy())
            .unwrap()
            .map(Result::unwrap)
            .collect::<Vec<_>>();
        assert!(inputs.len() >= 3, "{}", pat.display());
        for i in &inputs {
            xmllint_validate(i, version).unwrap_or_else(|e| panic!("input invalid: {e}"));
        }
        let out = tmp.path().join(format!("merged-{version}.gml"));
        let o = run(&[os("convert"), pat.as_os_str(), os("-o"), out.as_os_str()]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(0), "{err}");
        assert!(err.contains("gml:id(s) renamed"), "{err}");
        xmllint_validate(&out, version).unwrap_or_else(|e| panic!("{version} merge: {e}"));
        let text = std::fs::read_to_string(&out).unwrap();
        ids_unique(&text);
        assert_eq!(unresolved_refs(&out).unwrap(), Vec::<String>::new());
        assert_eq!(
            text.matches("CityModel ").count() + text.matches("CityModel>").count(),
            2
        );
        let (lo, hi, lower, upper) = coords_and_root_envelope(&text);
        for i in 0..3 {
            assert!(
                (lower[i] - lo[i]).abs() < 1e-6,
                "{version}: {lower:?} vs {lo:?}"
            );
            assert!(
                (upper[i] - hi[i]).abs() < 1e-6,
                "{version}: {upper:?} vs {hi:?}"
            );
        }
        // Standard output: the same bytes.
        let o = run(&[os("convert"), pat.as_os_str(), os("-o"), os("-")]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        assert!(o.stdout == text.as_bytes(), "-o - differs from -o FILE");
        // rough and lod merge their per-input models.
        let rough = tmp.path().join(format!("rough-{version}.gml"));
        let o = run(&[os("rough"), pat.as_os_str(), os("-o"), rough.as_os_str()]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        xmllint_validate(&rough, version).unwrap_or_else(|e| panic!("{version} rough: {e}"));
        ids_unique(&std::fs::read_to_string(&rough).unwrap());
        let lod = tmp.path().join(format!("lod-{version}.gml"));
        let o = run(&[
            os("lod"),
            pat.as_os_str(),
            os("--poi"),
            os("457848,5439070,112"),
            os("--rays"),
            os("500"),
            os("-o"),
            lod.as_os_str(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        xmllint_validate(&lod, version).unwrap_or_else(|e| panic!("{version} lod: {e}"));
        ids_unique(&std::fs::read_to_string(&lod).unwrap());
        assert_eq!(unresolved_refs(&lod).unwrap(), Vec::<String>::new());
    }
    // Different CityGML versions are refused before any work (exit 2), naming the files;
    // nothing is written. The same for rough and lod; reproject (one target CRS) compares
    // versions only.
    let mixed = tmp.path().join("mixed.gml");
    for cmd in ["convert", "rough", "lod"] {
        let v2 = data.join("kit-fzk-haus/citygml2/fzk_haus_lod2_v2.gml");
        let v3 = data.join("kit-fzk-haus/citygml3");
        let mut a = vec![
            os(cmd),
            v2.as_os_str(),
            v3.as_os_str(),
            os("-o"),
            mixed.as_os_str(),
        ];
        if cmd == "lod" {
            a.extend([os("--poi"), os("458877,5438353,1.5")]);
        }
        let o = run(&a);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{cmd}: {err}");
        assert!(
            err.contains("cannot merge CityGML 2.0") && err.contains("fzk_haus_lod2_v2.gml"),
            "{cmd}: {err}"
        );
        assert!(
            !err.contains(" -> "),
            "{cmd}: refused before any input is done: {err}"
        );
        assert!(!mixed.exists());
    }
    // Different CRSs too, from the documents' heads: FZK-Haus (EPSG:25832) and PLATEAU.
    let plateau = data.join("plateau/sapporo/64413325_bldg_6697_op.gml");
    {
        let o = run(&[
            os("convert"),
            data.join("kit-fzk-haus/citygml2/fzk_haus_lod2_v2.gml")
                .as_os_str(),
            plateau.as_os_str(),
            os("-o"),
            mixed.as_os_str(),
        ]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains("different CRSs"), "{err}");
        assert!(!mixed.exists());
    }
    assert_eq!(
        std::fs::read_dir(tmp.path())
            .unwrap()
            .filter(|e| e
                .as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .starts_with('.'))
            .count(),
        0,
        "no staging directory left behind"
    );
}

/// A merge of real Ingolstadt tiles (not XSD-valid themselves: their ids start with digits):
/// what `stats` counts in the merge is the sum over the tiles, ids are unique, references
/// resolve, and the envelope covers every coordinate.
#[test]
fn merged_ingolstadt_tiles_keep_every_feature() {
    let Some(src) = ingolstadt() else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let tiles = tmp.path().join("tiles");
    tile_tree(&src, &tiles, 10);
    let out = tmp.path().join("street.gml.gz");
    let o = run(&[os("convert"), tiles.as_os_str(), os("-o"), out.as_os_str()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let merged = stats(&[out.as_os_str()]);
    let each = stats(&[tiles.as_os_str()]);
    // One CityModel instead of ten; every other feature kept.
    let mut features = each["total"]["features"].clone();
    features["CityModel"] = 1.into();
    assert_eq!(merged["total"]["features"], features);
    assert_eq!(merged["total"]["polygons"], each["total"]["polygons"]);
    let text = String::from_utf8(gunzip(&std::fs::read(&out).unwrap())).unwrap();
    assert!(ids_unique(&text) > 1000);
    assert_eq!(unresolved_refs(&out).unwrap(), Vec::<String>::new());
    let (lo, hi, lower, upper) = coords_and_root_envelope(&text);
    for i in 0..3 {
        assert!(lower[i] <= lo[i] + 1e-6 && upper[i] >= hi[i] - 1e-6);
    }
}

/// `--jobs 1` and `--jobs 2` give the same bytes: convert to a mirrored tree and to a merge,
/// and the scene commands (lod's model, svf's values).
#[test]
fn jobs_one_and_two_give_the_same_bytes() {
    let Some(src) = ingolstadt() else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let tiles = tmp.path().join("tiles");
    tile_tree(&src, &tiles, 8);
    let pois = [
        "678060,5403830,416",
        "678070,5403800,416",
        "678090,5403835,418",
    ];
    let mut outs = Vec::new();
    for j in ["1", "2"] {
        let dir = tmp.path().join(format!("mirror{j}"));
        let merged = tmp.path().join(format!("merged{j}.gml"));
        let lod = tmp.path().join(format!("lod{j}.gml"));
        for target in [&dir, &merged] {
            let o = run(&[
                os("convert"),
                tiles.as_os_str(),
                os("-o"),
                target.as_os_str(),
                os("--jobs"),
                os(j),
            ]);
            assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        }
        let mut a = vec![os("lod"), tiles.as_os_str(), os("--jobs"), os(j)];
        for p in &pois {
            a.extend([os("--poi"), os(p)]);
        }
        a.extend([os("--rays"), os("2000"), os("-o"), lod.as_os_str()]);
        let o = run(&a);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let mut a = vec![
            os("svf"),
            os("--json"),
            tiles.as_os_str(),
            os("--jobs"),
            os(j),
        ];
        for p in &pois {
            a.extend([os("--poi"), os(p)]);
        }
        let o = run(&a);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let mut svf: Value = serde_json::from_slice(&o.stdout).unwrap();
        svf.as_object_mut().unwrap().remove("timings_ms");
        outs.push((
            tree_files(&dir),
            std::fs::read(&merged).unwrap(),
            std::fs::read(&lod).unwrap(),
            svf,
        ));
    }
    assert_eq!(outs[0].0.len(), 8);
    assert!(
        outs[0].0 == outs[1].0,
        "convert to a tree: --jobs 1 and 2 differ"
    );
    assert!(
        outs[0].1 == outs[1].1,
        "convert merge: --jobs 1 and 2 differ"
    );
    assert!(outs[0].2 == outs[1].2, "lod: --jobs 1 and 2 differ");
    assert_eq!(outs[0].3, outs[1].3, "svf: --jobs 1 and 2 differ");
}

/// A merge in which some inputs fail: the target holds the others and says so (exit 1); when
/// every input fails nothing is written and no staging directory is left (exit 1). The same
/// last step in convert and rough.
#[test]
fn a_merge_holds_the_inputs_that_did_not_fail() {
    let tmp = tempfile::tempdir().unwrap();
    let good = fixture("chimney-citygml2.gml");
    let text = std::fs::read(&good).unwrap();
    let (b1, b2) = (tmp.path().join("b1.gml"), tmp.path().join("b2.gml"));
    std::fs::write(&b1, &text[..text.len() / 2]).unwrap();
    std::fs::write(&b2, &text[..text.len() / 3]).unwrap();
    for cmd in ["convert", "rough"] {
        let out = tmp.path().join(format!("{cmd}-some.gml"));
        let o = run(&[
            os(cmd),
            good.as_os_str(),
            b1.as_os_str(),
            os("-o"),
            out.as_os_str(),
        ]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{cmd}: {err}");
        assert!(err.contains("holds 1 of the 2 inputs"), "{cmd}: {err}");
        assert!(err.contains("merged 1 file(s) into"), "{cmd}: {err}");
        assert!(err.contains("1 file(s) ok, 1 failed"), "{cmd}: {err}");
        let merged = std::fs::read_to_string(&out).unwrap();
        assert_eq!(merged.matches("<bldg:Building ").count(), 1, "{cmd}");

        let out = tmp.path().join(format!("{cmd}-none.gml"));
        let o = run(&[
            os(cmd),
            b1.as_os_str(),
            b2.as_os_str(),
            os("-o"),
            out.as_os_str(),
        ]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{cmd}: {err}");
        assert!(err.contains("nothing to merge"), "{cmd}: {err}");
        assert!(err.contains("0 file(s) ok, 2 failed"), "{cmd}: {err}");
        assert!(!out.exists(), "{cmd}: nothing written");
    }
    let left: Vec<_> = std::fs::read_dir(tmp.path())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with(".skylod"))
        .collect();
    assert!(left.is_empty(), "staging directories left: {left:?}");
}
