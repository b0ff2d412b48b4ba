//! `--stream-chunk`: how `stats` and `convert` read a large file (hidden: for tests and
//! measurements; the default suits every file).

use skylod::citygml::read::CHUNK_BYTES;
use std::path::Path;

/// `--stream-chunk BYTES`.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct StreamArgs {
    /// A file of at least four chunks (gzip: counted ten times its size) is read one chunk
    /// of whole top-level members at a time (memory follows the chunk, not the file; the same output); 0: read
    /// every file whole.
    #[arg(long, hide = true, value_name = "BYTES", default_value_t = CHUNK_BYTES)]
    pub stream_chunk: u64,
}

impl StreamArgs {
    /// The chunk size to stream `path` with, or `None` to read it whole (small files and
    /// standard input are read whole, and CityJSON). A gzip-compressed file counts as ten times its size
    /// (CityGML compresses 10 to 20 times): it is streamed from a temporary file.
    pub fn chunk_for(&self, path: &Path) -> Option<u64> {
        let len = std::fs::metadata(path).ok()?.len();
        let mut head = [0u8; 2];
        let gzip = std::fs::File::open(path)
            .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut head))
            .is_ok()
            && skylod::io::is_gzip(&head);
        let len = if gzip { len.saturating_mul(10) } else { len };
        // CityJSON is read whole (its reader is not the chunked CityGML one).
        let mut opened = skylod::citygml::source::open(path).ok()?.0;
        let json = std::io::BufRead::fill_buf(&mut opened)
            .map(|head| skylod::cityjson::sniff(head) == skylod::cityjson::Sniffed::Json)
            .unwrap_or(false);
        (!json && self.stream_chunk > 0 && len >= self.stream_chunk.saturating_mul(4))
            .then_some(self.stream_chunk)
    }
}
