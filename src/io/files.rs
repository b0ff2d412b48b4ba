//! Files in and out, the same for every reader and writer: gzip recognised by its magic
//! bytes, `-` as standard output, outputs checked before any work (never over an input, never
//! over an existing file unless allowed) and written atomically (a temporary file beside the
//! target, renamed into place, with the user's umask), and a writer that counts its bytes.
//!
//! The errors here are the file's and the cause alone ([`FileError`], [`TargetError`]); each
//! stage wraps them in its own error type (`citygml::WriteError`, ...).
//!
//! # Example
//! ```
//! use std::io::Write;
//! let dir = tempfile::tempdir()?;
//! let out = dir.path().join("table.csv");
//! skylod::io::check_target(&out, [], false)?;
//! let n = skylod::io::atomic_write(&out, |w| -> Result<u64, skylod::io::FileError> {
//!     let mut c = skylod::io::CountingWriter::new(w);
//!     c.write_all(b"id,svf\np1,0.5\n").map_err(|e| skylod::io::FileError::new("table.csv", e))?;
//!     Ok(c.count())
//! })?;
//! assert_eq!(n, 14);
//! assert!(skylod::io::check_target(&out, [], false).is_err()); // exists now
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::collections::HashSet;
use std::io::{BufRead, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The first two bytes of a gzip member (RFC 1952).
pub const GZIP_MAGIC: [u8; 2] = [0x1f, 0x8b];

/// Whether bytes that start a file are gzip's (whatever the file's name says).
///
/// ```
/// assert!(skylod::io::is_gzip(&[0x1f, 0x8b, 8, 0]));
/// assert!(!skylod::io::is_gzip(b"<?xml"));
/// ```
pub fn is_gzip(head: &[u8]) -> bool {
    head.starts_with(&GZIP_MAGIC)
}

/// Whether the file at `path` starts with gzip's bytes (false when it cannot be read).
pub fn is_gzip_file(path: &Path) -> bool {
    let mut head = [0u8; 2];
    std::fs::File::open(path)
        .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut head))
        .is_ok()
        && is_gzip(&head)
}

/// Bytes a reader of [`decoded`] and [`open_decoded`] asks for at a time.
const READ_BUF: usize = 256 * 1024;

/// `r`, gzip-decompressed when its first bytes are gzip's ([`is_gzip`]; the magic bytes
/// decide, not a name), as one buffered reader: the one place a gzip input is decoded. A
/// concatenation of gzip members (`cat a.gz b.gz`) reads as one document, as `gzip -d` does.
///
/// # Errors
/// Reading the first bytes failed.
///
/// ```
/// use std::io::{Read, Write};
/// let mut gz = flate2::write::GzEncoder::new(Vec::new(), Default::default());
/// gz.write_all(b"<CityModel/>")?;
/// let bytes = gz.finish()?;
/// let (mut r, was_gzip) = skylod::io::decoded(std::io::Cursor::new(bytes))?;
/// let mut text = String::new();
/// r.read_to_string(&mut text)?;
/// assert!(was_gzip);
/// assert_eq!(text, "<CityModel/>");
/// # Ok::<(), std::io::Error>(())
/// ```
pub fn decoded<R: BufRead + Send + 'static>(
    mut r: R,
) -> std::io::Result<(Box<dyn BufRead + Send>, bool)> {
    Ok(if is_gzip(r.fill_buf()?) {
        (gunzip(r), true)
    } else {
        (Box::new(r), false)
    })
}

/// `r` gzip-decompressed, buffered: [`decoded`] for a reader already known to be gzip.
pub fn gunzip<R: BufRead + Send + 'static>(r: R) -> Box<dyn BufRead + Send> {
    let dec = flate2::bufread::MultiGzDecoder::new(r);
    Box::new(std::io::BufReader::with_capacity(READ_BUF, dec))
}

/// The input named `path`, decompressed where it is gzip ([`decoded`]): standard input for
/// `-` (its bytes as kept by [`stdin_bytes`]), else the file.
///
/// # Errors
/// Opening or reading the file, or standard input, failed.
pub fn open_decoded(path: &Path) -> std::io::Result<(Box<dyn BufRead + Send>, bool)> {
    if path.as_os_str() == crate::model::STDIN_NAME {
        return decoded(std::io::Cursor::new(stdin_bytes()?));
    }
    let file = std::fs::File::open(path)?;
    decoded(std::io::BufReader::with_capacity(READ_BUF, file))
}

