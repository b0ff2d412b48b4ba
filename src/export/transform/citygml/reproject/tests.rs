//! Tests of the span-edit rewrite of coordinates, `srsName`s and envelopes.

use super::*;
use crate::model::crs::CrsName;

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

fn rewrite(body: &str, t: &PointsFn<'_>) -> (String, RewriteSummary) {
    rewrite_doc(&doc(body), t)
}

/// `text` rewritten whole and in passes ([`RewriteSource::read_with`]): the same bytes and
/// the same summary, or the same error (nothing written).
fn rewrite_doc(text: &str, t: &PointsFn<'_>) -> (String, RewriteSummary) {
    let (whole, passes) = (both(text, t, u64::MAX), both(text, t, 0));
    match (whole, passes) {
        (Ok(w), Ok(p)) => {
            assert_eq!(w, p, "whole vs passes");
            w
        }
        (w, p) => panic!("whole: {w:?}, passes: {p:?}"),
    }
}

fn both(
    text: &str,
    t: &PointsFn<'_>,
    stream_from: u64,
) -> Result<(String, RewriteSummary), String> {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("in.gml");
    std::fs::write(&src, text).unwrap();
    let out = dir.path().join("out.gml");
    let doc = RewriteSource::read_with(&src, stream_from).map_err(|e| e.to_string())?;
    assert_eq!(doc.in_passes(), stream_from == 0);
    let r = doc.rewrite(&out, t, "EPSG:2", &WriteOptions::default(), |_| {
        Ok::<(), WriteError>(())
    });
    match r {
        Ok(s) => Ok((std::fs::read_to_string(&out).unwrap(), s)),
        Err(e) => {
            assert!(!out.exists(), "{e}");
            Err(e.to_string())
        }
    }
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
    let body = r#"<core:cityObjectMember><gen:GenericCityObject gml:id="g">
<gen:lod1Geometry><gml:Point><gml:pos>1 2 3</gml:pos></gml:Point></gen:lod1Geometry>
</gen:GenericCityObject></core:cityObjectMember>"#;
    let unnamed = doc(body).replace(r#" srsName="urn:ogc:def:crs:EPSG::1""#, "");
    let (text, s) = rewrite_doc(&unnamed, &swap);
    assert!(s.source_srs_names.is_empty());
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
    for (body, what) in [
        ("<gml:pos>1 2 3 4</gml:pos>", "4 numbers"),
        ("<gml:pos>1 2<!-- z: --> 3</gml:pos>", "cannot be rewritten"),
    ] {
        for from in [0, u64::MAX] {
            let e = both(&doc(body), &swap, from).unwrap_err();
            assert!(e.contains(what), "{e}");
        }
    }
    std::fs::write(&src, doc("<gml:pos>1 2 3 4</gml:pos>")).unwrap();
    let e = rewrite_file(&src, &out, &swap, "EPSG:2", &WriteOptions::default()).unwrap_err();
    assert!(e.to_string().contains("4 numbers"), "{e}");
    std::fs::write(&src, doc("<gml:pos>1 2<!-- z: --> 3</gml:pos>")).unwrap();
    let e = rewrite_file(&src, &out, &swap, "EPSG:2", &WriteOptions::default()).unwrap_err();
    assert!(e.to_string().contains("cannot be rewritten"), "{e}");
    assert!(!out.exists());
}

/// Objects in one `gml:featureMembers` (no member ends at depth 1 to write at), each with an
/// envelope, an implicit geometry (its matrix written after its reference point is read), a
/// GML 2 coord and a reference to the next object's geometry: more edits than the writing
/// pass holds, so it writes inside the wrapper; the bytes are the whole rewrite's.
#[test]
fn passes_write_inside_one_wrapper_as_the_whole_rewrite() {
    let mut body = String::from("<gml:featureMembers>");
    for i in 0..1500 {
        body.push_str(&format!(
            r##"<gen:GenericCityObject gml:id="g{i}"><gml:boundedBy><gml:Envelope srsName="EPSG:1"><gml:lowerCorner>0 0 0</gml:lowerCorner><gml:upperCorner>1 1 1</gml:upperCorner></gml:Envelope></gml:boundedBy>
<gen:lod1Geometry xlink:href="#p{next}"/>
<gen:lod2Geometry><gml:Point gml:id="p{i}" srsName="EPSG:1"><gml:pos>{i} {i}.5 3</gml:pos></gml:Point></gen:lod2Geometry>
<gen:lod3Geometry><gml:Point><gml:coord><gml:X>{i}</gml:X><gml:Y>7</gml:Y><gml:Z>1</gml:Z></gml:coord></gml:Point></gen:lod3Geometry>
<gen:lod2ImplicitRepresentation><core:ImplicitGeometry><core:transformationMatrix>1 0 0 2 0 1 0 3 0 0 1 4 0 0 0 1</core:transformationMatrix>
<core:referencePoint><gml:Point><gml:pos>10 {i} 30</gml:pos></gml:Point></core:referencePoint></core:ImplicitGeometry></gen:lod2ImplicitRepresentation>
</gen:GenericCityObject>"##,
            next = (i + 1) % 1500
        ));
    }
    body.push_str("</gml:featureMembers>");
    let text = doc(&body);
    let (out, s) = rewrite_doc(&text, &swap);
    assert_eq!((s.envelopes, s.implicit), (1501, 1500));
    assert!(
        s.srs_names + s.elements > super::streamed::FLUSH_EDITS,
        "{s:?}"
    );
    // g0 bounds its own point (0, 0.5, 3), its coord (0, 7, 1), its implicit reference point
    // (10, 0, 30) and p1 (1, 1.5, 3), all swapped and shifted by 100.
    assert!(out.contains(r#"gml:id="g0"><gml:boundedBy><gml:Envelope srsName="EPSG:2" srsDimension="3"><gml:lowerCorner>100 100 1</gml:lowerCorner><gml:upperCorner>107 110 30</gml:upperCorner>"#), "{}", &out[..2000]);
}

#[test]
fn the_summary_line_names_both_crss_and_the_counts() {
    let rewrite = RewriteSummary {
        points: 12,
        elements: 3,
        envelopes: 2,
        srs_names: 4,
        ..RewriteSummary::default()
    };
    let s = ReprojectSummary {
        source: CrsName::parse("EPSG:25832").unwrap(),
        target: CrsName::parse("EPSG:4326").unwrap(),
        rewrite,
    };
    let line = s.line(Path::new("-"), Path::new("out.gml"));
    assert_eq!(
        line,
        format!(
            "<stdin> -> out.gml: {} -> {}, 12 points in 3 elements, 2 envelopes, 4 srsName",
            s.source, s.target
        )
    );
}
