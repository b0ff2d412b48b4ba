//! CityJSON boundaries → GML 3.1.1: polygons with closed rings (`gml:posList`, 3-D), solids
//! (`gml:exterior/gml:CompositeSurface`), multi-surfaces, curves, points, implicit geometry.

use super::doc::{Geometry, Templates};
use super::values::{push_number, Coords};
use serde_json::Value;
use std::fmt::Write as _;

/// One polygon: rings of vertex indices (exterior first) and its semantic surface index.
#[derive(Debug, Clone)]
pub(super) struct Poly {
    pub rings: Vec<Vec<usize>>,
    pub sem: Option<usize>,
}

/// A geometry's boundaries, read.
#[derive(Debug)]
pub(super) enum Parsed {
    /// `MultiSurface`, `CompositeSurface` (`composite`).
    Surfaces { polys: Vec<Poly>, composite: bool },
    /// `Solid` (one), `MultiSolid` / `CompositeSolid`: solids → shells → polygons.
    Solids {
        solids: Vec<Vec<Vec<Poly>>>,
        kind: SolidKind,
    },
    /// `MultiLineString`.
    Curves(Vec<Vec<usize>>),
    /// `MultiPoint`.
    Points(Vec<usize>),
}

/// Which solid type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum SolidKind {
    Solid,
    Multi,
    Composite,
}

/// How one polygon of a geometry is written where it is a member.
#[derive(Debug, Clone)]
pub(super) enum Member {
    /// Inline, with this `gml:id` if any.
    Inline(Option<String>),
    /// A reference to the polygon written (with that id) in a thematic surface.
    Href(String),
    /// Not here (in a thematic surface only).
    Skip,
}

impl Parsed {
    /// Every polygon in order (solid, shell, surface).
    pub fn polys(&self) -> Vec<&Poly> {
        match self {
            Parsed::Surfaces { polys, .. } => polys.iter().collect(),
            Parsed::Solids { solids, .. } => solids.iter().flatten().flatten().collect(),
            _ => Vec::new(),
        }
    }
}

fn indices(v: &Value, n: usize) -> Result<Vec<usize>, String> {
    let a = v.as_array().ok_or("a ring is not an array")?;
    a.iter()
        .map(|i| {
            i.as_u64()
                .map(|i| i as usize)
                .filter(|i| *i < n)
                .ok_or_else(|| format!("vertex index {i} is not one of the {n} vertices"))
        })
        .collect()
}

fn arr(v: &Value) -> Result<&Vec<Value>, String> {
    v.as_array()
        .ok_or_else(|| "boundaries are not nested arrays".to_string())
}

fn surfaces(b: &Value, values: Option<&Value>, n: usize) -> Result<Vec<Poly>, String> {
    arr(b)?
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let rings = arr(s)?
                .iter()
                .map(|r| indices(r, n))
                .collect::<Result<Vec<_>, _>>()?;
            let sem = values
                .and_then(|v| v.get(k))
                .and_then(Value::as_u64)
                .map(|i| i as usize);
            Ok(Poly { rings, sem })
        })
        .collect()
}

/// Read `g`'s boundaries against `n` vertices.
pub(super) fn parse(g: &Geometry, n: usize) -> Result<Parsed, String> {
    let values = g.semantics.as_ref().map(|s| &s.values);
    let b = &g.boundaries();
    let shells = |b: &Value, v: Option<&Value>| -> Result<Vec<Vec<Poly>>, String> {
        arr(b)?
            .iter()
            .enumerate()
            .map(|(k, sh)| surfaces(sh, v.and_then(|v| v.get(k)), n))
            .collect()
    };
    Ok(match g.ty.as_str() {
        "MultiSurface" | "CompositeSurface" => Parsed::Surfaces {
            polys: surfaces(b, values, n)?,
            composite: g.ty == "CompositeSurface",
        },
        "Solid" => Parsed::Solids {
            solids: vec![shells(b, values)?],
            kind: SolidKind::Solid,
        },
        "MultiSolid" | "CompositeSolid" => Parsed::Solids {
            solids: arr(b)?
                .iter()
                .enumerate()
                .map(|(k, so)| shells(so, values.and_then(|v| v.get(k))))
                .collect::<Result<_, _>>()?,
            kind: if g.ty == "MultiSolid" {
                SolidKind::Multi
            } else {
                SolidKind::Composite
            },
        },
        "MultiLineString" => Parsed::Curves(
            arr(b)?
                .iter()
                .map(|l| indices(l, n))
                .collect::<Result<_, _>>()?,
        ),
        "MultiPoint" => Parsed::Points(indices(b, n)?),
        t => return Err(format!("geometry type {t:?} is not a CityJSON geometry")),
    })
}

/// The vertices of one document or feature in real coordinates, and how to print them;
/// the box of every vertex written (the feature's envelope).
pub(super) struct Verts<'a> {
    pub list: &'a [[f64; 3]],
    pub coords: Coords,
    pub bbox: [f64; 6],
}

