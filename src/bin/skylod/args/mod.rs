//! The argument groups shared by the commands, one group per file, each a clap struct
//! flattened into the commands that take it (never copied, so the commands cannot drift
//! apart).

pub mod attributes;
pub mod bound;
pub mod citygml_io;
pub mod crs;
pub mod jobs;
pub mod output;
pub mod per_file;
pub mod poi;
pub mod region;
pub mod rough;
pub mod scene;
pub mod select;
pub mod shard;
pub mod site;
pub mod stream;
pub mod sun;
pub mod tracing;
pub mod weather;

/// A clap value parser: a finite number ≥ 0.
pub fn non_negative(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(format!("must be a finite number >= 0, got {s}"))
    }
}

/// A clap value parser: a finite number > 0.
pub fn positive(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("must be a finite number > 0, got {s}"))
    }
}
