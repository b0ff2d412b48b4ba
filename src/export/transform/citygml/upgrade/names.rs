//! Namespaces of CityGML 1.0 / 2.0 and 3.0, the prefixes the upgrade writes, and the order of
//! a 3.0 feature's properties (the sequences of the 3.0 XSDs, base type first).

/// A CityGML thematic module, by its 3.0 prefix.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Module {
    Bldg,
    App,
    Gen,
    Grp,
    Frn,
    Veg,
    Wtr,
    Luse,
    Dem,
    Tran,
    Brid,
    Tun,
    /// `texturedsurface` (1.0 / 2.0 only, no 3.0 counterpart).
    Tex,
    /// `construction` (3.0 only).
    Con,
}

/// (module, path in the namespace URI, 3.0 schema file).
const MODULES: &[(Module, &str, &str)] = &[
    (Module::Bldg, "building", "building.xsd"),
    (Module::App, "appearance", "appearance.xsd"),
    (Module::Gen, "generics", "generics.xsd"),
    (Module::Grp, "cityobjectgroup", "cityObjectGroup.xsd"),
    (Module::Frn, "cityfurniture", "cityFurniture.xsd"),
    (Module::Veg, "vegetation", "vegetation.xsd"),
    (Module::Wtr, "waterbody", "waterBody.xsd"),
    (Module::Luse, "landuse", "landUse.xsd"),
    (Module::Dem, "relief", "relief.xsd"),
    (Module::Tran, "transportation", "transportation.xsd"),
    (Module::Brid, "bridge", "bridge.xsd"),
    (Module::Tun, "tunnel", "tunnel.xsd"),
    (Module::Con, "construction", "construction.xsd"),
];

impl Module {
    /// The prefix written for the module's 3.0 namespace.
    pub(super) fn prefix(self) -> &'static str {
        match self {
            Module::Bldg => "bldg",
            Module::App => "app",
            Module::Gen => "gen",
            Module::Grp => "grp",
            Module::Frn => "frn",
            Module::Veg => "veg",
            Module::Wtr => "wtr",
            Module::Luse => "luse",
            Module::Dem => "dem",
            Module::Tran => "tran",
            Module::Brid => "brid",
            Module::Tun => "tun",
            Module::Tex => "tex",
            Module::Con => "con",
        }
    }
}

/// The namespace of a source element or attribute.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(super) enum Src {
    /// CityGML 1.0 / 2.0 core.
    Core,
    /// A CityGML 1.0 / 2.0 thematic module.
    Module(Module),
    /// GML 3.1.1.
    Gml,
    /// xAL 2.0 (addresses).
    Xal,
    Xlink,
    Xsi,
    /// CityGML 3.0 or GML 3.2: the document is already upgraded.
    V3,
    /// No namespace.
    #[default]
    None,
    /// Anything else (ADEs, metadata): copied as it is.
    Foreign,
    /// An element the upgrade made.
    Out,
}

pub(super) const GML_311: &[u8] = b"http://www.opengis.net/gml";
const XAL2: &[u8] = b"urn:oasis:names:tc:ciq:xsdschema:xAL:2.0";
const CITYGML: &str = "http://www.opengis.net/citygml/";

impl Src {
    pub(super) fn of(uri: &[u8]) -> Src {
        match uri {
            b"" => return Src::None,
            GML_311 => return Src::Gml,
            b"http://www.opengis.net/gml/3.2" => return Src::V3,
            XAL2 => return Src::Xal,
            b"http://www.w3.org/1999/xlink" => return Src::Xlink,
            b"http://www.w3.org/2001/XMLSchema-instance" => return Src::Xsi,
            _ => {}
        }
        let Some(rest) = uri.strip_prefix(CITYGML.as_bytes()) else {
            return Src::Foreign;
        };
        let rest = std::str::from_utf8(rest).unwrap_or("");
        let (module, version) = rest.rsplit_once('/').unwrap_or(("", rest));
        if version == "3.0" {
            return Src::V3;
        }
        if version != "1.0" && version != "2.0" {
            return Src::Foreign;
        }
        if module.is_empty() || module == "base" {
            return Src::Core;
        }
        if module == "texturedsurface" {
            return Src::Module(Module::Tex);
        }
        MODULES
            .iter()
            .find(|(_, path, _)| *path == module)
            .map_or(Src::Foreign, |(m, _, _)| Src::Module(*m))
    }

