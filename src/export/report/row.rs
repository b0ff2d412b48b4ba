//! One POI's row in the JSON of the tracing commands (`svf`, `sun-hours`, `horizon`,
//! `irradiance`): the POI, the command's values and the POI's flags.

use crate::lod::poi::checks::PoiFlag;
use crate::model::Poi;
use schemars::JsonSchema;
use serde::Serialize;

/// One POI of a tracing command's `--json` document: its id, position and normal, the
/// command's `values` (their fields written inline) and its flags, in that order.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
#[non_exhaustive]
pub struct PoiRow<T> {
    /// Id.
    pub id: String,
    /// Position in the model's CRS.
    pub poi: [f64; 3],
    /// Surface normal, if given (a horizontal plane otherwise).
    pub normal: Option<[f64; 3]>,
    /// What the command computed for this POI.
    #[serde(flatten)]
    pub values: T,
    /// What makes this POI's result suspect.
    pub flags: Vec<PoiFlag>,
}

impl<T> PoiRow<T> {
    /// The row of `poi` (in the model's CRS) with its `values` and `flags`.
    pub fn of(poi: &Poi, values: T, flags: &[PoiFlag]) -> Self {
        PoiRow {
            id: poi.id.clone(),
            poi: poi.position.to_array(),
            normal: poi.normal.map(|n| n.to_array()),
            values,
            flags: flags.to_vec(),
        }
    }
}

/// The values read through the row (`row.svf` for `row.values.svf`).
impl<T> std::ops::Deref for PoiRow<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.values
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_stand_between_the_poi_and_its_flags() {
        #[derive(Serialize)]
        struct V {
            a: u8,
        }
        let p = Poi::at("p", [1.0, 2.0, 3.0]);
        let row = PoiRow::of(&p, V { a: 7 }, &[]);
        assert_eq!(
            serde_json::to_string(&row).unwrap(),
            r#"{"id":"p","poi":[1.0,2.0,3.0],"normal":null,"a":7,"flags":[]}"#
        );
    }
}
