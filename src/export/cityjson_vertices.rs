//! The vertices of the CityJSON writer ([`super::cityjson::write`]): integer coordinates,
//! each distinct one numbered once ([`Vertices`]), in memory for a model, on disk for a
//! document written from a streamed read ([`super::Chunks::Stream`]: memory that follows a
//! chunk, not the document).
//!
//! CityJSON shares one vertex list over the whole document, numbered by first use: a list
//! as large as the document's distinct vertices, which a model in memory keeps in memory. A
//! stream runs the objects passes twice instead. The first writes nothing
//! ([`record_uses`]): every use of a vertex (its integer coordinates and its number among
//! all uses) goes to one of `B` temporary bucket files chosen by a hash of the coordinates.
//! Each bucket is then read alone, 1 MiB of records at a time (a map of its distinct
//! vertices in memory: `B` grows with the file, about one per 32 MiB of document), to find
//! every use's first use, written back over the record; a bit per use marks the first uses,
//! and a vertex's index is the number of first uses before its own (the bits and a count
//! per 64 of them: 0.19 bytes a use, the part of memory that grows with the document, 15 MB
//! for 80 million uses). The second objects pass writes the document: a use's index is read
//! from its bucket (in the order of the first pass) and a vertex met the first time goes to
//! a temporary list, copied out after the city objects.
//!
//! Temporary files are unnamed (in the system's temporary directory, `TMPDIR`), gone when
//! the writer ends whatever happens: 32 bytes a vertex use plus 24 a distinct vertex.

use super::cityjson::Plan;
use super::ExportSummary;
use foldhash::{HashMap, HashMapExt};
use glam::DVec3;
use std::fs::File;
use std::hash::BuildHasher;
use std::io::{self, BufReader, BufWriter, Read, Seek, Write};
use std::path::Path;

/// Integer vertices (millimetres from `translate`), each distinct one stored once: in memory,
/// or numbered by an [`External`] index (a streamed document's, on disk).
pub(super) struct Vertices {
    translate: DVec3,
    scale: DVec3,
    map: HashMap<[i64; 3], u32>,
    list: Vec<[i64; 3]>,
    /// Where the indices come from instead of `map` and `list`.
    external: Option<External>,
}

impl Vertices {
    pub(super) fn new(translate: DVec3, scale: DVec3) -> Self {
        Vertices {
            translate,
            scale,
            map: HashMap::new(),
            list: Vec::new(),
            external: None,
        }
    }

    pub(super) fn clear(&mut self) {
        self.map.clear();
        self.list.clear();
    }

    fn key(&self, p: DVec3) -> [i64; 3] {
        let q = ((p - self.translate) / self.scale).round();
        [q.x as i64, q.y as i64, q.z as i64]
    }

    /// The index of `key` (every call is one use of a vertex: an [`External`] index numbers
    /// the calls).
    fn index(&mut self, key: [i64; 3]) -> u32 {
        if let Some(x) = &mut self.external {
            return x.index(key);
        }
        let n = self.list.len() as u32;
        let k = *self.map.entry(key).or_insert(n);
        if k == n {
            self.list.push(key);
        }
        k
    }

    /// Indices of a ring, consecutive duplicates (after rounding) removed; `None` below 3.
    /// (Duplicates are found by their integer coordinates: equal keys, equal indices.)
    pub(super) fn ring(&mut self, ring: &[DVec3]) -> Option<Vec<u32>> {
        let mut v: Vec<u32> = Vec::with_capacity(ring.len());
        let mut keys: Vec<[i64; 3]> = Vec::with_capacity(ring.len());
        for p in ring {
            if !p.is_finite() {
                continue;
            }
            let key = self.key(*p);
            let k = self.index(key);
            if keys.last() != Some(&key) {
                v.push(k);
                keys.push(key);
            }
        }
        while v.len() > 1 && keys.first() == keys.last() {
            v.pop();
            keys.pop();
        }
        (v.len() >= 3).then_some(v)
    }

    /// The first I/O error of the external index, if any.
    pub(super) fn check(&mut self) -> io::Result<()> {
        let err = match &mut self.external {
            Some(External::Record(r)) => r.err.take(),
            Some(External::Replay(r)) => r.err.take(),
            None => None,
        };
        err.map_or(Ok(()), Err)
    }

    /// Write the vertex list to `w`, from memory or from the external index; how many.
    pub(super) fn write_list(&mut self, w: &mut dyn Write) -> io::Result<usize> {
        match self.external.take() {
            Some(External::Replay(rep)) => rep.copy_vertices(w),
            Some(External::Record(_)) => Err(io::Error::other("vertex index lost")),
            None => write_vertices(w, &self.list).map(|()| self.list.len()),
        }
    }
}

/// Vertices `list` as JSON arrays, a comma between two.
fn write_vertices(w: &mut dyn Write, list: &[[i64; 3]]) -> io::Result<()> {
    let mut buf = String::with_capacity(64);
    for (k, v) in list.iter().enumerate() {
        buf.clear();
        if k > 0 {
            buf.push(',');
        }
        use std::fmt::Write as _;
        let _ = write!(buf, "[{},{},{}]", v[0], v[1], v[2]);
        w.write_all(buf.as_bytes())?;
    }
    Ok(())
}

