//! A CityJSON / CityJSONSeq document into another CRS through any
//! [`PointTransform`] (the pure-Rust [`crate::model::crs::Builtin`], or PROJ with the feature
//! `proj`): the library side of `reproject` for CityJSON.
//!
//! Every vertex is taken to real coordinates (`transform`), converted, and stored again as
//! integers of a new `transform`: its `translate` is the old one converted, its `scale` 0.001
//! for a projected target and 1e-9 degrees (about 0.1 mm) for a geographic one in x and y,
//! heights (never changed) with the old `scale`. `metadata.referenceSystem` becomes
//! `https://www.opengis.net/def/crs/EPSG/0/<code>` and `metadata.geographicalExtent` the box of
//! the converted vertices. Geometry templates stay in their own local units. CityJSONSeq is
//! streamed in two passes (the extent, then the lines).

use super::{check_json_target, cj, transform_of, write_line, Transform, Values};
use crate::io::citygml::error::WriteError;
use crate::io::citygml::write::{atomic_write, check_target, WriteOptions};
use crate::model::crs::{Crs, CrsKind, PointTransform};
use crate::model::Bbox;
use glam::DVec3;
use serde_json::Value;
use std::path::Path;

/// What [`reproject_cityjson`] did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
#[non_exhaustive]
pub struct CityJsonReproject {
    /// Vertices converted.
    pub vertices: usize,
    /// The source CRS's name.
    pub from: String,
    /// The target CRS's name.
    pub to: String,
    /// Bytes written (before compression).
    pub bytes_out: u64,
}

