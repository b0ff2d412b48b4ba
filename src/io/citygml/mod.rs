//! CityGML 1.0 / 2.0 / 3.0: streaming reader into the model, span-preserving writer.

pub mod edit;
pub mod error;
pub mod ns;
pub mod read;
pub mod reproject;
pub mod source;
pub mod upgrade;
pub mod write;

pub use error::{Location, ReadError, WriteError};
pub use read::{read_file, read_file_with, read_source, ReadOptions};
