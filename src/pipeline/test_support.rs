//! What the unit tests of the pipeline share: the fixture, POIs on it, progress that
//! counts and cancels.

use super::analyse::trace;
use super::session::Error;
use super::Traced;
use super::{frame_in, FrameOptions, Framed, Inputs};
use crate::model::runtime::progress::Cancelled;
use crate::model::runtime::progress::{Progress, Silent, Stage};
use crate::model::CityModel;
use crate::model::Poi;
use crate::solar::{poi_sky_view, poi_sun_hours, SkyBundles, SkyView, SunHours, SunTable};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

pub(crate) fn fixture() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/synth-small.gml")
}

/// The file at `path` gzipped into `dir` as its name with `.gz` added: the new file's path.
pub(crate) fn gzip_copy(path: &Path, dir: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap().to_os_string();
    name.push(".gz");
    let gz = dir.join(name);
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    std::io::Write::write_all(&mut enc, &std::fs::read(path).unwrap()).unwrap();
    std::fs::write(&gz, enc.finish().unwrap()).unwrap();
    gz
}

/// A study of the [`fixture`] with `n` POIs ([`grid_pois`]), built and returned: nothing
/// borrowed.
pub(crate) fn study(n: usize) -> super::session::Study {
    use super::session::{Scene, SceneOptions};
    let scene = Scene::load(&[fixture()], &SceneOptions::default(), &Silent).unwrap();
    let pois = grid_pois(scene.model(), n);
    scene.frame(pois).unwrap()
}

/// The [`fixture`] read.
pub(crate) fn fixture_inputs() -> Inputs {
    super::read_inputs(&[fixture()], &Silent).unwrap()
}

/// Counts POIs of `stage` (selected or traced); cancels after `stop_after` of them.
pub(crate) struct Stopper {
    pub(crate) stage: Stage,
    pub(crate) selected: AtomicU64,
    pub(crate) stop_after: u64,
    pub(crate) stopped: AtomicBool,
}

impl Stopper {
    pub(crate) fn new(stage: Stage, stop_after: u64) -> Self {
        Stopper {
            stage,
            selected: AtomicU64::new(0),
            stop_after,
            stopped: AtomicBool::new(false),
        }
    }
}

impl Progress for Stopper {
    fn advance(&self, stage: Stage, items: u64, _: u64, _: Option<&str>) {
        if stage == self.stage
            && self.selected.fetch_add(items, Ordering::SeqCst) + items >= self.stop_after
        {
            self.stopped.store(true, Ordering::SeqCst);
        }
    }
    fn is_cancelled(&self) -> bool {
        self.stopped.load(Ordering::SeqCst)
    }
}

pub(crate) fn grid_pois(model: &CityModel, n: usize) -> Vec<Poi> {
    let b = model.bbox();
    let c = b.center();
    (0..n)
        .map(|i| Poi {
            id: format!("p{i}"),
            position: glam::DVec3::new(c.x + i as f64 * 0.1, c.y, b.min.z + 1.5),
            normal: None,
        })
        .collect()
}

/// Sums what each stage was told and what it got.
#[derive(Default)]
pub(crate) struct Tally(std::sync::Mutex<Vec<(Stage, &'static str, u64, u64)>>);

impl Progress for Tally {
    fn start(&self, stage: Stage, items: u64, bytes: u64) {
        self.0.lock().unwrap().push((stage, "start", items, bytes));
    }
    fn advance(&self, stage: Stage, items: u64, bytes: u64, _: Option<&str>) {
        self.0
            .lock()
            .unwrap()
            .push((stage, "advance", items, bytes));
    }
}

impl Tally {
    pub(crate) fn sum(&self, stage: Stage, what: &str) -> (u64, u64) {
        self.0
            .lock()
            .unwrap()
            .iter()
            .filter(|e| e.0 == stage && e.1 == what)
            .fold((0, 0), |a, e| (a.0 + e.2, a.1 + e.3))
    }
}

/// `n` POIs on the diagonal of the fixture at 1.5 m (streets and buildings), framed.
pub(crate) fn framed_with(inputs: &mut Inputs, n: usize) -> Framed<'_> {
    let b = inputs.model.bbox();
    let pois = (0..n)
        .map(|i| {
            let t = (i as f64 + 0.5) / n as f64;
            Poi {
                id: format!("d{i}"),
                position: b.min.lerp(b.max, t).with_z(b.min.z + 1.5),
                normal: None,
            }
        })
        .collect();
    frame(&mut inputs.model, pois, &FrameOptions::default()).unwrap()
}

/// `r` is the error of work cancelled in `stage` ([`super::session::Error::Cancelled`]).
#[track_caller]
pub(crate) fn assert_cancelled<T: std::fmt::Debug>(
    r: &Result<T, super::session::Error>,
    stage: Stage,
) {
    use super::session::Error;
    use crate::model::runtime::progress::Cancelled;
    assert!(
        matches!(r, Err(Error::Cancelled(Cancelled { stage: s })) if *s == stage),
        "{r:?}"
    );
}

/// The model and `pois` in the local frame (as a `Study` frames them).
pub(crate) fn frame<'a>(
    model: &'a mut CityModel,
    pois: Vec<Poi>,
    opts: &FrameOptions,
) -> Result<Framed<'a>, Error> {
    frame_in(model, None, pois, opts)
}

/// SVF and sky exposure of every POI, as `Study::svf` traces them.
pub(crate) fn svf(
    framed: &Framed<'_>,
    bundles: &SkyBundles,
    progress: &dyn Progress,
) -> Result<Traced<SkyView>, Cancelled> {
    let exposed = |v: &SkyView| (v.sky_exposure == 0.0).then_some(0);
    trace(
        framed,
        |s, p| poi_sky_view(s, p, bundles),
        exposed,
        progress,
    )
}

/// Hours of direct sun of every POI over `table`, as `Study::sun_hours` traces them.
pub(crate) fn sun_hours(
    framed: &Framed<'_>,
    table: &SunTable,
    progress: &dyn Progress,
) -> Result<Traced<SunHours>, Cancelled> {
    trace(
        framed,
        |s, p| poi_sun_hours(s, p, table),
        |_| None,
        progress,
    )
}