/// `-` as an output path: standard output (never a file named `-`).
///
/// ```
/// use std::path::Path;
/// assert!(skylod::io::is_stdout(Path::new("-")));
/// assert!(!skylod::io::is_stdout(Path::new("./-")));
/// ```
pub fn is_stdout(out: &Path) -> bool {
    out.as_os_str() == "-"
}

/// The bytes of standard input, the input named `-`: read whole on the first call (from the
/// process's standard input, unless [`set_stdin_bytes`] gave them before) and kept for the
/// rest of the process, so that a writer can copy from them again after the reader (a pipe
/// can be read only once). The memory held is the input's size, as given (a gzip-compressed
/// input stays compressed).
///
/// # Errors
/// Reading standard input failed.
pub fn stdin_bytes() -> std::io::Result<std::sync::Arc<[u8]>> {
    let mut held = STDIN
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some(b) = held.as_ref() {
        return Ok(std::sync::Arc::clone(b));
    }
    let mut v = Vec::new();
    std::io::Read::read_to_end(&mut std::io::stdin().lock(), &mut v)?;
    let b: std::sync::Arc<[u8]> = v.into();
    *held = Some(std::sync::Arc::clone(&b));
    Ok(b)
}

/// Read `reader` whole and make it standard input for [`stdin_bytes`] (the input `-`) from
/// now on; returns its length.
///
/// # Errors
/// Reading `reader` failed (standard input is then left as it was).
pub fn set_stdin_bytes(reader: &mut dyn std::io::Read) -> std::io::Result<u64> {
    let mut v = Vec::new();
    reader.read_to_end(&mut v)?;
    let n = v.len() as u64;
    let mut held = STDIN
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    *held = Some(v.into());
    Ok(n)
}

static STDIN: std::sync::Mutex<Option<std::sync::Arc<[u8]>>> = std::sync::Mutex::new(None);

/// I/O on a file failed.
#[derive(Debug, thiserror::Error)]
#[error("{file}: {}", describe_io(.source), file = .file.display())]
pub struct FileError {
    /// The file concerned.
    pub file: PathBuf,
    /// The cause.
    pub source: std::io::Error,
}

impl FileError {
    /// I/O on `file` failed with `source`.
    pub fn new(file: impl Into<PathBuf>, source: std::io::Error) -> FileError {
        FileError {
            file: file.into(),
            source,
        }
    }
}

/// The text of an I/O error, with a full disk said in plain words: `no space left on device`
/// (ENOSPC) rather than the system's capitalised message and number.
///
/// ```
/// let full = std::io::Error::from_raw_os_error(28);
/// assert_eq!(skylod::io::describe_io(&full), "no space left on device");
/// ```
pub fn describe_io(e: &std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::StorageFull => "no space left on device".into(),
        _ => e.to_string(),
    }
}

/// The name standard output is given in errors.
pub const STDOUT_NAME: &str = "standard output";

/// The name a caller's writer (the `_to` twins of the writers) is given in errors.
pub const WRITER_NAME: &str = "(writer)";

/// A writer that keeps the first error of the writer inside: when the function writing
/// through it fails, [`atomic_write`] reports that error against the target it was writing.
struct Recording<W> {
    inner: W,
    first: Option<(std::io::ErrorKind, Option<i32>, String)>,
}

impl<W: Write> Recording<W> {
    fn record<T>(&mut self, r: std::io::Result<T>) -> std::io::Result<T> {
        if let (Err(e), None) = (&r, &self.first) {
            self.first = Some((e.kind(), e.raw_os_error(), e.to_string()));
        }
        r
    }

    fn error(&self) -> Option<std::io::Error> {
        let (kind, os, text) = self.first.as_ref()?;
        Some(match os {
            Some(code) => std::io::Error::from_raw_os_error(*code),
            None => std::io::Error::new(*kind, text.clone()),
        })
    }
}

impl<W: Write> Write for Recording<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let r = self.inner.write(buf);
        self.record(r)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        let r = self.inner.flush();
        self.record(r)
    }
}

/// Write through `f` into `w` (gzip when `gz`) and flush: a failure of `w` (a full disk) is
/// reported as a [`FileError`] of `out` whatever `f` made of it.
fn write_through<W: Write, E, F>(w: W, out: &Path, gz: bool, f: F) -> Result<u64, E>
where
    F: FnOnce(&mut dyn Write) -> Result<u64, E>,
    E: From<FileError>,
{
    let name = if is_stdout(out) {
        Path::new(STDOUT_NAME)
    } else {
        out
    };
    let io = |source| E::from(FileError::new(name, source));
    let bw = BufWriter::with_capacity(256 * 1024, w);
    if gz {
        let mut rec = Recording {
            inner: flate2::write::GzEncoder::new(bw, flate2::Compression::default()),
            first: None,
        };
        let n = match f(&mut rec) {
            Ok(n) => n,
            Err(e) => return Err(rec.error().map_or(e, io)),
        };
        let mut bw = rec.inner.finish().map_err(io)?;
        bw.flush().map_err(io)?;
        Ok(n)
    } else {
        let mut rec = Recording {
            inner: bw,
            first: None,
        };
        let n = match f(&mut rec) {
            Ok(n) => n,
            Err(e) => return Err(rec.error().map_or(e, io)),
        };
        rec.flush().map_err(io)?;
        Ok(n)
    }
}

