//! City objects and their properties, CityGML 1.0 / 2.0 → 3.0: feature names (`bldg:RoofSurface`
//! → `con:RoofSurface`, `bldg:Window` → `con:WindowSurface`, `bldg:Room` →
//! `bldg:BuildingRoom`, ...), property names (`bldg:boundedBy` → `core:boundary`,
//! `bldg:lod2Solid` → `core:lod2Solid`, `bldg:opening` → `con:fillingSurface`, ...), LoD
//! geometry without a 3.0 place (LoD4, LoD0 roof edges, LoD1 multi-surfaces of spaces) as
//! the options say, and the properties of each feature in the order of its 3.0 XSD.

use super::dom::{El, Node};
use super::extras;
use super::geometry::{self, Shape};
use super::names::{sequence, Module, Src};
use super::{UpgradeOptions, UpgradeSummary};

/// What the rewrite of one member needs.
pub(super) struct Ctx<'a> {
    pub(super) opts: &'a UpgradeOptions,
    pub(super) counts: &'a mut UpgradeSummary,
    /// The top-level feature has LoD4 geometry that replaces its LoD3 (`use_lod4_as_lod3`).
    pub(super) drop_lod3: bool,
    pub(super) seqs: &'a mut foldhash::HashMap<String, Option<Vec<&'static str>>>,
    /// City objects to write as top-level members after this one (inline group members).
    pub(super) extra: Vec<El>,
    /// The `app:TexCoordList`s with a `gml:id` so far (3.0 has no ids on them: a reference
    /// to one is replaced by a copy). The one part of memory that grows with the document,
    /// by the lists that have an id.
    pub(super) texcoords: &'a mut foldhash::HashMap<Vec<u8>, El>,
}

/// The `app:TexCoordList`s with a `gml:id` in `e`.
pub(super) fn texcoord_lists(e: &El, into: &mut foldhash::HashMap<Vec<u8>, El>) {
    if e.local == "TexCoordList" {
        if let Some(id) = e.attr("id") {
            into.insert(id.to_vec(), e.clone());
        }
        return;
    }
    for c in e.els() {
        texcoord_lists(c, into);
    }
}

/// A city object, or anything a member or property holds (GML, ADE content).
pub(super) fn object(e: El, ctx: &mut Ctx<'_>) -> El {
    match e.ns {
        Src::Gml => geometry::gml(e),
        Src::Core if e.local == "ImplicitGeometry" => extras::implicit(e, ctx),
        Src::Core if e.local == "Address" => extras::address(e),
        Src::Module(Module::App) => extras::appearance(e, ctx),
        Src::Core | Src::Module(_) if upper(&e.local) => feature(e, ctx),
        Src::Core | Src::Module(_) => generic(e, ctx),
        _ => foreign(e, ctx),
    }
}

fn upper(s: &str) -> bool {
    s.starts_with(|c: char| c.is_ascii_uppercase())
}

/// Content this module does not know (ADEs, metadata): its own names kept, the CityGML and
/// GML inside upgraded.
pub(super) fn foreign(mut e: El, ctx: &mut Ctx<'_>) -> El {
    e.kids = std::mem::take(&mut e.kids)
        .into_iter()
        .map(|n| match n {
            Node::El(c) => Node::El(object(c, ctx)),
            other => other,
        })
        .collect();
    e
}

/// A CityGML element without a rule of its own: the same local name in the module's 3.0
/// namespace, its content upgraded.
pub(super) fn generic(mut e: El, ctx: &mut Ctx<'_>) -> El {
    let prefix = match e.ns {
        Src::Core => "core",
        Src::Module(m) => m.prefix(),
        _ => return foreign(e, ctx),
    };
    e.name = format!("{prefix}:{}", e.local);
    e.ns = Src::Out;
    foreign(e, ctx)
}

