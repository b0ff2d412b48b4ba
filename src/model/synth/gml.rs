//! CityGML 2.0 text output of the district generator: fixed-precision coordinates (3
//! decimals, so output is byte-deterministic), one `gml:Polygon` per line, element order as
//! the building schema requires (`roofType`, `measuredHeight`, `storeysAboveGround`, then
//! `outerBuildingInstallation`, then `boundedBy`; inside a boundary surface `lod2MultiSurface`,
//! `lod3MultiSurface`, then `opening`). Every written element is counted into the summary.
//!
//! # Example
//!
//! ```rust
//! let mut buf = Vec::new();
//! skylod::model::synth::push_num(&mut buf, -12.3456);
//! buf.push(b' ');
//! skylod::model::synth::push_num(&mut buf, 4581000.0004);
//! assert_eq!(buf, b"-12.346 4581000.000");
//! ```

use super::building::{BuildingGeom, OpeningKind, SurfaceKind};
use super::layout::{Lot, GROUND_Z};
use super::SynthSummary;
use crate::model::Bbox;
use std::ops::Range;

/// Append `v` with exactly 3 decimals (rounded half away from zero to the millimetre).
pub fn push_num(buf: &mut Vec<u8>, v: f64) {
    let mm = (v * 1000.0).round();
    let mm = if mm.is_finite() { mm as i64 } else { 0 };
    if mm < 0 {
        buf.push(b'-');
    }
    let a = mm.unsigned_abs();
    push_u64(buf, a / 1000);
    let f = a % 1000;
    buf.extend_from_slice(&[
        b'.',
        b'0' + (f / 100) as u8,
        b'0' + (f / 10 % 10) as u8,
        b'0' + (f % 10) as u8,
    ]);
}

/// Append a decimal integer.
pub fn push_u64(buf: &mut Vec<u8>, mut v: u64) {
    let mut tmp = [0u8; 20];
    let mut i = tmp.len();
    loop {
        i -= 1;
        if let Some(t) = tmp.get_mut(i) {
            *t = b'0' + (v % 10) as u8;
        }
        v /= 10;
        if v == 0 || i == 0 {
            break;
        }
    }
    buf.extend_from_slice(tmp.get(i..).unwrap_or(&[]));
}

/// Round a coordinate the way [`push_num`] writes it.
pub fn round_mm(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

/// The gml:id of a building.
pub fn building_id(lot: &Lot) -> String {
    format!("B{}_{}_{}", lot.bx, lot.by, lot.index)
}

/// The gml:id of opening `k` of building `bid`.
pub fn opening_id(bid: &str, k: usize) -> String {
    format!("{bid}_o{k}")
}

/// Document head up to the envelope.
pub fn header(buf: &mut Vec<u8>, name: &str, bbox: &Bbox) {
    buf.extend_from_slice(
        b"<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n\
<core:CityModel xmlns:core=\"http://www.opengis.net/citygml/2.0\" \
xmlns:bldg=\"http://www.opengis.net/citygml/building/2.0\" \
xmlns:gml=\"http://www.opengis.net/gml\" \
xmlns:xlink=\"http://www.w3.org/1999/xlink\" \
xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" \
xsi:schemaLocation=\"http://www.opengis.net/citygml/2.0 http://schemas.opengis.net/citygml/2.0/cityGMLBase.xsd \
http://www.opengis.net/citygml/building/2.0 http://schemas.opengis.net/citygml/building/2.0/building.xsd\">\n<gml:name>",
    );
    for c in name.bytes() {
        match c {
            b'<' => buf.extend_from_slice(b"&lt;"),
            b'>' => buf.extend_from_slice(b"&gt;"),
            b'&' => buf.extend_from_slice(b"&amp;"),
            _ => buf.push(c),
        }
    }
    buf.extend_from_slice(
        b"</gml:name>\n<gml:boundedBy>\n<gml:Envelope srsName=\"EPSG:25831\" srsDimension=\"3\">\n<gml:lowerCorner>",
    );
    push_point(buf, bbox.min);
    buf.extend_from_slice(b"</gml:lowerCorner>\n<gml:upperCorner>");
    push_point(buf, bbox.max);
    buf.extend_from_slice(b"</gml:upperCorner>\n</gml:Envelope>\n</gml:boundedBy>\n");
}

/// Document end.
pub fn footer(buf: &mut Vec<u8>) {
    buf.extend_from_slice(b"</core:CityModel>\n");
}

fn push_point(buf: &mut Vec<u8>, p: glam::DVec3) {
    push_num(buf, p.x);
    buf.push(b' ');
    push_num(buf, p.y);
    buf.push(b' ');
    push_num(buf, p.z);
}

struct Ids<'a> {
    bid: &'a str,
    poly: u64,
}

