//! Which CityGML 2.0 feature each CityJSON city object type becomes, and that feature's
//! properties in the order of its XSD (the writer emits them in this order).

use super::values::Kind;

/// A geometry property's shape (`lod{n}Solid`, ...).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Shape {
    Solid,
    MultiSolid,
    MultiSurface,
    MultiCurve,
    /// `lod{n}Geometry` (any `gml:_Geometry`).
    Geometry,
    /// `lod{n}ImplicitRepresentation`.
    Implicit,
    /// `lod0FootPrint`.
    FootPrint,
}

/// One property of a feature, in schema order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Prop {
    /// The CityJSON attribute of that name, as a property of that name in the feature's
    /// module (`many`: repeated for an array).
    Attr(&'static str, Kind, bool),
    /// Geometry of one LoD.
    Geom(u8, Shape),
    /// `boundedBy` thematic surfaces (from semantic surfaces of LoD 2 and 3).
    Bounded,
    /// `trafficArea` / `auxiliaryTrafficArea` (from semantic surfaces of LoD 2 and 3).
    Traffic,
    /// Child city objects of these CityJSON types, each in a property of that name.
    Child(&'static str, &'static [&'static str]),
    /// `dem:lod` and `dem:tin` of a `TINRelief`.
    Tin,
    /// `grp:groupMember` links to the group's `children`.
    Members,
}

/// A CityGML 2.0 feature type.
#[derive(Debug)]
pub(super) struct Spec {
    /// Module prefix (`bldg`).
    pub prefix: &'static str,
    /// Element (`Building`).
    pub element: String,
    pub props: Vec<Prop>,
}

use Kind::*;
use Prop::*;
use Shape::*;

const CFU: [Prop; 3] = [
    Attr("class", Code, false),
    Attr("function", Code, true),
    Attr("usage", Code, true),
];

fn geoms(lods: std::ops::RangeInclusive<u8>, shapes: &[Shape]) -> Vec<Prop> {
    let mut v = Vec::new();
    for s in shapes {
        for l in lods.clone() {
            v.push(Geom(l, *s));
        }
    }
    v
}

/// The properties of a building, bridge or tunnel (or a part), which CityGML 2.0 orders
/// alike (`_AbstractBuilding`, `_AbstractBridge`, `_AbstractTunnel`): class, function,
/// usage, the years of construction and demolition, the type's own `attrs`, LoD 1 and 2
/// geometry, its `children` (installations, constructions), the thematic surfaces, LoD 3
/// geometry, and last its `part`s.
fn construction(attrs: &[Prop], children: &[Prop], part: Prop) -> Vec<Prop> {
    let mut p = CFU.to_vec();
    p.extend([
        Attr("yearOfConstruction", Year, false),
        Attr("yearOfDemolition", Year, false),
    ]);
    p.extend_from_slice(attrs);
    p.extend(geoms(1..=1, &[Solid, MultiSurface]));
    p.extend([Geom(2, Solid), Geom(2, MultiSurface), Geom(2, MultiCurve)]);
    p.extend_from_slice(children);
    p.push(Bounded);
    p.extend([Geom(3, Solid), Geom(3, MultiSurface), Geom(3, MultiCurve)]);
    p.push(part);
    p
}

/// The spec of a CityJSON type (`None`: no CityGML 2.0 counterpart written: the object is
/// dropped and counted).
pub(super) fn spec(ty: &str) -> Option<Spec> {
    let (prefix, element, props): (&'static str, &str, Vec<Prop>) = match ty {
        "Building" | "BuildingPart" => {
            let attrs = [
                Attr("roofType", Code, false),
                Attr("measuredHeight", Length, false),
                Attr("storeysAboveGround", Count, false),
                Attr("storeysBelowGround", Count, false),
                Geom(0, FootPrint),
            ];
            let children = [Child(
                "outerBuildingInstallation",
                &["BuildingInstallation"],
            )];
            let part = Child("consistsOfBuildingPart", &["BuildingPart"]);
            ("bldg", ty, construction(&attrs, &children, part))
        }
        "Bridge" | "BridgePart" => {
            let attrs = [Attr("isMovable", Bool, false)];
            let children = [
                Child(
                    "outerBridgeConstruction",
                    &["BridgeConstructiveElement", "BridgeConstructionElement"],
                ),
                Child("outerBridgeInstallation", &["BridgeInstallation"]),
            ];
            let part = Child("consistsOfBridgePart", &["BridgePart"]);
            ("brid", ty, construction(&attrs, &children, part))
        }
        "Tunnel" | "TunnelPart" => {
            let children = [Child("outerTunnelInstallation", &["TunnelInstallation"])];
            let part = Child("consistsOfTunnelPart", &["TunnelPart"]);
            ("tun", ty, construction(&[], &children, part))
        }
        "BuildingInstallation" | "BridgeInstallation" | "TunnelInstallation" => {
            let mut p = CFU.to_vec();
            p.extend(geoms(2..=3, &[Geometry, Implicit]));
            p.push(Bounded);
            (module_of(ty), ty, p)
        }
        "BridgeConstructiveElement" | "BridgeConstructionElement" => {
            let mut p = CFU.to_vec();
            p.extend(geoms(1..=3, &[Geometry, Implicit]));
            p.push(Bounded);
            ("brid", "BridgeConstructionElement", p)
        }
        "CityFurniture" => {
            let mut p = CFU.to_vec();
            p.extend(geoms(1..=3, &[Geometry, Implicit]));
            ("frn", ty, p)
        }
        "GenericCityObject" | "OtherConstruction" | "Waterway" => {
            let mut p = CFU.to_vec();
            p.extend(geoms(0..=3, &[Geometry, Implicit]));
            ("gen", "GenericCityObject", p)
        }
        "LandUse" => {
            let mut p = CFU.to_vec();
            p.extend(geoms(0..=3, &[MultiSurface]));
            ("luse", ty, p)
        }
        "PlantCover" => {
            let mut p = CFU.to_vec();
            p.push(Attr("averageHeight", Length, false));
            p.extend(geoms(1..=3, &[MultiSurface, MultiSolid]));
            ("veg", ty, p)
        }
        "SolitaryVegetationObject" => {
            let mut p = CFU.to_vec();
            p.extend([
                Attr("species", Code, false),
                Attr("height", Length, false),
                Attr("trunkDiameter", Length, false),
                Attr("crownDiameter", Length, false),
            ]);
            p.extend(geoms(1..=3, &[Geometry, Implicit]));
            ("veg", ty, p)
        }
        "WaterBody" => {
            let mut p = CFU.to_vec();
            p.extend([
                Geom(0, MultiCurve),
                Geom(0, MultiSurface),
                Geom(1, MultiCurve),
                Geom(1, MultiSurface),
            ]);
            p.extend(geoms(1..=3, &[Solid]));
            p.push(Bounded);
            ("wtr", ty, p)
        }
        "Road" | "Railway" | "TransportSquare" => {
            let mut p = CFU.to_vec();
            p.push(Traffic);
            p.extend(geoms(1..=3, &[MultiSurface]));
            let el = if ty == "TransportSquare" {
                "Square"
            } else {
                ty
            };
            ("tran", el, p)
        }
        "TINRelief" => ("dem", ty, vec![Tin]),
        t if t.starts_with('+') => return spec("GenericCityObject"),
        "CityObjectGroup" => {
            let mut p = CFU.to_vec();
            p.push(Members);
            ("grp", ty, p)
        }
        _ => return None,
    };
    Some(Spec {
        prefix,
        element: element.to_string(),
        props,
    })
}

fn module_of(ty: &str) -> &'static str {
    if ty.starts_with("Bridge") {
        "brid"
    } else if ty.starts_with("Tunnel") {
        "tun"
    } else {
        "bldg"
    }
}

/// The thematic surface a semantic surface type becomes under a feature of module `prefix`
/// (`None`: its polygons stay in the feature's own geometry).
pub(super) fn surface(prefix: &str, ty: &str) -> Option<&'static str> {
    const BOUNDARY: &[&str] = &[
        "RoofSurface",
        "WallSurface",
        "GroundSurface",
        "ClosureSurface",
        "OuterCeilingSurface",
        "OuterFloorSurface",
        "FloorSurface",
        "InteriorWallSurface",
        "CeilingSurface",
    ];
    const WATER: &[&str] = &["WaterSurface", "WaterGroundSurface", "WaterClosureSurface"];
    const TRAFFIC: &[&str] = &["TrafficArea", "AuxiliaryTrafficArea"];
    let list = match prefix {
        "bldg" | "brid" | "tun" => BOUNDARY,
        "wtr" => WATER,
        "tran" => TRAFFIC,
        _ => return None,
    };
    list.iter().find(|s| **s == ty).copied()
}

