//! One city object (and the children nested in it) as a CityGML 2.0 feature: attributes,
//! geometry by LoD, semantic surfaces as thematic surfaces, in the order of its XSD.

use super::doc::{CityObject, Geometry, Templates};
use super::geometry::{implicit, parse, Member, Parsed, Verts, Want};
use super::types::{is_opening, spec, surface, Prop, Shape, Spec};
use super::values::{esc, generic, gml_id, property};
use serde_json::{Map, Value};
use std::collections::{BTreeMap, HashMap};
use std::fmt::Write as _;

/// The city objects of one document or feature, with who nests in whom.
pub(super) struct Unit<'a> {
    pub objects: &'a [(String, CityObject)],
    /// Children nested in each object (those of a type its feature holds).
    pub kids: Vec<Vec<usize>>,
    /// Objects written inside their parent (not as members).
    pub nested: Vec<bool>,
    pub templates: Option<&'a Templates>,
}

impl<'a> Unit<'a> {
    pub fn new(objects: &'a [(String, CityObject)], templates: Option<&'a Templates>) -> Self {
        let index: HashMap<&str, usize> = objects
            .iter()
            .enumerate()
            .map(|(k, (id, _))| (id.as_str(), k))
            .collect();
        let mut kids = vec![Vec::new(); objects.len()];
        let mut nested = vec![false; objects.len()];
        for (k, (_, o)) in objects.iter().enumerate() {
            let parent = o
                .parents
                .iter()
                .find_map(|p| index.get(p.as_str()).copied());
            let Some(p) = parent.filter(|p| *p != k) else {
                continue;
            };
            let holds = spec(&objects[p].1.ty).is_some_and(|s| {
                s.props
                    .iter()
                    .any(|pr| matches!(pr, Prop::Child(_, tys) if tys.contains(&o.ty.as_str())))
            });
            if holds {
                kids[p].push(k);
                nested[k] = true;
            }
        }
        Unit {
            objects,
            kids,
            nested,
            templates,
        }
    }
}

/// What was written and what was not.
#[derive(Debug, Default)]
pub(super) struct Tally {
    pub objects: BTreeMap<String, usize>,
    pub polygons: usize,
    pub ids_made: usize,
    pub dropped: BTreeMap<String, usize>,
}

impl Tally {
    pub fn drop(&mut self, what: String) {
        *self.dropped.entry(what).or_default() += 1;
    }
}

