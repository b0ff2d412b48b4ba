//! Shards for a cluster scheduler: the shards of a command, run as separate processes with
//! `--shard I/N` or with each scheduler's environment variables (Kubernetes, Slurm, AWS
//! Batch), and under GNU parallel, give together the bytes of one serial run; `lod` shards'
//! levels reduce to the serial model; `--scene-radius` reads only the nearby tiles.

use crate::util::*;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Scheduler variables cleared from every child, so that the test's own environment (a CI
/// job running inside an array job) cannot leak in.
const SCHED: [&str; 5] = [
    "JOB_COMPLETION_INDEX",
    "SLURM_ARRAY_TASK_ID",
    "SLURM_ARRAY_TASK_MIN",
    "SLURM_ARRAY_TASK_COUNT",
    "AWS_BATCH_JOB_ARRAY_INDEX",
];

fn skylod(args: &[String], env: &[(&str, String)]) -> Output {
    let mut c = Command::new(BIN);
    c.args(args);
    for k in SCHED {
        c.env_remove(k);
    }
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().unwrap()
}

fn ok(o: Output, what: &str) -> Vec<u8> {
    assert_eq!(o.status.code(), Some(0), "{what}: {}", stderr(&o));
    o.stdout
}

fn s(x: impl AsRef<std::ffi::OsStr>) -> String {
    x.as_ref().to_string_lossy().into_owned()
}

/// A case: inputs and POI options of a real file and of a synth district.
struct Case {
    name: &'static str,
    args: Vec<String>,
}

/// Ingolstadt tiles with POIs in the streets between them (free points and facade points).
fn ingolstadt() -> Option<Case> {
    let d = shared_data()?.join("ingolstadt-lod3");
    let tiles = ["4018106.xml.gz", "4018115.xml.gz", "4018128.xml.gz"];
    let mut args: Vec<String> = tiles.iter().map(|t| s(d.join(t))).collect();
    for p in [
        "678090,5403790,415",
        "678075,5403800,416",
        "678105,5403805,418",
        "678090,5403825,420",
        "678060,5403780,414",
    ] {
        args.push("--poi".into());
        args.push(p.into());
    }
    Some(Case {
        name: "ingolstadt",
        args,
    })
}

/// The committed synth district with its facade POIs and a ground point.
fn synth() -> Case {
    Case {
        name: "synth",
        args: vec![
            s(fixture("synth-small.gml")),
            "--pois".into(),
            s(fixture("synth-small.pois.csv")),
            "--poi".into(),
            "430000,4581000,13.5".into(),
        ],
    }
}

fn cases() -> Vec<Case> {
    let mut v = vec![synth()];
    v.extend(ingolstadt());
    v
}

fn with(base: &[&str], case: &Case, extra: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = base.iter().map(|x| x.to_string()).collect();
    v.extend(case.args.iter().cloned());
    v.extend(extra.iter().map(|x| x.to_string()));
    v
}

/// Per-POI commands whose standard output the shards split: svf (table), sun-hours (table),
/// horizon (CSV).
fn per_poi_commands() -> Vec<(&'static str, Vec<&'static str>)> {
    vec![
        ("svf", vec!["--rays", "1500"]),
        (
            "sun-hours",
            vec!["--lat", "48.76", "--lon", "11.42", "--step", "120"],
        ),
        ("horizon", vec!["--step", "10"]),
    ]
}