/// Whether a semantic surface type is an opening (`Window`, `Door`).
pub(super) fn is_opening(prefix: &str, ty: &str) -> Option<&'static str> {
    match (prefix, ty) {
        ("bldg" | "brid" | "tun", "Window") => Some("Window"),
        ("bldg" | "brid" | "tun", "Door") => Some("Door"),
        _ => None,
    }
}

/// The root's namespace declarations and schema locations (CityGML 2.0).
pub(super) const ROOT_NAMESPACES: &str = concat!(
    " xmlns=\"http://www.opengis.net/citygml/2.0\"",
    " xmlns:core=\"http://www.opengis.net/citygml/2.0\"",
    " xmlns:gml=\"http://www.opengis.net/gml\"",
    " xmlns:xlink=\"http://www.w3.org/1999/xlink\"",
    " xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\"",
    " xmlns:bldg=\"http://www.opengis.net/citygml/building/2.0\"",
    " xmlns:brid=\"http://www.opengis.net/citygml/bridge/2.0\"",
    " xmlns:tun=\"http://www.opengis.net/citygml/tunnel/2.0\"",
    " xmlns:tran=\"http://www.opengis.net/citygml/transportation/2.0\"",
    " xmlns:veg=\"http://www.opengis.net/citygml/vegetation/2.0\"",
    " xmlns:wtr=\"http://www.opengis.net/citygml/waterbody/2.0\"",
    " xmlns:luse=\"http://www.opengis.net/citygml/landuse/2.0\"",
    " xmlns:frn=\"http://www.opengis.net/citygml/cityfurniture/2.0\"",
    " xmlns:gen=\"http://www.opengis.net/citygml/generics/2.0\"",
    " xmlns:dem=\"http://www.opengis.net/citygml/relief/2.0\"",
    " xmlns:grp=\"http://www.opengis.net/citygml/cityobjectgroup/2.0\"",
    " xsi:schemaLocation=\"",
    "http://www.opengis.net/citygml/building/2.0 http://schemas.opengis.net/citygml/building/2.0/building.xsd ",
    "http://www.opengis.net/citygml/bridge/2.0 http://schemas.opengis.net/citygml/bridge/2.0/bridge.xsd ",
    "http://www.opengis.net/citygml/tunnel/2.0 http://schemas.opengis.net/citygml/tunnel/2.0/tunnel.xsd ",
    "http://www.opengis.net/citygml/transportation/2.0 http://schemas.opengis.net/citygml/transportation/2.0/transportation.xsd ",
    "http://www.opengis.net/citygml/vegetation/2.0 http://schemas.opengis.net/citygml/vegetation/2.0/vegetation.xsd ",
    "http://www.opengis.net/citygml/waterbody/2.0 http://schemas.opengis.net/citygml/waterbody/2.0/waterBody.xsd ",
    "http://www.opengis.net/citygml/landuse/2.0 http://schemas.opengis.net/citygml/landuse/2.0/landUse.xsd ",
    "http://www.opengis.net/citygml/cityfurniture/2.0 http://schemas.opengis.net/citygml/cityfurniture/2.0/cityFurniture.xsd ",
    "http://www.opengis.net/citygml/generics/2.0 http://schemas.opengis.net/citygml/generics/2.0/generics.xsd ",
    "http://www.opengis.net/citygml/relief/2.0 http://schemas.opengis.net/citygml/relief/2.0/relief.xsd ",
    "http://www.opengis.net/citygml/cityobjectgroup/2.0 http://schemas.opengis.net/citygml/cityobjectgroup/2.0/cityObjectGroup.xsd\""
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buildings_bridges_and_tunnels_order_their_properties_alike() {
        let props = |ty| spec(ty).unwrap().props;
        let tunnel = props("TunnelPart");
        let want = [
            CFU[0],
            CFU[1],
            CFU[2],
            Attr("yearOfConstruction", Year, false),
            Attr("yearOfDemolition", Year, false),
            Geom(1, Solid),
            Geom(1, MultiSurface),
            Geom(2, Solid),
            Geom(2, MultiSurface),
            Geom(2, MultiCurve),
            Child("outerTunnelInstallation", &["TunnelInstallation"]),
            Bounded,
            Geom(3, Solid),
            Geom(3, MultiSurface),
            Geom(3, MultiCurve),
            Child("consistsOfTunnelPart", &["TunnelPart"]),
        ];
        assert_eq!(tunnel, want);
        // a building: its attributes and footprint before LoD 1, its installations before
        // the surfaces, its parts last
        let b = props("Building");
        let at = |p: Prop| b.iter().position(|x| *x == p).unwrap();
        assert_eq!(at(Geom(0, FootPrint)) + 1, at(Geom(1, Solid)));
        assert_eq!(at(Bounded), at(Geom(2, MultiCurve)) + 2);
        assert!(matches!(b.last(), Some(Child("consistsOfBuildingPart", _))));
        let bridge = props("Bridge");
        assert_eq!(bridge.len(), tunnel.len() + 2);
        assert!(matches!(bridge[12], Child("outerBridgeInstallation", _)));
        assert_eq!(bridge[13], Bounded);
    }
}
