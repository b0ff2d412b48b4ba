use super::*;

const DOC: &str = r#"{"type":"CityJSON","version":"2.0",
 "transform":{"scale":[0.001,0.001,0.001],"translate":[1000,2000,0]},
 "metadata":{"referenceSystem":"https://www.opengis.net/def/crs/EPSG/0/7415"},
 "CityObjects":{
  "b":{"type":"Building","attributes":{"measuredHeight":3.0,"roofType":"flat","yearOfConstruction":"ca. 1900","owner":"x","n":2},
       "children":["p","i"],"geometry":[{"type":"Solid","lod":"1.2","boundaries":[[[[0,1,2,3]],[[4,5,6,7]]]]}]},
  "p":{"type":"BuildingPart","parents":["b"],"geometry":[
     {"type":"Solid","lod":"2.2","boundaries":[[[[0,1,2,3]],[[4,5,6,7]],[[0,1,5,4]],[[1,2,6,5]]]],
      "semantics":{"surfaces":[{"type":"GroundSurface"},{"type":"RoofSurface","slope":0},{"type":"WallSurface"}],
        "values":[[0,1,2,null]]}},
     {"type":"MultiSurface","lod":"3","boundaries":[[[0,1,5,4]],[[1,2,6]]],
      "semantics":{"surfaces":[{"type":"WallSurface"},{"type":"Window","parent":0}],"values":[0,1]}}]},
  "i":{"type":"BuildingInstallation","parents":["b"],"geometry":[{"type":"MultiSurface","lod":"2","boundaries":[[[4,5,6]]]}]},
  "1 room":{"type":"BuildingRoom","parents":["p"]},
  "9tree":{"type":"SolitaryVegetationObject","geometry":[{"type":"GeometryInstance","template":0,"boundaries":[0],
     "transformationMatrix":[2,0,0,0,0,2,0,0,0,0,2,0,0,0,0,1]}]}},
 "geometry-templates":{"templates":[{"type":"MultiSurface","lod":"2","boundaries":[[[0,1,2]]]}],
    "vertices-templates":[[0,0,0],[1,0,0],[0,1,0]]},
 "vertices":[[0,0,0],[1000,0,0],[1000,1000,0],[0,1000,0],[0,0,3000],[1000,0,3000],[1000,1000,3000],[0,1000,3000]]}"#;

fn convert(doc: &str) -> (String, FromCityJsonSummary) {
    let mut out = Vec::new();
    let s = write_citygml(doc.as_bytes(), Path::new("t.city.json"), &mut out).unwrap();
    (String::from_utf8(out).unwrap(), s)
}

#[test]
fn buildings_parts_surfaces_openings_and_templates() {
    let (x, s) = convert(DOC);
    assert!(x.contains("srsName=\"urn:ogc:def:crs:EPSG::7415\""), "{x}");
    assert_eq!(s.members, 2, "{x}");
    assert_eq!(s.objects.get("Building"), Some(&1));
    assert_eq!(s.objects.get("BuildingPart"), Some(&1));
    assert_eq!(s.objects.get("BuildingInstallation"), Some(&1));
    assert_eq!(s.objects.get("WallSurface"), Some(&2));
    assert_eq!(s.ids_made, 1);
    assert!(
        s.dropped.contains_key("BuildingRoom (no CityGML 2.0 type)"),
        "{:?}",
        s.dropped
    );
    // the LoD 2 solid refers to its semantic polygons, holds the unclassified one
    assert!(
        x.contains("<gml:surfaceMember xlink:href=\"#p.g0.p1\"/>"),
        "{x}"
    );
    assert!(x.contains("<gml:Polygon gml:id=\"p.g0.p1\">"));
    assert_eq!(x.matches("xlink:href=\"#p.g0.p").count(), 3);
    // transform applied, printed with the scale's decimals, rings closed
    assert!(x.contains("<gml:posList srsDimension=\"3\">1000 2000 0 1001 2000 0 1001 2001 0 1000 2001 0 1000 2000 0</gml:posList>"), "{x}");
    // attributes: properties in schema order, the rest generic
    let h = x.find("<bldg:roofType>flat</bldg:roofType>").unwrap();
    let m = x
        .find("<bldg:measuredHeight uom=\"m\">3</bldg:measuredHeight>")
        .unwrap();
    let g = x
        .find("<gen:stringAttribute name=\"yearOfConstruction\">")
        .unwrap();
    assert!(g < h && h < m);
    // parts and installations nested, in schema order
    let inst = x.find("<bldg:outerBuildingInstallation>").unwrap();
    let part = x.find("<bldg:consistsOfBuildingPart>").unwrap();
    assert!(x.find("<bldg:lod1Solid>").unwrap() < inst && inst < part);
    // LoD 3 opening under its wall
    assert!(
        x.contains("<bldg:opening><bldg:Window><bldg:lod3MultiSurface>"),
        "{x}"
    );
    // implicit geometry, id made
    assert!(x.contains("<veg:SolitaryVegetationObject gml:id=\"id_9tree\">"));
    assert!(x.contains("<veg:lod2ImplicitRepresentation><core:ImplicitGeometry><core:transformationMatrix>2 0 0 0 0 2 0 0 0 0 2 0 0 0 0 1</core:transformationMatrix>"));
    assert!(x.contains(
        "<core:referencePoint><gml:Point><gml:pos srsDimension=\"3\">1000 2000 0</gml:pos>"
    ));
    // the envelope of each member
    assert!(x.contains("<bldg:Building gml:id=\"b\"><gml:boundedBy><gml:Envelope srsName=\"urn:ogc:def:crs:EPSG::7415\" srsDimension=\"3\"><gml:lowerCorner>1000 2000 0</gml:lowerCorner><gml:upperCorner>1001 2001 3</gml:upperCorner>"), "{x}");
}

