//! A CRS by its EPSG codes, as `skylod reproject` and PROJ take it: [`CrsName`] is the
//! horizontal (or 3-D) code and an optional vertical one, read from a `srsName` or a
//! command-line CRS by the one `srsName` parser, [`Crs::parse`] (`EPSG:n`, `EPSG:a+b`,
//! `urn:ogc:def:crs:EPSG::n`, `urn:ogc:def:crs:EPSG:6.12:n`, the compound
//! `urn:ogc:def:crs,crs:EPSG::a,crs:EPSG::b`, `http://www.opengis.net/def/crs/EPSG/0/n`, the
//! AdV `urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH`), and written back as an OGC URN.
//!
//! # Example
//! ```
//! use skylod::model::crs::CrsName;
//! let c = CrsName::parse("urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783").unwrap();
//! assert_eq!((c.horizontal, c.vertical), (25832, Some(5783)));
//! assert_eq!(CrsName::parse("urn:adv:crs:ETRS89_UTM32*DE_DHHN2016_NH").unwrap().vertical, Some(7837));
//! assert_eq!(CrsName::parse("EPSG:4326").unwrap().urn(), "urn:ogc:def:crs:EPSG::4326");
//! assert!(CrsName::parse("#local-CRS-1").is_none());
//! ```

use super::parse::Crs;

/// A CRS by EPSG codes: horizontal (or 3-D) and optional vertical.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CrsName {
    /// Horizontal (projected or geographic, possibly 3-D) CRS.
    pub horizontal: u32,
    /// Vertical CRS of a compound CRS.
    pub vertical: Option<u32>,
}

impl CrsName {
    /// Parse a `srsName` or a command-line CRS (module docs). `None` when no EPSG code is
    /// found.
    pub fn parse(text: &str) -> Option<CrsName> {
        CrsName::from_crs(&Crs::parse(text))
    }

    /// The EPSG codes of a parsed [`Crs`] (`None` for one without a code,
    /// such as OGC:CRS84).
    pub fn from_crs(crs: &Crs) -> Option<CrsName> {
        Some(CrsName {
            horizontal: crs.epsg?,
            vertical: crs.vertical_epsg,
        })
    }

    /// The OGC URN of this CRS (compound when it has a vertical part).
    pub fn urn(&self) -> String {
        match self.vertical {
            Some(v) => format!(
                "urn:ogc:def:crs,crs:EPSG::{},crs:EPSG::{v}",
                self.horizontal
            ),
            None => format!("urn:ogc:def:crs:EPSG::{}", self.horizontal),
        }
    }
}

impl std::fmt::Display for CrsName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.vertical {
            Some(v) => write!(f, "EPSG:{}+{v}", self.horizontal),
            None => write!(f, "EPSG:{}", self.horizontal),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srs_name_forms() {
        for (name, h, v) in [
            ("EPSG:25832", 25832, None),
            ("epsg:25832+5783", 25832, Some(5783)),
            ("urn:ogc:def:crs:EPSG::6697", 6697, None),
            ("urn:ogc:def:crs:EPSG:6.12:31466", 31466, None),
            (
                "urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783",
                25832,
                Some(5783),
            ),
            (
                "urn:ogc:def:crs,crs:EPSG:6.12:31466,crs:EPSG:6.12:5783",
                31466,
                Some(5783),
            ),
            (
                "urn:ogc:def:crs:EPSG:25832, crs:EPSG:5783",
                25832,
                Some(5783),
            ),
            ("http://www.opengis.net/def/crs/EPSG/0/2263", 2263, None),
            ("urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH", 25832, Some(5783)),
            ("urn:adv:crs:ETRS89_UTM33", 25833, None),
        ] {
            let c = CrsName::parse(name).unwrap_or_else(|| panic!("{name}"));
            assert_eq!((c.horizontal, c.vertical), (h, v), "{name}");
        }
        for bad in ["", "#local-CRS-1", "urn:ogc:def:crs:OGC::CRS84", "EPSG:"] {
            assert_eq!(CrsName::parse(bad), None, "{bad}");
        }
        assert_eq!(
            CrsName::parse("EPSG:25832+5783").unwrap().urn(),
            "urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783"
        );
        assert_eq!(
            CrsName::parse("EPSG:25832+5783").unwrap().to_string(),
            "EPSG:25832+5783"
        );
    }
}