fn open_id(buf: &mut Vec<u8>, tag: &[u8], ids: &Ids, suffix: &[u8], k: u64) {
    buf.push(b'<');
    buf.extend_from_slice(tag);
    buf.extend_from_slice(b" gml:id=\"");
    buf.extend_from_slice(ids.bid.as_bytes());
    buf.push(b'_');
    buf.extend_from_slice(suffix);
    push_u64(buf, k);
    buf.extend_from_slice(b"\">\n");
}

fn multi_surface(
    buf: &mut Vec<u8>,
    prop: &[u8],
    g: &BuildingGeom,
    polys: Range<u32>,
    ids: &mut Ids,
    sum: &mut SynthSummary,
) {
    if polys.is_empty() {
        return;
    }
    buf.push(b'<');
    buf.extend_from_slice(prop);
    buf.extend_from_slice(b">\n<gml:MultiSurface>\n");
    for p in polys {
        buf.extend_from_slice(b"<gml:surfaceMember><gml:Polygon gml:id=\"");
        buf.extend_from_slice(ids.bid.as_bytes());
        buf.extend_from_slice(b"_p");
        push_u64(buf, ids.poly);
        ids.poly += 1;
        buf.extend_from_slice(b"\">");
        for (k, r) in g.mesh.rings_of(p).enumerate() {
            buf.extend_from_slice(if k == 0 {
                b"<gml:exterior>".as_slice()
            } else {
                b"<gml:interior>".as_slice()
            });
            buf.extend_from_slice(b"<gml:LinearRing><gml:posList srsDimension=\"3\">");
            let ring = g.mesh.ring(r);
            for (i, q) in ring.iter().chain(ring.first()).enumerate() {
                if i > 0 {
                    buf.push(b' ');
                }
                push_point(buf, *q);
            }
            buf.extend_from_slice(b"</gml:posList></gml:LinearRing>");
            buf.extend_from_slice(if k == 0 {
                b"</gml:exterior>".as_slice()
            } else {
                b"</gml:interior>".as_slice()
            });
        }
        buf.extend_from_slice(b"</gml:Polygon></gml:surfaceMember>\n");
        sum.polygons += 1;
    }
    buf.extend_from_slice(b"</gml:MultiSurface>\n</");
    buf.extend_from_slice(prop);
    buf.extend_from_slice(b">\n");
}

/// The property `prop` holding the feature `<tag gml:id="{building}_{suffix}{k}">` (the
/// building's id from `ids`) with what `content` writes in it.
fn feature(
    buf: &mut Vec<u8>,
    prop: &[u8],
    tag: &[u8],
    (ids, suffix, k): (&mut Ids, &[u8], usize),
    sum: &mut SynthSummary,
    content: impl FnOnce(&mut Vec<u8>, &mut Ids, &mut SynthSummary),
) {
    buf.push(b'<');
    buf.extend_from_slice(prop);
    buf.extend_from_slice(b">\n");
    open_id(buf, tag, ids, suffix, k as u64);
    content(buf, ids, sum);
    buf.extend_from_slice(b"</");
    buf.extend_from_slice(tag);
    buf.extend_from_slice(b">\n</");
    buf.extend_from_slice(prop);
    buf.extend_from_slice(b">\n");
}