/// The 3.0 name of a 1.0 / 2.0 feature.
fn feature_name(m: Option<Module>, local: &str) -> String {
    let surface = matches!(
        local,
        "RoofSurface"
            | "WallSurface"
            | "GroundSurface"
            | "OuterCeilingSurface"
            | "OuterFloorSurface"
            | "CeilingSurface"
            | "InteriorWallSurface"
            | "FloorSurface"
    );
    let p = m.map_or("core", Module::prefix);
    match (m, local) {
        (Some(Module::Bldg | Module::Brid | Module::Tun), _) if surface => format!("con:{local}"),
        (_, "ClosureSurface" | "WaterClosureSurface") => "core:ClosureSurface".into(),
        (Some(Module::Bldg | Module::Brid | Module::Tun), "Window") => "con:WindowSurface".into(),
        (Some(Module::Bldg | Module::Brid | Module::Tun), "Door") => "con:DoorSurface".into(),
        (Some(Module::Bldg), "IntBuildingInstallation") => "bldg:BuildingInstallation".into(),
        (Some(Module::Bldg), "Room") => "bldg:BuildingRoom".into(),
        (Some(Module::Brid), "IntBridgeInstallation") => "brid:BridgeInstallation".into(),
        (Some(Module::Brid), "BridgeConstructionElement") => {
            "brid:BridgeConstructiveElement".into()
        }
        (Some(Module::Tun), "IntTunnelInstallation") => "tun:TunnelInstallation".into(),
        (Some(Module::Gen), "GenericCityObject") => "gen:GenericOccupiedSpace".into(),
        _ => format!("{p}:{local}"),
    }
}

/// A city object: renamed, its properties mapped and put in the order of its 3.0 type.
pub(super) fn feature(e: El, ctx: &mut Ctx<'_>) -> El {
    let m = match e.ns {
        Src::Module(m) => Some(m),
        _ => None,
    };
    let name = feature_name(m, &e.local);
    let mut out = El::new(&name);
    out.attrs = e.attrs.clone();
    ctx.counts.city_objects += 1;
    if !ctx.seqs.contains_key(&name) {
        ctx.seqs.insert(name.clone(), sequence(&name));
    }
    let thematic = ctx
        .seqs
        .get(&name)
        .and_then(|s| s.as_ref())
        .is_some_and(|s| s.contains(&"core:lod1MultiSurface"));
    let mut props = Vec::new();
    for c in e.into_els() {
        props.extend(property(&name, thematic, c, ctx));
    }
    if let Some(Some(seq)) = ctx.seqs.get(&name) {
        let rank = |p: &El| seq.iter().position(|s| *s == p.name).unwrap_or(seq.len());
        props.sort_by_key(rank);
    }
    out.kids = props.into_iter().map(Node::El).collect();
    out
}

/// `p` renamed `name`, its attributes kept, its child elements upgraded as objects.
fn wrap(name: &str, p: El, ctx: &mut Ctx<'_>) -> El {
    let mut out = El::new(name);
    out.attrs = p.attrs.clone();
    for c in p.kids {
        match c {
            Node::El(c) => out.kids.push(Node::El(object(c, ctx))),
            Node::Text(t) if !t.iter().all(u8::is_ascii_whitespace) => out.kids.push(Node::Text(t)),
            _ => {}
        }
    }
    out
}