/// Bytes of a bucket record: the vertex's three integer coordinates, then the number of its
/// use (replaced by the number of its first use once the bucket is resolved).
const RECORD: usize = 32;

/// Buffer of each bucket file.
const BUCKET_BUF: usize = 32 << 10;

/// Bytes of bucket records resolved at a time (a whole number of records; 1 MiB, three
/// records in unit tests so that their buckets take several blocks).
const RESOLVE_BLOCK: usize = if cfg!(test) { RECORD * 3 } else { RECORD << 15 };

/// One bucket per this many bytes of document (at least one, at most [`MAX_BUCKETS`]).
const BUCKET_BYTES: u64 = 32 << 20;

/// At most this many bucket files (open at once).
const MAX_BUCKETS: u64 = 256;

/// The passes over the objects of [`super::cityjson::write`]: from the pass given on, `each`
/// sees every chunk's plan and the part (buildings, then the other city objects); false
/// where the stream declines.
pub(super) type OverParts<'o> =
    dyn FnMut(usize, &mut dyn FnMut(&Plan<'_>, bool) -> io::Result<()>) -> io::Result<bool> + 'o;

/// The first run of the objects passes (3 and 4) over the document at `path`: every vertex
/// use recorded in its bucket, then the buckets resolved, `verts` ready to number the uses of
/// the second run. False where the stream declines.
///
/// # Errors
/// I/O errors of the temporary files.
pub(super) fn record_uses(
    path: &Path,
    verts: &mut Vertices,
    over_parts: &mut OverParts<'_>,
) -> io::Result<bool> {
    let buckets = (std::fs::metadata(path).map_or(0, |m| m.len()) / BUCKET_BYTES)
        .clamp(1, MAX_BUCKETS) as usize;
    verts.external = Some(External::Record(Recorder::new(buckets)?));
    let mut throwaway = ExportSummary::default();
    let done = over_parts(3, &mut |plan, standalone| {
        plan.count_uses(standalone, verts, &mut throwaway);
        verts.check()
    })?;
    if !done {
        return Ok(false);
    }
    let Some(External::Record(rec)) = verts.external.take() else {
        return Err(io::Error::other("vertex index lost"));
    };
    verts.external = Some(External::Replay(rec.resolve()?));
    Ok(true)
}

/// The vertex index of a streamed CityJSON document, on disk (module docs).
enum External {
    /// First pass: every use recorded in its bucket.
    Record(Recorder),
    /// Second pass: every use's index read back.
    Replay(Replayer),
}

impl External {
    /// The index of one use of vertex `key` (0 while recording: the ring's duplicates are
    /// found by key, so the number does not matter yet).
    fn index(&mut self, key: [i64; 3]) -> u32 {
        match self {
            External::Record(r) => r.record(key),
            External::Replay(r) => r.index(key),
        }
    }
}

fn bucket_of(key: [i64; 3], n: usize) -> usize {
    let h = foldhash::fast::FixedState::with_seed(0x00b0_c4e7).hash_one(key);
    (h % n as u64) as usize
}

/// Records every use of a vertex in its bucket.
struct Recorder {
    buckets: Vec<BufWriter<File>>,
    uses: u64,
    err: Option<io::Error>,
}

impl Recorder {
    fn new(n: usize) -> io::Result<Self> {
        let buckets = (0..n)
            .map(|_| Ok(BufWriter::with_capacity(BUCKET_BUF, tempfile::tempfile()?)))
            .collect::<io::Result<_>>()?;
        Ok(Recorder {
            buckets,
            uses: 0,
            err: None,
        })
    }

    fn record(&mut self, key: [i64; 3]) -> u32 {
        let b = bucket_of(key, self.buckets.len());
        let mut rec = [0u8; RECORD];
        for (k, c) in key.iter().enumerate() {
            rec[k * 8..k * 8 + 8].copy_from_slice(&c.to_le_bytes());
        }
        rec[24..].copy_from_slice(&self.uses.to_le_bytes());
        self.uses += 1;
        if let Err(e) = self.buckets[b].write_all(&rec) {
            self.err.get_or_insert(e);
        }
        0
    }

    /// Every use's first use, bucket by bucket (written over its record), and the bits of
    /// the first uses with their counts: the index of every use, ready to be read back.
    fn resolve(self) -> io::Result<Replayer> {
        if let Some(e) = self.err {
            return Err(e);
        }
        let words = usize::try_from(self.uses.div_ceil(64)).map_err(io::Error::other)?;
        let mut first = vec![0u64; words];
        let mut files = Vec::with_capacity(self.buckets.len());
        let mut map: HashMap<[i64; 3], u64> = HashMap::new();
        let mut block = vec![0u8; RESOLVE_BLOCK];
        for b in self.buckets {
            let mut f = b.into_inner().map_err(|e| e.into_error())?;
            map.clear();
            // a block of records at a time, written back where it was read: memory follows
            // the bucket's distinct vertices, not its uses
            let mut pos = 0u64;
            loop {
                f.seek(io::SeekFrom::Start(pos))?;
                let k = read_full(&mut f, &mut block)?;
                let k = k - k % RECORD;
                if k == 0 {
                    break;
                }
                for r in block[..k].chunks_exact_mut(RECORD) {
                    let key = key_of(r);
                    let at = u64::from_le_bytes(r[24..32].try_into().map_err(io::Error::other)?);
                    let f0 = *map.entry(key).or_insert(at);
                    if f0 == at {
                        first[(at / 64) as usize] |= 1 << (at % 64);
                    }
                    r[24..32].copy_from_slice(&f0.to_le_bytes());
                }
                f.seek(io::SeekFrom::Start(pos))?;
                f.write_all(&block[..k])?;
                pos += k as u64;
            }
            f.rewind()?;
            files.push(BufReader::with_capacity(BUCKET_BUF, f));
        }
        let mut before = Vec::with_capacity(words);
        let mut n = 0u32;
        for w in &first {
            before.push(n);
            n += w.count_ones();
        }
        Ok(Replayer {
            buckets: files,
            first,
            before,
            next: 0,
            list: BufWriter::new(tempfile::tempfile()?),
            err: None,
        })
    }
}

/// Read `buf` full from `f`, or up to its end: the bytes read.
fn read_full(f: &mut File, buf: &mut [u8]) -> io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match f.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

fn key_of(r: &[u8]) -> [i64; 3] {
    let c = |k: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&r[k * 8..k * 8 + 8]);
        i64::from_le_bytes(b)
    };
    [c(0), c(1), c(2)]
}

