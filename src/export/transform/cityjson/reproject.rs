//! A CityJSON / CityJSONSeq document into another CRS through any
//! [`PointTransform`] (the pure-Rust [`crate::model::crs::Builtin`], or PROJ with the feature
//! `proj`): the library side of `reproject` for CityJSON.
//!
//! Every vertex is taken to real coordinates (`transform`), converted, and stored again as
//! integers of a new `transform`: its `translate` is the old one converted, its `scale` 0.001
//! for a projected target and 1e-9 degrees (about 0.1 mm) for a geographic one in x and y,
//! heights (never changed) with the old `scale`. `metadata.referenceSystem` becomes
//! `https://www.opengis.net/def/crs/EPSG/0/<code>` and `metadata.geographicalExtent` the box of
//! the converted vertices. CityJSONSeq is streamed in two passes (the extent, then the lines);
//! a document in two as well ([`super::stream`]): its small members and its vertices (kept
//! as stored and converted, 40 bytes a vertex for integer triples: what grows with it), then
//! its city objects one at a time as they are written.
//!
//! # Geometry templates
//! A template's vertices are shared by its instances and live in a local frame: an instance
//! puts vertex `v` at `ref + M·(v, 1)`, `ref` its reference point (a vertex, converted as every
//! vertex is) and `M` its 4×4 `transformationMatrix`. The templates are left as they are and
//! each instance's `M` is converted to first order instead: `J`, the Jacobian of the
//! conversion (heights kept) at the reference point, by central differences (a step of 1 m, or
//! 1e-5° in x and y from a geographic CRS), is folded into it — new linear part `J·L`, new
//! translation `J·t` for `M`'s linear part `L` and translation `t`. A template vertex `d` metres
//! from its reference point then lands within the conversion's curvature over `d` of its
//! converted position (about a millimetre at 80 m from UTM to WGS 84).

use super::stream::{self, Pass, Vertex};
use super::{check_json_target, cj, transform_of, Transform, Values};
use crate::io::citygml::error::WriteError;
use crate::io::citygml::write::{check_target, WriteOptions};
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

impl CityJsonReproject {
    /// The line `reproject` says for `input` written to `shown_output` (the output's name as
    /// the user gave it): `IN -> OUT: FROM -> TO, N vertices`.
    pub fn line(&self, input: &Path, shown_output: &Path) -> String {
        format!(
            "{} -> {}: {} -> {}, {} vertices",
            crate::model::shown(input),
            shown_output.display(),
            self.from,
            self.to,
            self.vertices
        )
    }
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
    // a document is read in passes (its small members and vertices, then its objects one
    // at a time as they are written); CityJSONSeq is its header line, then its features
    let mut scan = Scan::default();
    let seq = stream::read(input, input, &mut scan)?.more;
    let mut values = Values::open(input)?;
    let mut head = match seq {
        true => values.header()?,
        false => {
            let h = Value::Object(std::mem::take(&mut scan.members));
            super::check_type(input, h.as_object().unwrap_or(&Default::default()))?;
            h
        }
    };
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
    let step = match from.kind {
        CrsKind::Geographic { .. } => [1e-5, 1e-5, 1.0],
        _ => [1.0; 3],
    };
    let map = |p: DVec3| -> Result<DVec3, String> {
        let q = t.position(&from, target, p).map_err(|e| e.to_string())?;
        Ok(DVec3::new(q.x, q.y, p.z))
    };
    // a stored vertex (three numbers) as stored in the new frame, and where that is
    let quantise = |c: [f64; 3]| -> Result<([i64; 3], DVec3), String> {
        let p = DVec3::new(
            c[0] * old.0[0] + old.1[0],
            c[1] * old.0[1] + old.1[1],
            c[2] * old.0[2] + old.1[2],
        );
        let q = t.position(&from, target, p).map_err(|e| e.to_string())?;
        let q = DVec3::new(q.x, q.y, p.z);
        let i = |k: usize, c: f64| ((c - new.1[k]) / new.0[k]).round() as i64;
        let v = [i(0, q.x), i(1, q.y), i(2, q.z)];
        let at = |k: usize| v[k] as f64 * new.0[k] + new.1[k];
        Ok((v, DVec3::new(at(0), at(1), at(2))))
    };
    let convert = |f: &mut Value, line: u64, b: &mut Bbox, n: &mut usize| {
        reframe_instances(f, old, step, &map).map_err(|e| err(line, e))?;
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
            let (q, at) = quantise([x, y, z]).map_err(|e| err(line, e))?;
            *v = serde_json::json!(q);
            b.add(at);
            *n += 1;
        }
        Ok(())
    };
    let mut kept = Bbox::EMPTY;
    // a document's vertices in the new frame (24 bytes each: what grows with it)
    let mut moved: Vec<[i64; 3]> = Vec::new();
    for v in scan.vertices.iter().filter(|_| !seq) {
        let Some(c) = v.coords() else {
            let m = format!(
                "a vertex that is not three numbers: {}",
                v.clone().into_value()
            );
            return Err(err(1, m));
        };
        let (q, at) = quantise(c).map_err(|e| err(1, e))?;
        moved.push(q);
        kept.add(at);
    }
    s.vertices = moved.len();
    convert(&mut head, 1, &mut kept, &mut s.vertices)?;
    // CityJSONSeq: pass 1 for the extent
    let mut line = 1;
    while let Some(mut f) = match seq {
        true => values.next()?,
        false => None,
    } {
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
    if !seq {
        let Value::Object(head) = head else {
            return Err(err(1, "not a JSON object".into()));
        };
        let point = |i: u64| scan.vertices.get(usize::try_from(i).ok()?)?.coords();
        s.bytes_out = stream::write_document(out, &head, &mut |key, entries| {
            if key == "vertices" {
                for &[x, y, z] in &moved {
                    let v = Vertex::from_value(serde_json::json!([x, y, z]));
                    entries.vertex(&v).map_err(|e| err(0, e))?;
                }
                return Ok(());
            }
            let mut objects = stream::EachObject(|id: String, mut o: Value| {
                reframe_object(&id, &mut o, &point, old, step, &map)?;
                entries.object(&id, &o)
            });
            stream::read(input, input, &mut objects).map(|_| ())
        })?;
        return Ok(s);
    }
    let mut values = Values::open(input)?;
    values.header()?;
    s.bytes_out = values.write_seq(out, &head, |line, f| {
        let mut scratch = Bbox::EMPTY;
        convert(f, line, &mut scratch, &mut s.vertices)?;
        Ok(true)
    })?;
    Ok(s)
}

