//! `lod` on a hollow read (`skylod::pipeline::session::Study::read_hollow`): on real files of the
//! shared data (Ingolstadt LoD3 street tiles, LoD2 buildings, CityGML 3.0), read one
//! top-level member a chunk, the levels, the error bound (one that promotes), the report and
//! the sun's site are the whole read's; and the `lod` command says which read it takes
//! (`--stream-chunk` and `--max-memory 0` force the hollow one's conditions on a small file)
//! without changing a byte of its outputs.

use crate::util::*;
use skylod::export::Format;
use skylod::lod::BoundOptions;
use skylod::model::Silent;
use skylod::model::{Bbox, Poi};
use skylod::pipeline::session::RunMs;
use skylod::pipeline::session::{Scene, SceneOptions, Study};
use skylod::pipeline::{BoundSpec, LevelsOptions};
use std::path::{Path, PathBuf};

/// The files compared, plain CityGML (the Ingolstadt tiles decompressed into `dir`).
fn files(data: &Path, dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for tile in ["4018106", "4018115"] {
        let gz = data.join(format!("ingolstadt-lod3/{tile}.xml.gz"));
        let Ok(f) = std::fs::File::open(&gz) else {
            missing(&gz.display().to_string());
            continue;
        };
        let mut xml = Vec::new();
        std::io::Read::read_to_end(&mut flate2::read::GzDecoder::new(f), &mut xml).unwrap();
        let plain = dir.join(format!("{tile}.gml"));
        std::fs::write(&plain, xml).unwrap();
        out.push(plain);
    }
    for f in [
        "rotterdam/Source.gml",
        "kit-fzk-haus/citygml3/FZK-Haus-LoD2-KIT-IAI-KHH-B36-V1__v3.gml",
        "berlin/Berlin_Moabit_1Bldg_v3-draft2019.gml",
    ] {
        out.push(data.join(f));
    }
    out
}

/// Two POIs of the model of box `b`: 1.5 m above its lowest point at its centre and a
/// quarter of the way along its diagonal.
fn two_pois(b: &Bbox) -> Vec<Poi> {
    let (c, q) = (b.center(), b.min + (b.max - b.min) * 0.25);
    vec![
        Poi::at("centre", [c.x, c.y, b.min.z + 1.5]),
        Poi::at("quarter", [q.x, q.y, b.min.z + 1.5]),
    ]
}

#[test]
fn lod_on_a_hollow_read_of_shared_files_is_the_whole_reads() {
    let Some(data) = shared_data() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let opts = LevelsOptions {
        bound: Some(BoundSpec {
            options: BoundOptions {
                max_svf_error: Some(0.001),
                svf_rays: 4000,
                ..Default::default()
            },
            sun: None,
            irradiance: None,
        }),
        ..Default::default()
    };
    let so = SceneOptions::default();
    let (mut compared, mut promoted) = (0, 0);
    for path in files(&data, dir.path()) {
        let name = short(&path);
        let scene = Scene::load(&[&path], &so, &Silent).unwrap();
        let pois = two_pois(&scene.model().bbox());
        let mut study = scene.frame(pois.clone()).unwrap();
        let mut want = study.levels(&opts, &Silent).unwrap();
        let rough = &opts.lod.rough;
        let h = Study::read_hollow(&path, 1, pois, rough, &so, &Silent).unwrap();
        let mut h = h.unwrap_or_else(|| panic!("{name}: the hollow read declined"));
        let chunks = h.hollow().map(|h| h.summary.chunks);
        assert!(chunks > Some(1), "{name}: {chunks:?}");
        assert_eq!(h.pois(), study.pois(), "{name}");
        assert_eq!(h.bbox(), study.source().bbox(), "{name}");
        assert_eq!(h.sun_site(None, None), study.sun_site(None, None), "{name}");
        let got = h.levels(&opts, &Silent).unwrap();
        // each POI's time and the stages' aside
        for (w, g) in (want.lod.selection.pois.iter_mut()).zip(&got.lod.selection.pois) {
            w.seconds = g.seconds;
        }
        let g = &got.lod;
        (want.lod.rough_s, want.lod.bvh_s, want.lod.select_s) = (g.rough_s, g.bvh_s, g.select_s);
        assert_eq!(got.lod.selection, want.lod.selection, "{name}");
        assert_eq!(got.lod.flags, want.lod.flags, "{name}");
        assert_eq!(got.lod.rough, want.lod.rough, "{name}");
        assert_eq!(got.bound, want.bound, "{name}");
        promoted += usize::from(!got.bound.as_ref().unwrap().promotions.is_empty());
        let written = || [(0, "out.gml".to_string(), 0)];
        let (ms, guarantee) = (RunMs::default(), Default::default());
        let report = h.lod_report(&got, &opts.lod, ms, guarantee, written());
        let whole = study.lod_report(&want, &opts.lod, ms, Default::default(), written());
        assert!(whole.totals.polygons_in > 0, "{name}");
        assert_eq!(
            serde_json::to_value(&report).unwrap(),
            serde_json::to_value(&whole).unwrap(),
            "{name}"
        );
        // the CityGML written from the hollow read (a member a chunk, the polygons read
        // back) is the whole read's, byte for byte, with the same counts
        let (a, b) = (dir.path().join("whole.gml"), dir.path().join("hollow.gml"));
        let w = study.write_levels(&want, &a, Some(Format::CityGml), true, &Silent);
        let w = w.unwrap().remove(0).1;
        let g = h.write_levels(&got, &b, Some(Format::CityGml), true, &Silent);
        let g = g.unwrap().remove(0).1;
        assert!(
            std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(),
            "{name}: outputs differ"
        );
        assert_eq!(g, w, "{name}");
        let hollow = h.hollow().unwrap();
        assert!(
            (hollow.model.assets.iter().enumerate())
                .all(|(i, a)| hollow.kept[i] || a.geometries.iter().all(|g| g.polygons.is_empty())),
            "{name}: left hollow"
        );
        compared += 1;
    }
    assert!(compared >= 3, "{compared} files compared");
    assert!(promoted > 0, "no file where the bound promotes");
}

