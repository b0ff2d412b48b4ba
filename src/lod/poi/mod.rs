//! Points of interest: `--poi X,Y,Z[,NX,NY,NZ]` arguments and POI CSV files
//! (`id,x,y,z[,nx,ny,nz]`, described by `schemas/pois.schema.json`).

pub(crate) mod checks;
pub(crate) mod region;
pub(crate) mod surfaces;
mod validate;
pub use checks::surroundings::Surroundings;
pub use checks::{
    check_heights, check_lat_lon_order, check_pois_near, poi_flags, OutsideHint, PoiFlag,
    TrustError, DEFAULT_POI_MARGIN,
};
pub use region::{facade_pois, grid_pois, RegionError, RegionSpec};
pub use surfaces::{
    cadastre_surfaces, shard_range, surface_of_poi, surface_pois, surface_pois_of, CadastreSurface,
    SurfaceClass, WALL_MAX_NZ,
};

pub use validate::{check_poi, check_poi_list, check_pois, MIN_NORMAL_LENGTH};

pub use crate::model::poi::{Poi, POI_OFFSET};

use glam::DVec3;
use std::path::{Path, PathBuf};

/// Errors reading or checking POIs.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PoiError {
    /// A `--poi` argument or CSV row that does not parse.
    #[error("{at}: {message}")]
    Syntax {
        /// `--poi` argument text or `file:line`.
        at: String,
        /// What is wrong.
        message: String,
    },
    /// Two POIs share an id (outputs are keyed by it).
    #[error("POI id {id:?} is given twice: at {first} and at {second}")]
    DuplicateId {
        /// The id.
        id: String,
        /// Where it is given first.
        first: String,
        /// Where it is given again.
        second: String,
    },
    /// A POI's position or normal is NaN or infinite.
    #[error("{at}: POI {id:?} has a coordinate that is not finite")]
    NotFinite {
        /// The POI's id.
        id: String,
        /// Where it was given (`file:line`, `--poi …`, or `POI k` in a list).
        at: String,
    },
    /// A POI's normal has zero length (it would count as a horizontal surface).
    #[error("{at}: POI {id:?}: normal has zero length")]
    ZeroNormal {
        /// The POI's id.
        id: String,
        /// Where it was given.
        at: String,
    },
    /// The CSV file cannot be read.
    #[error("{}: {source}", .file.display())]
    Io {
        /// File.
        file: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
}

fn numbers(fields: &[&str], at: &str) -> Result<Vec<f64>, PoiError> {
    fields
        .iter()
        .map(|f| {
            let v: f64 = f.trim().parse().map_err(|_| PoiError::Syntax {
                at: at.to_string(),
                message: format!("{:?} is not a number", f.trim()),
            })?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(PoiError::Syntax {
                    at: at.to_string(),
                    message: format!("{:?} is not finite", f.trim()),
                })
            }
        })
        .collect()
}

fn build(id: String, v: &[f64], at: &str) -> Result<Poi, PoiError> {
    let position = DVec3::new(v[0], v[1], v[2]);
    let normal = if v.len() == 6 {
        let n = DVec3::new(v[3], v[4], v[5]);
        if n.length() < 1e-12 {
            return Err(PoiError::Syntax {
                at: at.to_string(),
                message: "normal has zero length".into(),
            });
        }
        Some(n.normalize())
    } else {
        None
    };
    Ok(Poi {
        id,
        position,
        normal,
    })
}

/// Parse `X,Y,Z` or `X,Y,Z,NX,NY,NZ`.
///
/// ```
/// let p = skylod::lod::poi::parse_poi("430000,4581000,12.5,0,-2,0", 0).unwrap();
/// assert_eq!(p.id, "poi-1");
/// assert_eq!(p.normal, Some(glam::DVec3::new(0.0, -1.0, 0.0)));
/// assert!(skylod::lod::poi::parse_poi("1,2", 0).is_err());
/// ```
pub fn parse_poi(text: &str, index: usize) -> Result<Poi, PoiError> {
    parse_poi_at(text, index, &format!("POI {text}"))
}

/// [`parse_poi`], its errors naming the place the text was given as `at` (e.g. the option
/// of a command line, `--poi 1,2`).
pub fn parse_poi_at(text: &str, index: usize, at: &str) -> Result<Poi, PoiError> {
    let fields: Vec<&str> = text.split(',').collect();
    if fields.len() != 3 && fields.len() != 6 {
        return Err(PoiError::Syntax {
            at: at.to_string(),
            message: format!(
                "expected X,Y,Z or X,Y,Z,NX,NY,NZ, got {} values",
                fields.len()
            ),
        });
    }
    let v = numbers(&fields, at)?;
    build(format!("poi-{}", index + 1), &v, at)
}

