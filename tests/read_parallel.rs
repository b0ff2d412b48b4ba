//! One document read by several cores (`ReadOptions::split_min_bytes`): forced on every real
//! file, every fixture and the bad-input corpus, the model (buildings, assets, geometry,
//! warnings with their lines and columns, per-file counts) and the errors are exactly the
//! serial read's; broken copies of real files fail with the serial read's message and position.

mod common;

use common::{all_inputs, citygml_files, manifest_dir, short};
use skylod::citygml::read::{read_file_split, read_file_with, ReadOptions};
use skylod::model::CityModel;
use std::path::{Path, PathBuf};

fn serial() -> ReadOptions {
    ReadOptions {
        split_min_bytes: u64::MAX,
        ..ReadOptions::default()
    }
}

fn forced(parts: usize) -> ReadOptions {
    ReadOptions {
        split_min_bytes: 0,
        split_parts: parts,
        ..ReadOptions::default()
    }
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

fn show(r: &Result<CityModel, skylod::citygml::error::ReadError>) -> String {
    match r {
        Ok(m) => format!(
            "ok: {} buildings, {} assets, {} warnings",
            m.buildings.len(),
            m.assets.len(),
            m.warnings.len()
        ),
        Err(e) => format!("error: {e}"),
    }
}

/// Read `path` serially and split in 2 and 3 parts on two threads: the results must be equal.
/// Returns how many of the split reads were really split (not declined).
fn check(path: &Path) -> usize {
    let want = read_file_with(path, &serial());
    let mut split = 0;
    for parts in [2, 3] {
        let opts = forced(parts);
        let (got, only) = pool(2).install(|| {
            (
                read_file_with(path, &opts),
                read_file_split(path, &opts).unwrap(),
            )
        });
        match (&want, &got) {
            (Ok(a), Ok(b)) => assert!(a == b, "{}: {parts} parts: model differs", short(path)),
            (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string(), "{}", short(path)),
            _ => panic!(
                "{}: {parts} parts: serial {} but split {}",
                short(path),
                show(&want),
                show(&got)
            ),
        }
        if let Some(m) = only {
            let Ok(a) = &want else {
                panic!(
                    "{}: the split read a file the serial read refuses",
                    short(path)
                );
            };
            assert!(
                *a == m,
                "{}: {parts} parts: split model differs",
                short(path)
            );
            split += 1;
        }
    }
    split
}

#[test]
fn every_input_reads_split_as_serially() {
    let files = all_inputs();
    let mut split = 0;
    let mut splittable = 0;
    for f in &files {
        let n = check(f);
        split += n;
        // documents with several top-level members and no DOCTYPE must really be split
        let text = std::fs::read(f).unwrap();
        let members = memchr::memmem::find_iter(&text, b"cityObjectMember>").count() / 2;
        let doctype = memchr::memmem::find(&text, b"<!DOCTYPE").is_some();
        let plain = !text.starts_with(&[0x1f, 0x8b]);
        if members >= 3 && !doctype && plain && read_file_with(f, &serial()).is_ok() {
            splittable += 1;
            assert!(n > 0, "{}: {members} members but never split", short(f));
        }
    }
    eprintln!(
        "{} files, {split} split reads, {splittable} files with 3+ members",
        files.len()
    );
    assert!(
        files.len() < 20 || split >= files.len(),
        "too few split reads"
    );
}

#[test]
fn bad_inputs_fail_split_as_serially() {
    for f in citygml_files(&manifest_dir().join("fixtures").join("bad")) {
        check(&f);
    }
}

/// Copies of real files, broken in a later part: truncated, a tag corrupted, an undeclared
/// xlink target, a duplicate gml:id across parts.
#[test]
fn broken_real_files_fail_split_as_serially() {
    let Some(data) = common::shared_data() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let mut sources: Vec<PathBuf> = citygml_files(&data)
        .into_iter()
        .filter(|p| {
            let t = std::fs::read(p).unwrap_or_default();
            !t.starts_with(&[0x1f, 0x8b])
                && memchr::memmem::find_iter(&t, b"cityObjectMember>").count() >= 12
                && read_file_with(p, &serial()).is_ok()
        })
        .collect();
    sources.sort_by_key(|p| std::fs::metadata(p).map(|m| m.len()).unwrap_or(0));
    sources.truncate(6);
    assert!(!sources.is_empty(), "no real file with members");
    let mut errors = 0;
    for (i, src) in sources.iter().enumerate() {
        let text = std::fs::read(src).unwrap();
        let len = text.len();
        let mut variants: Vec<Vec<u8>> =
            vec![text[..len * 2 / 3].to_vec(), text[..len - 20].to_vec()];
        // an end tag in the last third corrupted
        if let Some(at) = memchr::memmem::find(&text[len * 2 / 3..], b"</") {
            let mut v = text.clone();
            v[len * 2 / 3 + at + 1] = b'x';
            variants.push(v);
        }
        // a gml:id of the first third again in the last third, and an xlink to nowhere
        if let Some(at) = memchr::memmem::find(&text, b"gml:id=\"") {
            let start = at + 8;
            let end = start + memchr::memchr(b'"', &text[start..]).unwrap();
            let id = String::from_utf8_lossy(&text[start..end]).to_string();
            if let Some(late) = memchr::memmem::find(&text[len * 2 / 3..], b"gml:id=\"") {
                let late = len * 2 / 3 + late + 8;
                let late_end = late + memchr::memchr(b'"', &text[late..]).unwrap();
                let mut v = text[..late].to_vec();
                v.extend_from_slice(id.as_bytes());
                v.extend_from_slice(&text[late_end..]);
                variants.push(v);
            }
        }
        if let Some(at) = memchr::memmem::find(&text[len / 2..], b"<gml:Polygon") {
            let at = len / 2 + at;
            let mut v = text[..at].to_vec();
            v.extend_from_slice(b"<gml:Polygon xlink:href=\"#nowhere\" xmlns:xlink=\"http://www.w3.org/1999/xlink\"/>");
            v.extend_from_slice(&text[at..]);
            variants.push(v);
        }
        for (j, v) in variants.iter().enumerate() {
            let path = dir.path().join(format!("broken-{i}-{j}.gml"));
            std::fs::write(&path, v).unwrap();
            check(&path);
            if read_file_with(&path, &serial()).is_err() {
                errors += 1;
            }
        }
    }
    assert!(
        errors >= sources.len() * 2,
        "only {errors} broken copies fail"
    );
}

const HEAD: &str = r#"<?xml version="1.0"?>
<CityModel xmlns="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml"
  xmlns:bldg="http://www.opengis.net/citygml/building/2.0">
"#;

fn member(id: &str) -> String {
    format!(
        r#"  <cityObjectMember><bldg:Building gml:id="{id}"><bldg:lod2MultiSurface><gml:MultiSurface>
    <gml:surfaceMember><gml:Polygon><gml:exterior><gml:LinearRing><gml:posList>
      0 0 5 1 0 5 1 1 5 0 0 5</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember>
  </gml:MultiSurface></bldg:lod2MultiSurface></bldg:Building></cityObjectMember>
"#
    )
}

#[test]
fn doctype_and_one_thread_read_serially() {
    let dir = tempfile::tempdir().unwrap();
    let body: String = (0..20).map(|i| member(&format!("b{i}"))).collect();
    let plain = dir.path().join("plain.gml");
    std::fs::write(&plain, format!("{HEAD}{body}</CityModel>\n")).unwrap();
    let with_doctype = dir.path().join("doctype.gml");
    let doc = format!("{HEAD}{body}</CityModel>\n").replacen(
        "<?xml version=\"1.0\"?>\n",
        "<?xml version=\"1.0\"?>\n<!DOCTYPE CityModel [<!ENTITY e \"x\">]>\n",
        1,
    );
    std::fs::write(&with_doctype, doc).unwrap();
    let two = pool(2);
    let split = two.install(|| read_file_split(&plain, &forced(3)).unwrap());
    let m = split.expect("a plain document is split");
    assert_eq!(m.buildings.len(), 20);
    assert!(two
        .install(|| read_file_split(&with_doctype, &forced(3)))
        .unwrap()
        .is_none());
    check(&with_doctype);
    // one thread (--jobs 1): serial, whatever the parts asked for
    assert!(pool(1)
        .install(|| read_file_split(&plain, &forced(3)))
        .unwrap()
        .is_none());
    // gzip: streamed by one core
    let gz = dir.path().join("plain.gml.gz");
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    std::io::Write::write_all(&mut enc, &std::fs::read(&plain).unwrap()).unwrap();
    std::fs::write(&gz, enc.finish().unwrap()).unwrap();
    assert!(two
        .install(|| read_file_split(&gz, &forced(3)))
        .unwrap()
        .is_none());
    let streamed = two.install(|| read_file_with(&gz, &forced(3))).unwrap();
    assert!(streamed.assets == m.assets && streamed.buildings == m.buildings);
    // below the size threshold: serial
    let small = ReadOptions {
        split_min_bytes: 1 << 30,
        ..ReadOptions::default()
    };
    assert!(two
        .install(|| read_file_split(&plain, &small))
        .unwrap()
        .is_none());
}

#[test]
fn cut_inside_a_comment_or_nested_member_reads_serially() {
    let dir = tempfile::tempdir().unwrap();
    let body: String = (0..12).map(|i| member(&format!("b{i}"))).collect();
    // a fake end tag in a comment near the middle, where a cut is looked for
    let (a, b) = body.split_at(body.len() / 2);
    let a_end = a.rfind('\n').unwrap();
    let fake = format!(
        "{}<!-- </cityObjectMember> -->{}{}",
        &a[..a_end],
        &a[a_end..],
        b
    );
    let path = dir.path().join("comment.gml");
    std::fs::write(&path, format!("{HEAD}{fake}</CityModel>\n")).unwrap();
    check(&path);
    // members nested deeper (a cut after one is not between children of the root)
    let nested = body.replace(
        "</bldg:Building>",
        "<bldg:x><cityObjectMember><bldg:Building/></cityObjectMember></bldg:x></bldg:Building>",
    );
    let path = dir.path().join("nested.gml");
    std::fs::write(&path, format!("{HEAD}{nested}</CityModel>\n")).unwrap();
    check(&path);
    // warnings on later lines keep their line and column
    let warned = body.replace("0 0 5 1 0 5 1 1 5 0 0 5", "0 0 5 1 0 5 1 1 5");
    let path = dir.path().join("warn.gml");
    std::fs::write(&path, format!("{HEAD}{warned}</CityModel>\n")).unwrap();
    assert_eq!(check(&path), 2);
    let m = read_file_with(&path, &serial()).unwrap();
    assert_eq!(m.warnings.len(), 13, "{:?}", m.warnings);
    // all members on one line: the later parts' first line continues the line before them
    let path = dir.path().join("one-line.gml");
    std::fs::write(
        &path,
        format!("{HEAD}{}</CityModel>\n", warned.replace('\n', " ")),
    )
    .unwrap();
    assert_eq!(check(&path), 2);
    let m = read_file_with(&path, &serial()).unwrap();
    let rings: Vec<_> = m
        .warnings
        .iter()
        .filter(|w| w.message.starts_with("ring is not closed"))
        .collect();
    assert_eq!(rings.len(), 12);
    assert!(rings.iter().all(|w| w.line == rings[0].line));
    assert!(rings.windows(2).all(|w| w[0].column < w[1].column));
}

#[test]
fn ids_met_in_two_parts_are_warned_where_the_serial_read_warns() {
    let dir = tempfile::tempdir().unwrap();
    // ids of the first members again in later ones: as a building's id (nearest id: the
    // root's), a polygon's (nearest: its building's), twice in one part, with an entity
    let mut body = String::new();
    for i in 0..12 {
        let id = if i % 4 == 3 {
            format!("b{}", i % 3)
        } else {
            format!("b{i}")
        };
        let m = member(&id).replace(
            "<gml:Polygon>",
            &format!("<gml:Polygon gml:id=\"p{}&amp;\">", i % 5),
        );
        body.push_str(&m);
    }
    let root = HEAD.replacen("<CityModel ", "<CityModel gml:id=\"root\" ", 1);
    let path = dir.path().join("dups.gml");
    std::fs::write(&path, format!("{root}{body}</CityModel>\n")).unwrap();
    assert_eq!(check(&path), 2, "both split reads taken");
    let m = read_file_with(&path, &serial()).unwrap();
    let dups: Vec<_> = m
        .warnings
        .iter()
        .filter(|w| w.message.starts_with("duplicate"))
        .collect();
    assert_eq!(dups.len(), 3 + 7, "{dups:?}");
    assert!(dups.iter().any(|w| w.gml_id.as_deref() == Some("root")));
    assert!(dups.iter().any(|w| w.message.contains("p1&")));
}
