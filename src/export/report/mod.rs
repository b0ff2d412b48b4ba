//! What the commands report, as typed JSON: the `lod` report (`report`,
//! `schemas/report.schema.json`), the documents of `svf`, `sun-hours`, `horizon` and
//! `evaluate` with `--json`, and the model counts of `skylod stats` (`stats`).

pub(crate) mod cadastre;
pub(crate) mod evaluate;
pub(crate) mod horizon;
pub(crate) mod irradiance;
pub(crate) mod report;
pub(crate) mod row;
pub mod schema;
pub(crate) mod stats;
pub(crate) mod sun_hours;
pub(crate) mod svf;
pub(crate) mod text;
pub use cadastre::{
    surface_rows, write_point_table, write_surface_table, SurfaceRow, TableLayout, MONTH_COLUMNS,
};
pub use evaluate::write_table;
pub use irradiance::write_csv;
pub use report::{Guarantee, Parameters, Report, Timings};
pub use stats::{FileStats, Stats, StatsOutput};
pub use sun_hours::SunSetting;
pub use text::{Document, TextContext};
