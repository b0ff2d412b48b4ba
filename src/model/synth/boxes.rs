//! Box scenes: small CityGML 2.0 documents of box buildings (LoD2 thematic surfaces: four
//! walls, a flat roof, a ground) with box installations, for tests with known geometry,
//! property tests and the pipeline fuzz target. The same layout as the hand-made scenes of
//! `fixtures/scenes/` (walls `B_wall0..3` = south, east, north, west; `B_roof`; `B_ground`).
//!
//! # Example
//! ```
//! use skylod::model::synth::{BoxBuilding, boxes_citygml};
//! let b = BoxBuilding { id: "B".into(), min: [0.0, 0.0], max: [10.0, 8.0], height: 6.0,
//!     installations: vec![[2.0, 2.0, 6.0, 3.0, 3.0, 7.5]] };
//! let xml = boxes_citygml(&[b], [430000.0, 4581000.0, 10.0]);
//! let m = skylod::io::citygml::read_bytes(xml.as_bytes(), "boxes.gml").unwrap();
//! assert_eq!(m.assets.len(), 7); // 4 walls, roof, ground, one installation
//! ```

use std::fmt::Write as _;

/// A box building: footprint `min..max` (local x, y), walls up to `height`, flat roof, and
/// installations as boxes `[x0, y0, z0, x1, y1, z1]` (local coordinates).
#[derive(Debug, Clone, PartialEq)]
pub struct BoxBuilding {
    /// gml:id of the building (ids of its surfaces derive from it).
    pub id: String,
    /// South-west corner of the footprint.
    pub min: [f64; 2],
    /// North-east corner of the footprint.
    pub max: [f64; 2],
    /// Height of walls and roof above the ground (z = 0).
    pub height: f64,
    /// Installation boxes.
    pub installations: Vec<[f64; 6]>,
}

type P = [f64; 3];

fn ring(out: &mut String, origin: P, pts: &[P]) {
    for p in pts.iter().chain(pts.first()) {
        let _ = write!(
            out,
            "{} {} {} ",
            origin[0] + p[0],
            origin[1] + p[1],
            origin[2] + p[2]
        );
    }
    out.pop();
}

fn multi(out: &mut String, prop: &str, id: &str, origin: P, rings: &[Vec<P>]) {
    let _ = write!(out, "<bldg:{prop}><gml:MultiSurface>");
    for (k, r) in rings.iter().enumerate() {
        let _ = write!(
            out,
            "<gml:surfaceMember><gml:Polygon gml:id=\"{id}_{k}\"><gml:exterior><gml:LinearRing>\
             <gml:posList srsDimension=\"3\">"
        );
        ring(out, origin, r);
        out.push_str(
            "</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember>",
        );
    }
    let _ = write!(out, "</gml:MultiSurface></bldg:{prop}>");
}

/// The six faces of a box, counter-clockwise seen from outside.
pub fn box_faces(b: [f64; 6]) -> Vec<Vec<P>> {
    let [x0, y0, z0, x1, y1, z1] = b;
    vec![
        vec![[x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]],
        vec![[x0, y0, z0], [x0, y1, z0], [x1, y1, z0], [x1, y0, z0]],
        vec![[x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1]],
        vec![[x1, y0, z0], [x1, y1, z0], [x1, y1, z1], [x1, y0, z1]],
        vec![[x1, y1, z0], [x0, y1, z0], [x0, y1, z1], [x1, y1, z1]],
        vec![[x0, y1, z0], [x0, y0, z0], [x0, y0, z1], [x0, y1, z1]],
    ]
}

/// A CityGML 2.0 document (EPSG:25831) of `buildings`, every local coordinate shifted by
/// `origin`. Valid against the official XSD for positive sizes.
pub fn boxes_citygml(buildings: &[BoxBuilding], origin: P) -> String {
    let mut s = String::with_capacity(4096 * buildings.len().max(1));
    s.push_str(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<core:CityModel \
         xmlns:core=\"http://www.opengis.net/citygml/2.0\" \
         xmlns:bldg=\"http://www.opengis.net/citygml/building/2.0\" \
         xmlns:gml=\"http://www.opengis.net/gml\">\n",
    );
    for b in buildings {
        let ([x0, y0], [x1, y1], h) = (b.min, b.max, b.height);
        let _ = write!(
            s,
            "<core:cityObjectMember><bldg:Building gml:id=\"{}\">",
            b.id
        );
        for (k, inst) in b.installations.iter().enumerate() {
            let iid = format!("{}_i{k}", b.id);
            let _ = write!(
                s,
                "<bldg:outerBuildingInstallation><bldg:BuildingInstallation gml:id=\"{iid}\">"
            );
            multi(
                &mut s,
                "lod2Geometry",
                &format!("{iid}_p"),
                origin,
                &box_faces(*inst),
            );
            s.push_str("</bldg:BuildingInstallation></bldg:outerBuildingInstallation>");
        }
        let c = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
        let mut surfaces: Vec<(&str, String, Vec<P>)> = (0..4)
            .map(|k| {
                let (a, e) = (c[k], c[(k + 1) % 4]);
                (
                    "WallSurface",
                    format!("{}_wall{k}", b.id),
                    vec![
                        [a[0], a[1], 0.0],
                        [e[0], e[1], 0.0],
                        [e[0], e[1], h],
                        [a[0], a[1], h],
                    ],
                )
            })
            .collect();
        surfaces.push((
            "RoofSurface",
            format!("{}_roof", b.id),
            vec![[x0, y0, h], [x1, y0, h], [x1, y1, h], [x0, y1, h]],
        ));
        surfaces.push((
            "GroundSurface",
            format!("{}_ground", b.id),
            vec![[x0, y0, 0.0], [x0, y1, 0.0], [x1, y1, 0.0], [x1, y0, 0.0]],
        ));
        for (elem, sid, r) in surfaces {
            let _ = write!(s, "<bldg:boundedBy><bldg:{elem} gml:id=\"{sid}\">");
            multi(
                &mut s,
                "lod2MultiSurface",
                &format!("{sid}_p"),
                origin,
                &[r],
            );
            let _ = write!(s, "</bldg:{elem}></bldg:boundedBy>");
        }
        s.push_str("</bldg:Building></core:cityObjectMember>\n");
    }
    s.push_str("</core:CityModel>\n");
    s
}
