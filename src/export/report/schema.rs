//! JSON Schemas (draft 2020-12) of the typed outputs, generated from the types with
//! `schemars`: the committed files under `schemas/` are these, byte for byte (a unit test
//! regenerates them; `SKYLOD_BLESS=1 cargo test --lib output::schema` rewrites them).
//!
//! # Example
//! ```
//! let text = skylod::export::report::schema::text(&skylod::export::report::schema::report());
//! assert!(text.contains("\"report_version\""));
//! ```

use schemars::generate::SchemaSettings;
use schemars::{JsonSchema, Schema};

/// The schema of a `T` as serialized (an `Option` field is always there, `null` or not,
/// unless skipped when empty), as its own document (definitions under `$defs`).
fn root<T: JsonSchema>() -> Schema {
    SchemaSettings::draft2020_12()
        .for_serialize()
        .into_generator()
        .into_root_schema_for::<T>()
}

/// `schemas/report.schema.json`: the report of `skylod lod --report FILE`
/// ([`super::report::Report`]).
pub fn report() -> Schema {
    root::<super::report::Report>()
}

/// `schemas/svf.schema.json`: `skylod svf --json` (`super::svf::SvfOutput`).
pub fn svf() -> Schema {
    root::<super::svf::SvfOutput>()
}

/// `schemas/sun-hours.schema.json`: `skylod sun-hours --json`
/// (`super::sun_hours::SunHoursOutput`).
pub fn sun_hours() -> Schema {
    root::<super::sun_hours::SunHoursOutput>()
}

/// `schemas/horizon.schema.json`: `skylod horizon --json`
/// (`super::horizon::HorizonOutput`).
pub fn horizon() -> Schema {
    root::<super::horizon::HorizonOutput>()
}

/// `schemas/evaluate.schema.json`: `skylod evaluate --json`
/// (`super::evaluate::EvaluateOutput`).
pub fn evaluate() -> Schema {
    root::<super::evaluate::EvaluateOutput>()
}

/// `schemas/stats.schema.json`: `skylod stats --json` ([`super::stats::StatsOutput`]).
pub fn stats() -> Schema {
    root::<super::stats::StatsOutput>()
}

/// `schemas/irradiance.schema.json`: `skylod irradiance --json`
/// (`super::irradiance::IrradianceOutput`).
pub fn irradiance() -> Schema {
    root::<super::irradiance::IrradianceOutput>()
}

/// Every committed schema: its file name under `schemas/` and the schema.
pub fn all() -> Vec<(&'static str, Schema)> {
    vec![
        ("report.schema.json", report()),
        ("svf.schema.json", svf()),
        ("sun-hours.schema.json", sun_hours()),
        ("horizon.schema.json", horizon()),
        ("evaluate.schema.json", evaluate()),
        ("stats.schema.json", stats()),
        ("irradiance.schema.json", irradiance()),
    ]
}

/// A schema as written to its file: pretty JSON and a final newline.
pub fn text(schema: &Schema) -> String {
    let mut s = serde_json::to_string_pretty(schema).unwrap_or_default();
    s.push('\n');
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{AssetKind, CityGmlVersion};
    use std::path::Path;

    /// The enums written by hand in `#[schemars(extend(...))]` of the report are the names the
    /// types write (a new variant breaks the exhaustive matches below: add it to
    /// [`AssetKind::ALL`] and to the report's enum).
    #[test]
    fn report_enums_follow_the_types() {
        use AssetKind::*;
        let kinds = AssetKind::ALL;
        assert!(kinds.windows(2).all(|w| w[0] < w[1]));
        for k in kinds {
            match k {
                Roof | Wall | Ground | Closure | OuterCeiling | OuterFloor | Installation
                | Window | Door | Body | Other => {}
            }
        }
        let versions = [
            CityGmlVersion::V1_0,
            CityGmlVersion::V2_0,
            CityGmlVersion::V3_0,
        ];
        for v in versions {
            match v {
                CityGmlVersion::V1_0 | CityGmlVersion::V2_0 | CityGmlVersion::V3_0 => {}
            }
        }
        let schema = report().to_value();
        let defs = &schema["$defs"];
        let names = |v: &serde_json::Value| -> Vec<String> {
            v.as_array()
                .map(|a| {
                    a.iter()
                        .filter_map(|x| x.as_str().map(String::from))
                        .collect()
                })
                .unwrap_or_default()
        };
        let want: Vec<String> = kinds.iter().map(|k| k.as_str().to_string()).collect();
        assert_eq!(
            names(&defs["AssetEntry"]["properties"]["kind"]["enum"]),
            want
        );
        let want: Vec<String> = versions.iter().map(|v| v.as_str().to_string()).collect();
        assert_eq!(
            names(&defs["InputEntry"]["properties"]["citygml_version"]["enum"]),
            want
        );
    }

    /// The committed schemas are the generated ones; `SKYLOD_BLESS=1` rewrites them.
    #[test]
    fn committed_schemas_are_generated() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("schemas");
        let bless = std::env::var_os("SKYLOD_BLESS").is_some_and(|v| v == "1");
        let mut stale = Vec::new();
        for (name, schema) in all() {
            let path = dir.join(name);
            let want = text(&schema);
            let have = std::fs::read_to_string(&path).unwrap_or_default();
            if have == want {
                continue;
            }
            if bless {
                std::fs::write(&path, want).unwrap();
            } else {
                stale.push(format!("schemas/{name}"));
            }
        }
        assert!(
            stale.is_empty(),
            "{} differ from the types: regenerate with \
             `SKYLOD_BLESS=1 cargo test --lib output::schema` and review the diff",
            stale.join(", ")
        );
    }
}
