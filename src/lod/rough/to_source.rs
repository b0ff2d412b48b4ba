//! Rough geometry made in the local metric frame, brought back to the source CRS for writing
//! (the frame itself, [`LocalFrame`], knows nothing of rough geometry).

use super::RoughGeometry;
use crate::model::crs::LocalFrame;
use crate::model::CityModel;
use std::borrow::Cow;

/// Rough geometry computed on `local` (= [`LocalFrame::model_to_local`] of `source`)
/// brought back to the source CRS for writing: borrowed unchanged for the identity.
/// Where an asset's rough geometry is its own polygons at the rough LoD (LoD2 used
/// unchanged), the source polygons are taken as read, so that the writer keeps them
/// verbatim; generated polygons are converted back and rounded (1e-10 degree, 1e-6 unit).
/// Oriented boxes are converted to their six faces (`obb: None`): the box is a tracing aid
/// in the local frame, never written. With `levels`, only the assets at level 1 (the only
/// ones written with their rough geometry) are converted; the others get an empty
/// [`RoughGeometry`].
pub fn rough_to_source<'r>(
    frame: &LocalFrame,
    local: &CityModel,
    source: &CityModel,
    rough: &'r [RoughGeometry],
    levels: Option<&[u8]>,
) -> Cow<'r, [RoughGeometry]> {
    if frame.is_identity() {
        return Cow::Borrowed(rough);
    }
    let written = |i: usize| levels.is_none_or(|l| l.get(i) == Some(&1));
    rough
        .iter()
        .enumerate()
        .map(|(i, r)| {
            if !written(i) {
                return RoughGeometry::default();
            }
            let rp = r.polygons();
            let own = local.assets.get(i).and_then(|la| {
                let same: Vec<_> = la.polygons_at(r.lod).collect();
                (!rp.is_empty()
                    && same.len() == rp.len()
                    && same.iter().zip(rp.iter()).all(|(x, y)| *x == y))
                .then(|| source.assets.get(i))
                .flatten()
            });
            let polygons = match own {
                Some(sa) => sa.polygons_at(r.lod).cloned().collect(),
                None => rp
                    .iter()
                    .map(|p| {
                        let mut p = p.clone();
                        for q in p.points_mut().iter_mut() {
                            *q = frame.to_source_rounded(*q);
                        }
                        p
                    })
                    .collect(),
            };
            RoughGeometry {
                polygons,
                obb: None,
                lod: r.lod,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lod::rough::{rough_model, RoughOptions};
    use crate::model::crs::Crs;
    use crate::model::Bbox;
    use glam::DVec3;

    /// A roof with LoD2 and LoD3 (rough = its LoD2, unchanged) and an installation (rough =
    /// a generated box), in degrees: back in the source CRS, the LoD2 polygons are the ones
    /// read, bit for bit, and the box lies where the installation is.
    #[test]
    fn rough_back_to_source() {
        use crate::model::{Asset, AssetKind, LodGeometry, Polygon};
        let (lat, lon) = (35.54, 139.777);
        let d = 1e-4; // ~10 m
        let quad = |z: f64, s: f64| {
            Polygon::new(vec![
                DVec3::new(lat, lon, z),
                DVec3::new(lat, lon + s, z),
                DVec3::new(lat + s, lon + s, z + 0.1),
                DVec3::new(lat + s, lon, z + 0.1),
            ])
        };
        let asset = |kind, geometries| Asset {
            kind,
            id: None,
            element: "x".into(),
            building: None,
            parent: None,
            span: 0..0,
            line: 1,
            function: None,
            file: 0,
            geometries,
        };
        let mut m = CityModel::default();
        m.assets.push(asset(
            AssetKind::Roof,
            vec![
                LodGeometry {
                    lod: 2,
                    polygons: vec![quad(10.0, d)],
                    ..Default::default()
                },
                LodGeometry {
                    lod: 3,
                    polygons: vec![quad(10.0, d / 2.0), quad(10.05, d / 2.0)],
                    ..Default::default()
                },
            ],
        ));
        let cube: Vec<Polygon> = [10.0, 12.0].iter().map(|&z| quad(z, d / 10.0)).collect();
        m.assets.push(asset(
            AssetKind::Installation,
            vec![LodGeometry {
                lod: 3,
                polygons: cube,
                ..Default::default()
            }],
        ));
        let (f, _) = LocalFrame::new(&Crs::parse("EPSG:6697"), &m.bbox());
        let local = f.model_to_local(&m);
        let rough = rough_model(&local, &RoughOptions::default());
        let back = rough_to_source(&f, &local, &m, &rough, None);
        assert_eq!(back[0].lod, 2);
        assert_eq!(back[0].polygons, m.assets[0].geometries[0].polygons);
        assert!(!back[1].polygons.is_empty() && back[1].obb.is_none());
        let b = Bbox::of_points(back[1].polygons.iter().flat_map(|p| p.points()));
        let src = m.assets[1].bbox();
        assert!(
            (b.min - src.min).abs().max_element() < 1e-5,
            "{b:?} {src:?}"
        );
        assert!((b.max - src.max).abs().max_element() < 0.2, "{b:?} {src:?}");
        // Degrees, not metres, and rounded to 1e-10 degree.
        let q = back[1].polygons[0].exterior()[0];
        assert!((q.x - lat).abs() < 1e-3 && (q.y - lon).abs() < 1e-3);
        assert_eq!((q.x * 1e10).round() / 1e10, q.x);
        // Only what is written at level 1 is converted; the identity converts nothing.
        let some = rough_to_source(&f, &local, &m, &rough, Some(&[1, 2]));
        assert_eq!(some[0], back[0]);
        assert_eq!(some[1], RoughGeometry::default());
        let id = rough_to_source(&LocalFrame::IDENTITY, &m, &m, &rough, None);
        assert!(matches!(id, Cow::Borrowed(r) if std::ptr::eq(r, rough.as_slice())));
    }
}