/// An output that must not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TargetError {
    /// The output exists and overwriting was not allowed.
    #[error("{}: output exists", .0.display())]
    Exists(PathBuf),
    /// The output would replace an input.
    #[error("{}: output path is one of the inputs", .0.display())]
    IsInput(PathBuf),
}

/// Paths that no output may replace (the inputs of a batch), each resolved to its canonical
/// path once, when the set is made: checking a target then costs one resolution of the
/// target, however many paths are protected. A path that does not exist (yet) protects
/// nothing; cloning shares the set.
#[derive(Debug, Clone, Default)]
pub struct Protected(Arc<HashSet<PathBuf>>);

impl Protected {
    /// The set of `paths`, resolved.
    pub fn new<P: AsRef<Path>>(paths: impl IntoIterator<Item = P>) -> Protected {
        Protected::default().and(paths)
    }

    /// These paths and `more` (resolved); `self` unchanged.
    #[must_use]
    pub fn and<P: AsRef<Path>>(&self, more: impl IntoIterator<Item = P>) -> Protected {
        let mut set = (*self.0).clone();
        set.extend(
            more.into_iter()
                .filter_map(|p| p.as_ref().canonicalize().ok()),
        );
        Protected(Arc::new(set))
    }

    /// How many paths (that exist) are protected.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether nothing is protected.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

/// Refuse to write over one of `protected` (the inputs), or over an existing file unless
/// `overwrite`. Standard output (`-`) is always a valid target.
pub fn check_target<'a>(
    out: &Path,
    protected: impl IntoIterator<Item = &'a Path>,
    overwrite: bool,
) -> Result<(), TargetError> {
    check_target_in(out, &Protected::default(), protected, overwrite)
}

/// [`check_target`] with the paths of `set` protected too (resolved once, when the set was
/// made): `out` is resolved once, each of `protected` once.
pub(crate) fn check_target_in<'a>(
    out: &Path,
    set: &Protected,
    protected: impl IntoIterator<Item = &'a Path>,
    overwrite: bool,
) -> Result<(), TargetError> {
    if is_stdout(out) {
        return Ok(());
    }
    let canon_out = canonical_target(out);
    if let Some(c) = &canon_out {
        let given = |p: &Path| p.canonicalize().is_ok_and(|p| &p == c);
        if set.0.contains(c) || protected.into_iter().any(given) {
            return Err(TargetError::IsInput(out.to_path_buf()));
        }
    }
    if out.exists() && !overwrite {
        return Err(TargetError::Exists(out.to_path_buf()));
    }
    Ok(())
}

/// The path `out` will have once written: canonical, through its parent when it does not
/// exist yet.
fn canonical_target(out: &Path) -> Option<PathBuf> {
    if let Ok(c) = out.canonicalize() {
        return Some(c);
    }
    let parent = out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = out.file_name()?;
    parent.canonicalize().ok().map(|p| p.join(name))
}

/// Write through `f` into a temporary file beside `out`, gzip when `out` ends in `.gz`,
/// then rename it into place. On any error the temporary file is removed; a write that fails
/// (a full disk: "no space left on device") is reported against `out`. The file is created
/// with mode 0666 minus the process umask, as `open(2)` would create it.
///
/// `out` = `-` ([`is_stdout`]) streams to standard output instead (uncompressed; a closed
/// pipe is an error of kind [`std::io::ErrorKind::BrokenPipe`]).
pub fn atomic_write<E, F>(out: &Path, f: F) -> Result<u64, E>
where
    F: FnOnce(&mut dyn Write) -> Result<u64, E>,
    E: From<FileError>,
{
    let io = |source| E::from(FileError::new(out, source));
    if is_stdout(out) {
        return write_through(std::io::stdout().lock(), out, false, f);
    }
    let dir = out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    // A missing folder is made (errors name it), never reported as a temporary file in it.
    if !dir.exists() {
        std::fs::create_dir_all(dir).map_err(|source| E::from(FileError::new(dir, source)))?;
    }
    let mut builder = tempfile::Builder::new();
    builder.prefix(".skylod-").suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // Subject to the umask, like any file the user's tools create (tempfile's 0600 is
        // right for secrets, wrong for a city model others in the group must read).
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let tmp = builder
        .tempfile_in(dir)
        .map_err(|e| io(without_temporary_path(e)))?;
    let gz = out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("gz"));
    let file = tmp.as_file().try_clone().map_err(io)?;
    // On an error `tmp` is dropped here, which removes the temporary file.
    let n = write_through(file, out, gz, f)?;
    tmp.as_file().sync_all().map_err(io)?;
    tmp.persist(out).map_err(|e| io(e.error))?;
    Ok(n)
}

