//! The coordinate rewrite behind `reproject` in passes (large documents, issue 22: memory that
//! does not grow with the file) writes the bytes of the whole rewrite, on every shared file and
//! fixture; `reproject_with`'s CRS rules, without PROJ (a stand-in transform).

use crate::util::{all_inputs, short};
use glam::DVec3;
use skylod::export::transform::{
    reproject_with, CrsTransform, ReprojectError, RewriteSource, RewriteSummary,
};
use skylod::io::citygml::WriteError;
use skylod::io::citygml::WriteOptions;
use skylod::model::crs::CrsName;
use std::path::Path;

/// A change every coordinate shows: axes swapped, scaled, shifted, heights raised.
fn affine(p: &mut [DVec3]) -> Result<(), String> {
    for q in p {
        *q = DVec3::new(0.5 * q.y + 1000.25, 1.5 * q.x - 7.125, q.z + 0.3);
    }
    Ok(())
}

/// `input` rewritten to `out`, whole or in passes: the summary, or the error's text.
fn rewrite(input: &Path, out: &Path, stream_from: u64) -> Result<(RewriteSummary, bool), String> {
    let doc = RewriteSource::read_with(input, stream_from).map_err(|e| e.to_string())?;
    let passes = doc.in_passes();
    let opts = WriteOptions {
        overwrite: true,
        ..WriteOptions::default()
    };
    doc.rewrite(out, &affine, "EPSG:3857", &opts, |_| {
        Ok::<(), WriteError>(())
    })
    .map(|s| (s, passes))
    .map_err(|e| e.to_string())
}

#[test]
fn passes_write_the_bytes_of_the_whole_rewrite_on_every_input() {
    let dir = tempfile::tempdir().unwrap();
    let (whole_out, passes_out) = (dir.path().join("whole.gml"), dir.path().join("passes.gml"));
    let (mut same, mut in_passes, mut failed) = (0, 0, 0);
    let mut problems = Vec::new();
    for input in all_inputs() {
        let whole = rewrite(&input, &whole_out, u64::MAX);
        let passes = rewrite(&input, &passes_out, 0);
        match (whole, passes) {
            (Ok((w, _)), Ok((p, streamed))) => {
                in_passes += usize::from(streamed);
                if w != p {
                    problems.push(format!("{}: summaries {w:?} vs {p:?}", short(&input)));
                } else if std::fs::read(&whole_out).unwrap() != std::fs::read(&passes_out).unwrap()
                {
                    problems.push(format!("{}: bytes differ", short(&input)));
                } else {
                    same += 1;
                }
            }
            (Err(w), Err(p)) if w == p => failed += 1,
            (w, p) => problems.push(format!("{}: {w:?} vs {p:?}", short(&input))),
        }
    }
    eprintln!("{same} the same ({in_passes} of them in passes), {failed} fail alike");
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    assert!(same >= 20, "only {same} inputs rewritten");
    // The chunked reader declines only documents it cannot read alone (none here but a few).
    assert!(
        in_passes * 10 >= same * 9,
        "{in_passes} of {same} in passes"
    );
}

/// A stand-in for PROJ's transform: a shift, into EPSG:3857.
struct Shift {
    target: CrsName,
    warnings: Vec<String>,
}

impl CrsTransform for Shift {
    fn transform(&self, pts: &mut [DVec3]) -> Result<(), String> {
        pts.iter_mut().for_each(|p| p.x += 10.0);
        Ok(())
    }
    fn target(&self) -> &CrsName {
        &self.target
    }
    fn warnings(&self) -> &[String] {
        &self.warnings
    }
}

fn shift(source: CrsName) -> Result<Shift, ReprojectError> {
    assert_eq!(source.horizontal, 25832, "the document's CRS");
    Ok(Shift {
        target: CrsName::parse("EPSG:3857").unwrap(),
        warnings: vec!["a note of the transform".into()],
    })
}

const DOC: &str = r#"<core:CityModel xmlns:core="http://www.opengis.net/citygml/2.0"
 xmlns:gml="http://www.opengis.net/gml" xmlns:gen="http://www.opengis.net/citygml/generics/2.0">
<core:cityObjectMember><gen:GenericCityObject gml:id="g"><gen:lod1Geometry>
<gml:Point srsName="EPSG:25832"><gml:pos>1 2 3</gml:pos></gml:Point></gen:lod1Geometry>
<gen:lod2Geometry><gml:Point srsName="SECOND"><gml:pos>4 5 6</gml:pos></gml:Point></gen:lod2Geometry>
</gen:GenericCityObject></core:cityObjectMember></core:CityModel>"#;

