//! Opening a source document: plain or gzip-compressed, detected by content; on disk, in
//! memory ([`Source::Memory`]), or standard input (the path `-`, read whole into memory once:
//! [`crate::io::files::stdin_bytes`]).

use super::error::ReadError;
use crate::model::Source;
use std::fs::File;
use std::io::{BufRead, BufReader, Cursor, Read};
use std::path::Path;
use std::sync::Arc;

const BUF: usize = 256 * 1024;

/// Where the input named `path` is: standard input for `-` (its bytes, read whole on first
/// use and kept: [`crate::io::files::stdin_bytes`]), else the file.
///
/// # Errors
/// [`ReadError::Io`] when standard input cannot be read.
pub fn resolve(path: &Path) -> Result<Source, ReadError> {
    if path.as_os_str() == crate::model::STDIN_NAME {
        crate::io::files::stdin_bytes()
            .map(Source::Memory)
            .map_err(|source| ReadError::Io {
                file: path.to_path_buf(),
                source,
            })
    } else {
        Ok(Source::File(path.to_path_buf()))
    }
}

/// Open `path` for streaming; gzip is detected from the magic bytes (not the extension).
/// Returns the reader and whether the file was compressed. `-` is standard input
/// ([`resolve`]).
pub fn open(path: &Path) -> Result<(Box<dyn BufRead + Send>, bool), ReadError> {
    open_source(&resolve(path)?, path)
}

/// [`open`] on a [`Source`]; `name` names it in errors.
pub fn open_source(
    src: &Source,
    name: &Path,
) -> Result<(Box<dyn BufRead + Send>, bool), ReadError> {
    Ok(match open_stream(src, name)? {
        Stream::Plain(reader) => (Box::new(reader), false),
        Stream::Memory(reader) => (Box::new(reader), false),
        Stream::Gzip(reader) => (reader, true),
    })
}

/// A source opened for streaming ([`open_stream`]).
pub(crate) enum Stream {
    /// An uncompressed file, buffered (it can seek: [`SkipAhead`]).
    Plain(BufReader<File>),
    /// An uncompressed document in memory.
    Memory(Cursor<Arc<[u8]>>),
    /// A gzip-compressed document, decompressed as it is read.
    Gzip(Box<dyn BufRead + Send>),
}

/// [`open_source`], keeping the plain file's own reader.
pub(crate) fn open_stream(src: &Source, name: &Path) -> Result<Stream, ReadError> {
    let io = |source| ReadError::Io {
        file: name.to_path_buf(),
        source,
    };
    let path = match src {
        Source::File(p) => p,
        Source::Memory(bytes) => {
            let cursor = Cursor::new(Arc::clone(bytes));
            return Ok(if crate::io::files::is_gzip(bytes) {
                let mut dec = crate::io::files::gunzip(cursor);
                refuse_json(peek(&mut dec), name)?;
                Stream::Gzip(dec)
            } else {
                refuse_json(bytes, name)?;
                Stream::Memory(cursor)
            });
        }
    };
    let file = File::open(path).map_err(io)?;
    let mut reader = BufReader::with_capacity(BUF, file);
    let head = reader.fill_buf().map_err(io)?;
    if crate::io::files::is_gzip(head) {
        let mut dec = crate::io::files::gunzip(reader);
        refuse_json(peek(&mut dec), name)?;
        Ok(Stream::Gzip(dec))
    } else {
        refuse_json(head, name)?;
        Ok(Stream::Plain(reader))
    }
}

/// True when a document's first bytes are JSON (CityJSON, CityJSONSeq:
/// [`crate::io::cityjson::sniff`]).
pub fn is_json(head: &[u8]) -> bool {
    crate::io::cityjson::sniff(head) == crate::io::cityjson::Sniffed::Json
}

/// The bytes a reader holds ready (empty when it cannot read): what [`is_json`] looks at.
pub fn peek(reader: &mut Box<dyn BufRead + Send>) -> &[u8] {
    reader.fill_buf().unwrap_or(&[])
}

/// The error of the readers that copy a CityGML source's XML (writers, `subset`,
/// `filter-lods`, `reproject`, merges) when the source is CityJSON.
fn refuse_json(head: &[u8], name: &Path) -> Result<(), ReadError> {
    if !is_json(head) {
        return Ok(());
    }
    Err(ReadError::NotCityGml {
        loc: super::Location {
            file: name.to_path_buf(),
            line: 1,
            column: 1,
            gml_id: None,
        },
        message: "this is CityJSON, and this step copies a CityGML source's XML \
                  (CityGML output, subset, filter-lods, reproject, merge); a CityJSON input \
                  is written as OBJ, CityJSON or CityJSONSeq"
            .into(),
    })
}

/// A source document ready to parse: see [`load`].
pub enum Loaded {
    /// The whole uncompressed document.
    Plain(Bytes),
    /// A decompressing reader, and the compressed size in bytes.
    Gzip(Box<dyn BufRead + Send>, u64),
}

