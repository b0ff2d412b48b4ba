//! The `skylod lod` pipeline from a program: read → POIs → levels → write, with progress
//! printed by the caller and a cancellation flag (here: stop after a time limit).
//! `cargo run --release --example lod_pipeline -- MODEL.gml POIS.csv OUT.gml [SECONDS]`
//! (without arguments: the committed synth fixture, written to a temporary directory).
use skylod::model::Stage;
use skylod::prelude::*;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Prints each stage on stderr and cancels the work after `limit`.
struct Console {
    t: Instant,
    limit: Duration,
    pois: AtomicU64,
}

impl Progress for Console {
    fn start(&self, stage: Stage, items: u64, bytes: u64) {
        eprintln!(
            "[{:6.2} s] {stage}: {items} {}(s), {bytes} bytes",
            self.t.elapsed().as_secs_f64(),
            stage.item()
        );
    }
    fn advance(&self, stage: Stage, items: u64, _bytes: u64, name: Option<&str>) {
        if stage == Stage::Select {
            self.pois.fetch_add(items, Ordering::Relaxed);
        }
        if let Some(n) = name {
            eprintln!("[{:6.2} s]   {n}", self.t.elapsed().as_secs_f64());
        }
    }
    fn is_cancelled(&self) -> bool {
        self.t.elapsed() > self.limit
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let fixtures = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let tmp = tempfile::tempdir()?;
    let mut args = std::env::args_os().skip(1);
    let model = args
        .next()
        .map_or(fixtures.join("synth-small.gml"), PathBuf::from);
    let csv = args
        .next()
        .map_or(fixtures.join("synth-small.pois.csv"), PathBuf::from);
    let out = args
        .next()
        .map_or(tmp.path().join("lod.gml"), PathBuf::from);
    let limit = args
        .next()
        .and_then(|s| s.to_str()?.parse().ok())
        .map_or(Duration::from_secs(600), Duration::from_secs_f64);
    let progress = Console {
        t: Instant::now(),
        limit,
        pois: AtomicU64::new(0),
    };

    let scene = Scene::load(&[model], &SceneOptions::default(), &progress)?;
    for e in scene.failures() {
        eprintln!("error: {e}");
    }
    let pois = read_pois_csv(&csv)?.into_iter().map(|l| l.poi).collect();
    let mut study = scene.frame(pois)?;
    let lv = study.levels(&LevelsOptions::default(), &progress)?;
    let [l0, l1, l2] = lv.lod.selection.level_counts();
    eprintln!(
        "{} POI(s) selected: assets at level 0/1/2 = {l0}/{l1}/{l2}",
        progress.pois.load(Ordering::Relaxed)
    );
    let written = study.write_levels(&lv, &out, Some(Format::CityGml), false, &progress)?;
    for (path, w) in written {
        println!(
            "{}: polygons {} -> {}, {} bytes",
            path.display(),
            w.polygons_in,
            w.polygons_out,
            w.bytes
        );
    }
    Ok(())
}