#[test]
fn per_poi_shards_concatenate_to_the_serial_run() {
    for case in cases() {
        for (cmd, extra) in per_poi_commands() {
            let serial = ok(
                skylod(&with(&[cmd], &case, &extra), &[]),
                &format!("{} {cmd}", case.name),
            );
            assert!(serial.len() > 100, "{} {cmd}: output too short", case.name);
            for n in 1..=3 {
                let mut joined = Vec::new();
                for i in 0..n {
                    let shard = format!("{i}/{n}");
                    let mut e = extra.clone();
                    e.extend(["--shard", &shard]);
                    joined.extend(ok(
                        skylod(&with(&[cmd], &case, &e), &[]),
                        &format!("{} {cmd} {shard}", case.name),
                    ));
                }
                assert!(
                    joined == serial,
                    "{} {cmd}: {n} shards concatenated differ from the serial run:\n{}\n---\n{}",
                    case.name,
                    String::from_utf8_lossy(&joined),
                    String::from_utf8_lossy(&serial)
                );
            }
        }
    }
}

/// The shards of `svf` with a scheduler's variables (`env(i)`) and the count from
/// `--shards` when `shards_flag`.
fn scheduler_run(
    case: &Case,
    n: usize,
    env: impl Fn(usize) -> Vec<(&'static str, String)>,
    shards_flag: bool,
) -> Vec<u8> {
    let mut joined = Vec::new();
    let count = n.to_string();
    for i in 0..n {
        let mut extra = vec!["--rays", "1500"];
        if shards_flag {
            extra.extend(["--shards", &count]);
        }
        joined.extend(ok(
            skylod(&with(&["svf"], case, &extra), &env(i)),
            &format!("{} svf shard {i}/{n}", case.name),
        ));
    }
    joined
}

#[test]
fn schedulers_environments_give_the_shards() {
    for case in cases() {
        let serial = ok(
            skylod(&with(&["svf"], &case, &["--rays", "1500"]), &[]),
            "serial",
        );
        for n in [2, 3] {
            let k8s = scheduler_run(
                &case,
                n,
                |i| vec![("JOB_COMPLETION_INDEX", i.to_string())],
                true,
            );
            assert!(k8s == serial, "{}: Kubernetes, {n} shards", case.name);
            // `sbatch --array=5-(5+n-1)`: ids from 5, the count from Slurm itself.
            let slurm = scheduler_run(
                &case,
                n,
                |i| {
                    vec![
                        ("SLURM_ARRAY_TASK_ID", (5 + i).to_string()),
                        ("SLURM_ARRAY_TASK_MIN", "5".into()),
                        ("SLURM_ARRAY_TASK_COUNT", n.to_string()),
                    ]
                },
                false,
            );
            assert!(slurm == serial, "{}: Slurm, {n} shards", case.name);
            let aws = scheduler_run(
                &case,
                n,
                |i| vec![("AWS_BATCH_JOB_ARRAY_INDEX", i.to_string())],
                true,
            );
            assert!(aws == serial, "{}: AWS Batch, {n} shards", case.name);
        }
    }
}

/// Flags, environment, and what the error message must name.
type UsageCase = (Vec<&'static str>, Vec<(&'static str, String)>, &'static str);

#[test]
fn invalid_and_conflicting_shard_settings_are_usage_errors() {
    let case = synth();
    let table: Vec<UsageCase> = vec![
        (vec!["--shard", "2/2"], vec![], "--shard"),
        (vec!["--shard", "x"], vec![], "--shard"),
        (vec!["--shards", "2"], vec![], "--shards 2 without an index"),
        (
            vec![],
            vec![("JOB_COMPLETION_INDEX", "0".into())],
            "--shards N",
        ),
        (
            vec!["--shards", "2"],
            vec![("JOB_COMPLETION_INDEX", "x".into())],
            "JOB_COMPLETION_INDEX",
        ),
        (
            vec!["--shards", "2"],
            vec![
                ("JOB_COMPLETION_INDEX", "1".into()),
                ("AWS_BATCH_JOB_ARRAY_INDEX", "0".into()),
            ],
            "AWS_BATCH_JOB_ARRAY_INDEX",
        ),
        (
            vec!["--shard", "0/2"],
            vec![("JOB_COMPLETION_INDEX", "1".into())],
            "JOB_COMPLETION_INDEX=1",
        ),
        (
            vec!["--shards", "3"],
            vec![
                ("SLURM_ARRAY_TASK_ID", "1".into()),
                ("SLURM_ARRAY_TASK_COUNT", "2".into()),
            ],
            "SLURM_ARRAY_TASK_COUNT=2",
        ),
        (
            vec![],
            vec![
                ("SLURM_ARRAY_TASK_ID", "1".into()),
                ("SLURM_ARRAY_TASK_MIN", "3".into()),
            ],
            "SLURM_ARRAY_TASK_MIN",
        ),
    ];
    for (flags, env, says) in table {
        let o = skylod(&with(&["svf"], &case, &flags), &env);
        assert_eq!(
            o.status.code(),
            Some(2),
            "{flags:?} {env:?}: {}",
            stderr(&o)
        );
        assert!(
            stderr(&o).contains(says),
            "{flags:?} {env:?}: {}",
            stderr(&o)
        );
    }
}

#[test]
fn gnu_parallel_runs_the_shards_for_real() {
    if Command::new("parallel").arg("--version").output().is_err() {
        missing("GNU parallel (Debian package `parallel`)");
        return;
    }
    for case in cases() {
        let serial = ok(
            skylod(&with(&["svf"], &case, &["--rays", "1500"]), &[]),
            "serial",
        );
        // parallel -k keeps the outputs in the order of the arguments: shard order.
        let mut cmd = vec![
            "-k".to_string(),
            "-j".into(),
            "3".into(),
            BIN.into(),
            "svf".into(),
        ];
        cmd.extend(case.args.iter().cloned());
        cmd.extend(["--rays", "1500", "--shard", "{}/3", ":::", "0", "1", "2"].map(String::from));
        let mut c = Command::new("parallel");
        c.args(&cmd);
        for k in SCHED {
            c.env_remove(k);
        }
        let o = c.output().unwrap();
        let got = ok(o, "parallel");
        assert!(
            got == serial,
            "{}: parallel's shards differ from the serial run",
            case.name
        );
    }
}

/// Shards made with other options are refused at `--reduce` (exit 2), the message naming both
/// levels files and the options that must agree, in the command line's words.
#[test]
fn shards_of_other_options_are_refused_at_reduce() {
    let dir = tempfile::tempdir().unwrap();
    let case = synth();
    let mut levels = Vec::new();
    for (i, rays) in ["3000", "2000"].into_iter().enumerate() {
        let l = s(dir.path().join(format!("levels-{i}.jsonl")));
        let shard = format!("{i}/2");
        let e = ["--rays", rays, "--shard", &shard, "-o", &l];
        ok(skylod(&with(&["lod"], &case, &e), &[]), &shard);
        levels.push(l);
    }
    let out = s(dir.path().join("reduced.gml"));
    let mut args: Vec<String> = vec!["lod".into(), case.args[0].clone(), "-o".into(), out];
    args.push("--reduce".into());
    args.extend(levels.iter().cloned());
    let o = skylod(&args, &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let text = stderr(&o);
    assert!(text.contains("levels-0.jsonl and "), "{text}");
    assert!(text.contains("different options (rays, seed,"), "{text}");
    assert!(text.contains("or --no-lod2)"), "{text}");
}

/// `lod` shards write levels; `--reduce` writes models byte-identical to the serial run's.
#[test]
fn lod_shards_reduce_to_the_serial_model() {
    for case in cases() {
        let dir = tempfile::tempdir().unwrap();
        let several = case.args.iter().filter(|a| a.ends_with(".gz")).count() > 1;
        let out = |name: &str| -> PathBuf {
            if several {
                dir.path().join(name)
            } else {
                dir.path().join(format!("{name}.gml"))
            }
        };
        let rays = ["--rays", "3000"];
        let serial = out("serial");
        let report = dir.path().join("serial.json");
        let mut e = rays.to_vec();
        let (so, sr) = (s(&serial), s(&report));
        e.extend(["-o", &so, "--report", &sr]);
        ok(skylod(&with(&["lod"], &case, &e), &[]), "serial lod");
        for n in 1..=3 {
            let mut levels = Vec::new();
            for i in 0..n {
                let l = dir.path().join(format!("levels-{n}-{i}.jsonl"));
                let shard = format!("{i}/{n}");
                let mut e = rays.to_vec();
                let ls = s(&l);
                e.extend(["--shard", &shard, "-o", &ls]);
                ok(
                    skylod(&with(&["lod"], &case, &e), &[]),
                    &format!("lod shard {shard}"),
                );
                levels.push(ls);
            }
            let reduced = out(&format!("reduced-{n}"));
            let rep = dir.path().join(format!("reduced-{n}.json"));
            // Inputs only: POIs and options come from the levels files (given in any order).
            let mut args: Vec<String> = vec!["lod".into()];
            args.extend(
                case.args
                    .iter()
                    .take_while(|a| !a.starts_with("--"))
                    .cloned(),
            );
            args.extend([
                "-o".into(),
                s(&reduced),
                "--report".into(),
                s(&rep),
                "--reduce".into(),
            ]);
            args.extend(levels.iter().rev().cloned());
            ok(skylod(&args, &[]), &format!("{} reduce {n}", case.name));
            let pairs: Vec<(PathBuf, PathBuf)> = if several {
                let mut v: Vec<_> = std::fs::read_dir(&serial)
                    .unwrap()
                    .map(|e| e.unwrap().path())
                    .map(|p| (p.clone(), reduced.join(p.file_name().unwrap())))
                    .collect();
                v.sort();
                v
            } else {
                vec![(serial.clone(), reduced.clone())]
            };
            assert!(!pairs.is_empty());
            for (a, b) in &pairs {
                assert!(
                    std::fs::read(a).unwrap() == std::fs::read(b).unwrap(),
                    "{}: {n} shards: {} differs from {}",
                    case.name,
                    b.display(),
                    a.display()
                );
            }
            // The reports agree but for timings and output names.
            let strip = |p: &Path| {
                let mut v: serde_json::Value =
                    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap();
                v.as_object_mut().unwrap().remove("timings_ms");
                for i in v["inputs"].as_array_mut().unwrap() {
                    i.as_object_mut().unwrap().remove("output");
                }
                for poi in v["pois"].as_array_mut().unwrap() {
                    poi.as_object_mut().unwrap().remove("ms");
                }
                v
            };
            assert_eq!(
                strip(&report),
                strip(&rep),
                "{}: {n} shards: report",
                case.name
            );
        }
        // A missing shard is refused, naming it.
        let mut args: Vec<String> = vec!["lod".into()];
        args.extend(
            case.args
                .iter()
                .take_while(|a| !a.starts_with("--"))
                .cloned(),
        );
        let x = out("x");
        args.extend([
            "-o".into(),
            s(&x),
            "--reduce".into(),
            s(dir.path().join("levels-3-0.jsonl")),
        ]);
        let o = skylod(&args, &[]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(
            stderr(&o).contains("shard 1/3 is missing"),
            "{}",
            stderr(&o)
        );
    }
}

/// Per-file commands: each shard does its files, written where the serial run writes them.
/// The shards run last to first into one directory without `--overwrite`: a shard checks
/// only its own targets (the others' files already there are not its business).
#[test]
fn per_file_shards_write_the_serial_files() {
    let Some(d) = shared_data() else { return };
    let d = d.join("ingolstadt-lod3");
    let inputs: Vec<String> = [
        "4018106.xml.gz",
        "4018115.xml.gz",
        "4018128.xml.gz",
        "4018133.xml.gz",
    ]
    .iter()
    .map(|t| s(d.join(t)))
    .collect();
    let dir = tempfile::tempdir().unwrap();
    for cmd in ["rough", "convert"] {
        let serial = dir.path().join(format!("{cmd}-serial"));
        let mut a = vec![cmd.to_string()];
        a.extend(inputs.iter().cloned());
        a.extend(["-o".into(), s(&serial)]);
        ok(skylod(&a, &[]), &format!("serial {cmd}"));
        let sharded = dir.path().join(format!("{cmd}-sharded"));
        for i in (0..3).rev() {
            let mut a = vec![cmd.to_string()];
            a.extend(inputs.iter().cloned());
            a.extend(["-o".into(), s(&sharded), "--shard".into(), format!("{i}/3")]);
            ok(skylod(&a, &[]), &format!("{cmd} shard {i}/3"));
        }
        let names = |p: &Path| {
            let mut v: Vec<_> = std::fs::read_dir(p)
                .unwrap()
                .map(|e| e.unwrap().file_name())
                .collect();
            v.sort();
            v
        };
        assert_eq!(names(&serial).len(), inputs.len(), "{cmd}");
        assert_eq!(names(&serial), names(&sharded), "{cmd}");
        for n in names(&serial) {
            assert!(
                std::fs::read(serial.join(&n)).unwrap() == std::fs::read(sharded.join(&n)).unwrap(),
                "{cmd} {n:?}"
            );
        }
    }
}

/// `--scene-radius` on the Ingolstadt tiles with one POI: only the nearby tiles are read,
/// and with a radius that reaches every occluder the SVF is the full run's.
#[test]
fn scene_radius_reads_only_nearby_tiles() {
    let Some(d) = shared_data() else { return };
    let d = s(d.join("ingolstadt-lod3"));
    let base = |extra: &[&str]| {
        let mut v: Vec<String> = [
            "svf",
            &d,
            "--poi",
            "678090,5403790,415",
            "--rays",
            "3000",
            "--json",
        ]
        .iter()
        .map(|x| x.to_string())
        .collect();
        v.extend(extra.iter().map(|x| x.to_string()));
        v
    };
    let full = skylod(&base(&[]), &[]);
    let full_json = json(&full);
    let all = full_json["inputs"].as_array().unwrap().len();
    assert!(all > 20, "{all} tiles");
    let near = skylod(&base(&["--scene-radius", "30"]), &[]);
    let near_json = json(&near);
    let loaded = near_json["inputs"].as_array().unwrap();
    assert!(
        !loaded.is_empty() && loaded.len() < all / 2,
        "{} of {all} loaded",
        loaded.len()
    );
    assert!(
        loaded
            .iter()
            .any(|p| p.as_str().unwrap().ends_with("4018106.xml.gz")),
        "the tile beside the POI is read: {loaded:?}"
    );
    assert!(stderr(&near).contains("within reach"), "{}", stderr(&near));
    // Every occluder within 300 m: the same SVF as the full scene (and fewer tiles read).
    let wide = json(&skylod(&base(&["--scene-radius", "300"]), &[]));
    assert!(wide["inputs"].as_array().unwrap().len() <= all);
    assert_eq!(wide["pois"][0]["svf"], full_json["pois"][0]["svf"]);
    assert_eq!(
        wide["pois"][0]["sky_exposure"],
        full_json["pois"][0]["sky_exposure"]
    );
    // A POI far from every tile: nothing to read is a usage error.
    let far = skylod(
        &["svf", &d, "--poi", "0,0,0", "--scene-radius", "10"].map(String::from),
        &[],
    );
    assert_eq!(far.status.code(), Some(2), "{}", stderr(&far));
}

/// Daemons of the one-node Slurm cluster, stopped (by their pid files) when dropped.
struct Daemons(Vec<PathBuf>);

impl Drop for Daemons {
    fn drop(&mut self) {
        for pid in &self.0 {
            if let Ok(p) = std::fs::read_to_string(pid) {
                let _ = Command::new("kill").arg(p.trim()).status();
            }
        }
    }
}

/// A real Slurm job array on a one-node cluster brought up on localhost (Debian's
/// `slurm-wlm` and `munge`, as root): `sbatch --array=0-1 --wait`, the shards' outputs
/// concatenated equal the serial run.
#[test]
#[ignore = "brings up a one-node Slurm cluster (slurm-wlm, munge, root): cargo test --test it shard:: -- --ignored"]
fn slurm_job_array_for_real() {
    for tool in [
        "munged",
        "slurmctld",
        "slurmd",
        "sbatch",
        "sinfo",
        "hostname",
    ] {
        if Command::new("sh")
            .args(["-c", &format!("command -v {tool}")])
            .output()
            .map_or(true, |o| !o.status.success())
        {
            missing(&format!("{tool} (Debian packages slurm-wlm, munge)"));
            return;
        }
    }
    let dir = tempfile::Builder::new()
        .prefix("skylod-slurm-")
        .tempdir()
        .unwrap();
    let d = dir.path();
    let host = String::from_utf8(Command::new("hostname").output().unwrap().stdout).unwrap();
    let host = host.trim();
    let port = 20000 + (std::process::id() % 20000) as u16;
    for sub in ["state", "spool", "munge"] {
        std::fs::create_dir_all(d.join(sub)).unwrap();
    }
    let key = d.join("munge/munge.key");
    std::fs::write(
        &key,
        (0..1024u32)
            .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
            .collect::<Vec<u8>>(),
    )
    .unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&key, std::fs::Permissions::from_mode(0o600)).unwrap();
    std::fs::set_permissions(d.join("munge"), std::fs::Permissions::from_mode(0o700)).unwrap();
    let sock = d.join("munge/munge.sock");
    let p = |x: &str| d.join(x).display().to_string();
    let conf = d.join("slurm.conf");
    std::fs::write(
        &conf,
        format!(
            "ClusterName=skylodtest\nSlurmctldHost={host}\nSlurmUser=root\nSlurmdUser=root\n\
             AuthType=auth/munge\nAuthInfo=socket={sock}\nStateSaveLocation={state}\n\
             SlurmdSpoolDir={spool}\nSlurmctldPidFile={cpid}\nSlurmdPidFile={dpid}\n\
             SlurmctldPort={port}\nSlurmdPort={dport}\nProctrackType=proctrack/linuxproc\n\
             TaskPlugin=task/none\nSchedulerType=sched/builtin\nSelectType=select/cons_tres\n\
             SelectTypeParameters=CR_CPU\nReturnToService=2\nMpiDefault=none\n\
             JobAcctGatherType=jobacct_gather/none\nSlurmctldLogFile={clog}\nSlurmdLogFile={dlog}\n\
             NodeName={host} CPUs={cpus} State=UNKNOWN\n\
             PartitionName=test Nodes={host} Default=YES MaxTime=INFINITE State=UP\n",
            sock = sock.display(),
            state = p("state"),
            spool = p("spool"),
            cpid = p("slurmctld.pid"),
            dpid = p("slurmd.pid"),
            dport = port + 1,
            clog = p("slurmctld.log"),
            dlog = p("slurmd.log"),
            cpus = threads(),
        ),
    )
    .unwrap();
    let _daemons = Daemons(vec![
        d.join("slurmd.pid"),
        d.join("slurmctld.pid"),
        d.join("munge/munged.pid"),
    ]);
    let started = Command::new("munged")
        .arg("--force")
        .arg(format!("--socket={}", sock.display()))
        .arg(format!("--key-file={}", key.display()))
        .arg(format!("--pid-file={}", p("munge/munged.pid")))
        .arg(format!("--log-file={}", p("munge/munged.log")))
        .arg(format!("--seed-file={}", p("munge/munged.seed")))
        .status()
        .unwrap();
    assert!(started.success(), "munged did not start");
    for daemon in ["slurmctld", "slurmd"] {
        let st = Command::new(daemon)
            .arg("-f")
            .arg(&conf)
            .env("SLURM_CONF", &conf)
            .status()
            .unwrap();
        assert!(st.success(), "{daemon} did not start");
    }
    // Wait (at most 30 s) for the node to be idle.
    let mut idle = false;
    for _ in 0..60 {
        let o = Command::new("sinfo")
            .args(["-h", "-o", "%T"])
            .env("SLURM_CONF", &conf)
            .output()
            .unwrap();
        if String::from_utf8_lossy(&o.stdout).trim() == "idle" {
            idle = true;
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(500));
    }
    assert!(
        idle,
        "the node did not come up: {}",
        std::fs::read_to_string(d.join("slurmd.log")).unwrap_or_default()
    );
    let case = synth();
    let serial = ok(
        skylod(&with(&["svf"], &case, &["--rays", "1500"]), &[]),
        "serial",
    );
    let mut line = format!("'{BIN}' svf");
    for a in &case.args {
        line.push_str(&format!(" '{a}'"));
    }
    let script = d.join("job.sh");
    std::fs::write(
        &script,
        format!(
            "#!/bin/sh\n{line} --rays 1500 > '{}'/out.$SLURM_ARRAY_TASK_ID.txt\n",
            d.display()
        ),
    )
    .unwrap();
    let o = Command::new("sbatch")
        .args(["--array=0-1", "--wait", "-o"])
        .arg(d.join("log.%a.txt"))
        .arg(&script)
        .env("SLURM_CONF", &conf)
        .output()
        .unwrap();
    assert!(o.status.success(), "sbatch: {}", stderr(&o));
    let mut joined = Vec::new();
    for i in 0..2 {
        joined.extend(std::fs::read(d.join(format!("out.{i}.txt"))).unwrap());
    }
    assert!(
        joined == serial,
        "the Slurm array's outputs differ from the serial run:\n{}",
        String::from_utf8_lossy(&joined)
    );
}

/// `evaluate` (table, timing columns apart) and `svf --json` (the shards' `pois` arrays
/// joined, as README's `jq -s '.[0] + {pois: map(.pois) | add}'` does) split the same way.
#[test]
fn evaluate_table_and_json_shards_combine_to_the_serial_run() {
    let case = synth();
    let eval = ["--no-sun", "--rays", "1500", "--svf-rays", "2000"];
    // Everything but the last three columns (bvh ms, trace ms, select ms).
    let untimed = |out: &[u8]| -> Vec<String> {
        String::from_utf8_lossy(out)
            .lines()
            .map(|l| {
                let w: Vec<&str> = l.split_whitespace().collect();
                w[..w.len().saturating_sub(3)].join(" ")
            })
            .collect()
    };
    let serial = ok(skylod(&with(&["evaluate"], &case, &eval), &[]), "evaluate");
    let serial_json = json(&skylod(
        &with(&["svf"], &case, &["--rays", "1500", "--json"]),
        &[],
    ));
    assert!(untimed(&serial).len() > 6);
    for n in 2..=3 {
        let (mut table, mut pois) = (Vec::new(), Vec::new());
        for i in 0..n {
            let shard = format!("{i}/{n}");
            let mut e = eval.to_vec();
            e.extend(["--shard", &shard]);
            table.extend(ok(
                skylod(&with(&["evaluate"], &case, &e), &[]),
                "evaluate shard",
            ));
            let o = skylod(
                &with(
                    &["svf"],
                    &case,
                    &["--rays", "1500", "--json", "--shard", &shard],
                ),
                &[],
            );
            pois.extend(json(&o)["pois"].as_array().unwrap().clone());
        }
        assert_eq!(untimed(&table), untimed(&serial), "evaluate, {n} shards");
        assert_eq!(
            &pois,
            serial_json["pois"].as_array().unwrap(),
            "svf --json, {n} shards"
        );
    }
}
