//! The writer index's table of `gml:id`s ([`IdTable`]): every id of a document, those of
//! skipped content included, and the first element holding it.

/// `gml:id`s: their bytes in one arena, found by hash (a sorted table, so that hundreds of
/// thousands of ids cost no allocation each). An id that repeats maps to its smallest node,
/// the first in document order. The ids of skipped content found by the prescan are kept as
/// their hash alone ([`IdTable::push_hashed`]): a lookup matches them by their 64-bit hash,
/// as the reader's duplicate check does (a false match needs a 64-bit collision), and a
/// city's millions of dropped ids cost no bytes.
#[derive(Debug, Default, PartialEq)]
pub(super) struct IdTable {
    bytes: Vec<u8>,
    /// (hash, start in `bytes`, length or [`HASH_ONLY`], node); sorted by hash once the scan
    /// is done.
    entries: Vec<(u64, usize, u32, u32)>,
    /// After [`IdTable::finish`]: the first entry of each range of hashes with the same top
    /// `bits` bits (one more at the end), so that a lookup reads about one entry.
    dir: Vec<u32>,
    bits: u32,
}

/// The length of an entry kept as its hash alone.
const HASH_ONLY: u32 = u32::MAX;

impl IdTable {
    pub(super) fn hash(id: &[u8]) -> u64 {
        use std::hash::BuildHasher;
        foldhash::fast::FixedState::with_seed(0x05c7_110d).hash_one(id)
    }

    pub(super) fn push(&mut self, id: &[u8], node: u32) {
        let start = self.bytes.len();
        self.bytes.extend_from_slice(id);
        self.entries
            .push((Self::hash(id), start, id.len() as u32, node));
    }

    /// An id known by its hash alone ([`IdTable::hash`] of its unescaped value).
    pub(super) fn push_hashed(&mut self, hash: u64, node: u32) {
        self.entries.push((hash, 0, HASH_ONLY, node));
    }

    /// Room for the ids of a document of about `bytes` bytes (about one per 350 bytes in the
    /// files at hand; memory reserved and never touched is not resident).
    pub(super) fn expect_bytes(&mut self, bytes: u64) {
        let ids = (bytes / 350).min(1 << 24) as usize;
        self.entries.reserve(ids);
        self.bytes.reserve(ids * 16);
    }

    /// Group the entries by bucket (a counting sort: the order inside a bucket does not
    /// matter to [`IdTable::get`], which takes the smallest node of the matching ones).
    pub(super) fn finish(&mut self) {
        self.bits = (self.entries.len().max(1).ilog2() + 1).min(24);
        let buckets = 1usize << self.bits;
        let mut dir = vec![0u32; buckets + 1];
        for e in &self.entries {
            dir[self.bucket(e.0) + 1] += 1;
        }
        for b in 0..buckets {
            dir[b + 1] += dir[b];
        }
        let mut next = dir.clone();
        let mut sorted = vec![(0, 0, 0, 0); self.entries.len()];
        for e in &self.entries {
            let b = self.bucket(e.0);
            sorted[next[b] as usize] = *e;
            next[b] += 1;
        }
        self.entries = sorted;
        self.dir = dir;
    }

    fn bucket(&self, h: u64) -> usize {
        (h >> (64 - self.bits)) as usize
    }

    /// Smallest node holding `id`.
    pub(super) fn get(&self, id: &str) -> Option<u32> {
        let h = Self::hash(id.as_bytes());
        let entries = if self.dir.is_empty() {
            &self.entries[..] // before finish: all of them
        } else {
            let b = self.bucket(h);
            let (lo, hi) = (self.dir[b] as usize, self.dir[b + 1] as usize);
            &self.entries[lo..hi]
        };
        entries
            .iter()
            .filter(|e| e.0 == h)
            .filter(|e| {
                e.2 == HASH_ONLY || self.bytes.get(e.1..e.1 + e.2 as usize) == Some(id.as_bytes())
            })
            .map(|e| e.3)
            .min()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn id_table_finds_the_first_node() {
        let mut t = IdTable::default();
        t.push(b"a", 7);
        t.push(b"b", 3);
        t.push(b"a", 5);
        assert_eq!(t.get("a"), Some(5), "before finish");
        t.finish();
        assert_eq!(t.get("a"), Some(5));
        assert_eq!(t.get("b"), Some(3));
        assert_eq!(t.get("c"), None);
        assert_eq!(t.get(""), None);
        let mut big = IdTable::default();
        for i in 0..5000u32 {
            big.push(format!("id{i}").as_bytes(), i);
        }
        big.finish();
        assert!((0..5000u32).all(|i| big.get(&format!("id{i}")) == Some(i)));
        assert_eq!(big.get("id5000"), None);
    }
}