/// An error of `tempfile` without the temporary file's name it appends (`... at path
/// "dir/.skylod-XXXX.tmp"`): errors name the output, never a file the user did not ask for.
fn without_temporary_path(e: std::io::Error) -> std::io::Error {
    if let Some(code) = e.raw_os_error() {
        return std::io::Error::from_raw_os_error(code);
    }
    let text = e.to_string();
    match text.find(" at path ") {
        Some(i) => std::io::Error::new(e.kind(), text[..i].to_owned()),
        None => e,
    }
}

/// [`std::io::Read::read`] of a reader whose buffer is the truth ([`BufRead`]): copy what
/// [`BufRead::fill_buf`] holds (as much as fits) and [`BufRead::consume`] it, so that a
/// reader that watches or rewinds what is consumed sees every byte read.
pub(crate) fn read_through_buf<R: BufRead + ?Sized>(
    r: &mut R,
    buf: &mut [u8],
) -> std::io::Result<usize> {
    let avail = r.fill_buf()?;
    let n = avail.len().min(buf.len());
    buf[..n].copy_from_slice(&avail[..n]);
    r.consume(n);
    Ok(n)
}

/// A writer that counts the bytes written through it.
#[derive(Debug)]
pub struct CountingWriter<W> {
    inner: W,
    n: u64,
}

impl<W: Write> CountingWriter<W> {
    /// Count what goes into `inner`.
    pub fn new(inner: W) -> CountingWriter<W> {
        CountingWriter { inner, n: 0 }
    }

    /// Bytes written so far.
    pub fn count(&self) -> u64 {
        self.n
    }

    /// The writer inside.
    pub fn into_inner(self) -> W {
        self.inner
    }
}

