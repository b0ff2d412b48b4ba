//! Reprojection of one CityGML document (`skylod reproject`): the source CRS from `-s` or
//! the document's `srsName`, the points through PROJ ([`crate::model::crs::proj::Reprojector`],
//! feature `proj`), and every coordinate, `srsName`, envelope and implicit-geometry
//! translation rewritten by [`super::rewrite_edits`].
//!
//! The target's `srsName` is written as an OGC URN: `urn:ogc:def:crs:EPSG::n`, or the compound
//! `urn:ogc:def:crs,crs:EPSG::h,crs:EPSG::v` when the target is compound or is a 2-D CRS while
//! the source had a vertical CRS (the heights keep their datum, so the name says so).

#[cfg(feature = "proj")]
pub use with_proj::{reproject_file, ReprojectSummary};

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

#[cfg(feature = "proj")]
mod with_proj {
    use super::ReprojectError;
    use crate::io::citygml::read_file;
    use crate::io::citygml::reproject::{rewrite_edits, RewriteSummary};
    use crate::io::citygml::write::{write_document, WriteOptions};
    use crate::model::crs::proj::Reprojector;
    use crate::model::crs::CrsName;
    use glam::DVec3;
    use std::path::Path;

    /// What [`reproject_file`] did.
    #[derive(Debug, Clone)]
    pub struct ReprojectSummary {
        /// The source CRS used.
        pub source: CrsName,
        /// The target CRS written.
        pub target: CrsName,
        /// The rewrite.
        pub rewrite: RewriteSummary,
    }

    /// Reproject the document `src` into `out`: source CRS `source` or the document's
    /// `srsName`, target `target` (module docs). Without `source`, every `srsName` of the
    /// document must name the same horizontal CRS.
    pub fn reproject_file(
        src: &Path,
        out: &Path,
        source: Option<CrsName>,
        target: CrsName,
        opts: &WriteOptions,
    ) -> Result<ReprojectSummary, ReprojectError> {
        let model = read_file(src)?;
        let declared = model.files.first().and_then(|f| f.srs_name.clone());
        let given = source.is_some();
        let source = match (source, &declared) {
            (Some(s), _) => s,
            (None, Some(name)) => {
                CrsName::parse(name).ok_or_else(|| ReprojectError::UnknownCrs(name.clone()))?
            }
            (None, None) => return Err(ReprojectError::NoSourceCrs(src.to_path_buf())),
        };
        let r = Reprojector::new(source, target)?;
        let t = |p: &mut [DVec3]| r.transform(p);
        let urn = r.target.urn();
        let (edits, mut rewrite) = rewrite_edits(src, &t, &urn)?;
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
        rewrite.warnings.extend(r.warnings.iter().cloned());
        let wopts = WriteOptions {
            keep_envelopes: true,
            ..opts.clone()
        };
        rewrite.bytes = write_document(&model, 0, edits, out, &wopts)?.bytes;
        Ok(ReprojectSummary {
            source,
            target: r.target,
            rewrite,
        })
    }
}
