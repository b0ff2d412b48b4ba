//! GML 3.1.1 → 3.2: the geometry keeps its elements, ids and coordinates; what GML 3.2 no
//! longer has is rewritten (`gml:coord` → `gml:pos`, `gml:coordinates` → `gml:posList` /
//! `gml:pos`, `outerBoundaryIs` / `innerBoundaryIs` → `exterior` / `interior`, a solid's shell
//! `gml:CompositeSurface` → `gml:Shell`), and a geometry that must become a multi-surface
//! (a CityGML 2.0 `lodXGeometry` of an installation, furniture, generic object, ...) is
//! gathered into one.

use super::dom::{El, Node};
use super::names::Src;

/// The element `e` (any namespace) as GML 3.2.
pub(super) fn gml(mut e: El) -> El {
    if e.ns != Src::Gml {
        return e;
    }
    let local = match e.local.as_str() {
        "outerBoundaryIs" => "exterior",
        "innerBoundaryIs" => "interior",
        "coord" => "pos",
        l => l,
    }
    .to_string();
    if e.local == "coord" {
        let t: Vec<Vec<u8>> = ["X", "Y", "Z"]
            .iter()
            .filter_map(|c| e.child(c).map(|x| x.own_text()))
            .collect();
        e.kids = vec![Node::Text(t.join(&b' '))];
    }
    e.name = format!("gml:{local}");
    e.local = local;
    e.ns = Src::Out;
    let parent = e.local.clone();
    let mut kids = Vec::with_capacity(e.kids.len());
    for n in std::mem::take(&mut e.kids) {
        match n {
            Node::El(c) if c.ns == Src::Gml && c.local == "coordinates" => {
                kids.extend(coordinates(&parent, c).into_iter().map(Node::El));
            }
            Node::El(c) => kids.push(Node::El(gml(c))),
            other => kids.push(other),
        }
    }
    e.kids = kids;
    if (e.local == "exterior" || e.local == "interior") && is_solid_boundary(&e) {
        shell(&mut e);
    }
    e
}

/// Whether `e` (an `exterior` / `interior`) bounds a solid: it holds a surface, not a ring.
fn is_solid_boundary(e: &El) -> bool {
    e.els().any(|c| {
        matches!(
            c.local.as_str(),
            "CompositeSurface"
                | "Polygon"
                | "OrientableSurface"
                | "Surface"
                | "TriangulatedSurface"
        )
    }) || (e.attr("href").is_some() && e.els().next().is_none())
}

/// A solid's boundary as a GML 3.2 `gml:Shell`.
fn shell(e: &mut El) {
    let href = e.take_attr("href");
    let inner: Vec<El> = std::mem::take(&mut e.kids)
        .into_iter()
        .filter_map(|n| match n {
            Node::El(c) => Some(c),
            _ => None,
        })
        .collect();
    let mut sh = El::new("gml:Shell");
    for c in inner {
        if c.local == "CompositeSurface" {
            sh.attrs = c.attrs.clone();
            sh.kids = c.kids;
        } else {
            sh = sh.with(El::new("gml:surfaceMember").with(c));
        }
    }
    if let Some(h) = href {
        let mut m = El::new("gml:surfaceMember");
        m.attrs.push(("xlink:href".into(), h));
        sh = sh.with(m);
    }
    e.kids = vec![Node::El(sh)];
}

