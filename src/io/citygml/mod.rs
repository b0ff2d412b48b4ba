//! CityGML 1.0 / 2.0 / 3.0: streaming reader into the model, span-preserving writer.

pub(crate) mod error;
pub(crate) mod ns;
pub(crate) mod read;
pub(crate) mod source;
pub(crate) mod write;
pub use ns::{classify, Module, Ns};
pub use read::{
    read_bytes, read_file_chunked, read_from, stream, Chunk, Passes, Reread, Streamed, CHUNK_BYTES,
};
pub use source::{open, resolve};
pub use write::{
    atomic_write_bytes, check_target, is_stdout, write_document, write_document_to, Edit,
    GmlWriter, WriteOptions,
};

pub use error::{Location, ReadError, WriteError};
pub use read::{read_file, read_file_with, read_source, ReadOptions};
