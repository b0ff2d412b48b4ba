//! The CityJSON edits' side of the streaming reader ([`crate::io::cityjson::stream`]): its
//! passes with the edits' errors, and the writer of a document's members and entries.

use crate::io::citygml::error::{ReadError, WriteError};
use crate::io::citygml::write::atomic_write;
pub(crate) use crate::io::cityjson::stream::*;
use crate::io::cityjson::CityJsonError;
use crate::io::files::CountingWriter;
use serde_json::{Map, Value};
use std::io::Write;
use std::path::Path;

pub(crate) fn cj_error(e: CityJsonError) -> WriteError {
    WriteError::Read(ReadError::CityJson(e))
}

pub(crate) fn cj(file: &Path, line: u64, id: Option<&str>, m: String) -> WriteError {
    cj_error(CityJsonError::at(file, line, id, m))
}

/// The (decompressed) JSON text of `input`, a byte-order mark skipped.
pub(crate) fn open_json(input: &Path) -> Result<Box<dyn std::io::BufRead + Send>, WriteError> {
    crate::io::cityjson::stream::open_json(input).map_err(|source| {
        WriteError::Read(ReadError::Io {
            file: input.to_path_buf(),
            source,
        })
    })
}

/// Read the first JSON value of `input` (named `name` in errors) through `pass`.
///
/// # Errors
/// The source cannot be read, is empty, is not JSON, is not an object, or the pass refuses
/// something (its message with the file, line and column).
pub(crate) fn read(input: &Path, name: &Path, pass: &mut dyn Pass) -> Result<Seen, WriteError> {
    read_from(open_json(input)?, name, pass).map_err(cj_error)
}

/// The entries of `CityObjects` (`"id":{…}`) or `vertices` being written, separated by
/// commas; the first I/O error kept (the callers of a pass see only its message).
pub(crate) struct Entries<'w> {
    w: &'w mut dyn Write,
    any: bool,
    failed: Option<std::io::Error>,
}

impl Entries<'_> {
    fn put(&mut self, f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>) -> Result<(), String> {
        let go = || {
            if std::mem::replace(&mut self.any, true) {
                self.w.write_all(b",")?;
            }
            f(&mut *self.w)
        };
        go().map_err(|e| {
            let m = e.to_string();
            self.failed.get_or_insert(e);
            m
        })
    }

    /// `"id":o`.
    pub fn object(&mut self, id: &str, o: &Value) -> Result<(), String> {
        self.put(|w| {
            serde_json::to_writer(&mut *w, id)?;
            w.write_all(b":")?;
            serde_json::to_writer(w, o).map_err(std::io::Error::other)
        })
    }

    /// One vertex.
    pub fn vertex(&mut self, v: &Vertex) -> Result<(), String> {
        self.put(|w| v.write(w))
    }
}

/// Write a document to `out` (atomically): the members of `head` in its order as one line
/// of JSON, `CityObjects` and `vertices` (placeholders in `head`) by `body`, which is given
/// the member's name and its entries. The bytes written.
///
/// # Errors
/// `body`'s, I/O errors.
pub(crate) fn write_document(
    out: &Path,
    head: &Map<String, Value>,
    body: &mut dyn FnMut(&str, &mut Entries<'_>) -> Result<(), WriteError>,
) -> Result<u64, WriteError> {
    let io = |source| WriteError::Io {
        file: out.to_path_buf(),
        source,
    };
    atomic_write(out, |w| {
        let mut w = CountingWriter::new(w);
        w.write_all(b"{").map_err(io)?;
        for (k, (key, v)) in head.iter().enumerate() {
            if k > 0 {
                w.write_all(b",").map_err(io)?;
            }
            serde_json::to_writer(&mut w, key).map_err(|e| io(e.into()))?;
            w.write_all(b":").map_err(io)?;
            let brackets = match key.as_str() {
                "CityObjects" => b"{}",
                "vertices" => b"[]",
                _ => {
                    serde_json::to_writer(&mut w, v).map_err(|e| io(e.into()))?;
                    continue;
                }
            };
            w.write_all(&brackets[..1]).map_err(io)?;
            let mut entries = Entries {
                w: &mut w,
                any: false,
                failed: None,
            };
            let r = body(key, &mut entries);
            if let Some(e) = entries.failed {
                return Err(io(e));
            }
            r?;
            w.write_all(&brackets[1..]).map_err(io)?;
        }
        w.write_all(b"}\n").map_err(io)?;
        Ok(w.count())
    })
}
