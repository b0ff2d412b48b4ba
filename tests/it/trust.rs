//! Trust: inputs that would give a confidently wrong answer are refused or flagged, and the
//! file promises hold (`../shared/DESIGN.md`, "Trust: no confident wrong answer"). Real
//! files from `../shared/data` where the case exists there (Ingolstadt in UTM, FZK-Haus, its
//! LoD0 footprint, PLATEAU in EPSG:6697), generated box scenes where it does not.

use crate::util::*;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn data(rel: &str) -> Option<PathBuf> {
    let p = shared_data()?.join(rel);
    if p.is_file() {
        Some(p)
    } else {
        missing(&p.display().to_string());
        None
    }
}

const INGOLSTADT: &str = "ingolstadt-lod3/4018215.xml.gz";
const FZK_LOD2: &str = "kit-fzk-haus/citygml2/fzk_haus_lod2_v2.gml";
const FZK_LOD0: &str = "kit-fzk-haus/citygml2/fzk_haus_lod0_v2.gml";
const FZK_BUILDING: &str = "UUID_d281adfc-4901-0f52-540b-4cc1a9325f82";
/// Inside the FZK-Haus (footprint 457842..457854 x 5439083..5439093, eaves above 114 m).
const INSIDE_FZK: &str = "457848,5439088,114";
/// On open ground west of it.
const BESIDE_FZK: &str = "457830,5439088,112";

/// Every command that traces, with the arguments it needs beside inputs and POIs, and
/// whether it writes a file (`-o` is added then).
fn tracing_commands(dir: &Path) -> Vec<(&'static str, Vec<String>)> {
    let out = |n: &str| dir.join(n).display().to_string();
    vec![
        ("svf", vec!["--rays".into(), "2000".into()]),
        (
            "sun-hours",
            vec!["--step".into(), "60".into(), "--json".into()],
        ),
        (
            "evaluate",
            vec!["--no-sun".into(), "--rays".into(), "2000".into()],
        ),
        ("fisheye", vec!["-o".into(), out("sky.svg")]),
        ("lod", vec!["-o".into(), out("lod.gml")]),
    ]
}