/// A property of the feature written as `owner`: none (no 3.0 place), one or more.
fn property(owner: &str, thematic: bool, p: El, ctx: &mut Ctx<'_>) -> Vec<El> {
    let local = p.local.clone();
    match p.ns {
        Src::Gml => return vec![geometry::gml(p)],
        Src::Module(Module::App) if local == "appearance" => {
            return vec![wrap("core:appearance", p, ctx)]
        }
        Src::Module(Module::Gen)
            if local.ends_with("Attribute") || local == "genericAttributeSet" =>
        {
            ctx.counts.generic_attributes += 1;
            return vec![El::new("core:genericAttribute").with(extras::generic_attribute(p, ctx))];
        }
        Src::Core if local == "externalReference" => return vec![extras::external_reference(p)],
        Src::Core if local == "creationDate" || local == "terminationDate" => {
            // xs:date in 2.0, xs:dateTime in 3.0
            let mut t = p.own_text();
            t.retain(|c| !c.is_ascii_whitespace());
            if !t.contains(&b'T') {
                t.extend_from_slice(b"T00:00:00");
            }
            return vec![El::new(&format!("core:{local}")).text(&t)];
        }
        Src::Core | Src::Module(_) => {}
        _ => return vec![foreign(p, ctx)],
    }
    if let Some((lod, kind)) = lod_property(&local) {
        return lod_geometry(owner, thematic, lod, kind, p, ctx);
    }
    let m = match p.ns {
        Src::Module(m) => m,
        _ => return vec![generic(p, ctx)],
    };
    let pre = m.prefix();
    let renamed = match (m, local.as_str()) {
        (Module::Bldg | Module::Brid | Module::Tun | Module::Wtr, "boundedBy")
        | (Module::Tran, "trafficArea" | "auxiliaryTrafficArea") => "core:boundary".to_string(),
        (Module::Bldg | Module::Brid | Module::Tun, "opening") => "con:fillingSurface".into(),
        (
            Module::Bldg,
            "outerBuildingInstallation" | "interiorBuildingInstallation" | "roomInstallation",
        ) => "bldg:buildingInstallation".into(),
        (Module::Bldg, "interiorRoom") => "bldg:buildingRoom".into(),
        (Module::Bldg, "interiorFurniture") => "bldg:buildingFurniture".into(),
        (Module::Bldg, "consistsOfBuildingPart") => "bldg:buildingPart".into(),
        (
            Module::Brid,
            "outerBridgeInstallation" | "interiorBridgeInstallation" | "bridgeRoomInstallation",
        ) => "brid:bridgeInstallation".into(),
        (Module::Brid, "outerBridgeConstruction") => "brid:bridgeConstructiveElement".into(),
        (Module::Brid, "interiorBridgeRoom") => "brid:bridgeRoom".into(),
        (Module::Brid, "interiorFurniture") => "brid:bridgeFurniture".into(),
        (Module::Brid, "consistsOfBridgePart") => "brid:bridgePart".into(),
        (Module::Brid, "is_movable") => "brid:isMovable".into(),
        (
            Module::Tun,
            "outerTunnelInstallation" | "interiorTunnelInstallation" | "hollowSpaceInstallation",
        ) => "tun:tunnelInstallation".into(),
        (Module::Tun, "interiorHollowSpace") => "tun:hollowSpace".into(),
        (Module::Tun, "interiorFurniture") => "tun:tunnelFurniture".into(),
        (Module::Tun, "consistsOfTunnelPart") => "tun:tunnelPart".into(),
        (_, "address") if owner.starts_with("con:") => "con:address".into(),
        (_, "yearOfConstruction" | "yearOfDemolition") => {
            let what = if local == "yearOfConstruction" {
                "con:dateOfConstruction"
            } else {
                "con:dateOfDemolition"
            };
            let mut year = p.own_text();
            year.retain(|c| !c.is_ascii_whitespace());
            year.extend_from_slice(b"-01-01");
            return vec![El::new(what).text(&year)];
        }
        (_, "measuredHeight") => return vec![extras::height(p)],
        (Module::Grp, "groupMember") => return vec![extras::group_member(p, ctx)],
        (Module::Grp, "geometry") => {
            ctx.counts.dropped.push("grp:geometry".into());
            return Vec::new();
        }
        _ => format!("{pre}:{local}"),
    };
    vec![wrap(&renamed, p, ctx)]
}

/// `lod<N><Rest>` → (N, Rest).
fn lod_property(local: &str) -> Option<(u8, &str)> {
    let b = local.as_bytes();
    match b {
        [b'l', b'o', b'd', n @ b'0'..=b'4', c, ..] if c.is_ascii_uppercase() => {
            Some((n - b'0', &local[4..]))
        }
        _ => None,
    }
}

