//! What the commands report, as typed JSON: the `lod` report ([`report`],
//! `schemas/report.schema.json`), the documents of `svf`, `sun-hours`, `horizon` and
//! `evaluate` with `--json`, and the model counts of `skylod stats` ([`stats`]).

pub mod evaluate;
pub mod horizon;
pub mod irradiance;
pub mod report;
pub mod row;
pub mod schema;
pub mod stats;
pub mod sun_hours;
pub mod svf;
pub mod text;