/// The first pass over a document: its small members (`CityObjects` and `vertices` as
/// placeholders where they are) and its vertices as stored.
#[derive(Default)]
struct Scan {
    members: serde_json::Map<String, Value>,
    vertices: Vec<Vertex>,
}

impl Pass for Scan {
    fn members(&mut self) -> Option<&mut serde_json::Map<String, Value>> {
        Some(&mut self.members)
    }
    fn place(&mut self, key: &str) {
        self.members.insert(key.to_string(), Value::Null);
    }
    fn wants_vertices(&self) -> bool {
        true
    }
    fn vertex(&mut self, v: Vertex) -> Result<(), String> {
        self.vertices.push(v);
        Ok(())
    }
}

/// The Jacobian of `f` at `p`, by central differences of `step` per axis: `j[r][c]` =
/// ∂f_r/∂x_c.
fn jacobian(
    f: &dyn Fn(DVec3) -> Result<DVec3, String>,
    p: DVec3,
    step: [f64; 3],
) -> Result<[[f64; 3]; 3], String> {
    let mut j = [[0.0; 3]; 3];
    for (c, h) in step.into_iter().enumerate() {
        let mut e = DVec3::ZERO;
        e[c] = h;
        let d = (f(p + e)? - f(p - e)?) / (2.0 * h);
        for (r, row) in j.iter_mut().enumerate() {
            row[c] = d[r];
        }
    }
    Ok(j)
}

/// Fold the Jacobian of `f` (real coordinates in, real coordinates out) at the reference
/// point of each `GeometryInstance` of `doc` (a document or a feature, its vertices stored
/// with `old`) into the instance's `transformationMatrix` (module docs); the instances
/// changed.
fn reframe_instances(
    doc: &mut Value,
    old: Transform,
    step: [f64; 3],
    f: &dyn Fn(DVec3) -> Result<DVec3, String>,
) -> Result<usize, String> {
    let Some(o) = doc.as_object_mut() else {
        return Ok(0);
    };
    let verts = o
        .get_mut("vertices")
        .map(Value::take)
        .unwrap_or(Value::Null);
    let point = |i: u64| -> Option<[f64; 3]> {
        let v = verts.get(usize::try_from(i).ok()?)?;
        let c = |k: usize| v.get(k)?.as_f64();
        Some([c(0)?, c(1)?, c(2)?])
    };
    let mut n = 0;
    let mut r = Ok(());
    let objects = o.get_mut("CityObjects").and_then(Value::as_object_mut);
    for (id, obj) in objects.into_iter().flatten() {
        match reframe_object(id, obj, &point, old, step, f) {
            Ok(k) => n += k,
            Err(e) => r = Err(e),
        }
    }
    if let Some(v) = o.get_mut("vertices") {
        *v = verts;
    }
    r.map(|()| n)
}