#[test]
fn poi_in_degrees_or_swapped_is_refused_by_every_tracing_command() {
    let Some(model) = data(INGOLSTADT) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    for (poi, hint) in [
        ("48.7665,11.4258,400", "looks like degrees"),
        ("5403760,678115,418", "x and y look swapped"),
    ] {
        for (cmd, extra) in tracing_commands(dir.path()) {
            let mut args = vec![os(cmd), model.as_os_str(), os("--poi"), os(poi)];
            args.extend(extra.iter().map(os));
            let o = run(&args);
            let err = stderr(&o);
            assert_eq!(o.status.code(), Some(2), "{cmd} {poi}: {err}");
            assert!(err.contains("poi-1"), "{cmd}: {err}");
            assert!(err.contains(hint), "{cmd}: {err}");
            assert!(err.contains("--poi-crs"), "{cmd}: {err}");
            assert!(listing(dir.path()).is_empty(), "{cmd} wrote something");
        }
    }
    // Within the margin (documented default 1 km): accepted; --poi-margin widens it.
    let o = run(&[
        os("svf"),
        model.as_os_str(),
        os("--poi"),
        os("678700,5403760,418"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = run(&[
        os("svf"),
        model.as_os_str(),
        os("--poi"),
        os("680700,5403760,418"),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = run(&[
        os("svf"),
        model.as_os_str(),
        os("--poi"),
        os("680700,5403760,418"),
        os("--poi-margin"),
        os("5000"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn poi_inside_a_building_is_flagged_everywhere() {
    let Some(model) = data(FZK_LOD2) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let base = [
        os(model.as_os_str()),
        os("--poi"),
        os(INSIDE_FZK),
        os("--poi"),
        os(BESIDE_FZK),
    ];
    let inside = serde_json::json!([{"flag": "inside_building", "building": FZK_BUILDING}]);
    let check_warning = |o: &Output, cmd: &str| {
        let err = stderr(o);
        assert_eq!(o.status.code(), Some(0), "{cmd}: {err}");
        assert!(
            err.contains(&format!(
                "POI poi-1 lies inside a closed solid of building {FZK_BUILDING}"
            )),
            "{cmd}: {err}"
        );
        assert!(!err.contains("POI poi-2"), "{cmd}: {err}");
    };

    let mut args = base.to_vec();
    args.extend([os("--json"), os("--rays"), os("2000")]);
    let o = run(&[&[os("svf")], &args[..]].concat());
    check_warning(&o, "svf");
    let v = json(&o);
    assert_eq!(v["pois"][0]["flags"], inside);
    assert_eq!(v["pois"][0]["svf"], 0.0);
    assert_eq!(v["pois"][1]["flags"], serde_json::json!([]));

    let o = run(&[
        &[os("sun-hours")],
        &base[..],
        &[os("--json"), os("--step"), os("60")],
    ]
    .concat());
    check_warning(&o, "sun-hours");
    assert_eq!(json(&o)["pois"][0]["flags"], inside);

    let o = run(&[&[os("evaluate"), os("--no-sun")], &args[..]].concat());
    check_warning(&o, "evaluate");
    let v = json(&o);
    assert_eq!(v["pois"][0]["flags"], inside);
    assert_eq!(v["pois"][1]["flags"], serde_json::json!([]));

    let out = dir.path().join("lod.gml");
    let rep = dir.path().join("report.json");
    let mut l = vec![os("lod")];
    l.extend(base);
    l.extend([os("-o"), out.as_os_str(), os("--report"), rep.as_os_str()]);
    let o = run(&l);
    check_warning(&o, "lod");
    let r: Value = serde_json::from_slice(&std::fs::read(&rep).unwrap()).unwrap();
    assert_eq!(r["report_version"], 2);
    assert_eq!(r["pois"][0]["flags"], inside);
    assert_eq!(r["pois"][1]["flags"], serde_json::json!([]));
}

/// A POI under an open-bottomed box (an arcade): the sky is hidden in every direction above
/// the horizon, but it is not inside a closed solid.
#[test]
fn poi_without_sky_is_flagged() {
    use skylod::model::synth::{boxes_citygml, BoxBuilding};
    let b = BoxBuilding {
        id: "ARCADE".into(),
        min: [0.0, 0.0],
        max: [10.0, 10.0],
        height: 4.0,
        installations: vec![],
    };
    let xml = boxes_citygml(&[b], [430000.0, 4581000.0, 10.0]);
    let start = xml.find("<bldg:boundedBy><bldg:GroundSurface").unwrap();
    let end = xml[start..].find("</bldg:boundedBy>").unwrap() + start + "</bldg:boundedBy>".len();
    let xml = format!("{}{}", &xml[..start], &xml[end..]);
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("arcade.gml");
    std::fs::write(&input, xml).unwrap();
    let o = run(&[
        os("svf"),
        input.as_os_str(),
        os("--poi"),
        os("430005,4581005,11"),
        os("--json"),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(
        err.contains("every ray of the sky bundle is blocked"),
        "{err}"
    );
    assert_eq!(
        json(&o)["pois"][0]["flags"],
        serde_json::json!([{"flag": "no_sky"}])
    );
}

#[test]
fn inputs_in_different_crs_are_refused_unless_allowed() {
    let (Some(fzk), Some(ogc), Some(plateau), Some(gk)) = (
        data(FZK_LOD2),
        data("ogc-citygml2-examples/building/Building_LOD2-EPSG25832.gml"),
        data("plateau/yokosuka/52397519_bldg_6697_op.gml"),
        data("ogc-citygml2-examples/spec-examples/GenericCityObjects.xml"),
    ) else {
        return;
    };
    let o = run(&[
        os("svf"),
        fzk.as_os_str(),
        plateau.as_os_str(),
        os("--poi"),
        os(BESIDE_FZK),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("different CRSs"), "{err}");
    assert!(
        err.contains("urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH: 1 file (")
            && err.contains("fzk_haus_lod2_v2.gml)"),
        "{err}"
    );
    assert!(
        err.contains("http://www.opengis.net/def/crs/EPSG/0/6697: 1 file (")
            && err.contains("52397519_bldg_6697_op.gml)"),
        "{err}"
    );
    // An explicit override merges them (here two metric CRSs: FZK-Haus in UTM 32 and an OGC
    // example in Gauss-Krüger zone 2).
    let o = run(&[
        os("svf"),
        fzk.as_os_str(),
        gk.as_os_str(),
        os("--poi"),
        os(BESIDE_FZK),
        os("--poi-margin"),
        os("1e7"),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = run(&[
        os("svf"),
        fzk.as_os_str(),
        gk.as_os_str(),
        os("--poi"),
        os(BESIDE_FZK),
        os("--poi-margin"),
        os("1e7"),
        os("--allow-mixed-crs"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // One CRS spelled two ways (AdV name, compound EPSG URN) is one CRS.
    let o = run(&[
        os("svf"),
        fzk.as_os_str(),
        ogc.as_os_str(),
        os("--poi"),
        os(BESIDE_FZK),
        os("--poi-margin"),
        os("1e7"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn model_without_heights_is_refused_for_tracing_only() {
    let Some(lod0) = data(FZK_LOD0) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    for (cmd, extra) in tracing_commands(dir.path()) {
        let mut args = vec![os(cmd), lod0.as_os_str(), os("--poi"), os(BESIDE_FZK)];
        args.extend(extra.iter().map(os));
        let o = run(&args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{cmd}: {err}");
        assert!(
            err.contains("no heights") && err.contains("fzk_haus_lod0_v2.gml"),
            "{cmd}: {err}"
        );
    }
    assert!(listing(dir.path()).is_empty());
    let o = run(&[os("stats"), lod0.as_os_str()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = dir.path().join("copy.gml");
    let o = run(&[os("convert"), lod0.as_os_str(), os("-o"), out.as_os_str()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn poi_csv_dialects_and_duplicate_ids() {
    let dir = tempfile::tempdir().unwrap();
    let gml = fixture("synth-small.gml");
    let plain = fixture("synth-small.pois.csv");
    let text = std::fs::read_to_string(&plain).unwrap();
    // The same points with a BOM, CRLF, a comment, quoted ids and the columns reordered.
    let mut odd =
        String::from("\u{feff}# facade points, by hand\r\n\"Z\",nz,NX,ny,\"x\",y,\"id\"\r\n");
    for line in text.lines().skip(1).filter(|l| !l.is_empty()) {
        let f: Vec<&str> = line.split(',').collect();
        odd.push_str(&format!(
            "{},{},{},{},{},{},\"{}\"\r\n",
            f[3], f[6], f[4], f[5], f[1], f[2], f[0]
        ));
        odd.push_str("# between points\r\n");
    }
    let odd_path = dir.path().join("odd.csv");
    std::fs::write(&odd_path, odd).unwrap();
    let svf = |csv: &Path| {
        let o = run(&[
            os("svf"),
            gml.as_os_str(),
            os("--pois"),
            csv.as_os_str(),
            os("--json"),
            os("--rays"),
            os("2000"),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        json(&o)["pois"].clone()
    };
    assert_eq!(svf(&plain), svf(&odd_path));

    let mut dup = text.clone();
    let second = text.lines().nth(2).unwrap();
    dup.push_str(second);
    dup.push('\n');
    let dup_path = dir.path().join("dup.csv");
    std::fs::write(&dup_path, &dup).unwrap();
    let o = run(&[
        os("svf"),
        gml.as_os_str(),
        os("--pois"),
        dup_path.as_os_str(),
    ]);
    let err = stderr(&o);
    let id = second.split(',').next().unwrap();
    let last = dup.lines().count();
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains(&format!("POI id \"{id}\" is given twice")),
        "{err}"
    );
    assert!(
        err.contains("dup.csv:3") && err.contains(&format!("dup.csv:{last}")),
        "{err}"
    );

    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, "# c\nid,x,y,z\na,1,2,3\nb,1,\"two\",3\n").unwrap();
    let o = run(&[os("svf"), gml.as_os_str(), os("--pois"), bad.as_os_str()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("bad.csv:4: \"two\" is not a number"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn dash_is_standard_output_never_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let gml = fixture("chimney-citygml2.gml");
    let file = dir.path().join("file.gml");
    let o = run(&[os("convert"), gml.as_os_str(), os("-o"), file.as_os_str()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    for cmd in ["convert", "rough"] {
        let o = Command::new(BIN)
            .args([os(cmd), gml.as_os_str(), os("-o"), os("-")])
            .current_dir(dir.path())
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(0), "{cmd}: {}", stderr(&o));
        assert!(!dir.path().join("-").exists(), "{cmd} wrote a file named -");
        if cmd == "convert" {
            assert_eq!(o.stdout, std::fs::read(&file).unwrap());
        } else {
            assert!(String::from_utf8_lossy(&o.stdout).contains("skylod_level"));
        }
    }
    let scene = fixture("synth-small.gml");
    let o = Command::new(BIN)
        .args([
            os("lod"),
            scene.as_os_str(),
            os("--poi"),
            os("430010,4581010,12"),
            os("-o"),
            os("-"),
        ])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("<core:CityModel"));
    let o = Command::new(BIN)
        .args([
            os("fisheye"),
            scene.as_os_str(),
            os("--poi"),
            os("430010,4581010,12"),
            os("-o"),
            os("-"),
        ])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).starts_with("<svg"));
    // synth streams the district to standard output (the POI CSV only where asked).
    let o = Command::new(BIN)
        .args(["synth", "--preset", "small", "-o", "-"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(o.stdout, std::fs::read(fixture("synth-small.gml")).unwrap());
    assert_eq!(listing(dir.path()), vec!["file.gml"]);
}

#[test]
fn outputs_follow_the_umask() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let gml = fixture("chimney-citygml2.gml");
    for (umask, mode) in [("022", 0o644), ("027", 0o640), ("077", 0o600)] {
        let out = dir.path().join(format!("out-{umask}.gml"));
        let o = Command::new("sh")
            .arg("-c")
            .arg(format!(
                "umask {umask}; exec \"$0\" convert \"$1\" -o \"$2\""
            ))
            .arg(BIN)
            .arg(&gml)
            .arg(&out)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let got = std::fs::metadata(&out).unwrap().permissions().mode() & 0o777;
        assert_eq!(got, mode, "umask {umask}");
    }
}

/// Existing outputs are refused before any work: with a missing input, the refusal is what is
/// reported, so nothing was read first.
#[test]
fn existing_outputs_are_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let missing_input = dir.path().join("not-there.gml");
    let existing = dir.path().join("exists.svg");
    std::fs::write(&existing, "keep").unwrap();
    let existing_gml = dir.path().join("exists.gml");
    std::fs::write(&existing_gml, "keep").unwrap();
    let report = dir.path().join("report.json");
    std::fs::write(&report, "keep").unwrap();
    let lod_out = dir.path().join("lod.gml");
    for args in [
        vec![
            os("fisheye"),
            missing_input.as_os_str(),
            os("--poi"),
            os("0,0,0"),
            os("-o"),
            existing.as_os_str(),
        ],
        vec![
            os("lod"),
            missing_input.as_os_str(),
            os("--poi"),
            os("0,0,0"),
            os("-o"),
            existing_gml.as_os_str(),
        ],
        vec![
            os("lod"),
            missing_input.as_os_str(),
            os("--poi"),
            os("0,0,0"),
            os("-o"),
            lod_out.as_os_str(),
            os("--report"),
            report.as_os_str(),
        ],
    ] {
        let o = run(&args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains("output exists (use --overwrite)"), "{err}");
        assert!(
            !err.contains("not-there.gml"),
            "read before refusing: {err}"
        );
    }
    assert_eq!(std::fs::read_to_string(&existing).unwrap(), "keep");
    assert_eq!(std::fs::read_to_string(&report).unwrap(), "keep");
    assert_eq!(std::fs::read_to_string(&existing_gml).unwrap(), "keep");
    assert!(!lod_out.exists());
    // With --overwrite the fisheye replaces it.
    let scene = fixture("synth-small.gml");
    let o = run(&[
        os("fisheye"),
        scene.as_os_str(),
        os("--poi"),
        os("430010,4581010,12"),
        os("-o"),
        existing.as_os_str(),
        os("--overwrite"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(std::fs::read_to_string(&existing)
        .unwrap()
        .starts_with("<svg"));
}

/// `skylod stats … | head`: the reader goes away, skylod ends quietly with success.
#[test]
fn broken_pipe_ends_quietly() {
    let inputs: Vec<PathBuf> = fixture_files();
    let mut child = Command::new(BIN)
        .arg("stats")
        .args(&inputs)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(!stderr(&o).contains("error"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
}

#[test]
fn messages_say_a_thing_once_and_values_are_checked() {
    let gml = fixture("synth-small.gml");
    let o = run(&[os("svf"), gml.as_os_str(), os("--pois"), os("nope.csv")]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.matches("No such file or directory").count(), 1, "{err}");
    assert!(err.contains("nope.csv"), "{err}");
    for (flag, value) in [
        ("--threshold", "-1"),
        ("--thickness", "-0.3"),
        ("--poi-margin", "-5"),
        ("--threshold", "0"),
    ] {
        let o = run(&[
            os("lod"),
            gml.as_os_str(),
            os("--poi"),
            os("430010,4581010,12"),
            os("-o"),
            os("/nonexistent/x.gml"),
            os(flag),
            os(value),
        ]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{flag} {value}: {err}");
        assert!(
            err.contains("invalid value") && err.contains(value),
            "{flag} {value}: {err}"
        );
        assert!(!err.contains("unexpected argument"), "{err}");
    }
}

fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    v.sort();
    v
}
