//! Reprojection of CityGML documents (`skylod reproject`): CRS names, and with the cargo
//! feature `proj` the transform through the PROJ library (bundled build).
//!
//! * [`CrsName`] reads the `srsName` forms city models use (`EPSG:n`, `EPSG:a+b`,
//!   `urn:ogc:def:crs:EPSG::n`, `urn:ogc:def:crs:EPSG:6.12:n`, the compound
//!   `urn:ogc:def:crs,crs:EPSG::a,crs:EPSG::b`, `http://www.opengis.net/def/crs/EPSG/0/n`, the
//!   AdV `urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH`) into a horizontal EPSG code and an optional
//!   vertical one; pure Rust, in every build.
//! * `Reprojector` (feature `proj`) transforms points between the horizontal CRSs with PROJ,
//!   in the axis order of the files: geographic CRSs whose EPSG axis order is latitude first
//!   (4326, 4258, 6668, 6697, ...) are read and written latitude first, as CityGML files
//!   (PLATEAU's among them) write them; projected CRSs easting first, as city models write them
//!   whatever the EPSG order. Heights are passed through unchanged: the horizontal CRS is
//!   transformed, and a change of vertical datum would need geoid grids, which the bundled
//!   build has none of (PROJ itself falls back to the same "ballpark" identity then).
//! * `reproject_file` (feature `proj`) rewrites one document with
//!   [`crate::citygml::reproject`]: every coordinate, `srsName`, envelope and implicit-geometry
//!   translation.
//!
//! The target's `srsName` is written as an OGC URN: `urn:ogc:def:crs:EPSG::n`, or the compound
//! `urn:ogc:def:crs,crs:EPSG::h,crs:EPSG::v` when the target is compound or is a 2-D CRS while
//! the source had a vertical CRS (the heights keep their datum, so the name says so).
//!
//! # Example
//! ```
//! use skylod::crs::reproject::CrsName;
//! let c = CrsName::parse("urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783").unwrap();
//! assert_eq!((c.horizontal, c.vertical), (25832, Some(5783)));
//! assert_eq!(CrsName::parse("urn:adv:crs:ETRS89_UTM32*DE_DHHN2016_NH").unwrap().vertical, Some(7837));
//! assert_eq!(CrsName::parse("EPSG:4326").unwrap().urn(), "urn:ogc:def:crs:EPSG::4326");
//! assert!(CrsName::parse("#local-CRS-1").is_none());
//! ```

/// A CRS by EPSG codes: horizontal (or 3-D) and optional vertical.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CrsName {
    /// Horizontal (projected or geographic, possibly 3-D) CRS.
    pub horizontal: u32,
    /// Vertical CRS of a compound CRS.
    pub vertical: Option<u32>,
}

impl CrsName {
    /// Parse a `srsName` or a command-line CRS (module docs). `None` when no EPSG code is
    /// found.
    pub fn parse(text: &str) -> Option<CrsName> {
        let upper = text.trim().to_ascii_uppercase();
        if let Some(i) = upper.find("ETRS89_UTM") {
            let zone: u32 = upper[i + "ETRS89_UTM".len()..]
                .chars()
                .take_while(char::is_ascii_digit)
                .collect::<String>()
                .parse()
                .ok()
                .filter(|z| (28..=38).contains(z))?;
            let vertical = if upper.contains("DHHN2016") {
                Some(7837)
            } else if upper.contains("DHHN92") {
                Some(5783)
            } else {
                None
            };
            return Some(CrsName {
                horizontal: 25800 + zone,
                vertical,
            });
        }
        let mut codes = Vec::new();
        for rest in upper.split("EPSG").skip(1) {
            // The run of digits and separators after the authority; its last number is the
            // code (`::25832`, `/0/25832`, `:6.12:31466`); `EPSG:a+b` gives two.
            let run: &str = rest
                .split(|c: char| !(c.is_ascii_digit() || matches!(c, ':' | '/' | '.' | '+')))
                .next()
                .unwrap_or("");
            for part in run.split('+') {
                if let Some(code) = part
                    .rsplit(|c: char| !c.is_ascii_digit())
                    .find(|d| !d.is_empty())
                    .and_then(|d| d.parse::<u32>().ok())
                {
                    codes.push(code);
                }
            }
        }
        let horizontal = *codes.first()?;
        Some(CrsName {
            horizontal,
            vertical: codes.get(1).copied(),
        })
    }

