//! Tests of the body-asset rule and of the root envelope's box.

use super::*;

#[test]
fn the_content_box_holds_assets_and_the_buildings_own_geometry() {
    let geom = |pts: &[[f64; 3]]| LodGeometry {
        polygons: vec![Polygon::new(pts.iter().map(|p| DVec3::from(*p)).collect())],
        ..LodGeometry::default()
    };
    let a = Asset::new(
        AssetKind::Roof,
        None,
        "RoofSurface",
        vec![geom(&[[0.0, 1.0, 2.0]])],
    );
    let b = Building {
        geometries: vec![geom(&[[-1.0, 5.0, 0.5], [3.0, 0.0, 1.0]])],
        ..Building::new(None, vec![0])
    };
    let bb = content_bbox(&[a], &[b]);
    assert_eq!(
        (bb.min, bb.max),
        (DVec3::new(-1.0, 0.0, 0.5), DVec3::new(3.0, 5.0, 2.0))
    );
    assert!(content_bbox(&[], &[]).is_empty());
}

#[test]
fn a_building_without_shell_surfaces_gives_its_geometry_as_a_body() {
    let geom = || {
        vec![LodGeometry {
            lod: 1,
            ..LodGeometry::default()
        }]
    };
    let assets = vec![
        Asset::new(
            AssetKind::Installation,
            Some("i"),
            "BuildingInstallation",
            geom(),
        ),
        Asset::new(AssetKind::Roof, Some("r"), "RoofSurface", geom()),
    ];
    // an installation is no shell surface: the part's own geometry becomes its body
    let mut part = Building {
        is_part: true,
        span: 5..50,
        line: 3,
        geometries: geom(),
        ..Building::new(Some("p"), vec![0])
    };
    let body = part.take_body(7, &assets).unwrap();
    assert_eq!(body.kind, AssetKind::Body);
    assert_eq!(
        (body.id.as_deref(), &*body.element),
        (Some("p"), "BuildingPart")
    );
    assert_eq!((body.building, body.span, body.line), (Some(7), 5..50, 3));
    assert_eq!(body.geometries, geom());
    assert!(part.geometries.is_empty());
    // taken once; nothing without geometry
    assert!(part.take_body(7, &assets).is_none());
    // a roof among its assets: the geometry stays with the building
    let mut b = Building {
        geometries: geom(),
        ..Building::new(Some("b"), vec![0, 1])
    };
    assert!(b.take_body(0, &assets).is_none());
    assert_eq!(b.geometries, geom());
    assert_eq!(b.element(), "Building");
}