/// `gml:coordinates` in an element `parent` as `gml:posList` (curves, rings), `gml:pos`
/// (a point) or a lower and upper corner (an envelope).
fn coordinates(parent: &str, c: El) -> Vec<El> {
    let attr = |k: &str, d: u8| c.attr(k).and_then(|v| v.first().copied()).unwrap_or(d);
    let (dec, cs, ts) = (attr("decimal", b'.'), attr("cs", b','), attr("ts", b' '));
    let text = c.own_text();
    let tuples: Vec<Vec<Vec<u8>>> = text
        .split(|&b| b == ts || (ts == b' ' && b.is_ascii_whitespace()))
        .filter(|t| !t.is_empty())
        .map(|t| {
            t.split(|&b| b == cs)
                .map(|x| x.iter().map(|&b| if b == dec { b'.' } else { b }).collect())
                .collect()
        })
        .collect();
    let dim = tuples.first().map_or(3, Vec::len);
    let join = |ts: &[Vec<Vec<u8>>]| -> Vec<u8> {
        ts.iter()
            .map(|t| t.join(&b' '))
            .collect::<Vec<_>>()
            .join(&b' ')
    };
    match parent {
        "Envelope" if tuples.len() == 2 => vec![
            El::new("gml:lowerCorner").text(&join(&tuples[..1])),
            El::new("gml:upperCorner").text(&join(&tuples[1..])),
        ],
        "Point" => vec![El::new("gml:pos").text(&join(&tuples))],
        _ => {
            let mut p = El::new("gml:posList").text(&join(&tuples));
            p.attrs
                .push(("srsDimension".into(), dim.to_string().into_bytes()));
            vec![p]
        }
    }
}

/// What a geometry property holds, for the 3.0 property it goes to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Shape {
    Solid,
    Surfaces,
    Curves,
    Point,
    /// A reference (`xlink:href`) or nothing.
    Unknown,
}

/// The shape of the geometry `g` (a GML element, already upgraded).
pub(super) fn shape(g: &El) -> Shape {
    match g.local.as_str() {
        "Solid" | "CompositeSolid" => Shape::Solid,
        "MultiSurface"
        | "CompositeSurface"
        | "Polygon"
        | "OrientableSurface"
        | "Surface"
        | "TriangulatedSurface"
        | "Tin"
        | "MultiSolid" => Shape::Surfaces,
        "MultiCurve" | "CompositeCurve" | "LineString" | "Curve" | "OrientableCurve" => {
            Shape::Curves
        }
        "Point" | "MultiPoint" => Shape::Point,
        "MultiGeometry" | "GeometricComplex" => {
            let shapes: Vec<Shape> = members(g).map(shape).collect();
            if shapes.is_empty() {
                Shape::Unknown
            } else if shapes.iter().all(|s| *s == Shape::Curves) {
                Shape::Curves
            } else {
                Shape::Surfaces
            }
        }
        _ => Shape::Unknown,
    }
}

/// The geometries inside an aggregate's member properties.
fn members(g: &El) -> impl Iterator<Item = &El> {
    g.els().flat_map(|m| m.els())
}

/// `g` (upgraded GML) as one `gml:MultiSurface` of its surfaces (solids give their shells'
/// surfaces), the curves it held (for a `gml:MultiCurve`), and the number of points left out.
pub(super) fn to_multi_surface(g: El) -> (El, Vec<El>, usize) {
    if g.local == "MultiSurface" {
        return (g, Vec::new(), 0);
    }
    let mut ms = El::new("gml:MultiSurface");
    let surface = matches!(shape(&g), Shape::Surfaces)
        && !matches!(
            g.local.as_str(),
            "MultiGeometry" | "GeometricComplex" | "MultiSolid"
        );
    if let (false, Some(id)) = (surface, g.attr("id")) {
        // an aggregate's id goes to the multi-surface; a surface keeps its own
        ms.attrs.push(("gml:id".into(), id.to_vec()));
    }
    if let Some(s) = g.attr("srsName") {
        ms.attrs.push(("srsName".into(), s.to_vec()));
    }
    let (mut curves, mut points) = (Vec::new(), 0);
    gather(g, &mut ms, &mut curves, &mut points);
    (ms, curves, points)
}