    /// Whether the upgrade rewrites names of this namespace (their declarations are dropped).
    pub(super) fn rewritten(self) -> bool {
        matches!(
            self,
            Src::Core | Src::Module(_) | Src::Gml | Src::Xal | Src::Xlink | Src::Xsi | Src::V3
        )
    }
}

/// `xmlns:...` declarations and schema locations of the root written by the upgrade.
pub(super) fn root_declarations() -> (String, String) {
    let mut decl = String::from(
        r#" xmlns:core="http://www.opengis.net/citygml/3.0" xmlns:gml="http://www.opengis.net/gml/3.2" xmlns:xlink="http://www.w3.org/1999/xlink" xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xmlns:xAL="urn:oasis:names:tc:ciq:xal:3""#,
    );
    let mut loc = String::from(
        "http://www.opengis.net/citygml/3.0 http://schemas.opengis.net/citygml/3.0/core.xsd",
    );
    for (m, path, xsd) in MODULES {
        decl += &format!(
            r#" xmlns:{}="http://www.opengis.net/citygml/{path}/3.0""#,
            m.prefix()
        );
        loc += &format!(
            " http://www.opengis.net/citygml/{path}/3.0 http://schemas.opengis.net/citygml/3.0/{xsd}"
        );
    }
    (decl, loc)
}

const GML_FEATURE: &[&str] = &[
    "gml:metaDataProperty",
    "gml:description",
    "gml:descriptionReference",
    "gml:identifier",
    "gml:name",
    "gml:boundedBy",
    "gml:location",
];
const LIFESPAN: &[&str] = &[
    "core:creationDate",
    "core:terminationDate",
    "core:validFrom",
    "core:validTo",
];
const CITY_OBJECT: &[&str] = &[
    "core:externalReference",
    "core:generalizesTo",
    "core:relativeToTerrain",
    "core:relativeToWater",
    "core:relatedTo",
    "core:appearance",
    "core:genericAttribute",
    "core:dynamizer",
];
const SPACE: &[&str] = &[
    "core:spaceType",
    "core:volume",
    "core:area",
    "core:boundary",
    "core:lod0Point",
    "core:lod0MultiSurface",
    "core:lod0MultiCurve",
    "core:lod1Solid",
    "core:lod2Solid",
    "core:lod2MultiSurface",
    "core:lod2MultiCurve",
    "core:lod3Solid",
    "core:lod3MultiSurface",
    "core:lod3MultiCurve",
];
const PHYSICAL: &[&str] = &[
    "core:lod1TerrainIntersectionCurve",
    "core:lod2TerrainIntersectionCurve",
    "core:lod3TerrainIntersectionCurve",
    "core:pointCloud",
];
const OCCUPIED: &[&str] = &[
    "core:lod1ImplicitRepresentation",
    "core:lod2ImplicitRepresentation",
    "core:lod3ImplicitRepresentation",
];
const THEMATIC: &[&str] = &[
    "core:area",
    "core:lod0MultiCurve",
    "core:lod0MultiSurface",
    "core:lod1MultiSurface",
    "core:lod2MultiSurface",
    "core:lod3MultiSurface",
    "core:pointCloud",
];
const CONSTRUCTION: &[&str] = &[
    "con:conditionOfConstruction",
    "con:dateOfConstruction",
    "con:dateOfDemolition",
    "con:constructionEvent",
    "con:elevation",
    "con:height",
    "con:occupancy",
];
const BUILDING: &[&str] = &[
    "bldg:class",
    "bldg:function",
    "bldg:usage",
    "bldg:roofType",
    "bldg:storeysAboveGround",
    "bldg:storeysBelowGround",
    "bldg:storeyHeightsAboveGround",
    "bldg:storeyHeightsBelowGround",
    "bldg:buildingConstructiveElement",
    "bldg:buildingInstallation",
    "bldg:buildingRoom",
    "bldg:buildingFurniture",
    "bldg:buildingSubdivision",
    "bldg:address",
    "bldg:buildingPart",
];
const BRIDGE: &[&str] = &[
    "brid:class",
    "brid:function",
    "brid:usage",
    "brid:isMovable",
    "brid:bridgeConstructiveElement",
    "brid:bridgeInstallation",
    "brid:bridgeRoom",
    "brid:bridgeFurniture",
    "brid:address",
    "brid:bridgePart",
];
const TUNNEL: &[&str] = &[
    "tun:class",
    "tun:function",
    "tun:usage",
    "tun:tunnelConstructiveElement",
    "tun:tunnelInstallation",
    "tun:hollowSpace",
    "tun:tunnelFurniture",
    "tun:tunnelPart",
];
const TRANSPORTATION: &[&str] = &[
    "tran:trafficDirection",
    "tran:occupancy",
    "tran:trafficSpace",
    "tran:auxiliaryTrafficSpace",
    "tran:hole",
    "tran:marking",
    "tran:class",
    "tran:function",
    "tran:usage",
    "tran:section",
    "tran:intersection",
];