#[test]
fn reproject_with_takes_the_documents_crs_and_refuses_a_second_one_unless_given() {
    let dir = tempfile::tempdir().unwrap();
    let (src, out) = (dir.path().join("in.gml"), dir.path().join("out.gml"));
    let opts = WriteOptions::default();
    // One CRS: the document's, into the target's URN.
    std::fs::write(&src, DOC.replace("SECOND", "EPSG:25832")).unwrap();
    let s = reproject_with(&src, &out, None, &opts, shift).unwrap();
    assert_eq!((s.source.horizontal, s.target.horizontal), (25832, 3857));
    assert_eq!(s.rewrite.warnings, ["a note of the transform"]);
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.contains(
            r#"<gml:Point srsName="urn:ogc:def:crs:EPSG::3857"><gml:pos>11 2 3</gml:pos>"#
        ),
        "{text}"
    );
    std::fs::remove_file(&out).unwrap();
    // Two CRSs: refused, nothing written.
    std::fs::write(&src, DOC.replace("SECOND", "EPSG:4326")).unwrap();
    let e = reproject_with(&src, &out, None, &opts, shift).unwrap_err();
    assert!(
        matches!(e, ReprojectError::MixedCrs { ref names, .. } if names == "EPSG:25832, EPSG:4326"),
        "{e}"
    );
    assert!(!out.exists());
    // ... unless the source is given: every coordinate read as it, with a warning.
    let given = CrsName::parse("EPSG:25832");
    let s = reproject_with(&src, &out, given, &opts, shift).unwrap();
    assert!(s.rewrite.warnings[0].contains("names other CRSs"), "{s:?}");
    assert_eq!(s.rewrite.points, 2);
    // No CRS at all and none given.
    std::fs::write(
        &src,
        DOC.replace(r#" srsName="SECOND""#, "")
            .replace(r#" srsName="EPSG:25832""#, ""),
    )
    .unwrap();
    let e = reproject_with(&src, &dir.path().join("o2.gml"), None, &opts, shift).unwrap_err();
    assert!(matches!(e, ReprojectError::NoSourceCrs(_)), "{e}");
}

/// The largest `RssAnon` (kB) of this process while `f` runs, sampled every 20 ms.
fn peak_anon_kb(f: impl FnOnce()) -> u64 {
    fn anon() -> u64 {
        let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
        status
            .lines()
            .find_map(|l| l.strip_prefix("RssAnon:"))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
            .unwrap_or(0)
    }
    let done = std::sync::atomic::AtomicBool::new(false);
    std::thread::scope(|s| {
        let sampler = s.spawn(|| {
            let mut peak = 0;
            while !done.load(std::sync::atomic::Ordering::Relaxed) {
                peak = peak.max(anon());
                std::thread::sleep(std::time::Duration::from_millis(20));
            }
            peak.max(anon())
        });
        f();
        done.store(true, std::sync::atomic::Ordering::Relaxed);
        sampler.join().unwrap()
    })
}

/// Issue 22: the rewrite of a 400 MB document (the Ingolstadt street repeated) in passes holds
/// less than 256 MiB of heap; whole, it holds about the file twice (the read and the
/// replacement texts). Run with `cargo test --test it -- --ignored reproject_passes::`.
#[test]
#[ignore]
fn a_large_document_is_rewritten_in_little_memory() {
    let Some(data) = crate::util::shared_data() else {
        return;
    };
    let tool = crate::util::manifest_dir().join("../shared/tools/bench_inputs.py");
    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("big.gml");
    let made = std::process::Command::new("python3")
        .arg(&tool)
        .arg(&data)
        .arg(&big)
        .arg("400")
        .output()
        .unwrap();
    assert!(made.status.success(), "{}", crate::util::stderr(&made));
    let out = dir.path().join("out.gml");
    let mut summary = None;
    let t = std::time::Instant::now();
    let peak = peak_anon_kb(|| summary = Some(rewrite(&big, &out, 64 << 20)));
    let (s, passes) = summary.take().unwrap().unwrap();
    eprintln!(
        "in passes: {} points, {} envelopes, {:.1} s, peak RssAnon {peak} kB",
        s.points,
        s.envelopes,
        t.elapsed().as_secs_f64()
    );
    assert!(passes, "a 400 MB document is rewritten in passes");
    assert!(peak < 256 * 1024, "peak RssAnon {peak} kB");
    let t = std::time::Instant::now();
    let whole = peak_anon_kb(|| summary = Some(rewrite(&big, &out, u64::MAX)));
    let (w, _) = summary.unwrap().unwrap();
    eprintln!(
        "whole: {:.1} s, peak RssAnon {whole} kB",
        t.elapsed().as_secs_f64()
    );
    assert_eq!(w, s);
}