fn gather(g: El, ms: &mut El, curves: &mut Vec<El>, points: &mut usize) {
    match g.local.as_str() {
        "Polygon"
        | "CompositeSurface"
        | "OrientableSurface"
        | "Surface"
        | "TriangulatedSurface"
        | "Tin"
        | "Shell" => {
            let mut g = g;
            if g.local == "Shell" {
                g.local = "CompositeSurface".into();
                g.name = "gml:CompositeSurface".into();
            }
            ms.kids.push(Node::El(El::new("gml:surfaceMember").with(g)));
        }
        "Point" | "MultiPoint" => *points += 1,
        "MultiCurve" => {
            for m in g.into_els() {
                curves.extend(m.into_els());
            }
        }
        "LineString" | "CompositeCurve" | "Curve" | "OrientableCurve" => curves.push(g),
        _ => {
            // aggregates, solids, and their member / boundary properties
            for c in g.kids {
                let Node::El(c) = c else { continue };
                let property = c.local.starts_with(|ch: char| ch.is_ascii_lowercase());
                if property && c.els().next().is_none() {
                    if let Some(h) = c.attr("href") {
                        let mut m = El::new("gml:surfaceMember");
                        m.attrs.push(("xlink:href".into(), h.to_vec()));
                        ms.kids.push(Node::El(m));
                    }
                    continue;
                }
                gather(c, ms, curves, points);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> El {
        let root = br#"<CityModel xmlns:gml="http://www.opengis.net/gml" xmlns:xlink="http://www.w3.org/1999/xlink">"#;
        super::super::dom::parse(root, s.as_bytes()).unwrap()
    }

    fn text(e: &El) -> String {
        let mut w = Vec::new();
        e.write(&mut w);
        String::from_utf8(w).unwrap()
    }

    #[test]
    fn old_gml_rewritten() {
        let e = gml(parse(
            r#"<gml:Polygon gml:id="p"><gml:outerBoundaryIs><gml:LinearRing><gml:coordinates>0,0,1 1,0,1 1,1,1 0,0,1</gml:coordinates></gml:LinearRing></gml:outerBoundaryIs></gml:Polygon>"#,
        ));
        assert_eq!(
            text(&e),
            r#"<gml:Polygon gml:id="p"><gml:exterior><gml:LinearRing><gml:posList srsDimension="3">0 0 1 1 0 1 1 1 1 0 0 1</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon>"#
        );
        let p = gml(parse(
            "<gml:Point><gml:coord><gml:X>1</gml:X><gml:Y>2</gml:Y></gml:coord></gml:Point>",
        ));
        assert_eq!(text(&p), "<gml:Point><gml:pos>1 2</gml:pos></gml:Point>");
    }

    #[test]
    fn solid_shells() {
        let s = gml(parse(
            r##"<gml:Solid><gml:exterior><gml:CompositeSurface gml:id="c"><gml:surfaceMember xlink:href="#p"/></gml:CompositeSurface></gml:exterior><gml:interior xlink:href="#q"/></gml:Solid>"##,
        ));
        assert_eq!(
            text(&s),
            r##"<gml:Solid><gml:exterior><gml:Shell gml:id="c"><gml:surfaceMember xlink:href="#p"/></gml:Shell></gml:exterior><gml:interior><gml:Shell><gml:surfaceMember xlink:href="#q"/></gml:Shell></gml:interior></gml:Solid>"##
        );
        // a polygon's rings are not shells
        let p = gml(parse(
            r#"<gml:Polygon><gml:exterior><gml:LinearRing><gml:posList>0 0 0 1 0 0 1 1 0 0 0 0</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon>"#,
        ));
        assert!(!text(&p).contains("Shell"));
    }

    #[test]
    fn geometries_gathered_into_a_multi_surface() {
        let g = gml(parse(
            r##"<gml:MultiGeometry gml:id="g"><gml:geometryMember><gml:Polygon gml:id="a"/></gml:geometryMember><gml:geometryMember><gml:Solid><gml:exterior><gml:CompositeSurface><gml:surfaceMember><gml:Polygon gml:id="b"/></gml:surfaceMember></gml:CompositeSurface></gml:exterior></gml:Solid></gml:geometryMember><gml:geometryMember><gml:LineString/></gml:geometryMember></gml:MultiGeometry>"##,
        ));
        assert_eq!(shape(&g), Shape::Surfaces);
        let (ms, curves, points) = to_multi_surface(g);
        assert_eq!((curves.len(), points), (1, 0));
        let t = text(&ms);
        assert!(
            t.starts_with(
                r#"<gml:MultiSurface gml:id="g"><gml:surfaceMember><gml:Polygon gml:id="a"/>"#
            ),
            "{t}"
        );
        assert!(t.contains(r#"<gml:surfaceMember><gml:CompositeSurface><gml:surfaceMember><gml:Polygon gml:id="b"/>"#), "{t}");
    }
}
