//! The text of the tracing commands' documents: a table on standard output and the summary
//! lines the CLI writes on standard error, from the same types as their JSON.

use serde::Serialize;
use std::io::Write;

/// What the text of a document says beyond its JSON.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub struct TextContext {
    /// Polygons of the model that are traced ([`crate::model::CityModel::traced_polygon_count`]).
    pub traced_polygons: usize,
    /// Decimals of plan coordinates ([`crate::model::crs::Crs::plan_decimals`]).
    pub decimals: usize,
    /// Whether the table has its header line (a shard after the first leaves it out, so
    /// that the shards' tables concatenated are the serial run's).
    pub header: bool,
}

impl TextContext {
    /// The context of a model with `traced_polygons` traced, plan coordinates with
    /// `decimals` decimals, a header line when `header`.
    pub fn new(traced_polygons: usize, decimals: usize, header: bool) -> Self {
        TextContext {
            traced_polygons,
            decimals,
            header,
        }
    }
}

/// A document of a tracing command: JSON (serde), a table and summary lines.
pub trait Document: Serialize {
    /// The table, one line per POI (after a header line when `cx.header`).
    ///
    /// # Errors
    /// Writing to `out`.
    fn write_table(&self, out: &mut dyn Write, cx: &TextContext) -> std::io::Result<()>;

    /// The summary lines of the run (POIs, settings, model, inputs, timings).
    fn summary(&self, cx: &TextContext) -> Vec<String>;
}

/// `N polygons (T traced) from K input(s); read 1 ms, bvh 2 ms, ...`: the model and the
/// timings (`(stage, ms)`) that close a summary line.
pub(crate) fn run_part(
    polygons: usize,
    cx: &TextContext,
    inputs: usize,
    ms: &[(&str, f64)],
) -> String {
    let stages: Vec<String> = ms.iter().map(|(s, t)| format!("{s} {t:.0} ms")).collect();
    format!(
        "{polygons} polygons ({} traced) from {inputs} input(s); {}",
        cx.traced_polygons,
        stages.join(", ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::export::report::horizon::{profile_summary, HorizonOutput, HorizonPoi};
    use crate::export::report::svf::{SvfOutput, SvfPoi, TraceTimings};
    use crate::model::Poi;
    use crate::solar::{HorizonProfile, SkyView};

    #[test]
    fn summaries_and_tables_say_what_the_cli_printed() {
        let p = Poi::at("a", [1.0, 2.0, 3.0]);
        let view = SkyView {
            svf: 0.5,
            sky_exposure: 0.25,
            rays: 10,
        };
        let t = TraceTimings {
            read: 1.26,
            bvh: 2.0,
            trace: 3.5,
        };
        let rows = vec![SvfPoi::new(&p, &view, &[])];
        let doc = SvfOutput::new(rows, 100, 7, vec!["x.gml".into()], 12, t);
        let cx = TextContext::new(9, 2, false);
        assert_eq!(
            doc.summary(&cx),
            [
                "1 POI(s), 100 rays per bundle, seed 7; 12 polygons (9 traced) from 1 input(s); \
              read 1 ms, bvh 2 ms, trace 4 ms"
            ]
        );
        let mut table = Vec::new();
        doc.write_table(&mut table, &cx).unwrap();
        let table = String::from_utf8(table).unwrap();
        assert!(
            table.starts_with("a ") && table.contains(" 0.5000 "),
            "{table}"
        );
        assert_eq!(table.lines().count(), 1, "no header: {table}");
        let h = HorizonProfile {
            azimuth: vec![0.0, 90.0, 180.0, 270.0],
            elevation: vec![10.0, 30.0, 30.0, 2.0],
            overhang: vec![None; 4],
        };
        assert_eq!(
            profile_summary("a", &h),
            "a: mean elevation 18.00°, highest 30.00° at azimuth 90°"
        );
        let rows = vec![HorizonPoi::from_profile(&p, &h, &[])];
        let doc = HorizonOutput::new(rows, 90.0, 0.01, vec![], 12, t);
        assert_eq!(
            doc.summary(&cx),
            [
                "1 POI(s), 4 azimuths each (step 90°); 12 polygons (9 traced) from 0 input(s); \
              read 1 ms, bvh 2 ms, trace 4 ms"
            ]
        );
    }
}