/// The geometry property `p` (`lod<lod><kind>`) of the feature `owner`.
fn lod_geometry(
    owner: &str,
    thematic: bool,
    lod: u8,
    kind: &str,
    p: El,
    ctx: &mut Ctx<'_>,
) -> Vec<El> {
    let mut lod = lod;
    let from = format!("{}:{}", owner.split(':').next().unwrap_or(""), p.local);
    if lod == 4 {
        if !ctx.opts.use_lod4_as_lod3 {
            ctx.counts.dropped.push(from);
            return Vec::new();
        }
        ctx.counts.lod4_as_lod3 += 1;
        lod = 3;
    } else if lod == 3 && ctx.drop_lod3 {
        ctx.counts.lod3_replaced += 1;
        return Vec::new();
    }
    let attrs = p.attrs.clone();
    let g = p.into_els().next().map(|g| object(g, ctx));
    let named = |name: String, g: Option<El>| {
        let mut out = El::new(&name);
        out.attrs = attrs.clone();
        if let Some(g) = g {
            out.kids.push(Node::El(g));
        }
        vec![out]
    };
    let core = |k: &str| format!("core:lod{lod}{k}");
    match kind {
        "ImplicitRepresentation" if (1..=3).contains(&lod) => named(core(kind), g),
        "TerrainIntersection" if (1..=3).contains(&lod) => {
            named(core("TerrainIntersectionCurve"), g)
        }
        "FootPrint" if lod == 0 => named(core("MultiSurface"), g),
        "RoofEdge" if lod == 0 => {
            if !ctx.opts.map_lod0_roof_edge {
                ctx.counts.dropped.push(from);
                return Vec::new();
            }
            ctx.counts.mapped += 1;
            let prop = named(core("MultiSurface"), g).remove(0);
            let mut roof = El::new("con:RoofSurface").with(prop);
            roof.attrs.clear();
            vec![El::new("core:boundary").with(roof)]
        }
        "Solid" if (1..=3).contains(&lod) => named(core("Solid"), g),
        "MultiCurve" if matches!(lod, 0 | 2 | 3) => named(core("MultiCurve"), g),
        "MultiSurface" | "Surface" | "Geometry" | "MultiSolid" => {
            let shape = g.as_ref().map_or(Shape::Unknown, geometry::shape);
            let solid_member = g.as_ref().and_then(single_solid);
            match (shape, g) {
                (Shape::Solid, g) if (1..=3).contains(&lod) && !thematic => named(core("Solid"), g),
                (Shape::Surfaces, Some(g)) if solid_member.is_some() && !thematic && lod > 0 => {
                    named(core("Solid"), solid_member.or(Some(g)))
                }
                (Shape::Curves, g) if matches!(lod, 0 | 2 | 3) && !thematic => {
                    named(core("MultiCurve"), g)
                }
                (Shape::Point, g) if lod == 0 && !thematic => named(core("Point"), g),
                (Shape::Curves | Shape::Point | Shape::Solid, _) => {
                    ctx.counts.dropped.push(from);
                    Vec::new()
                }
                (_, g) => {
                    let mut curves = Vec::new();
                    let g = g.map(|g| {
                        let (ms, cs, points) = geometry::to_multi_surface(g);
                        if points > 0 {
                            ctx.counts.dropped.push(format!("{from} (points)"));
                        }
                        curves = cs;
                        ms
                    });
                    let mut extra = Vec::new();
                    if !curves.is_empty() {
                        if matches!(lod, 0 | 2 | 3) && !thematic {
                            let mc = curves.into_iter().fold(El::new("gml:MultiCurve"), |m, c| {
                                m.with(El::new("gml:curveMember").with(c))
                            });
                            extra.push(El::new(&core("MultiCurve")).with(mc));
                        } else {
                            ctx.counts.dropped.push(format!("{from} (curves)"));
                        }
                    }
                    if lod == 1 && !thematic {
                        if !ctx.opts.map_lod1_multi_surfaces {
                            ctx.counts.dropped.push(from);
                            return Vec::new();
                        }
                        ctx.counts.mapped += 1;
                        let prop = named("core:lod1MultiSurface".into(), g).remove(0);
                        return vec![El::new("core:boundary")
                            .with(El::new("gen:GenericThematicSurface").with(prop))];
                    }
                    let mut v = named(core("MultiSurface"), g);
                    v.extend(extra);
                    v
                }
            }
        }
        _ => {
            ctx.counts.dropped.push(from);
            Vec::new()
        }
    }
}

/// The solid of a `gml:MultiSolid` with one member.
fn single_solid(g: &El) -> Option<El> {
    if g.local != "MultiSolid" {
        return None;
    }
    let solids: Vec<&El> = g.els().flat_map(|m| m.els()).collect();
    match solids.as_slice() {
        [s] if s.local == "Solid" => Some((*s).clone()),
        _ => None,
    }
}

/// Whether the member holds LoD4 geometry (any `lod4...` element).
pub(super) fn has_lod4(e: &El) -> bool {
    e.local.starts_with("lod4") || e.els().any(has_lod4)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names() {
        for (module, name, upgraded) in [
            (Module::Bldg, "RoofSurface", "con:RoofSurface"),
            (Module::Bldg, "Window", "con:WindowSurface"),
            (Module::Bldg, "Room", "bldg:BuildingRoom"),
            (Module::Bldg, "ClosureSurface", "core:ClosureSurface"),
            (Module::Gen, "GenericCityObject", "gen:GenericOccupiedSpace"),
            (Module::Veg, "PlantCover", "veg:PlantCover"),
        ] {
            assert_eq!(feature_name(Some(module), name), upgraded, "{name}");
        }
        assert_eq!(lod_property("lod2MultiSurface"), Some((2, "MultiSurface")));
        assert_eq!(lod_property("lod0FootPrint"), Some((0, "FootPrint")));
        assert_eq!(lod_property("lod"), None);
    }
}
