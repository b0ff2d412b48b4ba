//! One module per subcommand: its arguments (the shared groups of [`crate::args`]
//! flattened) and its `run`.

pub mod completions;
pub mod convert;
pub mod evaluate;
pub mod fisheye;
pub mod horizon;
pub mod lod;
pub mod reproject;
pub mod rough;
pub mod stats;
pub mod sun_hours;
pub mod svf;
pub mod synth;
