//! The viewer page written beside a tileset: CesiumJS from its CDN (loaded by the user's
//! browser), the tileset styled by class, a click showing the picked object's properties.

/// The CesiumJS release the page loads.
pub(super) const CESIUM_VERSION: &str = "1.145";

/// The page, titled after the source `label`.
pub(super) fn page(label: &str) -> String {
    include_str!("viewer.html")
        .replace("{{TITLE}}", &crate::io::citygml::write::escape_attr(label))
        .replace("{{CESIUM_VERSION}}", CESIUM_VERSION)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn title_is_escaped_and_version_set() {
        let p = page("a<b>&\"c\".gml");
        assert!(p.contains("a&lt;b>&amp;&quot;c&quot;.gml"));
        assert!(!p.contains("{{"));
        assert!(p.contains(&format!("releases/{CESIUM_VERSION}/Build/Cesium/Cesium.js")));
    }
}