    /// The EPSG codes of a parsed [`Crs`](crate::crs::Crs) (`None` for one without a code,
    /// such as OGC:CRS84): the two parsers of `srsName` agree on the codes.
    pub fn from_crs(crs: &crate::crs::Crs) -> Option<CrsName> {
        Some(CrsName {
            horizontal: crs.epsg?,
            vertical: crs.vertical_epsg,
        })
    }

    /// The OGC URN of this CRS (compound when it has a vertical part).
    pub fn urn(&self) -> String {
        match self.vertical {
            Some(v) => format!(
                "urn:ogc:def:crs,crs:EPSG::{},crs:EPSG::{v}",
                self.horizontal
            ),
            None => format!("urn:ogc:def:crs:EPSG::{}", self.horizontal),
        }
    }
}

impl std::fmt::Display for CrsName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.vertical {
            Some(v) => write!(f, "EPSG:{}+{v}", self.horizontal),
            None => write!(f, "EPSG:{}", self.horizontal),
        }
    }
}

/// Errors of reprojection.
#[derive(Debug, thiserror::Error)]
pub enum ReprojectError {
    /// A CRS name without an EPSG code skylod can read.
    #[error("{0}: not a CRS skylod can read (give EPSG:n, EPSG:h+v, or an OGC URN of EPSG codes)")]
    UnknownCrs(String),
    /// The document has no `srsName` and no source CRS was given.
    #[error("{0}: the document names no CRS (srsName); give the source CRS with -s EPSG:n")]
    NoSourceCrs(std::path::PathBuf),
    /// The document uses several CRSs.
    #[error("{file}: the document uses several CRSs ({names}); give the source CRS with -s EPSG:n to treat them all as one", file = .file.display())]
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
    Read(#[from] crate::citygml::ReadError),
    /// Writing the document.
    #[error(transparent)]
    Write(#[from] crate::citygml::WriteError),
}

#[cfg(feature = "proj")]
mod with_proj {
    use super::{CrsName, ReprojectError};
    use crate::citygml::read_file;
    use crate::citygml::reproject::{rewrite_edits, RewriteSummary};
    use crate::citygml::write::{write_document, WriteOptions};
    use glam::DVec3;
    use std::path::Path;

    /// How PROJ describes a CRS: geographic or not, axis order, dimension.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub struct CrsInfo {
        /// A geographic (latitude/longitude) CRS.
        pub geographic: bool,
        /// Its EPSG axis order starts with latitude (north).
        pub lat_first: bool,
        /// Number of axes of the horizontal part (2, or 3 for a 3-D CRS such as EPSG:4979).
        pub axes: usize,
        /// EPSG code of the vertical part of a compound CRS (EPSG:6697 = 6668 + 6695).
        pub vertical: Option<u32>,
    }

    /// The EPSG code in the `id` of a PROJJSON object.
    fn epsg_id(v: &serde_json::Value) -> Option<u32> {
        let id = &v["id"];
        (id["authority"] == "EPSG")
            .then(|| id["code"].as_u64())
            .flatten()
            .and_then(|c| u32::try_from(c).ok())
    }

    /// Describe `EPSG:code` through PROJ's PROJJSON.
    pub fn crs_info(code: u32) -> Result<CrsInfo, ReprojectError> {
        let def = format!("EPSG:{code}");
        let p = proj::Proj::new(&def).map_err(|e| ReprojectError::Proj(format!("{def}: {e}")))?;
        let json = p
            .to_projjson(Some(false), None, None)
            .map_err(|e| ReprojectError::Proj(format!("{def}: {e}")))?;
        let v: serde_json::Value = serde_json::from_str(&json)
            .map_err(|e| ReprojectError::Proj(format!("{def}: PROJJSON: {e}")))?;
        // A compound CRS: its first component is the horizontal one.
        let h = if v["type"] == "CompoundCRS" {
            &v["components"][0]
        } else {
            &v
        };
        let ty = h["type"].as_str().unwrap_or("");
        let axes = h["coordinate_system"]["axis"]
            .as_array()
            .map_or(0, Vec::len);
        if axes == 0 {
            return Err(ReprojectError::Proj(format!(
                "{def}: a {ty} without coordinate axes"
            )));
        }
        let geographic = ty == "GeographicCRS"
            || (ty == "GeodeticCRS" && h["coordinate_system"]["subtype"] == "ellipsoidal");
        let lat_first = h["coordinate_system"]["axis"][0]["direction"] == "north";
        // The vertical part of a compound CRS: PROJJSON names it, and gives its id only when
        // it differs from the compound's; PROJ finds a CRS by its name in its database.
        let vertical = if v["type"] == "CompoundCRS" {
            let part = &v["components"][1];
            match epsg_id(part) {
                Some(c) => Some(c),
                None => part["name"].as_str().and_then(|name| {
                    let p = proj::Proj::new(name).ok()?;
                    let json = p.to_projjson(Some(false), None, None).ok()?;
                    epsg_id(&serde_json::from_str(&json).ok()?)
                }),
            }
        } else {
            None
        };
        Ok(CrsInfo {
            geographic,
            lat_first,
            axes,
            vertical,
        })
    }

    /// A PROJ transformation between two CRSs in the axis order of CityGML files (module
    /// docs), heights passed through.
    pub struct Reprojector {
        proj: proj::Proj,
        swap_in: bool,
        swap_out: bool,
        /// The source CRS.
        pub source: CrsName,
        /// The target CRS as written into `srsName` (with the source's vertical CRS kept
        /// when the target is 2-D).
        pub target: CrsName,
        /// What the caller should know (heights passed into an ellipsoidal 3-D CRS).
        pub warnings: Vec<String>,
    }

    impl std::fmt::Debug for Reprojector {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.debug_struct("Reprojector")
                .field("source", &self.source)
                .field("target", &self.target)
                .field("swap_in", &self.swap_in)
                .field("swap_out", &self.swap_out)
                .finish()
        }
    }