/// One `core:cityObjectMember` with its building.
pub fn building(buf: &mut Vec<u8>, g: &BuildingGeom, sum: &mut SynthSummary) {
    let Some(lot) = g.lot.as_ref() else {
        return;
    };
    let bid = building_id(lot);
    let mut ids = Ids { bid: &bid, poly: 0 };
    buf.extend_from_slice(b"<core:cityObjectMember>\n");
    buf.extend_from_slice(b"<bldg:Building gml:id=\"");
    buf.extend_from_slice(bid.as_bytes());
    buf.extend_from_slice(b"\">\n");
    buf.extend_from_slice(b"<bldg:roofType codeSpace=\"http://www.sig3d.org/codelists/standard/building/2.0/_AbstractBuilding_roofType.xml\">");
    buf.extend_from_slice(if g.pitched { b"1030" } else { b"1000" });
    buf.extend_from_slice(b"</bldg:roofType>\n<bldg:measuredHeight uom=\"m\">");
    push_num(buf, g.top_z - GROUND_Z);
    buf.extend_from_slice(b"</bldg:measuredHeight>\n<bldg:storeysAboveGround>");
    push_u64(buf, g.storeys as u64);
    buf.extend_from_slice(b"</bldg:storeysAboveGround>\n");
    sum.buildings += 1;

    for (k, inst) in g.installations.iter().enumerate() {
        let prop = b"bldg:outerBuildingInstallation";
        let tag = b"bldg:BuildingInstallation";
        feature(buf, prop, tag, (&mut ids, b"i", k), sum, |buf, ids, sum| {
            buf.extend_from_slice(b"<bldg:function>");
            buf.extend_from_slice(inst.kind.code().as_bytes());
            buf.extend_from_slice(b"</bldg:function>\n");
            multi_surface(buf, b"bldg:lod3Geometry", g, inst.polys.clone(), ids, sum);
        });
        *sum.installations.entry(inst.kind).or_insert(0) += 1;
    }

    for (k, s) in g.surfaces.iter().enumerate() {
        let (tag, count): (&[u8], _) = match s.kind {
            SurfaceKind::Wall => (b"bldg:WallSurface", &mut sum.wall_surfaces),
            SurfaceKind::Roof => (b"bldg:RoofSurface", &mut sum.roof_surfaces),
            SurfaceKind::Ground => (b"bldg:GroundSurface", &mut sum.ground_surfaces),
        };
        *count += 1;
        feature(
            buf,
            b"bldg:boundedBy",
            tag,
            (&mut ids, b"s", k),
            sum,
            |buf, ids, sum| {
                for (prop, polys) in [
                    (b"bldg:lod2MultiSurface", &s.lod2),
                    (b"bldg:lod3MultiSurface", &s.lod3),
                ] {
                    multi_surface(buf, prop, g, polys.clone(), ids, sum);
                }
                for oi in s.openings.clone() {
                    let Some(o) = g.openings.get(oi as usize) else {
                        continue;
                    };
                    let (tag, count): (&[u8], _) = match o.kind {
                        OpeningKind::Window => (b"bldg:Window", &mut sum.windows),
                        OpeningKind::Door => (b"bldg:Door", &mut sum.doors),
                    };
                    *count += 1;
                    let id = (&mut *ids, b"o".as_slice(), oi as usize);
                    feature(buf, b"bldg:opening", tag, id, sum, |buf, ids, sum| {
                        multi_surface(buf, b"bldg:lod3MultiSurface", g, o.polys.clone(), ids, sum);
                    });
                }
            },
        );
    }
    buf.extend_from_slice(b"</bldg:Building>\n</core:cityObjectMember>\n");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_fixed_precision() {
        let cases = [
            (0.0, "0.000"),
            (-0.0004, "0.000"),
            (-0.0006, "-0.001"),
            (1.5, "1.500"),
            (430000.1234, "430000.123"),
            (-7.0005, "-7.001"),
            (12345678.9, "12345678.900"),
        ];
        for (v, s) in cases {
            let mut b = Vec::new();
            push_num(&mut b, v);
            assert_eq!(std::str::from_utf8(&b).ok(), Some(s), "{v}");
            assert!((s.parse::<f64>().unwrap_or(f64::NAN) - round_mm(v)).abs() < 1e-9);
        }
        let mut b = Vec::new();
        push_u64(&mut b, 0);
        push_u64(&mut b, 1234567890);
        assert_eq!(b, b"01234567890");
    }
}