#[test]
fn seq_is_written_feature_by_feature_and_errors_name_the_line() {
    let seq = concat!(
        r#"{"type":"CityJSON","version":"2.0","transform":{"scale":[1,1,1],"translate":[0,0,0]},"metadata":{"geographicalExtent":[0,0,0,1,1,0]},"CityObjects":{},"vertices":[]}"#,
        "\n",
        r#"{"type":"CityJSONFeature","id":"a","CityObjects":{"a":{"type":"LandUse","geometry":[{"type":"MultiSurface","lod":"1","boundaries":[[[0,1,2]]]}]}},"vertices":[[0,0,0],[1,0,0],[1,1,0]]}"#,
        "\n",
        r#"{"type":"CityJSONFeature","id":"b","CityObjects":{"b":{"type":"Waterway","geometry":[]}},"vertices":[]}"#,
        "\n",
    );
    let (x, s) = convert(seq);
    assert!(s.seq);
    // Waterway has no CityGML 2.0 type: a generic object that says which (counted)
    assert_eq!(s.members, 2);
    assert!(x.contains("<gen:GenericCityObject gml:id=\"b\"><gen:stringAttribute name=\"cityjson_type\"><gen:value>Waterway</gen:value>"), "{x}");
    assert_eq!(s.dropped.len(), 1, "{:?}", s.dropped);
    assert!(x.contains("<luse:lod1MultiSurface><gml:MultiSurface><gml:surfaceMember><gml:Polygon>"));
    assert!(x.starts_with("<?xml") && x.contains("<gml:boundedBy><gml:Envelope srsDimension=\"3\"><gml:lowerCorner>0 0 0</gml:lowerCorner>"));
    let bad = seq.replace("[[[0,1,2]]]", "[[[0,1,7]]]");
    let e = write_citygml(bad.as_bytes(), Path::new("t.city.jsonl"), &mut Vec::new()).unwrap_err();
    let FromCityJsonError::CityJson(e) = e else {
        panic!("{e}")
    };
    assert_eq!((e.line, e.id.as_deref()), (2, Some("a")));
    for odd in [
        "",
        "{",
        "[1]",
        r#"{"type":"CityJSONFeature"}"#,
        r#"{"type":"CityJSON","CityObjects":{"a":{"type":"Building","geometry":[{"type":"Solid","lod":2,"boundaries":7}]}}}"#,
    ] {
        assert!(
            write_citygml(odd.as_bytes(), Path::new("o.json"), &mut Vec::new()).is_err(),
            "{odd}"
        );
    }
}

#[test]
fn a_document_in_chunks_is_written_as_whole() {
    use crate::io::cityjson::chunks::{prepare, Input};
    let dir = tempfile::tempdir().unwrap();
    // an appearance, and a tree that is its own chunk after the building's
    let doc = DOC.replace(
        r#""type":"CityJSON","#,
        r#""type":"CityJSON","appearance":{"materials":[]},"#,
    );
    let path = dir.path().join("t.city.json");
    std::fs::write(&path, &doc).unwrap();
    let (whole, ws) = convert(&doc);
    assert!(ws.dropped.contains_key("appearance (materials, textures)"));
    for chunk in [1, 1 << 20] {
        let p = prepare::<()>(Input::File(&path), &path, chunk)
            .ok()
            .flatten()
            .unwrap();
        let mut out = Vec::new();
        let s = document::write_chunked(&path, p, &mut out).unwrap();
        assert_eq!(String::from_utf8(out).unwrap(), whole, "chunk {chunk}");
        assert_eq!(s, ws, "chunk {chunk}");
    }
    // through the file API: 2.0 and 3.0 the same bytes as the whole conversion
    let opts = WriteOptions::default();
    for v in [TargetVersion::V2_0, TargetVersion::V3_0] {
        let a = dir.path().join(format!("a{v:?}.gml"));
        let b = dir.path().join(format!("b{v:?}.gml"));
        let sa = citygml_from_cityjson(&path, &a, v, &opts).unwrap();
        let sb = citygml_from_cityjson_chunked(&path, &b, v, &opts, 1).unwrap();
        assert_eq!(sa, sb);
        assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    }
    // an object that is refused names the file and the object
    let bad = doc.replace("[[[4,5,6]]]", "[[[4,5,66]]]");
    assert_ne!(bad, doc);
    std::fs::write(&path, &bad).unwrap();
    let out = dir.path().join("bad.gml");
    let e = citygml_from_cityjson_chunked(&path, &out, TargetVersion::V2_0, &opts, 1)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("t.city.json") && e.contains("[city object i]"),
        "{e}"
    );
    assert!(!out.exists());
}
