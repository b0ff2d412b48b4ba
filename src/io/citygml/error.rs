//! Errors of the CityGML reader and writer.

use std::fmt;
use std::path::{Path, PathBuf};

/// Where in a source document something happened.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Location {
    /// Source file.
    pub file: PathBuf,
    /// 1-based line (0 when unknown).
    pub line: u64,
    /// 1-based column (0 when unknown).
    pub column: u64,
    /// `gml:id` of the nearest enclosing element that has one.
    pub gml_id: Option<String>,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", crate::model::shown(&self.file))?;
        if self.line > 0 {
            write!(f, ":{}:{}", self.line, self.column)?;
        }
        if let Some(id) = &self.gml_id {
            write!(f, " [gml:id {id}]")?;
        }
        Ok(())
    }
}

/// Everything that can go wrong while reading a CityGML document.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReadError {
    /// The file could not be opened or read.
    #[error("{file}: cannot read: {source}", file = crate::model::shown(.file))]
    Io {
        /// File.
        file: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// The document is empty.
    #[error("{}: empty document", crate::model::shown(.0))]
    Empty(PathBuf),
    /// Not well-formed XML (includes truncated documents and broken gzip streams).
    #[error("{loc}: malformed XML: {message}")]
    Xml {
        /// Position.
        loc: Location,
        /// Parser message.
        message: String,
    },
    /// Well-formed XML that is not CityGML (no CityGML namespace on the root).
    #[error("{loc}: not a CityGML document: {message}")]
    NotCityGml {
        /// Position.
        loc: Location,
        /// Why.
        message: String,
    },
    /// A coordinate that is not a finite number, or is larger in magnitude than
    /// `MAX_COORDINATE`.
    #[error("{loc}: bad coordinate {token:?}: not a finite number of magnitude at most 1e12")]
    Coordinate {
        /// Position.
        loc: Location,
        /// The offending token (truncated).
        token: String,
    },
    /// A coordinate list whose length does not fit the dimension.
    #[error("{loc}: {count} coordinate values are not a multiple of srsDimension {dimension}")]
    CoordinateCount {
        /// Position.
        loc: Location,
        /// Number of values.
        count: usize,
        /// Dimension.
        dimension: u8,
    },
    /// An `srsDimension` other than 2 or 3.
    #[error("{loc}: unsupported srsDimension {value:?} (2 or 3 expected)")]
    Dimension {
        /// Position.
        loc: Location,
        /// Value found.
        value: String,
    },
    /// An `xlink:href` to geometry that is not in the document.
    #[error("{loc}: dangling xlink:href {href:?}")]
    DanglingHref {
        /// Position of the reference.
        loc: Location,
        /// The reference.
        href: String,
    },
    /// Geometry references that refer to themselves.
    #[error("{loc}: xlink:href cycle through {href:?}")]
    HrefCycle {
        /// Position of the reference.
        loc: Location,
        /// The reference.
        href: String,
    },
    /// A CityJSON document that cannot be read ([`crate::io::cityjson`]).
    #[error("{0}")]
    CityJson(#[from] crate::io::cityjson::CityJsonError),
    /// A resource limit protecting against hostile input was exceeded.
    #[error("{loc}: {message}")]
    Limit {
        /// Position.
        loc: Location,
        /// What was exceeded.
        message: String,
    },
}

impl ReadError {
    /// The file the error is about.
    pub fn file(&self) -> &std::path::Path {
        match self {
            ReadError::Io { file, .. } | ReadError::Empty(file) => file,
            ReadError::CityJson(e) => &e.file,
            ReadError::Xml { loc, .. }
            | ReadError::NotCityGml { loc, .. }
            | ReadError::Coordinate { loc, .. }
            | ReadError::CoordinateCount { loc, .. }
            | ReadError::Dimension { loc, .. }
            | ReadError::DanglingHref { loc, .. }
            | ReadError::HrefCycle { loc, .. }
            | ReadError::Limit { loc, .. } => &loc.file,
        }
    }

    /// Short machine-readable name of the error kind.
    pub fn kind(&self) -> &'static str {
        match self {
            ReadError::Io { .. } => "io",
            ReadError::Empty(_) => "empty",
            ReadError::Xml { .. } => "xml",
            ReadError::NotCityGml { .. } => "not_citygml",
            ReadError::Coordinate { .. } => "coordinate",
            ReadError::CoordinateCount { .. } => "coordinate_count",
            ReadError::Dimension { .. } => "dimension",
            ReadError::DanglingHref { .. } => "dangling_href",
            ReadError::HrefCycle { .. } => "href_cycle",
            ReadError::Limit { .. } => "limit",
            ReadError::CityJson(_) => "cityjson",
        }
    }
}

