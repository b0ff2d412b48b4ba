//! Wavefront OBJ for daylight tools (Radiance `obj2rad`, Ladybug/Honeybee, Rhino), by the
//! conventions of DESIGN.md "Interchange":
//!
//! * the first line is `# origin X Y Z`: a point in the model's CRS (the centre of the file's
//!   geometry, rounded to whole metres); every vertex is written relative to it, so a reader in
//!   single precision keeps centimetres on a UTM model;
//! * one `o` per asset, named by its `gml:id` (or its building's id and its index,
//!   [`crate::model::CityModel::asset_name`]);
//! * one `usemtl` per semantic class and level: `roof_l2`, `wall_l1`, `installation_l1`,
//!   `window_l2`, ... (the kinds of [`crate::model::AssetKind::as_str`]); `convert` writes full
//!   detail as level 2;
//! * triangles only ([`crate::model::triangulate()`]), oriented like the polygon's exterior ring;
//!   Z up, metres, no normals and no material library (the material names are the classes).
//!
//! What an asset contributes is [`crate::lod::level::traced`], the definition the traced
//! LoD scene uses ([`crate::lod::scene::mixed_scene`]): level 2 its highest LoD, level 1 its rough
//! geometry, level 0 nothing. Vertices are shared within an object.
//!
//! # Example
//! ```
//! use glam::DVec3;
//! use skylod::export::{Chunks, Content, write_obj};
//! use skylod::model::{Asset, AssetKind, CityModel, LodGeometry, Polygon};
//! let mut m = CityModel::default();
//! let quad = Polygon::new(vec![
//!     DVec3::new(430000.0, 4581000.0, 20.0), DVec3::new(430010.0, 4581000.0, 20.0),
//!     DVec3::new(430010.0, 4581010.0, 20.0), DVec3::new(430000.0, 4581010.0, 20.0),
//! ]);
//! m.assets.push(Asset::new(AssetKind::Roof, Some("r1"), "RoofSurface",
//!     vec![LodGeometry { lod: 2, polygons: vec![quad], ..Default::default() }],
//! ));
//! let mut out = Vec::new();
//! let (s, _) = write_obj(&Chunks::model(&m, 0, Content::Full), &mut out).unwrap().unwrap();
//! let text = String::from_utf8(out).unwrap();
//! assert!(text.starts_with("# origin 430005 4581005 20\n"));
//! assert!(text.contains("o r1\nusemtl roof_l2\nv "));
//! assert!(text.contains("\nv -5 -5 0\n") && text.contains("\nv 5 5 0\n"));
//! assert_eq!((s.objects, s.triangles, s.vertices), (1, 2, 4));
//! ```

use super::chunks::{Chunks, Part};
use super::ExportSummary;
use crate::io::citygml::read::StreamSummary;
use crate::lod::level::traced as level_polygons;
use crate::model::triangulate;
use crate::model::{Bbox, Polygon};
use foldhash::HashMap;
use glam::DVec3;
use std::io::{self, Write};

/// Write the assets of `chunks` as OBJ to `w` (see the module docs), in passes over the
/// chunks: 0 the origin (the centre of all the geometry written), 1 the assets, and 2, for
/// a stream with body assets (buildings without thematic surfaces: last in the whole model,
/// after each chunk's other assets in a stream's chunk), the bodies. With what was written,
/// the source's summary; `Ok(None)` where the stream declines.
///
/// # Errors
/// I/O errors of `w`.
pub fn write_obj(
    chunks: &Chunks<'_>,
    w: &mut dyn Write,
) -> io::Result<Option<(ExportSummary, StreamSummary)>> {
    let mut bbox = Bbox::EMPTY;
    let Some(sum) = chunks.pass(0, |p: &Part<'_>| -> io::Result<()> {
        for (i, a) in p.assets() {
            for q in level_polygons(a, p.content.rough(i), p.content.level(i)).iter() {
                q.points().for_each(|q| bbox.add(*q));
            }
        }
        Ok(())
    })?
    else {
        return Ok(None);
    };
    let origin = if bbox.is_empty() {
        DVec3::ZERO
    } else {
        bbox.center().round()
    };
    write_header(w, origin, &chunks.label(), sum.srs_name.as_deref())?;
    let mut s = ExportSummary::default();
    let mut scratch = Scratch::default();
    for bodies in [false, true] {
        if bodies && sum.bodies == 0 {
            break;
        }
        let done = chunks.pass(1 + usize::from(bodies), |p: &Part<'_>| -> io::Result<()> {
            for (i, a, global) in p.in_order(bodies, sum.assets) {
                let name = p.model.asset_name(i, global);
                let level = p.content.level(i);
                let polys = level_polygons(a, p.content.rough(i), level);
                let obj = (a.kind.as_str(), name.as_str(), level);
                write_asset(w, obj, &polys, origin, &mut s, &mut scratch)?;
            }
            Ok(())
        })?;
        if done.is_none() {
            return Ok(None);
        }
    }
    Ok(Some((s, sum)))
}

/// The origin line and the comment line of an OBJ of the file shown as `label` in CRS
/// `srs_name`.
fn write_header(
    w: &mut dyn Write,
    origin: DVec3,
    label: &str,
    srs_name: Option<&str>,
) -> io::Result<()> {
    writeln!(w, "# origin {} {} {}", origin.x, origin.y, origin.z)?;
    writeln!(
        w,
        "# skylod {} OBJ of {}; CRS {}; metres, Z up, vertices relative to the origin",
        env!("CARGO_PKG_VERSION"),
        label,
        srs_name.unwrap_or("unknown"),
    )
}

