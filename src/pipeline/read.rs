//! Step 1: the inputs read and merged, and the checks of the model alone.

use crate::io::citygml::read::read_source;
use crate::io::citygml::source::resolve;
use crate::io::citygml::{ReadError, ReadOptions};
use crate::lod::poi::checks::{self, TrustError};
use crate::model::runtime::progress::{check, Cancelled, Progress, Stage};
use crate::model::{Bbox, CityModel, Source};
use rayon::prelude::*;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// The inputs that could be read, merged in input order.
#[derive(Debug, Default)]
#[non_exhaustive]
pub struct Inputs {
    /// All inputs read, merged ([`CityModel::merge`]): `model.files[k]` is `read[k]`.
    pub model: CityModel,
    /// Paths read successfully, in input order.
    pub read: Vec<PathBuf>,
    /// Inputs that could not be read (file, line:column, reason), in input order.
    pub failures: Vec<ReadError>,
    /// Seconds spent reading.
    pub read_s: f64,
}

impl Inputs {
    /// Refuse a model that would give a confidently wrong answer whatever the POIs: no
    /// input read at all ([`TrustError::NoInput`]), inputs whose CRSs differ (unless
    /// `allow_mixed_crs`), a model without heights.
    ///
    /// # Errors
    /// [`TrustError`].
    pub fn check(&self, allow_mixed_crs: bool) -> Result<(), TrustError> {
        if self.read.is_empty() {
            return Err(TrustError::NoInput {
                failed: self.failures.len(),
            });
        }
        check_model(&self.model, allow_mixed_crs)
    }
}

/// The checks of [`Inputs::check`] on a model.
///
/// # Errors
/// [`TrustError`].
pub fn check_model(model: &CityModel, allow_mixed_crs: bool) -> Result<(), TrustError> {
    check_model_in(model, &model.bbox(), allow_mixed_crs)
}

/// [`check_model`] of a model whose box ([`CityModel::bbox`]) is `bbox`.
///
/// # Errors
/// [`TrustError`].
pub(crate) fn check_model_in(
    model: &CityModel,
    bbox: &Bbox,
    allow_mixed_crs: bool,
) -> Result<(), TrustError> {
    if !allow_mixed_crs {
        checks::check_same_crs(model)?;
    }
    checks::check_heights_in(model, bbox)
}

/// Read `paths` in parallel ([`Stage::Read`]: files and bytes) and merge them in input
/// order. A file that cannot be read goes to [`Inputs::failures`]. `-` is standard input
/// (read whole into memory, [`crate::io::files::stdin_bytes`]).
///
/// # Errors
/// [`Cancelled`] when `progress` asks to stop (before a file is started).
pub fn read_inputs(paths: &[PathBuf], progress: &dyn Progress) -> Result<Inputs, Cancelled> {
    let sources = paths.iter().map(|p| resolve(p)).collect();
    read_all(paths, sources, progress)
}

/// [`read_inputs`] of documents wherever they are ([`Source`]: files, bytes in memory), each
/// named by its path (`model.files[k].path`, errors, warnings; [`Inputs::read`]).
///
/// # Errors
/// As [`read_inputs`].
pub fn read_sources(
    sources: Vec<(PathBuf, Source)>,
    progress: &dyn Progress,
) -> Result<Inputs, Cancelled> {
    let (names, sources): (Vec<PathBuf>, Vec<Source>) = sources.into_iter().unzip();
    read_all(&names, sources.into_iter().map(Ok).collect(), progress)
}

fn read_all(
    paths: &[PathBuf],
    sources: Vec<Result<Source, ReadError>>,
    progress: &dyn Progress,
) -> Result<Inputs, Cancelled> {
    let t = Instant::now();
    let sizes: Vec<u64> = sources
        .iter()
        .map(|s| match s {
            Ok(Source::File(p)) => std::fs::metadata(p).map_or(0, |m| m.len()),
            Ok(Source::Memory(b)) => b.len() as u64,
            Err(_) => 0,
        })
        .collect();
    progress.start(Stage::Read, paths.len() as u64, sizes.iter().sum());
    let results: Result<Vec<_>, Cancelled> = paths
        .par_iter()
        .zip(sources)
        .zip(&sizes)
        .map(|((p, src), size)| {
            check(progress, Stage::Read)?;
            // bytes move while a large file is read; the rest when it is done
            let seen = AtomicU64::new(0);
            let r = src.and_then(|src| {
                read_source(src, p, &ReadOptions::default(), &|n| {
                    seen.fetch_add(n, Ordering::Relaxed);
                    progress.advance(Stage::Read, 0, n, None);
                })
            });
            let rest = size.saturating_sub(seen.load(Ordering::Relaxed));
            let name = crate::model::shown(p).to_string();
            progress.advance(Stage::Read, 1, rest, Some(&name));
            Ok(r)
        })
        .collect();
    progress.finish(Stage::Read);
    let mut inputs = Inputs::default();
    for (p, r) in paths.iter().zip(results?) {
        match r {
            Ok(m) => {
                inputs.model.merge(m);
                inputs.read.push(p.clone());
            }
            Err(e) => inputs.failures.push(e),
        }
    }
    // the reader's registry, id log and arena are freed: a large model's pages go back
    // before the next stage's large blocks are mapped
    crate::model::runtime::mem::give_back_for(inputs.model.assets.len());
    inputs.read_s = t.elapsed().as_secs_f64();
    Ok(inputs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::test_support::*;

    #[test]
    fn unreadable_input_is_a_failure_not_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let bad = dir.path().join("bad.gml");
        std::fs::write(&bad, "<CityModel").unwrap();
        let inputs = read_inputs(
            &[fixture(), bad.clone()],
            &crate::model::runtime::progress::Silent,
        )
        .unwrap();
        assert_eq!(inputs.read, vec![fixture()]);
        assert_eq!(inputs.failures.len(), 1);
        assert!(inputs.failures[0].to_string().contains("bad.gml"));
        assert!(inputs.check(false).is_ok());
        // Nothing read: refused here, not later as a POI far outside an empty scene.
        let none = read_inputs(&[bad], &crate::model::runtime::progress::Silent).unwrap();
        assert!(matches!(
            none.check(false),
            Err(TrustError::NoInput { failed: 1 })
        ));
        assert!(matches!(
            Inputs::default().check(true),
            Err(TrustError::NoInput { failed: 0 })
        ));
    }
}