/// Reads every use's index back in the order of the record.
struct Replayer {
    buckets: Vec<BufReader<File>>,
    /// Bit `u`: use `u` is its vertex's first.
    first: Vec<u64>,
    /// First uses before each word of `first`.
    before: Vec<u32>,
    /// Vertices listed so far.
    next: u32,
    /// The vertices in index order.
    list: BufWriter<File>,
    err: Option<io::Error>,
}

impl Replayer {
    fn index(&mut self, key: [i64; 3]) -> u32 {
        let b = bucket_of(key, self.buckets.len());
        let mut rec = [0u8; RECORD];
        if let Err(e) = self.buckets[b].read_exact(&mut rec) {
            self.err.get_or_insert(e);
            return 0;
        }
        if key_of(&rec) != key {
            self.err
                .get_or_insert(io::Error::other("vertex uses differ between the passes"));
            return 0;
        }
        let at = u64::from_le_bytes(rec[24..32].try_into().unwrap_or_default());
        let word = (at / 64) as usize;
        let below = self
            .first
            .get(word)
            .map_or(0, |w| w & ((1u64 << (at % 64)) - 1));
        let index = self.before.get(word).copied().unwrap_or(0) + below.count_ones();
        if index == self.next {
            if let Err(e) = self.list.write_all(&rec[..24]) {
                self.err.get_or_insert(e);
            }
            self.next += 1;
        }
        index
    }

    /// Write the vertex list to `w` (as the in-memory index does); how many.
    fn copy_vertices(self, w: &mut dyn Write) -> io::Result<usize> {
        if let Some(e) = self.err {
            return Err(e);
        }
        let mut f = self.list.into_inner().map_err(|e| e.into_error())?;
        f.rewind()?;
        let mut r = BufReader::with_capacity(1 << 20, f);
        let mut rec = [0u8; 24];
        let mut batch: Vec<[i64; 3]> = Vec::with_capacity(4096);
        let mut n = 0usize;
        loop {
            match r.read_exact(&mut rec) {
                Ok(()) => batch.push(key_of(&rec)),
                Err(e) if e.kind() == io::ErrorKind::UnexpectedEof => break,
                Err(e) => return Err(e),
            }
            if batch.len() == batch.capacity() {
                flush_vertices(w, &batch, n)?;
                n += batch.len();
                batch.clear();
            }
        }
        flush_vertices(w, &batch, n)?;
        Ok(n + batch.len())
    }
}

/// Vertices `batch`, the first of which is vertex `n` of the list (a comma before it but
/// the first).
fn flush_vertices(w: &mut dyn Write, batch: &[[i64; 3]], n: usize) -> io::Result<()> {
    if batch.is_empty() {
        return Ok(());
    }
    if n > 0 {
        w.write_all(b",")?;
    }
    write_vertices(w, batch)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rings_drop_duplicates_after_rounding() {
        let mut v = Vertices::new(DVec3::new(100.0, 200.0, 0.0), DVec3::splat(0.001));
        let r = v
            .ring(&[
                DVec3::new(100.0, 200.0, 0.0),
                DVec3::new(100.0002, 200.0, 0.0),
                DVec3::new(101.0, 200.0, 0.0),
                DVec3::new(101.0, 201.0, 0.0),
                DVec3::new(100.0, 200.0001, 0.0),
            ])
            .unwrap();
        assert_eq!(r, vec![0, 1, 2]);
        assert_eq!(v.list[2], [1000, 1000, 0]);
        assert!(v
            .ring(&[DVec3::ZERO, DVec3::X * 1e-5, DVec3::Y * 1e-5])
            .is_none());
    }
}