/// Convert the document at `input` from `source` (default: its `metadata.referenceSystem`)
/// into `target` with `t`, into `out` (atomically; see the module docs).
///
/// # Errors
/// A refused target, a source that is not CityJSON, no source CRS, a target without an EPSG
/// code, a point `t` cannot convert, I/O errors.
pub fn reproject_cityjson(
    input: &Path,
    out: &Path,
    source: Option<&Crs>,
    target: &Crs,
    t: &dyn PointTransform,
    opts: &WriteOptions,
) -> Result<CityJsonReproject, WriteError> {
    check_target(out, opts, std::iter::once(input))?;
    check_json_target(out)?;
    let Some(code) = target.epsg else {
        let m = format!("the target CRS {} has no EPSG code", target.name);
        return Err(WriteError::Invalid(m));
    };
    let mut values = Values::open(input)?;
    let mut head = values.header()?;
    let from = match source {
        Some(s) => s.clone(),
        None => match super::srs_of(&head) {
            Some(s) => Crs::parse(&s),
            None => {
                let m = "no metadata.referenceSystem: give the source CRS".to_string();
                return Err(cj(input, 1, None, m));
            }
        },
    };
    let old = transform_of(&head).unwrap_or(([1.0; 3], [0.0; 3]));
    let err = |line: u64, e: String| cj(input, line, None, e);
    let origin = t
        .position(&from, target, DVec3::from_array(old.1))
        .map_err(|e| err(1, e.to_string()))?;
    let xy = match target.kind {
        CrsKind::Geographic { .. } => 1e-9,
        _ => 0.001,
    };
    let new: Transform = ([xy, xy, old.0[2]], [origin.x, origin.y, origin.z]);
    let mut s = CityJsonReproject {
        from: from.name.clone(),
        to: target.name.clone(),
        ..CityJsonReproject::default()
    };
    let convert = |f: &mut Value, line: u64, b: &mut Bbox, n: &mut usize| {
        let Some(Value::Array(vs)) = f.get_mut("vertices") else {
            return Ok(());
        };
        for v in vs.iter_mut() {
            let c = |k: usize| v.get(k).and_then(Value::as_f64);
            let (Some(x), Some(y), Some(z)) = (c(0), c(1), c(2)) else {
                return Err(err(
                    line,
                    format!("a vertex that is not three numbers: {v}"),
                ));
            };
            let p = DVec3::new(
                x * old.0[0] + old.1[0],
                y * old.0[1] + old.1[1],
                z * old.0[2] + old.1[2],
            );
            let q = t
                .position(&from, target, p)
                .map_err(|e| err(line, e.to_string()))?;
            let q = DVec3::new(q.x, q.y, p.z);
            let i = |k: usize, c: f64| ((c - new.1[k]) / new.0[k]).round() as i64;
            *v = serde_json::json!([i(0, q.x), i(1, q.y), i(2, q.z)]);
            b.add(DVec3::new(
                i(0, q.x) as f64 * new.0[0] + new.1[0],
                i(1, q.y) as f64 * new.0[1] + new.1[1],
                i(2, q.z) as f64 * new.0[2] + new.1[2],
            ));
            *n += 1;
        }
        Ok(())
    };
    let mut kept = Bbox::EMPTY;
    convert(&mut head, 1, &mut kept, &mut s.vertices)?;
    // CityJSONSeq: pass 1 for the extent
    let mut line = 1;
    while let Some(mut f) = values.next()? {
        line += 1;
        convert(&mut f, line, &mut kept, &mut 0)?;
    }
    if let Some(h) = head.as_object_mut() {
        h.insert(
            "transform".into(),
            serde_json::json!({"scale": new.0, "translate": new.1}),
        );
        let meta = h
            .entry("metadata")
            .or_insert_with(|| Value::Object(Default::default()));
        if let Some(m) = meta.as_object_mut() {
            let url = format!("https://www.opengis.net/def/crs/EPSG/0/{code}");
            m.insert("referenceSystem".into(), url.into());
        }
    }
    super::set_extent(&mut head, &kept);
    let mut values = Values::open(input)?;
    values.header()?;
    let io = |e| WriteError::Io {
        file: out.to_path_buf(),
        source: e,
    };
    s.bytes_out = atomic_write(out, |w| {
        let mut n = write_line(w, &head).map_err(io)?;
        let mut line = 1;
        while let Some(mut f) = values.next()? {
            line += 1;
            let mut scratch = Bbox::EMPTY;
            convert(&mut f, line, &mut scratch, &mut s.vertices)?;
            n += write_line(w, &f).map_err(io)?;
        }
        Ok(n)
    })?;
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utm_to_wgs84_and_back_within_a_millimetre() {
        let doc = serde_json::json!({"type":"CityJSON","version":"2.0",
          "transform":{"scale":[0.001,0.001,0.001],"translate":[678083.0,5403796.0,413.0]},
          "metadata":{"referenceSystem":"https://www.opengis.net/def/crs/EPSG/0/32632"},
          "CityObjects":{"b":{"type":"Building","geometry":[{"type":"MultiSurface","lod":"1",
            "boundaries":[[[0,1,2]]]}]}},
          "vertices":[[0,0,0],[10000,0,0],[10000,20000,5000]]});
        let dir = tempfile::tempdir().unwrap();
        let src = dir.path().join("a.city.json");
        std::fs::write(&src, serde_json::to_vec(&doc).unwrap()).unwrap();
        let t = crate::model::crs::Builtin;
        let wgs = Crs::epsg(4326);
        let geo = dir.path().join("b.city.json");
        let s = reproject_cityjson(&src, &geo, None, &wgs, &t, &Default::default()).unwrap();
        assert_eq!(s.vertices, 3);
        let g: Value = serde_json::from_slice(&std::fs::read(&geo).unwrap()).unwrap();
        assert_eq!(
            g["metadata"]["referenceSystem"],
            "https://www.opengis.net/def/crs/EPSG/0/4326"
        );
        // Ingolstadt: latitude first (EPSG order), about 48.76 N 11.42 E; heights kept
        let e = &g["metadata"]["geographicalExtent"];
        assert!((e[0].as_f64().unwrap() - 48.76).abs() < 0.01, "{e}");
        assert!((e[1].as_f64().unwrap() - 11.42).abs() < 0.01, "{e}");
        assert!((e[2].as_f64().unwrap() - 413.0).abs() < 1e-9, "{e}");
        assert!((e[5].as_f64().unwrap() - 418.0).abs() < 1e-9, "{e}");
        let back = dir.path().join("c.city.json");
        let utm32 = Crs::epsg(32632);
        reproject_cityjson(&geo, &back, None, &utm32, &t, &Default::default()).unwrap();
        let m = crate::io::citygml::read_file(&back).unwrap();
        let p = m.assets[0].detail_polygons()[0].exterior().to_vec();
        let want = [
            DVec3::new(678083.0, 5403796.0, 413.0),
            DVec3::new(678093.0, 5403796.0, 413.0),
            DVec3::new(678093.0, 5403816.0, 418.0),
        ];
        // against the transform's own round trip (its accuracy is not what is tested here)
        let utm = Crs::epsg(32632);
        let want = want.map(|w| {
            let g = t.position(&utm, &wgs, w).unwrap();
            let b = t.position(&wgs, &utm, g).unwrap();
            DVec3::new(b.x, b.y, w.z)
        });
        for (a, b) in p.iter().zip(want) {
            assert!((*a - b).abs().max_element() < 1e-3, "{a} {b}");
        }
    }
}
