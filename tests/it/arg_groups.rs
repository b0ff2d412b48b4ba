//! The shared argument groups (rough model, selection, site, sun, output) are flattened into
//! every command that needs them, with one help text: the commands cannot drift apart.

use crate::util::{os, run};

/// The first line of the help text of `flag` in `skylod <cmd> --help` (on the flag's line in
/// short help, on the next line in long help), without its `[default: ...]`.
fn help_of(cmd: &str, flag: &str) -> Option<String> {
    let o = run(&[os(cmd), os("--help")]);
    assert!(o.status.success(), "{cmd} --help failed");
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    let mut lines = text.lines();
    while let Some(l) = lines.next() {
        let Some(rest) = l.trim_start().strip_prefix(flag) else {
            continue;
        };
        if !(rest.is_empty() || rest.starts_with("  ")) {
            continue;
        }
        let first = match rest.trim() {
            "" => lines.next().unwrap_or("").trim().to_string(),
            t => t.to_string(),
        };
        return Some(first.split(" [default").next().unwrap_or("").to_string());
    }
    None
}

/// Each group: its flags and the commands that must all have them, with the same text.
const GROUPS: &[(&str, &[&str], &[&str])] = &[
    (
        "rough model",
        &["--angle <DEG>", "--thickness <M>", "--no-lod2"],
        &["lod", "evaluate", "rough", "fisheye"],
    ),
    (
        "silhouette",
        &["--threshold <DEG>", "--roof-tolerance <M>"],
        &["lod", "evaluate", "fisheye"],
    ),
    (
        "selection bundle",
        &["--rays <RAYS>", "--seed <SEED>"],
        &["lod", "evaluate"],
    ),
    (
        "site",
        &["--lat <LAT>", "--lon <LON>"],
        &["lod", "evaluate", "sun-hours", "fisheye"],
    ),
    (
        "sun",
        &["--year <YEAR>", "--step <STEP>"],
        &["lod", "evaluate", "sun-hours"],
    ),
    (
        "source CRS",
        &["--source-crs <CRS>"],
        &["lod", "evaluate", "svf", "convert", "irradiance"],
    ),
    (
        "output",
        &[
            "-o, --output <OUTPUT>",
            "--format <citygml|obj|cityjson|cityjsonseq|3dtiles>",
            "--overwrite",
        ],
        &["lod", "rough"],
    ),
];

#[test]
fn every_command_has_its_groups_with_one_text() {
    let mut problems = Vec::new();
    for (group, flags, cmds) in GROUPS {
        for flag in *flags {
            let texts: Vec<(&str, Option<String>)> =
                cmds.iter().map(|c| (*c, help_of(c, flag))).collect();
            for (c, t) in &texts {
                if t.is_none() {
                    problems.push(format!("{group}: `skylod {c}` lacks {flag}"));
                }
            }
            let first = texts.iter().find_map(|(_, t)| t.clone());
            for (c, t) in &texts {
                if let (Some(t), Some(f)) = (t, &first) {
                    if t != f {
                        problems.push(format!("{group}: `skylod {c}` says {t:?}, not {f:?}"));
                    }
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn fisheye_site_flags_go_together() {
    let o = run(&[
        os("fisheye"),
        os("x.gml"),
        os("--poi"),
        os("0,0,0"),
        os("-o"),
        os("x.svg"),
        os("--lat"),
        os("41.4"),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let e = crate::util::stderr(&o);
    assert!(e.contains("--lat") && e.contains("--lon"), "{e}");
}
