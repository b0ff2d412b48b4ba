//! Files and the city formats: the file helpers every reader and writer shares (`files`:
//! gzip, standard input and output, target checks, atomic writes), CityGML ([`citygml`]:
//! the streaming reader, the span-preserving writer, merge, reprojection, edits, upgrade)
//! and CityJSON ([`cityjson`]), both read into the same [`crate::model::CityModel`]; an
//! error's chain as one message (`message`).

// CityGML 1.0/2.0/3.0: the streaming reader, the span-preserving writer, merge, reprojection.
pub mod citygml;
// CityJSON 1.x/2.0 and CityJSONSeq read into the same model as CityGML.
pub mod cityjson;
// Files in and out: gzip, standard output, target checks, atomic writes.
pub(crate) mod files;
// An error and its causes as one message.
pub(crate) mod message;
pub use files::{
    atomic_write, check_target, decoded, describe_io, is_gzip, is_stdout, set_stdin_bytes,
    stdin_bytes, CountingWriter, FileError, Protected, TargetError,
};
pub use message::{chain_message, is_broken_pipe, plain_text};