impl<W: Write> Write for CountingWriter<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let k = self.inner.write(buf)?;
        self.n += k as u64;
        Ok(k)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_protected_set_refuses_its_paths_however_spelled() {
        let dir = tempfile::tempdir().unwrap();
        let inputs: Vec<PathBuf> = (0..3)
            .map(|k| dir.path().join(format!("{k}.gml")))
            .collect();
        for p in &inputs {
            std::fs::write(p, b"x").unwrap();
        }
        let missing = dir.path().join("not-yet.gml");
        let set = Protected::new(&inputs).and([&missing]);
        assert_eq!(set.len(), 3, "a path that does not exist protects nothing");
        let again = dir.path().join(".").join("1.gml");
        assert!(matches!(
            check_target_in(&again, &set, [], true),
            Err(TargetError::IsInput(_))
        ));
        let new = dir.path().join("out.gml");
        assert!(check_target_in(&new, &set, [], false).is_ok());
        assert!(check_target_in(Path::new("-"), &set, [], false).is_ok());
        // the paths given beside the set count as well
        assert!(matches!(
            check_target_in(&new, &Protected::default(), [new.as_path()], true),
            Ok(())
        ));
        std::fs::write(&new, b"y").unwrap();
        assert!(matches!(
            check_target_in(&new, &Protected::default(), [new.as_path()], true),
            Err(TargetError::IsInput(_))
        ));
    }

    #[test]
    fn an_input_is_never_a_target_and_stdout_always_is() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.gml");
        std::fs::write(&input, b"x").unwrap();
        let same = dir.path().join(".").join("in.gml");
        assert!(matches!(
            check_target(&same, [input.as_path()], true),
            Err(TargetError::IsInput(_))
        ));
        assert!(check_target(Path::new("-"), [input.as_path()], false).is_ok());
        let new = dir.path().join("new.gml");
        assert!(check_target(&new, [input.as_path()], false).is_ok());
    }

    #[test]
    fn missing_folders_are_made_and_no_error_names_the_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("a/b/out.gml");
        let n = atomic_write(&out, |w| -> Result<u64, FileError> {
            w.write_all(b"<x/>").map_err(|e| FileError::new("w", e))?;
            Ok(4)
        })
        .unwrap();
        assert_eq!((n, std::fs::read(&out).unwrap()), (4, b"<x/>".to_vec()));
        // A folder that cannot be made (a file is in the way), and one that cannot take the
        // temporary file (a read-only folder): the errors name the output or its folder.
        std::fs::write(dir.path().join("file"), b"").unwrap();
        let blocked = dir.path().join("file/sub/out.gml");
        let e = atomic_write(&blocked, |_| Ok::<u64, FileError>(0)).unwrap_err();
        assert_eq!(e.file, dir.path().join("file/sub"), "{e}");
        // A folder that takes no new file, even from root: /proc.
        #[cfg(target_os = "linux")]
        {
            let out = Path::new("/proc/skylod-out.gml");
            let e = atomic_write(out, |_| Ok::<u64, FileError>(0)).unwrap_err();
            assert_eq!(e.file, out);
            assert!(!e.to_string().contains(".skylod-"), "{e}");
            assert!(!e.to_string().contains(".tmp"), "{e}");
        }
    }

    #[test]
    fn temporary_paths_are_cut_from_errors() {
        let e = std::io::Error::new(
            std::io::ErrorKind::NotFound,
            "No such file or directory (os error 2) at path \"/x/.skylod-ab.tmp\"",
        );
        let e = without_temporary_path(e);
        assert_eq!(e.kind(), std::io::ErrorKind::NotFound);
        assert_eq!(e.to_string(), "No such file or directory (os error 2)");
    }

    /// A disk that takes `room` bytes, then fails with ENOSPC (write or flush).
    struct Full {
        room: usize,
    }

    impl Write for Full {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            if self.room == 0 {
                return Err(std::io::Error::from_raw_os_error(28));
            }
            let k = buf.len().min(self.room);
            self.room -= k;
            Ok(k)
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// A writer as a stage writes: its own error type, naming something else than the target.
    #[derive(Debug)]
    enum StageError {
        File(FileError),
    }
    impl From<FileError> for StageError {
        fn from(e: FileError) -> Self {
            StageError::File(e)
        }
    }

    #[test]
    fn a_full_disk_names_the_target_and_says_no_space() {
        let out = Path::new("city/out.gml");
        for gz in [false, true] {
            // In a write inside the function (more than the buffer) and at the final flush.
            for (room, len) in [(1000, 1 << 20), (10, 100)] {
                let r = write_through(Full { room }, out, gz, |w| -> Result<u64, StageError> {
                    let data = vec![b'x'; len];
                    w.write_all(&data)
                        .map_err(|e| FileError::new("a chunk of somewhere else", e))?;
                    Ok(len as u64)
                });
                let Err(StageError::File(e)) = r else {
                    panic!("gz {gz}, room {room}: a full disk must fail");
                };
                if gz && len == 100 {
                    // 100 compressible bytes fit in 10: the disk fills, or not, in finish.
                    continue;
                }
                assert_eq!(e.file, out, "gz {gz}, room {room}");
                assert_eq!(
                    e.to_string(),
                    "city/out.gml: no space left on device",
                    "gz {gz}, room {room}"
                );
            }
        }
        let e = write_through(Full { room: 0 }, Path::new("-"), false, |w| {
            w.write_all(b"{}").map_err(|e| FileError::new("x", e))?;
            Ok::<u64, FileError>(2)
        })
        .unwrap_err();
        assert_eq!(e.to_string(), "standard output: no space left on device");
    }

    #[test]
    fn a_full_disk_leaves_no_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.gml");
        let r = atomic_write(&out, |w| -> Result<u64, FileError> {
            w.write_all(&[b'x'; 300 * 1024])
                .map_err(|e| FileError::new("out", e))?;
            Err(FileError::new(
                "elsewhere",
                std::io::Error::from_raw_os_error(28),
            ))
        });
        let e = r.unwrap_err();
        assert!(e.to_string().ends_with("no space left on device"), "{e}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn a_failed_write_leaves_nothing_behind() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.gml.gz");
        let r = atomic_write(&out, |w| {
            w.write_all(b"partial")
                .map_err(|e| FileError::new("out", e))?;
            Err(FileError::new("out", std::io::Error::other("stop")))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        let n = atomic_write(&out, |w| -> Result<u64, FileError> {
            w.write_all(b"<CityModel/>")
                .map_err(|e| FileError::new("out", e))?;
            Ok(12)
        })
        .unwrap();
        assert_eq!(n, 12);
        let bytes = std::fs::read(&out).unwrap();
        assert!(is_gzip(&bytes), "a .gz output is compressed");
    }
}
