use super::*;

const V2: &str = r##"<?xml version="1.0" encoding="UTF-8"?>
<!-- a comment -->
<CityModel xmlns="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml" xmlns:bldg="http://www.opengis.net/citygml/building/2.0" xmlns:gen="http://www.opengis.net/citygml/generics/2.0" xmlns:app="http://www.opengis.net/citygml/appearance/2.0" xmlns:xlink="http://www.w3.org/1999/xlink" xmlns:ade="urn:ade" gml:id="cm">
 <gml:boundedBy><gml:Envelope srsName="EPSG:25832" srsDimension="3"><gml:lowerCorner>0 0 0</gml:lowerCorner><gml:upperCorner>9 9 9</gml:upperCorner></gml:Envelope></gml:boundedBy>
 <cityObjectMember>
  <bldg:Building gml:id="b">
   <gml:name>B</gml:name>
   <gen:stringAttribute name="k"><gen:value>v</gen:value></gen:stringAttribute>
   <bldg:yearOfConstruction>1990</bldg:yearOfConstruction>
   <bldg:measuredHeight uom="m">9</bldg:measuredHeight>
   <bldg:lod0RoofEdge><gml:MultiSurface><gml:surfaceMember><gml:Polygon gml:id="e"><gml:exterior><gml:LinearRing><gml:posList>0 0 9 1 0 9 1 1 9 0 0 9</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></bldg:lod0RoofEdge>
   <bldg:lod2Solid><gml:Solid><gml:exterior><gml:CompositeSurface><gml:surfaceMember xlink:href="#r"/></gml:CompositeSurface></gml:exterior></gml:Solid></bldg:lod2Solid>
   <bldg:boundedBy><bldg:RoofSurface gml:id="rs"><bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember><gml:Polygon gml:id="r"><gml:exterior><gml:LinearRing><gml:posList>0 0 9 1 0 9 1 1 9 0 0 9</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface>
   <bldg:opening><bldg:Window gml:id="w"><bldg:lod4MultiSurface><gml:MultiSurface><gml:surfaceMember><gml:Polygon gml:id="wp"><gml:exterior><gml:LinearRing><gml:posList>0 0 9 1 0 9 1 1 9 0 0 9</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></bldg:lod4MultiSurface></bldg:Window></bldg:opening>
   </bldg:RoofSurface></bldg:boundedBy>
   <ade:thing>x</ade:thing>
  </bldg:Building>
 </cityObjectMember>
 <app:appearanceMember><app:Appearance><app:theme>t</app:theme><app:surfaceDataMember><app:ParameterizedTexture><app:imageURI>a.png</app:imageURI><app:target uri="#r"><app:TexCoordList><app:textureCoordinates ring="#ring">0 0 1 0 1 1 0 0</app:textureCoordinates></app:TexCoordList></app:target></app:ParameterizedTexture></app:surfaceDataMember></app:Appearance></app:appearanceMember>
</CityModel>
"##;

fn run(src: &str, o: UpgradeOptions) -> (String, UpgradeSummary) {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.gml");
    std::fs::write(&input, src).unwrap();
    let out = dir.path().join("out.gml");
    let s = upgrade(&input, &out, &o, &WriteOptions::default()).unwrap();
    (std::fs::read_to_string(&out).unwrap(), s)
}

#[test]
fn building_mapped_to_3_0() {
    let (t, s) = run(V2, UpgradeOptions::default());
    assert!(
        t.starts_with(
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<!-- a comment -->\n<core:CityModel "
        ),
        "{t}"
    );
    assert!(t.contains(r#"xmlns:ade="urn:ade""#) && t.contains(r#"gml:id="cm""#));
    assert!(t.trim_end().ends_with("</core:CityModel>"));
    for want in [
        r#"<core:cityObjectMember><bldg:Building gml:id="b"><gml:name>B</gml:name><core:genericAttribute><gen:StringAttribute><gen:name>k</gen:name><gen:value>v</gen:value></gen:StringAttribute></core:genericAttribute><core:boundary><con:RoofSurface gml:id="rs">"#,
        r##"<core:lod2Solid><gml:Solid><gml:exterior><gml:Shell><gml:surfaceMember xlink:href="#r"/></gml:Shell></gml:exterior></gml:Solid></core:lod2Solid>"##,
        r#"<con:dateOfConstruction>1990-01-01</con:dateOfConstruction><con:height><con:Height>"#,
        r#"<con:value uom="m">9</con:value>"#,
        r#"<con:fillingSurface><con:WindowSurface gml:id="w"/></con:fillingSurface>"#,
        r#"<ade:thing>x</ade:thing></bldg:Building>"#,
        r##"<core:appearanceMember><app:Appearance><app:theme>t</app:theme><app:surfaceData><app:ParameterizedTexture><app:imageURI>a.png</app:imageURI><app:textureParameterization><app:TextureAssociation><app:target>#r</app:target><app:textureParameterization><app:TexCoordList><app:textureCoordinates>0 0 1 0 1 1 0 0</app:textureCoordinates><app:ring>#ring</app:ring></app:TexCoordList>"##,
    ] {
        assert!(t.contains(want), "missing {want} in {t}");
    }
    // LoD4 and the roof edge have no 3.0 place by default
    assert!(!t.contains("lod4") && !t.contains(r#"gml:id="e""#) && !t.contains("wp"));
    assert_eq!(s.dropped.len(), 2, "{:?}", s.dropped);
    assert_eq!((s.members, s.city_objects, s.from.as_str()), (1, 3, "2.0"));
    assert_eq!((s.generic_attributes, s.appearance_targets), (1, 1));
}

#[test]
fn options_map_lod4_and_roof_edges() {
    let (t, s) = run(V2, UpgradeOptions::new(true, true, true));
    assert!(t.contains(r#"<con:WindowSurface gml:id="w"><core:lod3MultiSurface><gml:MultiSurface><gml:surfaceMember><gml:Polygon gml:id="wp">"#), "{t}");
    assert!(t.contains(r#"<core:boundary><con:RoofSurface><core:lod0MultiSurface><gml:MultiSurface><gml:surfaceMember><gml:Polygon gml:id="e">"#), "{t}");
    assert!(s.dropped.is_empty(), "{:?}", s.dropped);
    assert_eq!((s.lod4_as_lod3, s.mapped), (1, 1));
    assert!(s
        .describe(Path::new("a"), Path::new("b"))
        .contains("1 LoD4 propert(ies) as LoD3"));
}

#[test]
fn version_3_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.gml");
    std::fs::write(
        &input,
        r#"<CityModel xmlns="http://www.opengis.net/citygml/3.0"/>"#,
    )
    .unwrap();
    std::fs::write(
        &input,
        r#"<core:CityModel xmlns:core="http://www.opengis.net/citygml/3.0"></core:CityModel>"#,
    )
    .unwrap();
    let e = upgrade(
        &input,
        &dir.path().join("o.gml"),
        &UpgradeOptions::default(),
        &WriteOptions::default(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("already CityGML 3.0"), "{e}");
    assert!(!dir.path().join("o.gml").exists());
}