/// The properties of the 3.0 feature written as `name`, in the order of its XSD sequence;
/// `None` for a name the table does not know (its properties keep their order).
pub(super) fn sequence(name: &str) -> Option<Vec<&'static str>> {
    let (prefix, local) = name.split_once(':')?;
    let cfu = |p: &str| -> Vec<&'static str> {
        ["class", "function", "usage"]
            .iter()
            .map(|l| leak(p, l))
            .collect()
    };
    let mut seq: Vec<&'static str> = Vec::new();
    let obj = |s: &mut Vec<&'static str>| {
        s.extend(GML_FEATURE);
        s.extend(LIFESPAN);
        s.extend(CITY_OBJECT);
    };
    let occupied = |s: &mut Vec<&'static str>| {
        obj(s);
        s.extend(SPACE);
        s.extend(PHYSICAL);
        s.extend(OCCUPIED);
    };
    let thematic = |s: &mut Vec<&'static str>| {
        obj(s);
        s.extend(THEMATIC);
    };
    match (prefix, local) {
        ("bldg", "Building" | "BuildingPart") => {
            occupied(&mut seq);
            seq.extend(CONSTRUCTION);
            seq.extend(BUILDING);
        }
        ("brid", "Bridge" | "BridgePart") => {
            occupied(&mut seq);
            seq.extend(CONSTRUCTION);
            seq.extend(BRIDGE);
        }
        ("tun", "Tunnel" | "TunnelPart") => {
            occupied(&mut seq);
            seq.extend(CONSTRUCTION);
            seq.extend(TUNNEL);
        }
        (
            "bldg" | "brid" | "tun",
            "BuildingInstallation" | "BridgeInstallation" | "TunnelInstallation",
        ) => {
            occupied(&mut seq);
            seq.push("con:relationToConstruction");
            seq.extend(cfu(prefix));
        }
        ("bldg" | "brid" | "tun", _) if local.ends_with("Furniture") => {
            occupied(&mut seq);
            seq.extend(cfu(prefix));
        }
        ("bldg" | "brid" | "tun", _) if local.ends_with("ConstructiveElement") => {
            occupied(&mut seq);
            seq.push("con:isStructuralElement");
            seq.push("con:filling");
            seq.extend(cfu(prefix));
        }
        ("bldg", "BuildingRoom") | ("brid", "BridgeRoom") | ("tun", "HollowSpace") => {
            obj(&mut seq);
            seq.extend(SPACE);
            seq.extend(PHYSICAL);
            seq.extend(cfu(prefix));
            seq.push(leak(prefix, "roomHeight"));
            for l in ["Furniture", "Installation"] {
                let p = match prefix {
                    "bldg" => "building",
                    "brid" => "bridge",
                    _ => "tunnel",
                };
                seq.push(leak(prefix, &format!("{p}{l}")));
            }
        }
        ("con", "WindowSurface" | "DoorSurface") => {
            thematic(&mut seq);
            seq.push("con:address");
        }
        ("con", _) if local.ends_with("Surface") => {
            thematic(&mut seq);
            seq.push("con:fillingSurface");
        }
        ("core", "ClosureSurface") => thematic(&mut seq),
        ("gen", "GenericThematicSurface") | ("luse", "LandUse") => {
            thematic(&mut seq);
            seq.extend(cfu(prefix));
        }
        ("tran", "TrafficArea" | "AuxiliaryTrafficArea") => {
            thematic(&mut seq);
            seq.extend(cfu(prefix));
            seq.push("tran:surfaceMaterial");
        }
        ("wtr", "WaterSurface" | "WaterGroundSurface") => {
            thematic(&mut seq);
            seq.push("wtr:waterLevel");
        }
        ("gen", "GenericOccupiedSpace") | ("frn", "CityFurniture") | ("wtr", "WaterBody") => {
            occupied(&mut seq);
            seq.extend(cfu(prefix));
        }
        ("veg", "SolitaryVegetationObject") => {
            occupied(&mut seq);
            seq.extend(cfu(prefix));
            for l in [
                "species",
                "height",
                "trunkDiameter",
                "crownDiameter",
                "rootBallDiameter",
                "maxRootBallDepth",
            ] {
                seq.push(leak("veg", l));
            }
        }
        ("veg", "PlantCover") => {
            occupied(&mut seq);
            seq.extend(cfu(prefix));
            for l in ["averageHeight", "minHeight", "maxHeight"] {
                seq.push(leak("veg", l));
            }
        }
        ("tran", "Road" | "Railway" | "Track" | "Square" | "Waterway") => {
            obj(&mut seq);
            seq.extend(SPACE);
            seq.extend(PHYSICAL);
            seq.extend(TRANSPORTATION);
        }
        ("grp", "CityObjectGroup") => {
            obj(&mut seq);
            seq.extend(SPACE);
            seq.extend(cfu(prefix));
            seq.push("grp:groupMember");
            seq.push("grp:parent");
        }
        ("dem", "ReliefFeature") => {
            obj(&mut seq);
            seq.push("dem:lod");
            seq.push("dem:reliefComponent");
        }
        ("dem", _) if local.ends_with("Relief") => {
            obj(&mut seq);
            seq.push("dem:lod");
            seq.push("dem:extent");
            for l in ["tin", "grid", "ridgeOrValleyLines", "breaklines"] {
                seq.push(leak("dem", l));
            }
        }
        ("app", "Appearance") => {
            seq.extend(GML_FEATURE);
            seq.extend(LIFESPAN);
            seq.push("app:theme");
            seq.push("app:surfaceData");
        }
        _ => return None,
    }
    Some(seq)
}

