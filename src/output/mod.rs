//! What the commands report: the `lod` report ([`report`], `schemas/report.schema.json`)
//! and the model counts of `skylod stats` ([`stats`]).

pub mod report;
pub mod stats;