impl Verts<'_> {
    pub fn reset_box(&mut self) {
        self.bbox = [f64::MAX, f64::MAX, f64::MAX, f64::MIN, f64::MIN, f64::MIN];
    }

    fn push(&mut self, s: &mut String, i: usize) {
        let p = self.list[i];
        for (a, v) in p.iter().enumerate() {
            self.bbox[a] = self.bbox[a].min(*v);
            self.bbox[a + 3] = self.bbox[a + 3].max(*v);
        }
        self.coords.push(s, p);
    }

    /// A closed ring (`None` for one of fewer than 3 vertices).
    fn ring(&mut self, s: &mut String, r: &[usize]) -> bool {
        if r.len() < 3 {
            return false;
        }
        s.push_str("<gml:LinearRing><gml:posList srsDimension=\"3\">");
        for (k, i) in r.iter().chain(std::iter::once(&r[0])).enumerate() {
            if k > 0 {
                s.push(' ');
            }
            self.push(s, *i);
        }
        s.push_str("</gml:posList></gml:LinearRing>");
        true
    }

    /// A `gml:Polygon`; false (nothing written) when its exterior has fewer than 3 vertices.
    pub fn polygon(&mut self, s: &mut String, p: &Poly, id: Option<&str>) -> bool {
        let Some(ext) = p.rings.first().filter(|r| r.len() >= 3) else {
            return false;
        };
        match id {
            Some(id) => {
                let _ = write!(s, "<gml:Polygon gml:id=\"{id}\">");
            }
            None => s.push_str("<gml:Polygon>"),
        }
        s.push_str("<gml:exterior>");
        self.ring(s, ext);
        s.push_str("</gml:exterior>");
        for r in &p.rings[1..] {
            let mut t = String::new();
            if self.ring(&mut t, r) {
                let _ = write!(s, "<gml:interior>{t}</gml:interior>");
            }
        }
        s.push_str("</gml:Polygon>");
        true
    }

    /// `<gml:surfaceMember>`s of `polys` (their members by index into the geometry's
    /// polygons, from `first`); the number of polygons written inline.
    fn members(
        &mut self,
        s: &mut String,
        polys: &[Poly],
        first: usize,
        member: &dyn Fn(usize) -> Member,
    ) -> usize {
        let mut n = 0;
        for (k, p) in polys.iter().enumerate() {
            match member(first + k) {
                Member::Skip => {}
                Member::Href(id) => {
                    let _ = write!(s, "<gml:surfaceMember xlink:href=\"#{id}\"/>");
                }
                Member::Inline(id) => {
                    let mut t = String::new();
                    if self.polygon(&mut t, p, id.as_deref()) {
                        let _ = write!(s, "<gml:surfaceMember>{t}</gml:surfaceMember>");
                        n += 1;
                    }
                }
            }
        }
        n
    }

    /// A `gml:Solid` of `shells`; the polygons written.
    fn solid(
        &mut self,
        s: &mut String,
        shells: &[Vec<Poly>],
        first: usize,
        member: &dyn Fn(usize) -> Member,
    ) -> usize {
        s.push_str("<gml:Solid>");
        let (mut n, mut at) = (0, first);
        for (k, sh) in shells.iter().enumerate() {
            let side = if k == 0 { "exterior" } else { "interior" };
            let _ = write!(s, "<gml:{side}><gml:CompositeSurface>");
            n += self.members(s, sh, at, member);
            at += sh.len();
            let _ = write!(s, "</gml:CompositeSurface></gml:{side}>");
        }
        s.push_str("</gml:Solid>");
        n
    }

    /// `g` as the GML geometry of a property of `shape` ([`Want`]); `None` when nothing
    /// is left to write (every polygon skipped). The number of polygons written inline.
    pub fn write(
        &mut self,
        g: &Parsed,
        want: Want,
        member: &dyn Fn(usize) -> Member,
    ) -> Option<(String, usize)> {
        let mut s = String::new();
        let n = match (g, want) {
            (Parsed::Solids { solids, kind }, Want::Solid | Want::Any) => {
                let one = *kind == SolidKind::Solid && solids.len() == 1;
                if one {
                    self.solid(&mut s, &solids[0], 0, member)
                } else {
                    let el = if *kind == SolidKind::Multi && want == Want::Any {
                        "MultiSolid"
                    } else {
                        "CompositeSolid"
                    };
                    self.solids(&mut s, el, solids, member)
                }
            }
            (Parsed::Solids { solids, .. }, Want::MultiSolid) => {
                self.solids(&mut s, "MultiSolid", solids, member)
            }
            (Parsed::Surfaces { polys, composite }, Want::Any) if *composite => {
                s.push_str("<gml:CompositeSurface>");
                let n = self.members(&mut s, polys, 0, member);
                s.push_str("</gml:CompositeSurface>");
                n
            }
            (Parsed::Surfaces { .. } | Parsed::Solids { .. }, Want::MultiSurface | Want::Any) => {
                let polys: Vec<Poly> = g.polys().into_iter().cloned().collect();
                s.push_str("<gml:MultiSurface>");
                let n = self.members(&mut s, &polys, 0, member);
                s.push_str("</gml:MultiSurface>");
                if n == 0 && !s.contains("xlink:href") {
                    return None;
                }
                n
            }
            (Parsed::Curves(lines), Want::MultiCurve | Want::Any) => {
                s.push_str("<gml:MultiCurve>");
                for l in lines.iter().filter(|l| l.len() >= 2) {
                    s.push_str("<gml:curveMember><gml:LineString><gml:posList srsDimension=\"3\">");
                    for (k, i) in l.iter().enumerate() {
                        if k > 0 {
                            s.push(' ');
                        }
                        self.push(&mut s, *i);
                    }
                    s.push_str("</gml:posList></gml:LineString></gml:curveMember>");
                }
                s.push_str("</gml:MultiCurve>");
                0
            }
            (Parsed::Points(points), Want::Any) => {
                s.push_str("<gml:MultiPoint>");
                for i in points {
                    s.push_str("<gml:pointMember><gml:Point><gml:pos srsDimension=\"3\">");
                    self.push(&mut s, *i);
                    s.push_str("</gml:pos></gml:Point></gml:pointMember>");
                }
                s.push_str("</gml:MultiPoint>");
                0
            }
            _ => return None,
        };
        Some((s, n))
    }

    fn solids(
        &mut self,
        s: &mut String,
        el: &str,
        solids: &[Vec<Vec<Poly>>],
        member: &dyn Fn(usize) -> Member,
    ) -> usize {
        let _ = write!(s, "<gml:{el}>");
        let (mut n, mut at) = (0, 0);
        for shells in solids {
            s.push_str("<gml:solidMember>");
            n += self.solid(s, shells, at, member);
            at += shells.iter().map(Vec::len).sum::<usize>();
            s.push_str("</gml:solidMember>");
        }
        let _ = write!(s, "</gml:{el}>");
        n
    }

    /// A `gml:TriangulatedSurface` of `g`'s polygons (exteriors; one of more than 3 vertices
    /// as a fan of triangles: the second value counts them).
    pub fn tin(&mut self, g: &Parsed) -> (String, usize, usize) {
        let mut s = String::from("<gml:TriangulatedSurface><gml:trianglePatches>");
        let (mut n, mut fanned) = (0, 0);
        for p in g.polys() {
            let Some(r) = p.rings.first().filter(|r| r.len() >= 3) else {
                continue;
            };
            if r.len() > 3 {
                fanned += 1;
            }
            for k in 1..r.len() - 1 {
                s.push_str("<gml:Triangle><gml:exterior>");
                self.ring(&mut s, &[r[0], r[k], r[k + 1]]);
                s.push_str("</gml:exterior></gml:Triangle>");
                n += 1;
            }
        }
        s.push_str("</gml:trianglePatches></gml:TriangulatedSurface>");
        (s, n, fanned)
    }
}