/// A POI with the place it was given: `--poi …` or `file:line`, for messages.
#[derive(Debug, Clone, PartialEq)]
pub struct Located {
    /// The point.
    pub poi: Poi,
    /// Where it was given (`--poi 1,2,3` or `pois.csv:7`).
    pub at: String,
}

/// Read a POI CSV file ([`parse_pois_csv`]).
pub fn read_pois_csv(path: &Path) -> Result<Vec<Located>, PoiError> {
    let bytes = std::fs::read(path).map_err(|source| PoiError::Io {
        file: path.to_path_buf(),
        source,
    })?;
    parse_pois_csv(&bytes, &path.display().to_string())
}

/// Parse POI CSV text (`name` is used in messages) with the `csv` crate: a header naming at
/// least `x,y,z` (or `lat,lon,z`: see below; and optionally `id`, `nx,ny,nz`) in any order
/// and any case, then one
/// point per record. A UTF-8 byte-order mark is skipped, fields may be quoted, lines starting
/// with `#` and empty lines are skipped, surrounding spaces are trimmed. Without an `id`
/// column the points are named `poi-1`, `poi-2`, … in file order. Errors name `name:line`.
///
/// Columns `lat` and `lon` (or `latitude`, `longitude`; the height `z` or `height`) give
/// points in degrees for `--poi-crs EPSG:4326` (or another latitude-first geographic CRS):
/// the point's first coordinate is the latitude, as in `--poi LAT,LON,H`.
///
/// ```
/// let text = "longitude,latitude,height\n11.42,48.77,380\n";
/// let p = skylod::lod::poi::parse_pois_csv(text.as_bytes(), "p.csv").unwrap();
/// assert_eq!(p[0].poi.position.to_array(), [48.77, 11.42, 380.0]);
/// ```
///
/// ```
/// let text = "\u{feff}# facade points\nZ,\"Id\",x,y\n12.5,\"w,1\",430000,4581000\n";
/// let p = skylod::lod::poi::parse_pois_csv(text.as_bytes(), "p.csv").unwrap();
/// assert_eq!(p[0].poi.id, "w,1");
/// assert_eq!(p[0].at, "p.csv:3");
/// ```
pub fn parse_pois_csv(bytes: &[u8], name: &str) -> Result<Vec<Located>, PoiError> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    // `#` comment lines become blank lines of the same length: the csv crate's own comment
    // support loses their bytes from its positions, and line numbers must stay right.
    let mut text = bytes.to_vec();
    let mut start = 0;
    while start < text.len() {
        let end = memchr::memchr(b'\n', &text[start..]).map_or(text.len(), |i| start + i);
        let line = &mut text[start..end];
        if line.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'#') {
            line.fill(b' ');
        }
        start = end + 1;
    }
    let bytes = &text[..];
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(bytes);
    let syntax = |line: u64, message: String| PoiError::Syntax {
        at: format!("{name}:{line}"),
        message,
    };
    let line_at = |pos: Option<&csv::Position>| {
        let byte = pos.map_or(0, |p| p.byte() as usize).min(bytes.len());
        1 + memchr::memchr_iter(b'\n', &bytes[..byte]).count() as u64
    };
    let mut cols: Option<(Vec<String>, u64)> = None;
    let mut out = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| syntax(line_at(e.position()), e.to_string()))?;
        let line = line_at(rec.position());
        if rec.iter().all(str::is_empty) {
            continue;
        }
        let Some((cols, hl)) = &cols else {
            cols = Some((rec.iter().map(|c| c.to_ascii_lowercase()).collect(), line));
            continue;
        };
        let find = |n: &str| cols.iter().position(|c| c == n);
        let Some((x, y, z)) = position_columns(cols) else {
            return Err(syntax(*hl, HEADER.into()));
        };
        let at = format!("{name}:{line}");
        if rec.len() != cols.len() {
            return Err(syntax(
                line,
                format!("expected {} columns, got {}", cols.len(), rec.len()),
            ));
        }
        let get = |i: usize| rec.get(i).unwrap_or("");
        let mut vals = vec![get(x), get(y), get(z)];
        if let (Some(a), Some(b), Some(c)) = (find("nx"), find("ny"), find("nz")) {
            let nv = [get(a), get(b), get(c)];
            if nv.iter().any(|s| !s.is_empty()) {
                vals.extend(nv);
            }
        }
        let v = numbers(&vals, &at)?;
        let id = match find("id") {
            Some(i) if !get(i).is_empty() => get(i).to_string(),
            Some(_) => return Err(syntax(line, "empty id".into())),
            None => format!("poi-{}", out.len() + 1),
        };
        out.push(Located {
            poi: build(id, &v, &at)?,
            at,
        });
    }
    if let Some((cols, hl)) = &cols {
        if position_columns(cols).is_none() {
            return Err(syntax(*hl, HEADER.into()));
        }
    }
    Ok(out)
}

