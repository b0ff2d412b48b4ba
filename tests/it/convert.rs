//! `skylod convert` on every shared file and every fixture: same stats, schema-valid output for
//! schema-valid input, idempotent (byte-identical round trip), gzip output.

use crate::util::*;
use skylod::export::report::Stats;
use skylod::io::citygml::read_file;
use std::io::Read;
use std::path::{Path, PathBuf};

struct Converted {
    input: PathBuf,
    version: String,
    out: PathBuf,
}

fn convert(input: &Path, out: &Path) -> Result<(), String> {
    let o = run(&[
        "convert".as_ref(),
        input.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    if o.status.success() {
        Ok(())
    } else {
        Err(format!(
            "exit {:?}: {}",
            o.status.code(),
            String::from_utf8_lossy(&o.stderr).trim()
        ))
    }
}

/// Stats without the fields a conversion may legitimately change: none today; warnings are
/// compared too (the output is the same document up to recomputed envelopes).
fn stats(p: &Path) -> Result<Stats, String> {
    read_file(p)
        .map(|m| Stats::of(&m))
        .map_err(|e| e.to_string())
}

fn gunzip(p: &Path) -> Vec<u8> {
    let f = std::fs::File::open(p).unwrap();
    let mut d = flate2::read::GzDecoder::new(f);
    let mut v = Vec::new();
    d.read_to_end(&mut v).unwrap();
    v
}

#[test]
fn convert_every_file() {
    let inputs: Vec<PathBuf> = all_inputs()
        .into_iter()
        .filter(|p| !p.ends_with("val3dity/csol1b.gml")) // plain GML, not CityGML
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let mut problems = Vec::new();
    let mut done = Vec::new();
    for (i, input) in inputs.iter().enumerate() {
        let name = short(input);
        let before = match stats(input) {
            Ok(s) => s,
            Err(e) => {
                problems.push(format!("{name}: input does not read: {e}"));
                continue;
            }
        };
        let out = dir.path().join(format!("{i:03}.gml"));
        if let Err(e) = convert(input, &out) {
            problems.push(format!("{name}: convert failed: {e}"));
            continue;
        }
        match stats(&out) {
            Ok(after) if after == before => {}
            Ok(after) => problems.push(format!(
                "{name}: stats differ after convert:\n  in:  {before:?}\n  out: {after:?}"
            )),
            Err(e) => problems.push(format!("{name}: output does not read: {e}")),
        }
        let first = std::fs::read(&out).unwrap();
        // Round trip: converting the output again changes nothing.
        let out2 = dir.path().join(format!("{i:03}-again.gml"));
        match convert(&out, &out2) {
            Ok(()) => {
                if std::fs::read(&out2).unwrap() != first {
                    problems.push(format!("{name}: convert(convert(x)) != convert(x)"));
                }
            }
            Err(e) => problems.push(format!("{name}: second convert failed: {e}")),
        }
        // Gzip output when the name ends in .gz.
        let gz = dir.path().join(format!("{i:03}.gml.gz"));
        match convert(input, &gz) {
            Ok(()) => {
                let raw = std::fs::read(&gz).unwrap();
                if raw.get(..2) != Some(&[0x1f, 0x8b][..]) {
                    problems.push(format!("{name}: .gz output is not gzip"));
                } else if gunzip(&gz) != first {
                    problems.push(format!("{name}: gunzip(.gz output) != plain output"));
                }
            }
            Err(e) => problems.push(format!("{name}: convert to .gz failed: {e}")),
        }
        done.push(Converted {
            input: input.clone(),
            version: before.citygml_version.clone().unwrap_or_default(),
            out,
        });
    }
    // Schema validity: decided by validating the input; valid in => valid out.
    if have_xmllint() {
        let threads = std::thread::available_parallelism()
            .map(|n| n.get().min(4))
            .unwrap_or(2);
        let ins: Vec<(PathBuf, String)> = done
            .iter()
            .map(|c| (c.input.clone(), c.version.clone()))
            .collect();
        let valid_in = xmllint_validate_all(&ins, threads);
        let outs: Vec<(PathBuf, String)> = done
            .iter()
            .filter(|c| matches!(valid_in.get(&c.input), Some(Ok(()))))
            .map(|c| (c.out.clone(), c.version.clone()))
            .collect();
        let n_valid = outs.len();
        let valid_out = xmllint_validate_all(&outs, threads);
        for c in &done {
            if let Some(Err(e)) = valid_out.get(&c.out) {
                problems.push(format!(
                    "{}: input validates, output does not:\n{e}",
                    short(&c.input)
                ));
            }
        }
        // The fixtures are hand-made to be valid: they must be among the valid inputs.
        for c in done
            .iter()
            .filter(|c| short(&c.input).starts_with("fixtures/"))
        {
            if let Some(Err(e)) = valid_in.get(&c.input) {
                problems.push(format!(
                    "{}: fixture is not XSD-valid:\n{e}",
                    short(&c.input)
                ));
            }
        }
        eprintln!("{n_valid} of {} inputs are XSD-valid", done.len());
    }
    assert!(
        problems.is_empty(),
        "{} problem(s):\n{}",
        problems.len(),
        problems.join("\n")
    );
}