    impl Reprojector {
        /// The transformation from `source` to `target` (horizontal parts).
        pub fn new(source: CrsName, target: CrsName) -> Result<Reprojector, ReprojectError> {
            let si = crs_info(source.horizontal)?;
            let ti = crs_info(target.horizontal)?;
            let (from, to) = (
                format!("EPSG:{}", source.horizontal),
                format!("EPSG:{}", target.horizontal),
            );
            let proj = proj::Proj::new_known_crs(&from, &to, None)
                .map_err(|e| ReprojectError::Proj(format!("{from} to {to}: {e}")))?;
            let mut warnings = Vec::new();
            let mut target = target;
            let source_vertical = source.vertical.or(si.vertical);
            if target.vertical.is_none() && ti.vertical.is_none() && ti.axes == 2 {
                target.vertical = source_vertical;
            }
            let target_vertical = target.vertical.or(ti.vertical);
            if let (Some(sv), Some(tv)) = (source_vertical, target_vertical) {
                if sv != tv {
                    warnings.push(format!(
                        "heights are kept as they are: values in EPSG:{sv} are written as \
                         EPSG:{tv} (no geoid grids in this build)"
                    ));
                }
            }
            if ti.axes == 3 && ti.geographic && target.vertical.is_none() {
                warnings.push(format!(
                    "heights are kept as they are: EPSG:{} has ellipsoidal heights, and {} \
                     (no geoid grid in this build; PROJ's own fallback does the same)",
                    target.horizontal,
                    match source_vertical {
                        Some(v) => format!("the source's heights are in EPSG:{v}"),
                        None => "the source names no vertical CRS".to_string(),
                    }
                ));
            }
            Ok(Reprojector {
                proj,
                swap_in: si.geographic && si.lat_first,
                swap_out: ti.geographic && ti.lat_first,
                source,
                target,
                warnings,
            })
        }

        /// Transform points in place (file axis order in and out; z unchanged).
        pub fn transform(&self, pts: &mut [DVec3]) -> Result<(), String> {
            let mut xy: Vec<(f64, f64)> = pts
                .iter()
                .map(|p| if self.swap_in { (p.y, p.x) } else { (p.x, p.y) })
                .collect();
            self.proj
                .convert_array(&mut xy)
                .map_err(|e| format!("{} to {}: {e}", self.source, self.target))?;
            for (p, (x, y)) in pts.iter_mut().zip(xy) {
                if !(x.is_finite() && y.is_finite()) {
                    return Err(format!(
                        "({}, {}) has no image in {}",
                        p.x, p.y, self.target
                    ));
                }
                (p.x, p.y) = if self.swap_out { (y, x) } else { (x, y) };
            }
            Ok(())
        }
    }

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