/// The bytes of a whole file: mapped into memory, or read into a buffer where it cannot be
/// mapped (empty files, special files), or a document already in memory.
pub enum Bytes {
    /// A read-only memory map of the file.
    Mapped(memmap2::Mmap),
    /// The file read into memory.
    Read(Vec<u8>),
    /// A document held in memory ([`Source::Memory`]).
    Shared(Arc<[u8]>),
}

impl std::ops::Deref for Bytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        match self {
            Bytes::Mapped(m) => m,
            Bytes::Read(v) => v,
            Bytes::Shared(b) => b,
        }
    }
}

/// Open `path` whole ([`load_source`] of [`resolve`]: `-` is standard input).
pub fn load(path: &Path) -> Result<Loaded, ReadError> {
    load_source(&resolve(path)?, path)
}

/// Open a source whole; gzip is detected from the magic bytes (not the extension) and then
/// decompressed as it is read (the compressed bytes are held, not the document). An
/// uncompressed file is memory-mapped: its pages come from the page cache as they are (no
/// copy, no zeroed buffer), the cheapest way to hold a large document; a document in memory
/// is parsed where it is. `name` names the source in errors.
pub fn load_source(src: &Source, name: &Path) -> Result<Loaded, ReadError> {
    let path = match src {
        Source::File(p) => p.as_path(),
        Source::Memory(b) => return Ok(document(Bytes::Shared(Arc::clone(b)))),
    };
    let io = |source| ReadError::Io {
        file: name.to_path_buf(),
        source,
    };
    let mut file = File::open(path).map_err(io)?;
    let meta = file.metadata().map_err(io)?;
    let bytes = if meta.is_file() && meta.len() > 0 {
        // SAFETY: the map is read-only and private to this process; as with any reader of
        // memory-mapped input (ripgrep, the linkers), a file truncated or rewritten by another
        // process while it is read is outside what the reader protects against.
        match unsafe { memmap2::Mmap::map(&file) } {
            Ok(m) => {
                // read ahead of the parser (a hint: failure is harmless)
                let _ = m.advise(memmap2::Advice::Sequential);
                Bytes::Mapped(m)
            }
            Err(_) => Bytes::Read(read_all(&mut file).map_err(io)?),
        }
    } else {
        Bytes::Read(read_all(&mut file).map_err(io)?)
    };
    Ok(document(bytes))
}

/// A whole document: plain, or gzip to decompress as it is read.
fn document(bytes: Bytes) -> Loaded {
    if crate::io::files::is_gzip(&bytes) {
        let len = bytes.len() as u64;
        Loaded::Gzip(crate::io::files::gunzip(Cursor::new(bytes)), len)
    } else {
        Loaded::Plain(bytes)
    }
}

/// Decompress `reader` into an unnamed temporary file (in [`std::env::temp_dir`], removed
/// by the system when it is closed, whatever happens) and map it: a whole document that
/// takes room on disk, not in memory (the streamed read of a compressed file).
///
/// # Errors
/// I/O errors of the decompression or the temporary file.
pub(crate) fn spill(reader: &mut dyn BufRead) -> std::io::Result<Bytes> {
    let mut file = tempfile::tempfile()?;
    {
        let mut w = std::io::BufWriter::with_capacity(BUF, &mut file);
        std::io::copy(reader, &mut w)?;
        std::io::Write::flush(&mut w)?;
    }
    if file.metadata()?.len() == 0 {
        return Ok(Bytes::Read(Vec::new()));
    }
    // SAFETY: the file is this process's own, unnamed: no other process can change it.
    let m = unsafe { memmap2::Mmap::map(&file)? };
    let _ = m.advise(memmap2::Advice::Sequential);
    Ok(Bytes::Mapped(m))
}

fn read_all(file: &mut File) -> std::io::Result<Vec<u8>> {
    let mut v = Vec::new();
    file.read_to_end(&mut v)?;
    Ok(v)
}

impl Bytes {
    /// Let the memory of the first `upto` bytes go (a mapped file's pages return to the page
    /// cache, out of this process's resident set): the parser calls this as it moves on, so
    /// that a large document does not stay resident whole. Reading those bytes again stays
    /// correct (they are mapped in again from the file).
    pub fn release_before(&self, upto: usize) {
        #[cfg(unix)]
        if let Bytes::Mapped(m) = self {
            let len = upto.min(m.len());
            // SAFETY: the map is private and read-only, never written: after MADV_DONTNEED
            // its pages read the file's contents again, the same bytes as before.
            let _ = unsafe { m.unchecked_advise_range(memmap2::UncheckedAdvice::DontNeed, 0, len) };
        }
        #[cfg(not(unix))]
        let _ = upto;
    }
}

