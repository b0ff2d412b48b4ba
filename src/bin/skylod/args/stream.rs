//! `--stream-chunk` (hidden: for tests and measurements; the default suits every file): the
//! chunk in which `stats`, `convert` and `lod` read a large file ([`skylod::pipeline::batch::chunk_for`]).

use skylod::io::citygml::CHUNK_BYTES;

/// `--stream-chunk BYTES`.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct StreamArgs {
    /// A file of at least four chunks (gzip: counted ten times its size) is read one chunk
    /// of whole top-level members at a time (memory follows the chunk, not the file; the same output); 0: read
    /// every file whole.
    #[arg(long, hide = true, value_name = "BYTES", default_value_t = CHUNK_BYTES)]
    pub stream_chunk: u64,
}
