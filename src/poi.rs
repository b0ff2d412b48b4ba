//! Points of interest: `--poi X,Y,Z[,NX,NY,NZ]` arguments and POI CSV files
//! (`id,x,y,z[,nx,ny,nz]`, described by `schemas/pois.schema.json`).

use glam::DVec3;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// A point of interest in the model's CRS, with an optional outward surface normal.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Poi {
    /// Identifier (CSV `id`, or `poi-N` for command-line points).
    pub id: String,
    /// Position in model coordinates.
    pub position: DVec3,
    /// Unit outward normal of the surface the point lies on; `None` for a free point
    /// (then the whole upper hemisphere counts and SVF is the horizontal one).
    pub normal: Option<DVec3>,
}

/// Errors reading POIs.
#[derive(Debug, thiserror::Error)]
pub enum PoiError {
    /// A `--poi` argument or CSV row that does not parse.
    #[error("{at}: {message}")]
    Syntax {
        /// `--poi` argument text or `file:line`.
        at: String,
        /// What is wrong.
        message: String,
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
/// let p = skylod::poi::parse_poi("430000,4581000,12.5,0,-2,0", 0).unwrap();
/// assert_eq!(p.id, "poi-1");
/// assert_eq!(p.normal, Some(glam::DVec3::new(0.0, -1.0, 0.0)));
/// assert!(skylod::poi::parse_poi("1,2", 0).is_err());
/// ```
pub fn parse_poi(text: &str, index: usize) -> Result<Poi, PoiError> {
    let fields: Vec<&str> = text.split(',').collect();
    if fields.len() != 3 && fields.len() != 6 {
        return Err(PoiError::Syntax {
            at: format!("--poi {text}"),
            message: format!(
                "expected X,Y,Z or X,Y,Z,NX,NY,NZ, got {} values",
                fields.len()
            ),
        });
    }
    let at = format!("--poi {text}");
    let v = numbers(&fields, &at)?;
    build(format!("poi-{}", index + 1), &v, &at)
}

/// Read a POI CSV file: a header naming at least `x,y,z` (and optionally `id`, `nx,ny,nz`,
/// in any order), then one point per line. Empty lines and lines starting with `#` are skipped.
pub fn read_pois_csv(path: &Path) -> Result<Vec<Poi>, PoiError> {
    let text = std::fs::read_to_string(path).map_err(|source| PoiError::Io {
        file: path.to_path_buf(),
        source,
    })?;
    parse_pois_csv(&text, &path.display().to_string())
}

/// [`read_pois_csv`] on text; `name` is used in messages.
pub fn parse_pois_csv(text: &str, name: &str) -> Result<Vec<Poi>, PoiError> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let Some((hl, header)) = lines.next() else {
        return Ok(Vec::new());
    };
    let cols: Vec<String> = header
        .split(',')
        .map(|c| c.trim().to_ascii_lowercase())
        .collect();
    let find = |n: &str| cols.iter().position(|c| c == n);
    let (Some(x), Some(y), Some(z)) = (find("x"), find("y"), find("z")) else {
        return Err(PoiError::Syntax {
            at: format!("{name}:{}", hl + 1),
            message: "header must name the columns x, y and z (and optionally id, nx, ny, nz)"
                .into(),
        });
    };
    let id = find("id");
    let normal = match (find("nx"), find("ny"), find("nz")) {
        (Some(a), Some(b), Some(c)) => Some([a, b, c]),
        _ => None,
    };
    let mut out = Vec::new();
    for (n, (ln, line)) in lines.enumerate() {
        let at = format!("{name}:{}", ln + 1);
        let fields: Vec<&str> = line.split(',').collect();
        let get = |i: usize| {
            fields.get(i).copied().ok_or_else(|| PoiError::Syntax {
                at: at.clone(),
                message: format!("expected {} columns, got {}", cols.len(), fields.len()),
            })
        };
        let mut vals = vec![get(x)?, get(y)?, get(z)?];
        if let Some(nc) = normal {
            let nv: Vec<&str> = nc.iter().map(|&i| get(i)).collect::<Result<_, _>>()?;
            if nv.iter().any(|s| !s.trim().is_empty()) {
                vals.extend(nv);
            }
        }
        let v = numbers(&vals, &at)?;
        let pid = match id {
            Some(i) => get(i)?.trim().to_string(),
            None => format!("poi-{}", n + 1),
        };
        out.push(build(pid, &v, &at)?);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_with_and_without_normals() {
        let t = "id,x,y,z,nx,ny,nz\n# comment\nw1,1,2,3,0,0,1\nw2,4,5,6,,,\n";
        let p = parse_pois_csv(t, "t.csv").unwrap();
        assert_eq!(p.len(), 2);
        assert_eq!(p[0].normal, Some(DVec3::Z));
        assert_eq!(p[1].normal, None);
        assert_eq!(p[1].id, "w2");
        let e = parse_pois_csv("x,y,z\n1,2\n", "t.csv").unwrap_err();
        assert!(e.to_string().starts_with("t.csv:2"), "{e}");
        assert!(parse_pois_csv("a,b\n1,2\n", "t.csv").is_err());
        assert!(parse_poi("1,2,NaN", 0).is_err());
        assert!(parse_poi("1,2,3,0,0,0", 0).is_err());
    }
}
