//! The CityJSON side of the chunked read and of the streamed CityJSON edits, here because
//! they hand out this folder's [`Chunk`](crate::io::citygml::read::Chunk)s and errors
//! (`io::cityjson`, the format's mapping into the model, imports nothing of `io::citygml`):
//! `stream` reads a JSON document in passes (its members in any order, `CityObjects` one
//! object and `vertices` one vertex at a time), `chunks` a `.city.json` in chunks of whole
//! city-object trees, `seq` CityJSONSeq in chunks of lines, `source` what the CityJSON writer
//! copies from a CityJSON source.

pub(crate) mod chunks;
mod seq;
pub(crate) mod source;
pub(crate) mod stream;

use crate::io::citygml::error::ReadError;
use std::io::BufRead;
use std::path::Path;

/// Whether the file at `path` holds JSON (CityJSON, CityJSONSeq; gzip-compressed or not), by
/// its first bytes ([`crate::io::cityjson::sniff`]); false when it cannot be read.
pub fn is_json_file(path: &Path) -> bool {
    open(path).is_ok_and(|mut r| {
        r.fill_buf()
            .is_ok_and(|h| crate::io::cityjson::sniff(h) == crate::io::cityjson::Sniffed::Json)
    })
}

/// Open a (possibly gzip-compressed) file, or standard input for `-` (its bytes as kept by
/// [`crate::io::files::stdin_bytes`]).
pub(crate) fn open(input: &Path) -> Result<Box<dyn BufRead + Send>, ReadError> {
    let (r, _) = crate::io::files::open_decoded(input).map_err(|source| ReadError::Io {
        file: input.to_path_buf(),
        source,
    })?;
    Ok(r)
}
