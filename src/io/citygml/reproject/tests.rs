//! Tests of the span-edit rewrite of coordinates, `srsName`s and envelopes.

use super::*;

#[test]
fn attribute_spans_of_a_tag() {
    let raw = br#"gml:Envelope srsName = "EPSG:1" srsDimension='3' a="x>y""#;
    let a = attribute_spans(raw);
    let names: Vec<&[u8]> = a.iter().map(|(n, _)| *n).collect();
    assert_eq!(names, [&b"srsName"[..], b"srsDimension", b"a"]);
    assert_eq!(&raw[a[0].1.clone()], b"EPSG:1");
    assert_eq!(&raw[a[1].1.clone()], b"3");
    assert_eq!(&raw[a[2].1.clone()], b"x>y");
    assert!(attribute_spans(b"gml:pos").is_empty());
}

fn doc(body: &str) -> String {
    format!(
        r#"<?xml version="1.0"?>
<core:CityModel xmlns:core="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml"
 xmlns:xlink="http://www.w3.org/1999/xlink" xmlns:bldg="http://www.opengis.net/citygml/building/2.0"
 xmlns:gen="http://www.opengis.net/citygml/generics/2.0">
<gml:boundedBy><gml:Envelope srsName="urn:ogc:def:crs:EPSG::1"><gml:lowerCorner>0 0 0</gml:lowerCorner><gml:upperCorner>1 1 1</gml:upperCorner></gml:Envelope></gml:boundedBy>
{body}
</core:CityModel>
"#
    )
}

fn rewrite(body: &str, t: &PointTransform<'_>) -> (String, RewriteSummary) {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("in.gml");
    std::fs::write(&src, doc(body)).unwrap();
    let out = dir.path().join("out.gml");
    let s = rewrite_file(&src, &out, t, "EPSG:2", &WriteOptions::default()).unwrap();
    (std::fs::read_to_string(&out).unwrap(), s)
}

/// Swap x and y, add 100 to both: a change a test can see in every position.
fn swap(p: &mut [DVec3]) -> Result<(), String> {
    for q in p {
        *q = DVec3::new(q.y + 100.0, q.x + 100.0, q.z);
    }
    Ok(())
}

