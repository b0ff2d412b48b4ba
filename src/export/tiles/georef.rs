//! Where a tileset stands on the globe: the model's points in an east-north-up frame at the
//! model's first object (metres, what the features are made in), and each tile's own frame.
//!
//! An object up to [`AFFINE_EXTENT`] across goes through the affine fit of the conversion at
//! its centre ([`Georef::affine`]: exact there, central differences): what is left out is
//! second order, the Earth's curvature and the projection's change of scale across the
//! object, under a millimetre at 100 m from the centre. Larger objects go point by point.

use crate::io::citygml::WriteError;
use crate::model::crs::{Crs, CrsError, Ellipsoid, Enu, ToEcef};
use crate::model::{Asset, CityModel, Polygon};
use glam::{DMat3, DVec3};
use std::path::{Path, PathBuf};

/// The largest extent (m) of an object converted through an affine fit.
pub(super) const AFFINE_EXTENT: f64 = 200.0;

/// The conversion near a point, as an affine map.
#[derive(Debug, Clone, Copy)]
pub(super) struct Affine {
    at: DVec3,
    to: DVec3,
    m: DMat3,
}

impl Affine {
    /// `p` (in the CRS) in the model's frame.
    pub fn apply(&self, p: DVec3) -> DVec3 {
        self.to + self.m * (p - self.at)
    }

    /// `p` with every point in the model's frame.
    pub fn polygon(&self, p: &Polygon) -> Polygon {
        let mut q = p.clone();
        for v in q.points_mut() {
            *v = self.apply(*v);
        }
        q
    }
}

/// The model's CRS to its east-north-up frame.
#[derive(Debug)]
pub(super) struct Georef {
    to: ToEcef,
    /// The frame at the model's first object.
    pub frame: Enu,
    /// The CRS is geographic (degrees).
    geographic: bool,
    /// The source, for errors.
    file: PathBuf,
}

impl Georef {
    /// The frame of a model in `crs` at `centre` (a point in `crs`), read from `file`.
    ///
    /// # Errors
    /// [`WriteError::NotOnGlobe`] for a CRS that cannot be placed; [`WriteError::Crs`] for a
    /// centre outside the CRS's range.
    pub fn new(crs: &Crs, centre: DVec3, file: &Path) -> Result<Georef, WriteError> {
        let to = ToEcef::new(crs).map_err(|_| WriteError::NotOnGlobe {
            file: file.to_path_buf(),
            crs: crs.name.clone(),
        })?;
        let (lat, lon, h) = to.geodetic(centre).map_err(|source| WriteError::Crs {
            file: file.to_path_buf(),
            line: 0,
            id: "the model's centre".into(),
            source: Box::new(source),
        })?;
        let frame = Enu::new(Ellipsoid::WGS84, lat.to_radians(), lon.to_radians(), h);
        Ok(Georef {
            to,
            frame,
            geographic: matches!(crs.kind, crate::model::crs::CrsKind::Geographic { .. }),
            file: file.to_path_buf(),
        })
    }

    /// `p` (in the CRS) in the model's frame.
    pub fn enu(&self, p: DVec3) -> Result<DVec3, CrsError> {
        Ok(self.frame.from_ecef(self.to.ecef(p)?))
    }

    /// `p` with every point in the model's frame.
    pub fn polygon(&self, p: &Polygon) -> Result<Polygon, CrsError> {
        let mut q = p.clone();
        for v in q.points_mut() {
            *v = self.enu(*v)?;
        }
        Ok(q)
    }

    /// The affine fit of the conversion at `at` (a point in the CRS): the value and the
    /// central differences over 1 m (1e-5 degrees on a geographic CRS) along each axis.
    ///
    /// # Errors
    /// A point the conversion does not cover.
    pub fn affine(&self, at: DVec3) -> Result<Affine, CrsError> {
        let h = if self.geographic { 1e-5 } else { 1.0 };
        let step = [DVec3::X * h, DVec3::Y * h, DVec3::Z];
        let mut cols = [DVec3::ZERO; 3];
        for (k, d) in step.into_iter().enumerate() {
            let len = d.length();
            cols[k] = (self.enu(at + d)? - self.enu(at - d)?) / (2.0 * len);
        }
        Ok(Affine {
            at,
            to: self.enu(at)?,
            m: DMat3::from_cols(cols[0], cols[1], cols[2]),
        })
    }

    /// A conversion error at asset `a` of `model`.
    pub fn error(&self, model: &CityModel, a: &Asset, source: CrsError) -> WriteError {
        let file = model
            .files
            .get(a.file)
            .map_or_else(|| self.file.clone(), |f| f.path.clone());
        WriteError::Crs {
            file,
            line: a.line,
            id: a.id.as_deref().unwrap_or(&a.element).to_string(),
            source: Box::new(source),
        }
    }

    /// The east-north-up frame at `p`, a point of the model's frame: a tile's frame.
    pub fn frame_at(&self, p: DVec3) -> Enu {
        let (lat, lon, h) =
            crate::model::crs::ecef_to_geodetic(Ellipsoid::WGS84, self.frame.to_ecef(p));
        Enu::new(Ellipsoid::WGS84, lat, lon, h)
    }
}