/// Where a semantic surface's polygons go.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Target {
    /// A thematic surface of this element.
    Thematic(&'static str),
    /// An opening of this element under the thematic surface of that semantic index.
    Opening(&'static str, usize),
    /// Into the thematic surface of that index (an opening below LoD 3).
    Into(usize),
    /// The object's own geometry.
    Own,
}

/// Object `k` of `u` as a CityGML 2.0 feature element (`None`: its type has no CityGML 2.0
/// counterpart; dropped and counted). Errors: (object id, message).
pub(super) fn write_object(
    u: &Unit<'_>,
    k: usize,
    verts: &mut Verts<'_>,
    t: &mut Tally,
    depth: usize,
) -> Result<Option<String>, (String, String)> {
    let (key, o) = &u.objects[k];
    let Some(sp) = spec(&o.ty).filter(|_| depth < 16) else {
        t.drop(format!("{} (no CityGML 2.0 type)", o.ty));
        return Ok(None);
    };
    let err = |m: String| (key.clone(), m);
    let (id, made) = gml_id(key);
    t.ids_made += usize::from(made);
    let p = sp.prefix;
    let el = format!("{p}:{}", sp.element);
    *t.objects.entry(sp.element.clone()).or_default() += 1;
    let mut s = format!("<{el} gml:id=\"{}\">", esc(&id));
    if sp.element != o.ty && sp.element == "GenericCityObject" {
        // CityGML 2.0 has no such type: the CityJSON type is kept as an attribute
        s += &generic("cityjson_type", &Value::String(o.ty.clone())).unwrap_or_default();
        t.drop(format!(
            "{} as GenericCityObject (type in cityjson_type)",
            o.ty
        ));
    }
    // properties by schema position
    let mut at: BTreeMap<usize, String> = BTreeMap::new();
    let mut used = std::collections::HashSet::new();
    let empty = Map::new();
    let attrs = o.attributes.as_ref().unwrap_or(&empty);
    for (i, pr) in sp.props.iter().enumerate() {
        if let Prop::Attr(name, kind, many) = pr {
            if let Some(x) = attrs
                .get(*name)
                .and_then(|v| property(&format!("{p}:{name}"), v, *kind, *many))
            {
                at.insert(i, x);
                used.insert(*name);
            }
        }
    }
    // generic attributes come first (core's _GenericApplicationPropertyOfCityObject)
    for (name, v) in attrs.iter().filter(|(n, _)| !used.contains(n.as_str())) {
        match generic(name, v) {
            Some(x) => s.push_str(&x),
            None => t.drop("null attribute".into()),
        }
    }
    if o.address.is_some() {
        t.drop("address".into());
    }
    let mut surfaces: Vec<(u8, String)> = Vec::new();
    for (gi, g) in o.geometry.iter().enumerate() {
        geometry(&sp, &id, gi, g, u, verts, t, &mut at, &mut surfaces).map_err(err)?;
    }
    for (i, pr) in sp.props.iter().enumerate() {
        match pr {
            Prop::Bounded | Prop::Traffic => {
                // trafficArea before auxiliaryTrafficArea; thematic surfaces in LoD order
                surfaces.sort_by_key(|(l, x)| (x.contains(":auxiliaryTrafficArea>"), *l));
                let all: String = surfaces.iter().map(|(_, x)| x.as_str()).collect();
                at.insert(i, all);
            }
            Prop::Child(name, tys) => {
                let mut x = String::new();
                for &c in &u.kids[k] {
                    if tys.contains(&u.objects[c].1.ty.as_str()) {
                        if let Some(child) = write_object(u, c, verts, t, depth + 1)? {
                            let _ = write!(x, "<{p}:{name}>{child}</{p}:{name}>");
                        }
                    }
                }
                at.insert(i, x);
            }
            Prop::Members => {
                let mut x = String::new();
                for c in &o.children {
                    let _ = write!(
                        x,
                        "<grp:groupMember xlink:href=\"#{}\"/>",
                        esc(&gml_id(c).0)
                    );
                }
                at.insert(i, x);
            }
            Prop::Tin => {
                let tin = o.geometry.iter().find_map(|g| {
                    let parsed = parse(g, verts.list.len()).ok()?;
                    Some((g.whole_lod().unwrap_or(2), parsed))
                });
                let Some((lod, parsed)) = tin else {
                    t.drop("TINRelief without surfaces".into());
                    return Ok(None);
                };
                let (x, n, fanned) = verts.tin(&parsed);
                t.polygons += n;
                for _ in 0..fanned {
                    t.drop(
                        "TIN polygon of more than 3 vertices (written as a fan of triangles)"
                            .into(),
                    );
                }
                at.insert(i, format!("<dem:lod>{lod}</dem:lod><dem:tin>{x}</dem:tin>"));
            }
            _ => {}
        }
    }
    for x in at.values() {
        s.push_str(x);
    }
    let _ = write!(s, "</{el}>");
    Ok(Some(s))
}

/// The property name of a geometry slot.
fn slot_name(p: &str, lod: u8, shape: Shape) -> String {
    let tail = match shape {
        Shape::Solid => "Solid",
        Shape::MultiSolid => "MultiSolid",
        Shape::MultiSurface => "MultiSurface",
        Shape::MultiCurve => "MultiCurve",
        Shape::Geometry => "Geometry",
        Shape::Implicit => "ImplicitRepresentation",
        Shape::FootPrint => return format!("{p}:lod0FootPrint"),
    };
    format!("{p}:lod{lod}{tail}")
}

/// Geometry `gi` of an object: into the first free property that can hold it, its semantic
/// surfaces into `surfaces` (LoD, XML).
#[allow(clippy::too_many_arguments)]
fn geometry(
    sp: &Spec,
    id: &str,
    gi: usize,
    g: &Geometry,
    u: &Unit<'_>,
    verts: &mut Verts<'_>,
    t: &mut Tally,
    at: &mut BTreeMap<usize, String>,
    surfaces: &mut Vec<(u8, String)>,
) -> Result<(), String> {
    let p = sp.prefix;
    let free = |lod: u8, shapes: &[Shape], at: &BTreeMap<usize, String>| {
        shapes.iter().find_map(|sh| {
            sp.props
                .iter()
                .position(|pr| *pr == Prop::Geom(lod, *sh))
                .filter(|i| !at.contains_key(i))
                .map(|i| (i, *sh))
        })
    };
    if g.ty == "GeometryInstance" {
        let Some((x, lod, n)) = implicit(g, verts, u.templates)? else {
            t.drop("GeometryInstance without a LoD or geometry".into());
            return Ok(());
        };
        match free(lod, &[Shape::Implicit], at) {
            Some((i, sh)) => {
                let name = slot_name(p, lod, sh);
                at.insert(i, format!("<{name}>{x}</{name}>"));
                t.polygons += n;
            }
            None => t.drop(format!("{} LoD {lod} implicit geometry", sp.element)),
        }
        return Ok(());
    }
    let Some(lod) = g.whole_lod() else {
        t.drop(format!("{} geometry without a LoD in 0..3", g.ty));
        return Ok(());
    };
    let parsed = parse(g, verts.list.len())?;
    let shapes: &[Shape] = match &parsed {
        Parsed::Solids { .. } => &[
            Shape::Solid,
            Shape::MultiSolid,
            Shape::Geometry,
            Shape::MultiSurface,
        ],
        Parsed::Surfaces { .. } => &[Shape::MultiSurface, Shape::FootPrint, Shape::Geometry],
        Parsed::Curves(_) => &[Shape::MultiCurve, Shape::Geometry],
        Parsed::Points(_) => &[Shape::Geometry],
    };
    let slot = free(lod, shapes, at);
    // semantic surfaces → targets
    let sems = g.semantics.as_ref().map_or(&[][..], |s| &s.surfaces[..]);
    let has_surfaces = sp
        .props
        .iter()
        .any(|pr| matches!(pr, Prop::Bounded | Prop::Traffic));
    let ty_of = |i: usize| sems.get(i).map_or("", |m| m.ty.as_str());
    let targets: Vec<Target> = (0..sems.len())
        .map(|i| {
            if !has_surfaces || lod < 2 {
                return Target::Own;
            }
            if let Some(th) = surface(p, ty_of(i)) {
                return Target::Thematic(th);
            }
            let parent = sems[i].parent;
            let parent = parent.filter(|q| *q < sems.len() && surface(p, ty_of(*q)).is_some());
            match (is_opening(p, ty_of(i)), parent) {
                (Some(op), Some(q)) if lod >= 3 => Target::Opening(op, q),
                (Some(_), Some(q)) => Target::Into(q),
                _ => Target::Own,
            }
        })
        .collect();
    let polys = parsed.polys();
    let owner = |k: usize| -> Option<usize> {
        let i = polys.get(k)?.sem?;
        match targets.get(i)? {
            Target::Thematic(_) | Target::Opening(..) => Some(i),
            Target::Into(q) => Some(*q),
            Target::Own => None,
        }
    };
    for (i, tg) in targets.iter().enumerate() {
        if *tg == Target::Own && polys.iter().any(|pl| pl.sem == Some(i)) && !ty_of(i).is_empty() {
            let why = if !has_surfaces {
                format!(
                    "{} semantic surface of a {} (no thematic surfaces)",
                    ty_of(i),
                    sp.element
                )
            } else if lod < 2 {
                format!(
                    "LoD {lod} {} semantic surface (CityGML 2.0 has thematic surfaces from LoD 2)",
                    ty_of(i)
                )
            } else {
                format!(
                    "{} semantic surface of a {} (no CityGML 2.0 place)",
                    ty_of(i),
                    sp.element
                )
            };
            t.drop(format!("{why}: polygons kept in the object's geometry"));
        }
    }
    let solid = matches!(slot, Some((_, Shape::Solid | Shape::MultiSolid)))
        || matches!(
            (&parsed, slot),
            (Parsed::Solids { .. }, Some((_, Shape::Geometry)))
        );
    let pid = |k: usize| format!("{id}.g{gi}.p{k}");
    // the object's own property
    match slot {
        Some((i, sh)) => {
            let member = |k: usize| match owner(k) {
                None => Member::Inline(None),
                Some(_) if solid && polys[k].rings.first().is_some_and(|r| r.len() >= 3) => {
                    Member::Href(pid(k))
                }
                Some(_) if solid => Member::Skip,
                Some(_) => Member::Skip,
            };
            let want = match sh {
                Shape::Solid => Want::Solid,
                Shape::MultiSolid => Want::MultiSolid,
                Shape::MultiSurface | Shape::FootPrint => Want::MultiSurface,
                Shape::MultiCurve => Want::MultiCurve,
                Shape::Geometry | Shape::Implicit => Want::Any,
            };
            if let Some((x, n)) = verts.write(&parsed, want, &member) {
                let name = slot_name(p, lod, sh);
                at.insert(i, format!("<{name}>{x}</{name}>"));
                t.polygons += n;
            }
        }
        None => {
            let unowned = (0..polys.len()).any(|k| owner(k).is_none());
            if unowned || polys.is_empty() {
                t.drop(format!(
                    "{} LoD {lod} {} (no free CityGML 2.0 property)",
                    sp.element, g.ty
                ));
            }
        }
    }
    // thematic surfaces, each with its openings
    for (i, tg) in targets.iter().enumerate() {
        let Target::Thematic(th) = tg else { continue };
        let mine: Vec<usize> = (0..polys.len())
            .filter(|k| {
                owner(*k) == Some(i)
                    && polys[*k]
                        .sem
                        .is_some_and(|s| !matches!(targets[s], Target::Opening(..)))
            })
            .collect();
        let mut inner = String::new();
        for (j, tj) in targets.iter().enumerate() {
            if let Target::Opening(op, q) = tj {
                if *q == i {
                    let ks: Vec<usize> = (0..polys.len())
                        .filter(|k| polys[*k].sem == Some(j))
                        .collect();
                    let ms = multi(verts, &polys, &ks, solid.then_some(&pid), t);
                    let _ = write!(inner, "<{p}:opening><{p}:{op}>{}<{p}:lod{lod}MultiSurface>{ms}</{p}:lod{lod}MultiSurface></{p}:{op}></{p}:opening>", attrs_of(&sems[j].others, t));
                }
            }
        }
        if mine.is_empty() && inner.is_empty() {
            continue;
        }
        let x = if p == "wtr" {
            let ms = multi(verts, &polys, &mine, solid.then_some(&pid), t)
                .replace("gml:MultiSurface>", "gml:CompositeSurface>");
            format!("<wtr:boundedBy><wtr:{th}>{}<wtr:lod{lod}Surface>{ms}</wtr:lod{lod}Surface></wtr:{th}></wtr:boundedBy>", attrs_of(&sems[i].others, t))
        } else {
            let ms = if mine.is_empty() {
                String::new()
            } else {
                let m = multi(verts, &polys, &mine, solid.then_some(&pid), t);
                format!("<{p}:lod{lod}MultiSurface>{m}</{p}:lod{lod}MultiSurface>")
            };
            let prop = match (p, *th) {
                ("tran", "AuxiliaryTrafficArea") => "auxiliaryTrafficArea",
                ("tran", _) => "trafficArea",
                _ => "boundedBy",
            };
            format!(
                "<{p}:{prop}><{p}:{th}>{}{ms}{inner}</{p}:{th}></{p}:{prop}>",
                attrs_of(&sems[i].others, t)
            )
        };
        *t.objects.entry(th.to_string()).or_default() += 1;
        surfaces.push((lod, x));
    }
    if g.material.is_some() || g.texture.is_some() {
        t.drop("appearance (material / texture) of a geometry".into());
    }
    Ok(())
}

/// A `gml:MultiSurface` of polygons `ks` (with their ids when a solid refers to them).
fn multi(
    verts: &mut Verts<'_>,
    polys: &[&super::geometry::Poly],
    ks: &[usize],
    id: Option<&dyn Fn(usize) -> String>,
    t: &mut Tally,
) -> String {
    let mut s = String::from("<gml:MultiSurface>");
    for &k in ks {
        let mut x = String::new();
        let pid = id.map(|f| f(k));
        if verts.polygon(&mut x, polys[k], pid.as_deref()) {
            let _ = write!(s, "<gml:surfaceMember>{x}</gml:surfaceMember>");
            t.polygons += 1;
        } else if pid.is_some() {
            t.drop("degenerate polygon referred to by a solid".into());
        }
    }
    s.push_str("</gml:MultiSurface>");
    s
}

/// A semantic object's own attributes (not `type`, `parent`, `children`, `id`) as generic
/// attributes.
fn attrs_of(m: &Map<String, Value>, t: &mut Tally) -> String {
    let mut s = String::new();
    for (k, v) in m {
        if matches!(k.as_str(), "type" | "parent" | "children" | "id") {
            continue;
        }
        match generic(k, v) {
            Some(x) => s.push_str(&x),
            None => t.drop("null attribute".into()),
        }
    }
    s
}
