//! The one error of the library ([`Error`], [`Result`]): every stage's error converts into it.

use crate::lod::bound::BoundError;
use crate::lod::evaluation::EvalError;
use crate::lod::poi::checks::TrustError;
use crate::lod::poi::PoiError;
use crate::lod::select::SelectError;
use crate::model::crs::CrsError;
use crate::model::runtime::progress::Cancelled;
use crate::pipeline::PoiCrsError;
use crate::solar::SolarError;

/// The one error of the library ([`crate::Error`]), the pipeline's calls' among them: every
/// sub-error converts into it (`?` works on all of them; a stage's cancellation becomes
/// [`Error::Cancelled`]), so a program matches one enum. Messages are in the library's terms (no command-line flags).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An input could not be read (file, line:column, gml:id where known).
    #[error(transparent)]
    Read(#[from] crate::io::citygml::ReadError),
    /// The input arguments name no file (a pattern or directory without CityGML).
    #[error(transparent)]
    Input(#[from] crate::pipeline::batch::inputs::InputError),
    /// A POI could not be read or is invalid.
    #[error(transparent)]
    Poi(#[from] PoiError),
    /// POIs of a region could not be made.
    #[error(transparent)]
    Region(#[from] crate::lod::poi::region::RegionError),
    /// The model or the POIs would give a confidently wrong answer (structured:
    /// [`TrustError::PoiOutside`] names each POI and its distance).
    #[error(transparent)]
    Trust(#[from] TrustError),
    /// The POIs could not be brought from their CRS to the model's.
    #[error(transparent)]
    PoiCrs(#[from] PoiCrsError),
    /// A CRS could not be used.
    #[error(transparent)]
    Crs(#[from] CrsError),
    /// Invalid sky bundles (ray count).
    #[error(transparent)]
    Sky(#[from] crate::solar::sky::SkyError),
    /// Invalid solar options (site, time zone, step, horizon step).
    #[error(transparent)]
    Solar(SolarError),
    /// The selection failed.
    #[error(transparent)]
    Select(SelectError),
    /// The error bound could not be computed.
    #[error(transparent)]
    Bound(#[from] BoundError),
    /// The evaluation could not be made.
    #[error(transparent)]
    Eval(EvalError),
    /// The outputs could not be planned (mirror, merge).
    #[error(transparent)]
    Plan(#[from] crate::pipeline::batch::outputs::PlanError),
    /// An output could not be written (the target is named).
    #[error(transparent)]
    Write(#[from] crate::io::citygml::WriteError),
    /// Per-input outputs could not be merged into one document.
    #[error(transparent)]
    Merge(Box<crate::export::merge::MergeError>),
    /// The model gives no site for the sun (empty, or a CRS not converted).
    #[error(transparent)]
    Site(#[from] crate::model::crs::NoSite),
    /// I/O on something that is not a named file (a caller's writer).
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// The caller asked to stop.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
    /// What needs the model read whole asked of a study read hollow
    /// ([`super::Study::read_hollow`]).
    #[error(
        "{}: read hollow (the polygons near the POIs only): this needs the model read whole",
        crate::model::shown(file)
    )]
    Hollow {
        /// The document read hollow.
        file: std::path::PathBuf,
    },
}

/// `Result` with the library's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl From<SolarError> for Error {
    fn from(e: SolarError) -> Self {
        match e {
            SolarError::Cancelled(c) => Error::Cancelled(c),
            e => Error::Solar(e),
        }
    }
}

impl From<SelectError> for Error {
    fn from(e: SelectError) -> Self {
        match e {
            SelectError::Cancelled(c) => Error::Cancelled(c),
            e => Error::Select(e),
        }
    }
}

impl From<EvalError> for Error {
    fn from(e: EvalError) -> Self {
        match e {
            EvalError::Cancelled(c) => Error::Cancelled(c),
            e => Error::Eval(e),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::runtime::progress::Stage;

    #[test]
    fn cancellations_flatten_and_messages_are_kept() {
        let c = Cancelled {
            stage: Stage::Select,
        };
        for e in [
            Error::from(SelectError::Cancelled(c)),
            Error::from(EvalError::Cancelled(c)),
        ] {
            assert!(
                matches!(
                    e,
                    Error::Cancelled(Cancelled {
                        stage: Stage::Select
                    })
                ),
                "{e:?}"
            );
        }
        let p = PoiCrsError::UnknownModelCrs {
            from: "EPSG:4326".into(),
            model: "none".into(),
        };
        let text = p.to_string();
        let e = Error::from(p);
        assert!(matches!(e, Error::PoiCrs(_)), "{e:?}");
        assert_eq!(e.to_string(), text);
        // Library terms: no command-line flag in the message.
        assert!(!text.contains("--"), "{text}");
        fn q() -> Result<()> {
            Err(TrustError::NoInput { failed: 2 })?;
            Ok(())
        }
        assert!(matches!(
            q(),
            Err(Error::Trust(TrustError::NoInput { failed: 2 }))
        ));
    }
}