impl Bytes {
    /// Let the memory of the bytes `from..upto` go, like [`Bytes::release_before`] for one
    /// part of the document (a part read by its own core). Only whole pages inside the range
    /// are released, none of the neighbouring parts.
    pub fn release_range(&self, from: usize, upto: usize) {
        #[cfg(unix)]
        if let Bytes::Mapped(m) = self {
            const PAGE: usize = 64 << 10; // a multiple of any page size
            let from = from.div_ceil(PAGE) * PAGE;
            let upto = upto.min(m.len()) / PAGE * PAGE;
            if upto > from {
                // SAFETY: as in `release_before`: a private read-only map reads the file's
                // bytes again after MADV_DONTNEED.
                let _ = unsafe {
                    m.unchecked_advise_range(memmap2::UncheckedAdvice::DontNeed, from, upto - from)
                };
            }
        }
        #[cfg(not(unix))]
        let _ = (from, upto);
    }
}

impl AsRef<[u8]> for Bytes {
    fn as_ref(&self) -> &[u8] {
        self
    }
}

/// Skip a UTF-8 byte-order mark at the start of `reader`, so that every position recorded
/// after it is a true offset in the document (quick-xml would skip it without counting it).
/// Returns the offset the reader now stands at: 3 after a mark, 0 otherwise.
pub(crate) fn skip_bom<R: BufRead + ?Sized>(reader: &mut R, path: &Path) -> Result<u64, ReadError> {
    let head = reader.fill_buf().map_err(|source| ReadError::Io {
        file: path.to_path_buf(),
        source,
    })?;
    if head.starts_with(&[0xEF, 0xBB, 0xBF]) {
        reader.consume(3);
        Ok(3)
    } else {
        Ok(0)
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

/// A source that can pass over bytes without handing them out: a plain file seeks, anything
/// else reads and drops them.
pub(crate) trait SkipAhead: BufRead {
    /// Pass over the next `n` bytes; fails when the source ends before.
    fn skip_ahead(&mut self, n: u64) -> std::io::Result<()> {
        let mut left = n;
        while left > 0 {
            let avail = self.fill_buf()?.len();
            if avail == 0 {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::UnexpectedEof,
                    "source shorter than expected",
                ));
            }
            let k = usize::try_from(left).map_or(avail, |l| l.min(avail));
            self.consume(k);
            left -= k as u64;
        }
        Ok(())
    }
}

impl SkipAhead for Box<dyn BufRead + Send> {}

impl SkipAhead for Cursor<Arc<[u8]>> {
    fn skip_ahead(&mut self, n: u64) -> std::io::Result<()> {
        let to = self.position().saturating_add(n);
        if to > self.get_ref().len() as u64 {
            return Err(std::io::Error::new(
                std::io::ErrorKind::UnexpectedEof,
                "source shorter than expected",
            ));
        }
        self.set_position(to);
        Ok(())
    }
}

impl SkipAhead for BufReader<File> {
    fn skip_ahead(&mut self, n: u64) -> std::io::Result<()> {
        let n = i64::try_from(n).map_err(std::io::Error::other)?;
        self.seek_relative(n)
    }
}

/// A [`BufRead`] that refuses to hand out more than `limit` bytes between two calls of
/// [`Limited::reset`]: the reader resets it before every XML event, so that one hostile token
/// (a 100 MB attribute, an endless text node or comment) fails with a clear error after
/// `limit` bytes instead of growing the event buffer without bound.
pub(crate) struct Limited<R> {
    inner: R,
    used: usize,
    limit: usize,
    exceeded: bool,
}

impl<R> Limited<R> {
    pub(crate) fn new(inner: R, limit: usize) -> Self {
        Limited {
            inner,
            used: 0,
            limit,
            exceeded: false,
        }
    }

    /// Start counting anew (called at the start of every XML event).
    #[inline]
    pub(crate) fn reset(&mut self) {
        self.used = 0;
    }

    /// True once a read was refused because of the limit.
    pub(crate) fn exceeded(&self) -> bool {
        self.exceeded
    }
}

impl<R: Read> Read for Limited<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.used = self.used.saturating_add(n);
        Ok(n)
    }
}

impl<R: BufRead> BufRead for Limited<R> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        if self.used > self.limit {
            self.exceeded = true;
            return Err(std::io::Error::other("XML token exceeds the size limit"));
        }
        self.inner.fill_buf()
    }

    #[inline]
    fn consume(&mut self, amt: usize) {
        self.used = self.used.saturating_add(amt);
        self.inner.consume(amt);
    }
}

impl<R: SkipAhead> SkipAhead for Limited<R> {
    fn skip_ahead(&mut self, n: u64) -> std::io::Result<()> {
        self.inner.skip_ahead(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limited_refuses_after_limit_until_reset() {
        let data = [b'x'; 100];
        let mut r = Limited::new(&data[..], 10);
        let n = r.fill_buf().map(<[u8]>::len).unwrap_or(0);
        assert_eq!(n, 100);
        r.consume(11);
        assert!(r.fill_buf().is_err());
        assert!(r.exceeded());
        r.reset();
        assert_eq!(r.fill_buf().map(<[u8]>::len).unwrap_or(0), 89);
    }
}
