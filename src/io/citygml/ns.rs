//! Namespace URIs of CityGML 1.0, 2.0 and 3.0 and of GML, matched by URI, never by prefix.

use crate::model::CityGmlVersion;

/// GML 3.1.1 (CityGML 1.0 and 2.0).
pub const GML_311: &[u8] = b"http://www.opengis.net/gml";
/// GML 3.2 (CityGML 3.0).
pub const GML_32: &[u8] = b"http://www.opengis.net/gml/3.2";
/// XLink.
pub const XLINK: &[u8] = b"http://www.w3.org/1999/xlink";

const CITYGML_PREFIX: &[u8] = b"http://www.opengis.net/citygml/";

/// A CityGML module.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Module {
    /// Core (`citygml/2.0`, `citygml/3.0`, ...).
    Core,
    /// Building.
    Building,
    /// Construction (3.0).
    Construction,
    /// Appearance.
    Appearance,
    /// Generics.
    Generics,
    /// Relief.
    Relief,
    /// Any other thematic module (vegetation, bridge, tunnel, furniture, ...).
    Other,
}

/// What a namespace URI is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ns {
    /// GML (3.1.1 or 3.2).
    Gml,
    /// A CityGML module of a given version.
    CityGml(Module, CityGmlVersion),
    /// XLink.
    Xlink,
    /// Unbound (no namespace).
    None,
    /// Anything else: xAL, ADEs, foreign XML.
    Foreign,
}

/// Classify a namespace URI.
///
/// ```
/// use skylod::io::citygml::{Module, Ns, classify};
/// use skylod::model::CityGmlVersion;
/// assert_eq!(
///     classify(b"http://www.opengis.net/citygml/building/2.0"),
///     Ns::CityGml(Module::Building, CityGmlVersion::V2_0)
/// );
/// assert_eq!(classify(b"http://www.opengis.net/gml/3.2"), Ns::Gml);
/// ```
pub fn classify(uri: &[u8]) -> Ns {
    if uri == GML_311 || uri == GML_32 {
        return Ns::Gml;
    }
    if uri == XLINK {
        return Ns::Xlink;
    }
    if let Some(rest) = uri.strip_prefix(CITYGML_PREFIX) {
        let rest = rest.strip_suffix(b"/").unwrap_or(rest);
        let (module, version) = match rest.iter().rposition(|&c| c == b'/') {
            Some(i) => (&rest[..i], &rest[i + 1..]),
            None => (&b""[..], rest),
        };
        let version = match version {
            b"1.0" => CityGmlVersion::V1_0,
            b"2.0" => CityGmlVersion::V2_0,
            b"3.0" => CityGmlVersion::V3_0,
            _ => return Ns::Foreign,
        };
        let module = match module {
            b"" => Module::Core,
            b"building" => Module::Building,
            b"construction" => Module::Construction,
            b"appearance" => Module::Appearance,
            b"generics" => Module::Generics,
            b"relief" => Module::Relief,
            _ => Module::Other,
        };
        return Ns::CityGml(module, version);
    }
    Ns::Foreign
}

/// Namespaces that are not ADEs although they are not CityGML or GML: xAL, XML Schema instance, SMIL, WFS.
pub fn is_standard_foreign(uri: &[u8]) -> bool {
    uri.starts_with(b"urn:oasis:names:tc:ciq")
        || uri == b"http://www.w3.org/2001/XMLSchema-instance"
        || uri.starts_with(b"http://www.w3.org/2001/SMIL20")
        || uri == b"http://www.opengis.net/wfs"
        || uri == b"http://www.w3.org/XML/1998/namespace"
}

/// Core properties that come before any other child of a city object (CityGML 1.0 to 3.0,
/// `core:_CityObject` / `core:AbstractCityObject`): a generic attribute added to a feature goes
/// after them. Local names; GML's own leading properties and the generics module come before
/// them in document order.
pub const CORE_LEADING: &[&str] = &[
    "creationDate",
    "terminationDate",
    "validFrom",
    "validTo",
    "externalReference",
    "generalizesTo",
    "relativeToTerrain",
    "relativeToWater",
    "relatedTo",
    "appearance",
    "genericAttribute",
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn versions_and_modules() {
        assert_eq!(
            classify(b"http://www.opengis.net/citygml/1.0"),
            Ns::CityGml(Module::Core, CityGmlVersion::V1_0)
        );
        assert_eq!(
            classify(b"http://www.opengis.net/citygml/construction/3.0"),
            Ns::CityGml(Module::Construction, CityGmlVersion::V3_0)
        );
        assert_eq!(
            classify(b"http://www.opengis.net/citygml/vegetation/2.0"),
            Ns::CityGml(Module::Other, CityGmlVersion::V2_0)
        );
        assert_eq!(
            classify(b"http://www.opengis.net/citygml/building/9.9"),
            Ns::Foreign
        );
        assert_eq!(classify(b"http://www.opengis.net/gml"), Ns::Gml);
        assert_eq!(classify(b"urn:x"), Ns::Foreign);
        assert!(is_standard_foreign(b"urn:oasis:names:tc:ciq:xal:3"));
    }
}