/// Buffers reused from one asset to the next.
#[derive(Default)]
struct Scratch {
    tris: Vec<[DVec3; 3]>,
    index: HashMap<[u64; 3], usize>,
    faces: Vec<[usize; 3]>,
    line: String,
}

/// One asset as an OBJ object (nothing when its polygons give no triangle): `(kind, name,
/// level)`; `s` counts what was written (its vertices number the next object's).
fn write_asset(
    w: &mut dyn Write,
    (kind, name, level): (&str, &str, u8),
    polys: &[Polygon],
    origin: DVec3,
    s: &mut ExportSummary,
    scratch: &mut Scratch,
) -> io::Result<()> {
    let Scratch {
        tris,
        index,
        faces,
        line,
    } = scratch;
    tris.clear();
    for p in polys.iter() {
        triangulate(p, tris);
    }
    if tris.is_empty() {
        return Ok(());
    }
    let name: String = name
        .chars()
        .map(|c| if c.is_whitespace() { '_' } else { c })
        .collect();
    writeln!(w, "o {name}\nusemtl {kind}_l{level}")?;
    index.clear();
    faces.clear();
    let first = s.vertices + 1;
    for t in tris.iter() {
        let mut f = [0usize; 3];
        for (k, v) in t.iter().enumerate() {
            let key = [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
            let n = index.len();
            let id = *index.entry(key).or_insert(n);
            if id == n {
                line.clear();
                line.push('v');
                for c in (*v - origin).to_array() {
                    line.push(' ');
                    push_coord(line, c);
                }
                line.push('\n');
                w.write_all(line.as_bytes())?;
            }
            f[k] = id;
        }
        faces.push(f);
    }
    for f in faces.iter() {
        line.clear();
        line.push('f');
        for k in f {
            line.push(' ');
            line.push_str(&(first + k).to_string());
        }
        line.push('\n');
        w.write_all(line.as_bytes())?;
    }
    s.vertices += index.len();
    s.objects += 1;
    s.polygons += polys.len();
    s.triangles += tris.len();
    Ok(())
}

/// A coordinate with 0.1 mm resolution, without trailing zeros (`-5`, `12.25`).
fn push_coord(s: &mut String, x: f64) {
    let mut t = format!("{x:.4}");
    if t.contains('.') {
        while t.ends_with('0') {
            t.pop();
        }
        if t.ends_with('.') {
            t.pop();
        }
    }
    if t == "-0" {
        t = "0".into();
    }
    s.push_str(&t);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::export::Content;
    use crate::lod::rough::RoughGeometry;
    use crate::model::{Asset, AssetKind, CityModel, LodGeometry, Polygon};

    fn asset(kind: AssetKind, id: Option<&str>, z: f64) -> Asset {
        let sq = Polygon::new(vec![
            DVec3::new(0.0, 0.0, z),
            DVec3::new(2.0, 0.0, z),
            DVec3::new(2.0, 2.0, z),
            DVec3::new(0.0, 2.0, z),
        ]);
        Asset::new(
            kind,
            id,
            "X",
            vec![LodGeometry {
                lod: 3,
                property: "lod3MultiSurface".into(),
                polygons: vec![sq],
                ..Default::default()
            }],
        )
    }

    #[test]
    fn coords() {
        let mut s = String::new();
        for x in [0.0, -0.00001, 1.5, -2.25, 100.0, 0.12345] {
            push_coord(&mut s, x);
            s.push(' ');
        }
        assert_eq!(s, "0 0 1.5 -2.25 100 0.1235 ");
    }

    #[test]
    fn levels_pick_geometry_and_material() {
        let mut m = CityModel::default();
        m.assets.push(asset(AssetKind::Roof, Some("r"), 10.0));
        m.assets.push(asset(AssetKind::Installation, None, 11.0));
        m.assets.push(asset(AssetKind::Wall, Some("w"), 12.0));
        let tri = Polygon::new(vec![
            DVec3::new(0.0, 0.0, 11.0),
            DVec3::new(1.0, 0.0, 11.0),
            DVec3::new(0.0, 1.0, 11.0),
        ]);
        let rough = vec![
            RoughGeometry::default(),
            RoughGeometry {
                polygons: vec![tri],
                obb: None,
                lod: 3,
            },
            RoughGeometry::default(),
        ];
        let levels = [2, 1, 0];
        let mut out = Vec::new();
        let content = Content::Levels {
            rough: &rough,
            levels: &levels,
        };
        let (s, _) = write_obj(&Chunks::model(&m, 0, content), &mut out)
            .unwrap()
            .unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(text.contains("o r\nusemtl roof_l2\n"), "{text}");
        assert!(
            text.contains("o asset_1\nusemtl installation_l1\n"),
            "{text}"
        );
        assert!(!text.contains("o w\n"), "{text}");
        assert_eq!((s.objects, s.triangles, s.vertices), (2, 3, 7));
        // Faces index the vertices written so far (1-based, global).
        let nv = text.lines().filter(|l| l.starts_with("v ")).count();
        for l in text.lines().filter(|l| l.starts_with("f ")) {
            for k in l[2..].split(' ') {
                let k: usize = k.parse().unwrap();
                assert!(k >= 1 && k <= nv);
            }
        }
    }
}
