//! The streamed edits of `subset`, `filter-lods` and `upgrade`, one call each whatever the
//! input's format: CityGML through [`crate::export::transform::citygml::edit`] and
//! [`crate::export::transform::citygml::upgrade`], CityJSON and CityJSONSeq (by content, [`is_json_file`])
//! through [`crate::export::transform::cityjson`] and, for an upgrade to a CityGML name,
//! [`crate::export::citygml_from_cityjson`]. [`Transform::apply`] is what
//! [`Batch::run_each`](super::run::Batch::run_each) runs on each input.

use super::inputs::is_citygml_name;
use crate::export::citygml_from_cityjson::{citygml_from_cityjson, is_json_file, TargetVersion};
use crate::export::transform::citygml::edit::{self, Lods, Subset};
use crate::export::transform::citygml::upgrade::{upgrade, UpgradeOptions};
use crate::export::transform::cityjson;
use crate::io::citygml::write::WriteOptions;
use crate::io::citygml::WriteError;
use std::path::Path;

/// An edit of a document, its rule with it.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub enum Transform {
    /// Keep the top-level city objects that match a box, ids or types.
    Subset(Box<Subset>),
    /// Keep or remove LoD representations.
    FilterLods(Lods),
    /// CityGML 1.0 / 2.0 → 3.0; CityJSON → CityGML 3.0 for a CityGML output name, else
    /// CityJSON 1.x → 2.0 (as `cjio upgrade`).
    Upgrade(UpgradeOptions),
}

impl Transform {
    /// Apply the edit to `input`, written to `out` (atomically; `-` for standard output); its
    /// summary line, naming the output `shown` (the merge target of a staged part).
    ///
    /// # Errors
    /// A refused target, a source that cannot be read, a rule that cannot be applied (a box
    /// that cannot be converted into the document's CRS), I/O errors.
    pub fn apply(
        &self,
        input: &Path,
        out: &Path,
        shown: &Path,
        opts: &WriteOptions,
    ) -> Result<String, WriteError> {
        let json = is_json_file(input);
        Ok(match self {
            Transform::Subset(r) if json => {
                cityjson::subset(input, out, r, opts)?.describe(input, shown)
            }
            Transform::Subset(r) => edit::subset(input, out, r, opts)?.describe(input, shown),
            Transform::FilterLods(r) if json => {
                cityjson::filter_lods(input, out, r, opts)?.describe(input, shown)
            }
            Transform::FilterLods(r) => {
                edit::filter_lods(input, out, r, opts)?.describe(input, shown)
            }
            Transform::Upgrade(o) if !json => upgrade(input, out, o, opts)?.describe(input, shown),
            Transform::Upgrade(_) if is_citygml_name(&out.to_string_lossy()) => {
                let v = TargetVersion::V3_0;
                citygml_from_cityjson(input, out, v, opts)?.describe(input, shown)
            }
            Transform::Upgrade(_) => {
                cityjson::upgrade_cityjson(input, out, opts)?.describe(input, shown)
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::export::transform::citygml::edit::LodMode;
    use std::path::PathBuf;

    fn fixture(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fixtures")
            .join(name)
    }

    /// `edit` and `direct` on `input`, each written into a new directory as `name`: their
    /// lines (the directory left out) and their bytes.
    fn both(
        edit: &Transform,
        input: &Path,
        name: &str,
        direct: impl Fn(&Path, &Path) -> String,
    ) -> [(String, Vec<u8>); 2] {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (
            dir.path().join("a").join(name),
            dir.path().join("b").join(name),
        );
        std::fs::create_dir_all(a.parent().unwrap()).unwrap();
        std::fs::create_dir_all(b.parent().unwrap()).unwrap();
        let opts = WriteOptions::default();
        let la = edit.apply(input, &a, Path::new(name), &opts).unwrap();
        let lb = direct(&b, Path::new(name));
        [
            (la, std::fs::read(&a).unwrap()),
            (lb, std::fs::read(&b).unwrap()),
        ]
    }

    #[test]
    fn each_format_goes_to_its_own_editor() {
        let (lods, mode) = (vec![2], LodMode::Remove);
        let lods = Lods {
            lods,
            mode,
            ..Lods::default()
        };
        let e = Transform::FilterLods(lods.clone());
        let gml = fixture("chimney-citygml2.gml");
        let [a, b] = both(&e, &gml, "o.gml", |o, shown| {
            let opts = WriteOptions::default();
            edit::filter_lods(&gml, o, &lods, &opts)
                .unwrap()
                .describe(&gml, shown)
        });
        assert_eq!(a, b);
        let json = fixture("cityjson/cjio-multi_lod.city.json");
        let [a, b] = both(&e, &json, "o.city.json", |o, shown| {
            let opts = WriteOptions::default();
            let s = cityjson::filter_lods(&json, o, &lods, &opts).unwrap();
            s.describe(&json, shown)
        });
        assert_eq!(a, b);
        assert!(
            a.1.starts_with(b"{"),
            "CityJSON written for a CityJSON input"
        );
    }

    #[test]
    fn an_upgrade_of_cityjson_follows_the_output_name() {
        let e = Transform::Upgrade(UpgradeOptions::default());
        let json = fixture("cityjson/cjio-dummy.city.json");
        let [a, b] = both(&e, &json, "o.gml", |o, shown| {
            let (v, opts) = (TargetVersion::V3_0, WriteOptions::default());
            let s = citygml_from_cityjson(&json, o, v, &opts).unwrap();
            s.describe(&json, shown)
        });
        assert_eq!(a, b);
        assert!(String::from_utf8_lossy(&a.1).contains("citygml/3.0"));
        let [a, b] = both(&e, &json, "o.city.json", |o, shown| {
            let s = cityjson::upgrade_cityjson(&json, o, &WriteOptions::default()).unwrap();
            s.describe(&json, shown)
        });
        assert_eq!(a, b);
        let gml = fixture("chimney-citygml2.gml");
        let [a, b] = both(&e, &gml, "o.gml", |o, shown| {
            let (u, opts) = (UpgradeOptions::default(), WriteOptions::default());
            upgrade(&gml, o, &u, &opts).unwrap().describe(&gml, shown)
        });
        assert_eq!(a, b);
    }
}
