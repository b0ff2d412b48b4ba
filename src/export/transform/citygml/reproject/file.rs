//! Reprojection of one CityGML document (`skylod reproject`): the source CRS from `-s` or
//! the document's `srsName`, the points through PROJ ([`crate::model::crs::proj::Reprojector`],
//! feature `proj`), and every coordinate, `srsName`, envelope and implicit-geometry
//! translation rewritten by [`super::RewriteSource`] (in passes from 64 MiB on).
//!
//! The target's `srsName` is written as an OGC URN: `urn:ogc:def:crs:EPSG::n`, or the compound
//! `urn:ogc:def:crs,crs:EPSG::h,crs:EPSG::v` when the target is compound or is a 2-D CRS while
//! the source had a vertical CRS (the heights keep their datum, so the name says so).

pub use with_crs::{reproject_with, CrsTransform, ReprojectSummary};
#[cfg(feature = "proj")]
pub use with_proj::reproject_file;

/// Errors of reprojection.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReprojectError {
    /// A CRS name without an EPSG code skylod can read.
    #[error("{0}: not a CRS skylod can read (give EPSG:n, EPSG:h+v, or an OGC URN of EPSG codes)")]
    UnknownCrs(String),
    /// The document has no `srsName` and no source CRS was given.
    #[error("{0}: the document names no CRS (srsName); give the source CRS with -s EPSG:n")]
    NoSourceCrs(std::path::PathBuf),
    /// The document uses several CRSs.
    #[error("{file}: the document uses several CRSs ({names}); give the source CRS with -s EPSG:n to treat them all as one", file = crate::model::shown(.file))]
    MixedCrs {
        /// Document.
        file: std::path::PathBuf,
        /// The `srsName` values found.
        names: String,
    },
    /// PROJ could not create the transformation or describe a CRS.
    #[error("PROJ: {0}")]
    Proj(String),
    /// Reading the document.
    #[error(transparent)]
    Read(#[from] crate::io::citygml::ReadError),
    /// Writing the document.
    #[error(transparent)]
    Write(#[from] crate::io::citygml::WriteError),
}

#[cfg(feature = "proj")]
impl From<crate::model::crs::proj::ProjError> for ReprojectError {
    fn from(e: crate::model::crs::proj::ProjError) -> Self {
        ReprojectError::Proj(e.0)
    }
}

mod with_crs {
    use super::ReprojectError;
    use crate::export::transform::citygml::reproject::{RewriteSource, RewriteSummary};
    use crate::io::citygml::write::WriteOptions;
    use crate::model::crs::CrsName;
    use glam::DVec3;
    use std::path::Path;

    /// A transform between two CRSs, as [`reproject_with`] needs it (PROJ's
    /// `model::crs::proj::Reprojector` with the feature `proj`).
    pub trait CrsTransform {
        /// Transform points in place, in the documents' axis order.
        fn transform(&self, pts: &mut [DVec3]) -> Result<(), String>;
        /// The target CRS as written into `srsName`.
        fn target(&self) -> &CrsName;
        /// What the caller should know about the transform.
        fn warnings(&self) -> &[String];
    }

    /// What [`reproject_with`] did.
    #[derive(Debug, Clone)]
    pub struct ReprojectSummary {
        /// The source CRS used.
        pub source: CrsName,
        /// The target CRS written.
        pub target: CrsName,
        /// The rewrite.
        pub rewrite: RewriteSummary,
    }

    impl ReprojectSummary {
        /// The line `reproject` says for `input` written to `shown_output` (the output's name
        /// as the user gave it):
        /// `IN -> OUT: SOURCE -> TARGET, N points in E elements, V envelopes, S srsName`.
        pub fn line(&self, input: &Path, shown_output: &Path) -> String {
            let w = &self.rewrite;
            format!(
                "{} -> {}: {} -> {}, {} points in {} elements, {} envelopes, {} srsName",
                crate::model::shown(input),
                shown_output.display(),
                self.source,
                self.target,
                w.points,
                w.elements,
                w.envelopes,
                w.srs_names
            )
        }
    }

    /// Reproject the document `src` into `out` through the transform `make` gives for the
    /// source CRS: `source`, or the document's `srsName` (module docs). Without `source`,
    /// every `srsName` of the document must name the same horizontal CRS. Large documents are
    /// rewritten in passes ([`RewriteSource`]).
    pub fn reproject_with<T: CrsTransform>(
        src: &Path,
        out: &Path,
        source: Option<CrsName>,
        opts: &WriteOptions,
        make: impl FnOnce(CrsName) -> Result<T, ReprojectError>,
    ) -> Result<ReprojectSummary, ReprojectError> {
        let doc = RewriteSource::read(src)?;
        let given = source.is_some();
        let source = match (source, doc.srs_name()) {
            (Some(s), _) => s,
            (None, Some(name)) => {
                CrsName::parse(name).ok_or_else(|| ReprojectError::UnknownCrs(name.to_string()))?
            }
            (None, None) => return Err(ReprojectError::NoSourceCrs(src.to_path_buf())),
        };
        let r = make(source)?;
        let t = |p: &mut [DVec3]| r.transform(p);
        let urn = r.target().urn();
        let check = |rewrite: &mut RewriteSummary| {
            let other = rewrite
                .source_srs_names
                .iter()
                .any(|n| CrsName::parse(n).map(|c| c.horizontal) != Some(source.horizontal));
            if other {
                let names = rewrite.source_srs_names.join(", ");
                if !given {
                    return Err(ReprojectError::MixedCrs {
                        file: src.to_path_buf(),
                        names,
                    });
                }
                rewrite.warnings.push(format!(
                    "the document names other CRSs ({names}); all coordinates were read as {source}"
                ));
            }
            rewrite.warnings.extend(r.warnings().iter().cloned());
            Ok(())
        };
        let rewrite = doc.rewrite(out, &t, &urn, opts, check)?;
        Ok(ReprojectSummary {
            source,
            target: *r.target(),
            rewrite,
        })
    }
}

#[cfg(feature = "proj")]
mod with_proj {
    use super::{reproject_with, CrsTransform, ReprojectError, ReprojectSummary};
    use crate::io::citygml::write::WriteOptions;
    use crate::model::crs::proj::Reprojector;
    use crate::model::crs::CrsName;
    use glam::DVec3;
    use std::path::Path;

    impl CrsTransform for Reprojector {
        fn transform(&self, pts: &mut [DVec3]) -> Result<(), String> {
            Reprojector::transform(self, pts)
        }
        fn target(&self) -> &CrsName {
            &self.target
        }
        fn warnings(&self) -> &[String] {
            &self.warnings
        }
    }

    /// Reproject the document `src` into `out` through PROJ: source CRS `source` or the
    /// document's `srsName`, target `target` ([`reproject_with`]).
    pub fn reproject_file(
        src: &Path,
        out: &Path,
        source: Option<CrsName>,
        target: CrsName,
        opts: &WriteOptions,
    ) -> Result<ReprojectSummary, ReprojectError> {
        reproject_with(src, out, source, opts, |s| Ok(Reprojector::new(s, target)?))
    }
}
