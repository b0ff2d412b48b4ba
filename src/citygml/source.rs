//! Opening a source document: plain or gzip-compressed, detected by content.

use super::error::ReadError;
use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

const BUF: usize = 256 * 1024;

/// Open `path` for streaming; gzip is detected from the magic bytes (not the extension).
/// Returns the reader and whether the file was compressed.
pub fn open(path: &Path) -> Result<(Box<dyn BufRead + Send>, bool), ReadError> {
    let io = |source| ReadError::Io {
        file: path.to_path_buf(),
        source,
    };
    let file = File::open(path).map_err(io)?;
    let mut reader = BufReader::with_capacity(BUF, file);
    let head = reader.fill_buf().map_err(io)?;
    if head.starts_with(&[0x1f, 0x8b]) {
        let dec = flate2::bufread::MultiGzDecoder::new(reader);
        Ok((Box::new(BufReader::with_capacity(BUF, dec)), true))
    } else {
        Ok((Box::new(reader), false))
    }
}

/// Copy `len` bytes starting at the current position of `src` into `out`.
pub(crate) fn copy_exact<R: Read + ?Sized, W: std::io::Write + ?Sized>(
    src: &mut R,
    out: &mut W,
    len: u64,
) -> std::io::Result<u64> {
    let n = std::io::copy(&mut src.take(len), out)?;
    if n != len {
        return Err(std::io::Error::new(
            std::io::ErrorKind::UnexpectedEof,
            "source shorter than expected",
        ));
    }
    Ok(n)
}