    #[cfg(test)]
    mod tests {
        use super::*;

        #[test]
        fn axis_order_and_dimension_from_proj() {
            let g = crs_info(4326).unwrap();
            assert!(g.geographic && g.lat_first && g.axes == 2);
            assert_eq!(crs_info(4979).unwrap().axes, 3);
            let u = crs_info(25832).unwrap();
            assert!(!u.geographic && !u.lat_first);
            let j = crs_info(6697).unwrap();
            assert!(j.geographic && j.lat_first && j.axes == 2);
            assert_eq!(j.vertical, Some(6695));
        }

        #[test]
        fn utm_to_lat_lon_and_back() {
            let to = Reprojector::new(
                CrsName::parse("EPSG:25832+5783").unwrap(),
                CrsName::parse("EPSG:4326").unwrap(),
            )
            .unwrap();
            assert_eq!(to.target.vertical, Some(5783));
            // UTM 32N central meridian 9°E, false easting 500 km: on it, lon = 9.
            let mut p = [DVec3::new(500000.0, 5_400_000.0, 123.5)];
            to.transform(&mut p).unwrap();
            assert!((p[0].y - 9.0).abs() < 1e-9, "{p:?}"); // lat first: y is the longitude
            assert!(p[0].x > 48.0 && p[0].x < 49.0);
            assert_eq!(p[0].z, 123.5);
            let back = Reprojector::new(to.target, to.source).unwrap();
            back.transform(&mut p).unwrap();
            assert!((p[0].x - 500000.0).abs() < 1e-6 && (p[0].y - 5_400_000.0).abs() < 1e-6);
        }

        #[test]
        fn ellipsoidal_target_warns() {
            let r = Reprojector::new(
                CrsName::parse("EPSG:25832+5783").unwrap(),
                CrsName::parse("EPSG:4979").unwrap(),
            )
            .unwrap();
            assert_eq!(r.target.vertical, None);
            assert_eq!(r.warnings.len(), 1);
            // A compound target with another vertical datum: heights kept, and said so.
            let j = Reprojector::new(
                CrsName::parse("EPSG:25832+5783").unwrap(),
                CrsName::parse("EPSG:25832+7837").unwrap(),
            )
            .unwrap();
            assert!(j.warnings[0].contains("EPSG:5783"), "{:?}", j.warnings);
        }
    }
}

#[cfg(feature = "proj")]
pub use with_proj::{crs_info, reproject_file, CrsInfo, ReprojectSummary, Reprojector};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srs_name_forms() {
        for (name, h, v) in [
            ("EPSG:25832", 25832, None),
            ("epsg:25832+5783", 25832, Some(5783)),
            ("urn:ogc:def:crs:EPSG::6697", 6697, None),
            ("urn:ogc:def:crs:EPSG:6.12:31466", 31466, None),
            (
                "urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783",
                25832,
                Some(5783),
            ),
            (
                "urn:ogc:def:crs,crs:EPSG:6.12:31466,crs:EPSG:6.12:5783",
                31466,
                Some(5783),
            ),
            (
                "urn:ogc:def:crs:EPSG:25832, crs:EPSG:5783",
                25832,
                Some(5783),
            ),
            ("http://www.opengis.net/def/crs/EPSG/0/2263", 2263, None),
            ("urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH", 25832, Some(5783)),
            ("urn:adv:crs:ETRS89_UTM33", 25833, None),
        ] {
            let c = CrsName::parse(name).unwrap_or_else(|| panic!("{name}"));
            assert_eq!((c.horizontal, c.vertical), (h, v), "{name}");
        }
        for bad in ["", "#local-CRS-1", "urn:ogc:def:crs:OGC::CRS84", "EPSG:"] {
            assert_eq!(CrsName::parse(bad), None, "{bad}");
        }
        assert_eq!(
            CrsName::parse("EPSG:25832+5783").unwrap().urn(),
            "urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783"
        );
        assert_eq!(
            CrsName::parse("EPSG:25832+5783").unwrap().to_string(),
            "EPSG:25832+5783"
        );
    }
}