#[test]
fn every_kind_of_coordinate() {
    let body = r#"<core:cityObjectMember><gen:GenericCityObject gml:id="g">
<gml:boundedBy><gml:Envelope srsName="EPSG:1" srsDimension="3"><gml:lowerCorner>0 0 0</gml:lowerCorner><gml:upperCorner>9 9 9</gml:upperCorner></gml:Envelope></gml:boundedBy>
<gen:lod1Geometry><gml:MultiSurface srsName="EPSG:1" srsDimension="2"><gml:surfaceMember><gml:Polygon gml:id="p"><gml:exterior><gml:LinearRing>
<gml:posList>1 2
 3 4 5 6 1 2</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></gen:lod1Geometry>
<gen:lod2Geometry><gml:LineString><gml:coordinates cs=";" ts="|" decimal=",">1,5;2,5;3|4;5;6</gml:coordinates></gml:LineString></gen:lod2Geometry>
<gen:lod3Geometry><gml:Point><gml:pos>7 8 9.25</gml:pos></gml:Point></gen:lod3Geometry>
<gen:lod4Geometry><gml:Point><gml:coord><gml:X>1</gml:X><gml:Y>2</gml:Y></gml:coord></gml:Point></gen:lod4Geometry>
</gen:GenericCityObject></core:cityObjectMember>"#;
    let (text, s) = rewrite(body, &swap);
    assert!(
        text.contains("<gml:posList>102 101 104 103 106 105 102 101</gml:posList>"),
        "{text}"
    );
    assert!(text.contains(r#"<gml:coordinates cs=";" ts="|" decimal=",">102,5;101,5;3|105;104;6</gml:coordinates>"#), "{text}");
    assert!(text.contains("<gml:pos>108 107 9.25</gml:pos>"));
    assert!(text.contains("<gml:X>102</gml:X><gml:Y>101</gml:Y>"));
    assert!(text.contains(r#"<gml:MultiSurface srsName="EPSG:2" srsDimension="2">"#));
    assert!(!text.contains("EPSG:1"));
    assert_eq!(s.srs_names, 3);
    assert_eq!(s.envelopes, 2);
    assert_eq!(s.points, 4 + 2 + 1 + 1);
    // The object's envelope: the box of its transformed coordinates.
    assert!(text.contains(r#"<gml:Envelope srsName="EPSG:2" srsDimension="3"><gml:lowerCorner>102 101 0</gml:lowerCorner><gml:upperCorner>108 107 9.25</gml:upperCorner></gml:Envelope>"#), "{text}");
    assert_eq!(s.source_srs_names, ["urn:ogc:def:crs:EPSG::1", "EPSG:1"]);
}

#[test]
fn implicit_geometry_and_template() {
    let body = r#"<core:cityObjectMember><gen:GenericCityObject gml:id="g">
<gen:lod2ImplicitRepresentation><core:ImplicitGeometry>
<core:transformationMatrix>1 0 0 2 0 1 0 3 0 0 1 4 0 0 0 1</core:transformationMatrix>
<core:relativeGMLGeometry><gml:Point><gml:pos>0.5 0.5 0.5</gml:pos></gml:Point></core:relativeGMLGeometry>
<core:referencePoint><gml:Point><gml:pos>10 20 30</gml:pos></gml:Point></core:referencePoint>
</core:ImplicitGeometry></gen:lod2ImplicitRepresentation>
</gen:GenericCityObject></core:cityObjectMember>"#;
    // Scale by 2 about the origin: the displacement (2, 3, 4) becomes (4, 6, 4).
    let scale = |p: &mut [DVec3]| -> Result<(), String> {
        p.iter_mut().for_each(|q| {
            q.x *= 2.0;
            q.y *= 2.0
        });
        Ok(())
    };
    let (text, s) = rewrite(body, &scale);
    assert!(
        text.contains("<gml:pos>0.5 0.5 0.5</gml:pos>"),
        "template untouched"
    );
    assert!(text.contains("<gml:pos>20 40 30</gml:pos>"));
    assert!(text.contains(
        "<core:transformationMatrix>1 0 0 4 0 1 0 6 0 0 1 4 0 0 0 1</core:transformationMatrix>"
    ));
    assert_eq!(s.implicit, 1);
    assert!(!s.warnings.is_empty());
}

#[test]
fn envelope_follows_references_and_falls_back_to_corners() {
    let body = r##"<core:cityObjectMember><bldg:Building gml:id="b1">
<gml:boundedBy><gml:Envelope><gml:lowerCorner>0 0 0</gml:lowerCorner><gml:upperCorner>1 1 1</gml:upperCorner></gml:Envelope></gml:boundedBy>
<bldg:lod2MultiSurface xlink:href="#ms"/>
</bldg:Building></core:cityObjectMember>
<core:cityObjectMember><bldg:Building gml:id="b2">
<gml:boundedBy><gml:Envelope><gml:lowerCorner>5 5 5</gml:lowerCorner><gml:upperCorner>6 7 8</gml:upperCorner></gml:Envelope></gml:boundedBy>
<bldg:lod2MultiSurface><gml:MultiSurface gml:id="ms"><gml:surfaceMember><gml:Polygon><gml:exterior><gml:LinearRing>
<gml:posList>0 0 1 4 0 1 4 4 1 0 0 1</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface>
</bldg:Building></core:cityObjectMember>
<core:cityObjectMember><bldg:Building gml:id="b3">
<gml:boundedBy><gml:Envelope><gml:lowerCorner>1 2 3</gml:lowerCorner><gml:upperCorner>4 5 6</gml:upperCorner></gml:Envelope></gml:boundedBy>
</bldg:Building></core:cityObjectMember>"##;
    let (text, s) = rewrite(body, &swap);
    assert_eq!(s.envelopes, 4);
    let boxes: Vec<&str> = text
        .match_indices("<gml:Envelope")
        .map(|(i, _)| &text[i..i + 150])
        .collect();
    // b1 references b2's geometry (a forward reference): same box.
    let b =
        "<gml:lowerCorner>100 100 1</gml:lowerCorner><gml:upperCorner>104 104 1</gml:upperCorner>";
    assert!(boxes[1].contains(b) && boxes[2].contains(b), "{boxes:?}");
    // b3 has no geometry: its old corners, transformed.
    assert!(boxes[3].contains("<gml:lowerCorner>102 101 3</gml:lowerCorner><gml:upperCorner>105 104 6</gml:upperCorner>"), "{boxes:?}");
    // The model's envelope: every coordinate (b3 has none of its own).
    assert!(boxes[0].contains(b), "{boxes:?}");
}

#[test]
fn a_document_without_crs_gets_the_target_on_its_first_envelope() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("in.gml");
    let body = r#"<core:cityObjectMember><gen:GenericCityObject gml:id="g">
<gen:lod1Geometry><gml:Point><gml:pos>1 2 3</gml:pos></gml:Point></gen:lod1Geometry>
</gen:GenericCityObject></core:cityObjectMember>"#;
    std::fs::write(
        &src,
        doc(body).replace(r#" srsName="urn:ogc:def:crs:EPSG::1""#, ""),
    )
    .unwrap();
    let out = dir.path().join("out.gml");
    let s = rewrite_file(&src, &out, &swap, "EPSG:2", &WriteOptions::default()).unwrap();
    assert!(s.source_srs_names.is_empty());
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains(r#"<gml:Envelope srsName="EPSG:2" srsDimension="3"><gml:lowerCorner>102 101 3</gml:lowerCorner>"#), "{text}");
}

#[test]
fn bad_numbers_and_transform_errors_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("in.gml");
    let out = dir.path().join("out.gml");
    std::fs::write(&src, doc("<gml:pos>1 2 3</gml:pos>")).unwrap();
    let fail = |_: &mut [DVec3]| -> Result<(), String> { Err("outside".into()) };
    let e = rewrite_file(&src, &out, &fail, "EPSG:2", &WriteOptions::default()).unwrap_err();
    assert!(e.to_string().contains("outside"), "{e}");
    assert!(!out.exists());
    std::fs::write(&src, doc("<gml:pos>1 2 3 4</gml:pos>")).unwrap();
    let e = rewrite_file(&src, &out, &swap, "EPSG:2", &WriteOptions::default()).unwrap_err();
    assert!(e.to_string().contains("4 numbers"), "{e}");
    std::fs::write(&src, doc("<gml:pos>1 2<!-- z: --> 3</gml:pos>")).unwrap();
    let e = rewrite_file(&src, &out, &swap, "EPSG:2", &WriteOptions::default()).unwrap_err();
    assert!(e.to_string().contains("cannot be rewritten"), "{e}");
    assert!(!out.exists());
}