/// [`reframe_instances`] of one city object `id` (`obj`), its vertices' stored coordinates
/// given by `point`.
fn reframe_object(
    id: &str,
    obj: &mut Value,
    point: &dyn Fn(u64) -> Option<[f64; 3]>,
    old: Transform,
    step: [f64; 3],
    f: &dyn Fn(DVec3) -> Result<DVec3, String>,
) -> Result<usize, String> {
    let real = |i: u64| -> Option<DVec3> {
        let v = point(i)?;
        let c = |k: usize| v[k] * old.0[k] + old.1[k];
        Some(DVec3::new(c(0), c(1), c(2)))
    };
    let mut n = 0;
    let mut r = Ok(());
    let Some(Value::Array(gs)) = obj.get_mut("geometry") else {
        return Ok(0);
    };
    for g in gs {
        if g.get("type").and_then(Value::as_str) != Some("GeometryInstance") {
            continue;
        }
        let at = g.pointer("/boundaries/0").and_then(Value::as_u64);
        let Some(p) = at.and_then(real) else {
            r = Err(format!(
                "city object {id}: an instance without a reference point"
            ));
            continue;
        };
        let m: Option<Vec<f64>> = g
            .get("transformationMatrix")
            .and_then(Value::as_array)
            .map(|a| a.iter().filter_map(Value::as_f64).collect());
        let Some(m) = m.filter(|m| m.len() == 16) else {
            r = Err(format!(
                "city object {id}: an instance needs a transformationMatrix of 16 numbers"
            ));
            continue;
        };
        let j = match jacobian(f, p, step) {
            Ok(j) => j,
            Err(e) => {
                r = Err(e);
                continue;
            }
        };
        let mut new = m.clone();
        for row in 0..3 {
            for col in 0..4 {
                new[row * 4 + col] = (0..3).map(|k| j[row][k] * m[k * 4 + col]).sum();
            }
        }
        g["transformationMatrix"] = serde_json::json!(new);
        n += 1;
    }
    r.map(|()| n)
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_summary_line_names_both_crss_and_the_vertices() {
        let s = CityJsonReproject {
            vertices: 7,
            from: "EPSG:7415".into(),
            to: "EPSG:4979".into(),
            bytes_out: 1,
        };
        assert_eq!(
            s.line(Path::new("-"), Path::new("-")),
            "<stdin> -> -: EPSG:7415 -> EPSG:4979, 7 vertices"
        );
    }

    use super::*;

    #[test]
    fn template_instances_land_where_their_points_are_converted() {
        // cjio's dummy file (a template instanced once) placed in Ingolstadt, UTM 32N; its
        // instance scaled, turned 30° and moved
        let fx = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fixtures/cityjson/cjio-dummy.city.json"
        );
        let mut doc: Value = serde_json::from_slice(&std::fs::read(fx).unwrap()).unwrap();
        doc["transform"]["translate"] = serde_json::json!([678083.0, 5403796.0, 413.0]);
        let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let m = [
            2.0 * c,
            -2.0 * s,
            0.0,
            5.0,
            2.0 * s,
            2.0 * c,
            0.0,
            -3.0,
            0.0,
            0.0,
            1.5,
            2.0,
            0.0,
            0.0,
            0.0,
            1.0,
        ];
        doc["CityObjects"]["1243"]["geometry"][0]["transformationMatrix"] = serde_json::json!(m);
        let dir = tempfile::tempdir().unwrap();
        let src = dir.path().join("a.city.json");
        std::fs::write(&src, serde_json::to_vec(&doc).unwrap()).unwrap();
        let out = dir.path().join("b.city.json");
        let (utm, wgs, t) = (
            Crs::epsg(32632),
            Crs::epsg(4326),
            crate::model::crs::Builtin,
        );
        reproject_cityjson(&src, &out, Some(&utm), &wgs, &t, &Default::default()).unwrap();
        let g: Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
        assert_eq!(g["geometry-templates"], doc["geometry-templates"]);
        let inst = |d: &Value| d["CityObjects"]["1243"]["geometry"][0].clone();
        let (a, b) = (inst(&doc), inst(&g));
        let tv = doc["geometry-templates"]["vertices-templates"]
            .as_array()
            .unwrap();
        let point = |d: &Value, i: &Value| {
            let k = i["boundaries"][0].as_u64().unwrap() as usize;
            let v = &d["vertices"][k];
            let c = |n: usize| {
                v[n].as_f64().unwrap() * d["transform"]["scale"][n].as_f64().unwrap()
                    + d["transform"]["translate"][n].as_f64().unwrap()
            };
            DVec3::new(c(0), c(1), c(2))
        };
        let placed = |i: &Value, at: DVec3, v: &Value| {
            let m = |k: usize| i["transformationMatrix"][k].as_f64().unwrap();
            let x = |k: usize| v[k].as_f64().unwrap();
            let r = |row: usize| {
                m(row * 4) * x(0) + m(row * 4 + 1) * x(1) + m(row * 4 + 2) * x(2) + m(row * 4 + 3)
            };
            at + DVec3::new(r(0), r(1), r(2))
        };
        assert_ne!(a["transformationMatrix"], b["transformationMatrix"]);
        let (ra, rb) = (point(&doc, &a), point(&g, &b));
        let mut far = 0.0f64;
        for v in tv {
            let w = placed(&a, ra, v);
            let want = t.position(&utm, &wgs, w).unwrap();
            let got = placed(&b, rb, v);
            far = far.max((w - ra).length());
            // 5e-8 degrees: about 5 mm; heights kept
            assert!((got.x - want.x).abs() < 5e-8, "{got} {want}");
            assert!((got.y - want.y).abs() < 5e-8, "{got} {want}");
            assert!((got.z - w.z).abs() < 5e-3, "{got} {w}");
        }
        // the check covers points well away from the reference point
        assert!(far > 50.0, "{far}");
    }

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