/// `prefix:local` as a `&'static str` from a small fixed set (interned once).
fn leak(prefix: &str, local: &str) -> &'static str {
    use std::sync::{Mutex, OnceLock};
    static NAMES: OnceLock<Mutex<foldhash::HashSet<&'static str>>> = OnceLock::new();
    let name = format!("{prefix}:{local}");
    let set = NAMES.get_or_init(Default::default);
    let mut set = match set.lock() {
        Ok(s) => s,
        Err(p) => p.into_inner(),
    };
    if let Some(s) = set.get(name.as_str()) {
        return s;
    }
    let s: &'static str = Box::leak(name.into_boxed_str());
    set.insert(s);
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn namespaces() {
        assert_eq!(Src::of(b"http://www.opengis.net/citygml/2.0"), Src::Core);
        assert_eq!(
            Src::of(b"http://www.opengis.net/citygml/base/1.0"),
            Src::Core
        );
        assert_eq!(
            Src::of(b"http://www.opengis.net/citygml/building/1.0"),
            Src::Module(Module::Bldg)
        );
        assert_eq!(
            Src::of(b"http://www.opengis.net/citygml/building/3.0"),
            Src::V3
        );
        assert_eq!(Src::of(b"http://www.opengis.net/gml"), Src::Gml);
        assert_eq!(Src::of(b"urn:x"), Src::Foreign);
        assert!(!Src::Foreign.rewritten());
    }

    #[test]
    fn building_sequence_follows_the_xsd() {
        let s = sequence("bldg:Building").unwrap();
        let at = |n: &str| s.iter().position(|x| *x == n).unwrap();
        assert!(at("gml:name") < at("core:creationDate"));
        assert!(at("core:genericAttribute") < at("core:boundary"));
        assert!(at("core:boundary") < at("core:lod2Solid"));
        assert!(at("core:lod2Solid") < at("con:height"));
        assert!(at("con:height") < at("bldg:function"));
        assert!(at("bldg:address") < at("bldg:buildingPart"));
        let t = sequence("con:RoofSurface").unwrap();
        let at = |n: &str| t.iter().position(|x| *x == n).unwrap();
        assert!(at("core:lod0MultiSurface") < at("core:lod2MultiSurface"));
        assert!(at("core:lod3MultiSurface") < at("con:fillingSurface"));
        assert!(sequence("x:Unknown").is_none());
    }
}
