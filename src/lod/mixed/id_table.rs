//! The writer index's table of `gml:id`s ([`IdTable`]): every id of a document, those of
//! skipped content included, and the first element holding it.

/// `gml:id`s: their bytes in one arena, found by hash (a table sorted by hash once, so that
/// hundreds of thousands of ids cost no allocation each). An id that repeats maps to its
/// smallest node, the first in document order. The ids of skipped content found by the
/// prescan are kept as their hash alone ([`IdTable::push_hashed`]): a lookup matches them by
/// their 64-bit hash, as the reader's duplicate check does (a false match needs a 64-bit
/// collision), and a city's millions of dropped ids cost no bytes.
///
/// 16 bytes an id ([`Entry`]) plus, for an id kept with its text, its bytes and their length
/// (one byte below 128); [`IdTable::finish`] sorts in place (no second table at the writer's
/// peak) and keeps a directory of one entry per two to four ids.
#[derive(Debug, Default, PartialEq)]
pub(super) struct IdTable {
    /// Each id kept with its text: its length (LEB128) then its bytes.
    bytes: Vec<u8>,
    /// Sorted by hash once the scan is done.
    entries: Vec<Entry>,
    /// After [`IdTable::finish`]: the first entry of each range of hashes with the same top
    /// `bits` bits (one more at the end), so that a lookup reads a few entries.
    dir: Vec<u32>,
    bits: u32,
}

/// One id: its hash, where its text starts in [`IdTable::bytes`] ([`HASH_ONLY`]: kept as its
/// hash alone), its node.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
struct Entry {
    hash: u64,
    at: u32,
    node: u32,
}

/// [`Entry::at`] of an entry kept as its hash alone (also an id whose text would start past
/// 4 GiB of id text: matched by its hash like the ids of skipped content).
const HASH_ONLY: u32 = u32::MAX;

impl IdTable {
    pub(super) fn hash(id: &[u8]) -> u64 {
        use std::hash::BuildHasher;
        foldhash::fast::FixedState::with_seed(0x05c7_110d).hash_one(id)
    }

    pub(super) fn push(&mut self, id: &[u8], node: u32) {
        let hash = Self::hash(id);
        let at = match u32::try_from(self.bytes.len()) {
            Ok(at) if at < HASH_ONLY => at,
            _ => return self.push_hashed(hash, node),
        };
        let mut len = id.len();
        while len >= 0x80 {
            self.bytes.push((len & 0x7f) as u8 | 0x80);
            len >>= 7;
        }
        self.bytes.push(len as u8);
        self.bytes.extend_from_slice(id);
        self.entries.push(Entry { hash, at, node });
    }

    /// An id known by its hash alone ([`IdTable::hash`] of its unescaped value).
    pub(super) fn push_hashed(&mut self, hash: u64, node: u32) {
        self.entries.push(Entry {
            hash,
            at: HASH_ONLY,
            node,
        });
    }

    /// Room for the ids of a document of about `bytes` bytes (about one per 350 bytes in the
    /// files at hand; memory reserved and never touched is not resident).
    pub(super) fn expect_bytes(&mut self, bytes: u64) {
        let ids = (bytes / 350).min(1 << 24) as usize;
        self.entries.reserve(ids);
        self.bytes.reserve(ids * 16);
    }

    /// Sort the entries by hash, in place, and index the ranges of their top bits.
    pub(super) fn finish(&mut self) {
        use rayon::slice::ParallelSliceMut;
        self.entries.par_sort_unstable();
        self.bits = self
            .entries
            .len()
            .max(1)
            .ilog2()
            .saturating_sub(1)
            .clamp(1, 24);
        let buckets = 1usize << self.bits;
        let mut dir = vec![0u32; buckets + 1];
        for e in &self.entries {
            dir[self.bucket(e.hash) + 1] += 1;
        }
        for b in 0..buckets {
            dir[b + 1] += dir[b];
        }
        self.dir = dir;
    }

    fn bucket(&self, h: u64) -> usize {
        (h >> (64 - self.bits)) as usize
    }

    /// The text of the id kept at `at` in [`IdTable::bytes`].
    fn text(&self, at: u32) -> Option<&[u8]> {
        let mut i = at as usize;
        let (mut len, mut shift) = (0usize, 0u32);
        loop {
            let b = *self.bytes.get(i)?;
            i += 1;
            len |= usize::from(b & 0x7f).checked_shl(shift)?;
            if b < 0x80 {
                break;
            }
            shift += 7;
        }
        self.bytes.get(i..i.checked_add(len)?)
    }

    /// The hash ([`IdTable::hash`]) of every id, in no order.
    pub(super) fn hashes(&self) -> impl Iterator<Item = u64> + '_ {
        self.entries.iter().map(|e| e.hash)
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
            .filter(|e| e.hash == h)
            .filter(|e| e.at == HASH_ONLY || self.text(e.at) == Some(id.as_bytes()))
            .map(|e| e.node)
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

    #[test]
    fn long_ids_and_hashed_ids_are_found_and_a_prefix_is_not() {
        let long = "x".repeat(300); // a length of two bytes
        let mut t = IdTable::default();
        t.push(long.as_bytes(), 4);
        t.push(b"short", 9);
        t.push_hashed(IdTable::hash(b"skipped"), 2);
        t.push(b"skipped", 6);
        for i in 0..100u32 {
            t.push(format!("{long}{i}").as_bytes(), 100 + i);
        }
        t.finish();
        assert_eq!(t.get(&long), Some(4));
        assert_eq!(t.get(&long[..299]), None);
        assert_eq!(t.get("short"), Some(9));
        assert_eq!(t.get("shor"), None);
        assert_eq!(
            t.get("skipped"),
            Some(2),
            "the first node, kept as its hash"
        );
        assert!((0..100u32).all(|i| t.get(&format!("{long}{i}")) == Some(100 + i)));
    }
}