/// What a property holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Want {
    Solid,
    MultiSolid,
    MultiSurface,
    MultiCurve,
    /// Any `gml:_Geometry`.
    Any,
}

/// A `core:ImplicitGeometry` for the `GeometryInstance` `g` of a feature with vertices
/// `verts` (its reference point); `None` when the template or the point is missing.
pub(super) fn implicit(
    g: &Geometry,
    verts: &mut Verts<'_>,
    templates: Option<&Templates>,
) -> Result<Option<(String, u8, usize)>, String> {
    let Some(t) = templates.and_then(|t| t.templates.get(g.template?)) else {
        return Err(format!(
            "template {:?} is not one of the document's",
            g.template
        ));
    };
    let Some(lod) = t.whole_lod() else {
        return Ok(None);
    };
    let point = g
        .boundaries()
        .get(0)
        .and_then(Value::as_u64)
        .map(|i| i as usize)
        .filter(|i| *i < verts.list.len())
        .ok_or("a GeometryInstance's boundaries are not one vertex index")?;
    let tv = templates.map_or(&[][..], |t| &t.vertices[..]);
    let parsed = parse(t, tv.len())?;
    let mut tverts = Verts {
        list: tv,
        coords: Coords::new(None),
        bbox: [0.0; 6],
    };
    let Some((geom, n)) = tverts.write(&parsed, Want::Any, &|_| Member::Inline(None)) else {
        return Ok(None);
    };
    let identity = [
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    ];
    let m = g
        .matrix
        .as_deref()
        .filter(|m| m.len() == 16)
        .unwrap_or(&identity);
    let mut s = String::from("<core:ImplicitGeometry><core:transformationMatrix>");
    for (k, x) in m.iter().enumerate() {
        if k > 0 {
            s.push(' ');
        }
        push_number(&mut s, *x, None);
    }
    let _ = write!(
        s,
        "</core:transformationMatrix><core:relativeGMLGeometry>{geom}</core:relativeGMLGeometry><core:referencePoint><gml:Point><gml:pos srsDimension=\"3\">"
    );
    verts.push(&mut s, point);
    s.push_str("</gml:pos></gml:Point></core:referencePoint></core:ImplicitGeometry>");
    Ok(Some((s, lod, n)))
}
