//! Where a tileset stands on the globe: the model's points in an east-north-up frame at the
//! model's centre (metres, what the features are made in), and each tile's own frame.

use crate::io::citygml::WriteError;
use crate::model::crs::{Crs, CrsError, Ellipsoid, Enu, ToEcef};
use crate::model::{Asset, CityModel, Polygon};
use glam::DVec3;
use std::path::{Path, PathBuf};

/// The model's CRS to its east-north-up frame.
#[derive(Debug)]
pub(super) struct Georef {
    to: ToEcef,
    /// The frame at the model's centre.
    pub frame: Enu,
    /// The source, for errors.
    file: PathBuf,
}

impl Georef {
    /// The frame of a model in `crs` centred at `centre` (a point in `crs`), read from
    /// `file`.
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