/// The `lod` command on a hollow read (`--stream-chunk` small: a member a chunk; `--max-memory
/// 0`: the whole read would not fit) writes the
/// whole read's CityGML byte for byte with the whole read's report (but for timings), on the
/// Ingolstadt LoD3 tiles, LoD2 and CityGML 3.0 files, the default bound and a tighter one
/// (which promotes somewhere); it says at info level which read it takes: hollow, or whole
/// and why (nothing for a file under the streaming threshold, the ordinary case), and reads
/// whole for an OBJ output.
#[test]
fn lod_on_a_hollow_read_writes_the_whole_reads_bytes() {
    let Some(data) = shared_data() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let run_lod = |input: &Path, tag: &str, ext: &str, extra: &[&str]| {
        let scene = Scene::load(&[input], &SceneOptions::default(), &Silent).unwrap();
        let pois = two_pois(&scene.model().bbox());
        let out = dir.path().join(format!("{tag}.{ext}"));
        let rep = dir.path().join(format!("{tag}.json"));
        let at: Vec<String> = (pois.iter().map(|p| p.position.to_array()))
            .map(|[x, y, z]| format!("{x},{y},{z}"))
            .collect();
        let rest = [os("-o"), out.as_os_str(), os("--report"), rep.as_os_str()];
        let mut args = vec![os("--log-level"), os("info")];
        args.extend(poi_args("lod", input, &at, &rest));
        args.push(os("--overwrite"));
        args.extend(extra.iter().map(os));
        let o = run(&args);
        assert!(o.status.success(), "{tag}: {}", stderr(&o));
        let mut report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&rep).unwrap()).unwrap();
        report["timings_ms"] = serde_json::Value::Null;
        for p in report["pois"].as_array_mut().unwrap() {
            p["ms"] = serde_json::Value::Null;
        }
        report["inputs"][0]["output"] = serde_json::Value::Null;
        (std::fs::read(&out).unwrap(), report, stderr(&o))
    };
    let (mut compared, mut promoted) = (0, 0);
    for input in files(&data, dir.path()) {
        let name = short(&input);
        for bound in [
            &[][..],
            &["--max-svf-error", "0.001", "--bound-rays", "4000"][..],
        ] {
            let (whole, whole_report, said) = run_lod(&input, "whole", "gml", bound);
            assert!(!said.contains("lod reads"), "{name}: {said}");
            let mut hollow = vec!["--stream-chunk", "1", "--max-memory", "0"];
            hollow.extend(bound);
            let (got, report, said) = run_lod(&input, "hollow", "gml", &hollow);
            assert!(
                said.contains("lod reads hollow, in chunks of 1 bytes"),
                "{name}: {said}"
            );
            assert!(got == whole, "{name} {bound:?}: outputs differ");
            assert!(report == whole_report, "{name} {bound:?}: reports differ");
            let promotions = &report["bound"]["promotions"];
            promoted += usize::from(promotions.as_array().is_some_and(|p| !p.is_empty()));
            compared += 1;
        }
    }
    assert!(compared >= 6, "{compared} runs compared");
    assert!(promoted > 0, "no run where the bound promotes");
    let input = data.join("rotterdam/Source.gml");
    let (_, _, said) = run_lod(
        &input,
        "obj",
        "obj",
        &["--stream-chunk", "1", "--max-memory", "0"],
    );
    let why = "lod reads whole (OBJ and CityJSON outputs are written from the whole read)";
    assert!(said.contains(why), "{said}");
    let (_, _, said) = run_lod(&input, "off", "gml", &["--stream-chunk", "0"]);
    assert!(
        said.contains("lod reads whole (the streaming chunk is 0)"),
        "{said}"
    );
    // where the whole read fits in the memory lod may take, it is read whole: by default
    // 1 GiB or half of what is available (this file is far under it), or as --max-memory says
    let (_, _, said) = run_lod(&input, "fits", "gml", &["--stream-chunk", "1"]);
    let fits = "MiB lod may take by default (1 GiB, or half the memory available where that is less); --max-memory sets it)";
    assert!(
        said.contains("lod reads whole (") && said.contains(fits),
        "{said}"
    );
    let (_, _, said) = run_lod(
        &input,
        "fits",
        "gml",
        &["--stream-chunk", "1", "--max-memory", "1G"],
    );
    assert!(
        said.contains("MiB fit in the 1024.0 MiB of --max-memory"),
        "{said}"
    );
    let lots = [os("--max-memory"), os("lots")];
    let o = run(&poi_args("lod", &input, ["0,0,0"], &lots));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--max-memory"), "{}", stderr(&o));
    let crs = [
        "--stream-chunk",
        "1",
        "--max-memory",
        "0",
        "--source-crs",
        "EPSG:2263",
    ];
    let (_, _, said) = run_lod(&input, "crs", "gml", &crs);
    assert!(said.contains("EPSG:2263"), "{said}");
    assert!(
        said.contains("is not traced in its own coordinates"),
        "{said}"
    );
}