/// What a POI CSV header must name.
const HEADER: &str = "header must name the columns x, y and z, or lat, lon and z (latitude, \
                      longitude, height also do; optionally id, nx, ny, nz)";

/// The columns of a point's three coordinates in a lower-cased header: `x,y,z`, or
/// `lat,lon` (`latitude,longitude`) with `z` (or `height`), read in the axis order of
/// `--poi-crs EPSG:4326` (latitude first, as [`parse_poi`] reads `--poi LAT,LON,H`).
fn position_columns(cols: &[String]) -> Option<(usize, usize, usize)> {
    let find = |names: &[&str]| cols.iter().position(|c| names.contains(&c.as_str()));
    let z = find(&["z"]).or_else(|| find(&["height"]))?;
    match (find(&["x"]), find(&["y"])) {
        (Some(x), Some(y)) => Some((x, y, z)),
        _ => Some((find(&["lat", "latitude"])?, find(&["lon", "longitude"])?, z)),
    }
}

/// Refuse two POIs with the same id, naming the id and where each was given.
///
/// ```
/// use skylod::lod::poi::{check_unique_ids, parse_pois_csv};
/// let p = parse_pois_csv(b"id,x,y,z\na,0,0,0\nb,1,0,0\na,2,0,0\n", "p.csv").unwrap();
/// let e = check_unique_ids(&p).unwrap_err().to_string();
/// assert!(e.contains("\"a\"") && e.contains("p.csv:2") && e.contains("p.csv:4"), "{e}");
/// ```
pub fn check_unique_ids(pois: &[Located]) -> Result<(), PoiError> {
    let mut first: std::collections::HashMap<&str, &str> = std::collections::HashMap::new();
    for p in pois {
        if let Some(prev) = first.insert(&p.poi.id, &p.at) {
            return Err(PoiError::DuplicateId {
                id: p.poi.id.clone(),
                first: prev.to_string(),
                second: p.at.clone(),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(t: &str) -> Result<Vec<Located>, PoiError> {
        parse_pois_csv(t.as_bytes(), "t.csv")
    }

    #[test]
    fn csv_with_and_without_normals() {
        let p = parse("id,x,y,z,nx,ny,nz\n# comment\nw1,1,2,3,0,0,1\nw2,4,5,6,,,\n").unwrap();
        assert_eq!(p.len(), 2);
        assert_eq!(p[0].poi.normal, Some(DVec3::Z));
        assert_eq!(p[1].poi.normal, None);
        assert_eq!(p[1].poi.id, "w2");
        assert_eq!(p[1].at, "t.csv:4");
        let e = parse("x,y,z\n1,2\n").unwrap_err();
        assert!(e.to_string().starts_with("t.csv:2"), "{e}");
        assert!(parse("a,b\n1,2\n").is_err());
        assert!(parse_poi("1,2,NaN", 0).is_err());
        assert!(parse_poi("1,2,3,0,0,0", 0).is_err());
    }

    #[test]
    fn bom_quotes_comments_and_column_order() {
        let t = "\u{feff}# made by hand\n\n\"Z\" , id, X ,y\r\n3,\"a \"\"b\"\"\",1,2\r\n# skip\n6,c,4,5\n";
        let p = parse(t).unwrap();
        assert_eq!(p.len(), 2);
        assert_eq!(p[0].poi.id, "a \"b\"");
        assert_eq!(p[0].poi.position, DVec3::new(1.0, 2.0, 3.0));
        assert_eq!(p[1].poi.position, DVec3::new(4.0, 5.0, 6.0));
        assert_eq!(p[1].at, "t.csv:6");
    }

    #[test]
    fn errors_name_the_line() {
        let e = parse("id,x,y,z\na,1,2,3\nb,1,two,3\n")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("t.csv:3:") && e.contains("\"two\""), "{e}");
        let e = parse("id,x,y,z\n,1,2,3\n").unwrap_err().to_string();
        assert!(e.starts_with("t.csv:2:") && e.contains("empty id"), "{e}");
        let e = parse("id,x,y\n").unwrap_err().to_string();
        assert!(e.starts_with("t.csv:1:"), "{e}");
    }

    #[test]
    fn no_id_column_numbers_points() {
        let p = parse("x,y,z\n1,2,3\n4,5,6\n").unwrap();
        assert_eq!(p[1].poi.id, "poi-2");
        assert!(check_unique_ids(&p).is_ok());
    }
}