/// Everything that can go wrong while writing.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WriteError {
    /// I/O on the output or on re-reading the source.
    #[error("{file}: {}", crate::io::files::describe_io(.source), file = crate::model::shown(.file))]
    Io {
        /// File concerned.
        file: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// The output exists and overwriting was not allowed.
    #[error("{}: output exists (overwriting not allowed)", .0.display())]
    Exists(PathBuf),
    /// The output would replace an input.
    #[error("{}: output path is one of the inputs; refusing to overwrite an input", .0.display())]
    IsInput(PathBuf),
    /// The source changed between reading and writing.
    #[error("{}: source changed while writing (length differs)", crate::model::shown(.0))]
    SourceChanged(PathBuf),
    /// Re-reading the source failed.
    #[error(transparent)]
    Read(#[from] ReadError),
    /// The arguments do not fit the model (e.g. one level per asset expected).
    #[error("invalid writer input: {0}")]
    Invalid(String),
    /// A document written from a streamed read ([`crate::export::Chunks::Stream`]) does not
    /// read in chunks alone (see [`crate::io::citygml::read::stream`]): nothing was written;
    /// read it whole and write the model instead.
    #[error("{}: the stream declined (read it whole)", crate::model::shown(.0))]
    Declined(PathBuf),
    /// The output places the model on the globe (3D Tiles), and its CRS cannot be placed:
    /// none is named (`crs` empty) or this build does not convert it.
    #[error("{}: {}", crate::model::shown(.file), no_globe(.crs))]
    NotOnGlobe {
        /// The source.
        file: PathBuf,
        /// The CRS named, empty when none.
        crs: String,
    },
    /// A point of the source could not be converted to the output's CRS.
    #[error("{}:{line}: {id}: {source}", crate::model::shown(.file))]
    Crs {
        /// The source.
        file: PathBuf,
        /// Line of the object's start tag (0 when unknown).
        line: u64,
        /// The object's gml:id or name.
        id: String,
        /// Why.
        source: Box<crate::model::crs::CrsError>,
    },
}

/// Why a model cannot be placed on the globe.
fn no_globe(crs: &str) -> String {
    if crs.is_empty() {
        "the model names no CRS; placing it on the globe needs one".into()
    } else {
        format!("cannot place {crs} on the globe in this build (UTM, geographic on GRS 1980/WGS 84 and the projected CRSs in metres of proj4rs only; others need the `proj` feature)")
    }
}

impl From<crate::io::files::FileError> for WriteError {
    fn from(e: crate::io::files::FileError) -> Self {
        WriteError::Io {
            file: e.file,
            source: e.source,
        }
    }
}

impl From<crate::io::files::TargetError> for WriteError {
    fn from(e: crate::io::files::TargetError) -> Self {
        match e {
            crate::io::files::TargetError::Exists(p) => WriteError::Exists(p),
            crate::io::files::TargetError::IsInput(p) => WriteError::IsInput(p),
        }
    }
}

impl ReadError {
    /// An XML error of `path` at byte offset `at` (no line known: the stream was read
    /// without a line counter).
    pub fn xml_at_byte(path: &Path, at: u64, message: impl std::fmt::Display) -> ReadError {
        ReadError::Xml {
            loc: Location {
                file: path.to_path_buf(),
                ..Default::default()
            },
            message: format!("at byte {at}: {message}"),
        }
    }
}

impl WriteError {
    /// [`ReadError::xml_at_byte`] met by a writer reading its source.
    pub(crate) fn xml_at_byte(path: &Path, at: u64, message: String) -> Self {
        WriteError::Read(ReadError::xml_at_byte(path, at, message))
    }
}
