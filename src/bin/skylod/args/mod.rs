//! The argument groups shared by the commands, one group per file, each a clap struct
//! flattened into the commands that take it (never copied, so the commands cannot drift
//! apart).

pub mod bound;
pub mod common;
pub mod crs;
pub mod region;
pub mod scene;
pub mod shard;
pub mod tracing;
