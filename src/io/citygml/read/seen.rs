//! The gml:id hashes of a streamed document's chunks read so far ([`SeenIds`]): which ids of
//! the next chunk repeat an earlier one (the stream's "duplicate gml:id" warnings across
//! chunks, the chunked writer's fresh ids).

use super::state::Parser;

/// The gml:id hashes of the chunks read so far (8 bytes an id, and 1.25 to 2.5 more for the
/// filter and the runs' directories): which ids of the next chunk repeat an earlier one.
/// They are kept in sorted runs, each at least twice as long as the next (a run merged into
/// the one before it once it is half as long): a chunk's ids are looked up in a few runs,
/// and an id is moved in about log2(chunks) merges, not once per chunk after it (a single
/// sorted vector made a 4 GB document's writer quadratic). Before the runs, a bit per slot
/// of the hashes' top bits (its `filter`) turns most ids away: an id whose bit is clear was
/// never met; the others are looked up in each run's range of their top bits ([`Run`]).
/// (The 1 GB bench file's stream spent 5.6 % of its CPU here with a galloping walk of every
/// id through every run, 2.6 % so: BENCHMARKS.md, "The streamed read beside the whole one".)
#[derive(Default)]
pub(crate) struct SeenIds {
    runs: Vec<Run>,
    /// The filter: bit `filter_slot(hash, filter_bits)` of every hash in the runs is set; 8
    /// to 16 bits per id held (made larger, and filled again from the runs, where it would
    /// hold more than one id per 8 bits), so that about 6 to 12 % of the bits are set.
    /// Empty while no id is held.
    filter: Vec<u64>,
    /// log2 of the filter's bits.
    filter_bits: u32,
    /// Ids held in the runs.
    len: usize,
}

/// The filter's slot of hash `h` among `1 << bits` (`bits` >= 6): its top bits (the hashes
/// are uniform; in the order of the sorted hashes, so that a sorted chunk's lookups and the
/// runs' rebuilds go through the filter in order, not at random).
fn filter_slot(h: u64, bits: u32) -> usize {
    usize::try_from(h >> (64 - bits)).unwrap_or(0)
}

impl SeenIds {
    /// The ids of chunk `p` met in earlier chunks; `p`'s ids are then added.
    pub(super) fn check_and_add(&mut self, p: &Parser<'_>) -> foldhash::HashSet<u64> {
        self.check_and_add_hashes(p.id_log.iter().map(|r| r.hash).collect())
    }

    /// Could an id of hash `h` have been met? `false`: certainly not.
    fn may_hold(&self, h: u64) -> bool {
        if self.filter.is_empty() {
            return false;
        }
        let s = filter_slot(h, self.filter_bits);
        self.filter
            .get(s / 64)
            .is_some_and(|w| w >> (s % 64) & 1 == 1)
    }

    /// Set the filter's bits of `h`, made larger first (and filled again from the runs)
    /// where the ids held would pass one per 8 bits.
    fn filter_add(&mut self, h: &[u64]) {
        let held = self.len + h.len();
        if self.filter.is_empty() || held.saturating_mul(8) > 1usize << self.filter_bits {
            // 8 to 16 bits per id held, at least one word
            let bits = held.saturating_mul(8).max(64).next_power_of_two();
            self.filter_bits = bits.trailing_zeros();
            self.filter = vec![0u64; bits / 64];
            let (filter, n) = (&mut self.filter, self.filter_bits);
            for &x in self.runs.iter().flat_map(|r| &r.ids) {
                let s = filter_slot(x, n);
                filter[s / 64] |= 1 << (s % 64);
            }
        }
        let n = self.filter_bits;
        for &x in h {
            let s = filter_slot(x, n);
            self.filter[s / 64] |= 1 << (s % 64);
        }
        self.len = held;
    }

    /// Was an id of hash `h` met in an earlier chunk?
    pub(crate) fn contains(&self, h: u64) -> bool {
        self.may_hold(h) && self.runs.iter().any(|r| r.holds(h))
    }

    /// The hashes of `h` (a chunk's ids, any hash function used throughout) met in earlier
    /// chunks; they are then added.
    pub(crate) fn check_and_add_hashes(&mut self, mut h: Vec<u64>) -> foldhash::HashSet<u64> {
        h.sort_unstable();
        h.dedup();
        let mut before = foldhash::HashSet::default();
        // the ids the filter does not turn away, still sorted
        let maybe: Vec<u64> = h.iter().copied().filter(|&x| self.may_hold(x)).collect();
        for x in maybe {
            if self.runs.iter().any(|r| r.holds(x)) {
                before.insert(x);
            }
        }
        self.filter_add(&h);
        self.runs.push(Run::new(h));
        while let [.., a, b] = &self.runs[..] {
            if b.ids.len() * 2 < a.ids.len() {
                break;
            }
            if let Some(b) = self.runs.pop() {
                if let Some(a) = self.runs.last_mut() {
                    a.merge(&b);
                }
            }
        }
        before
    }
}

/// One sorted run of [`SeenIds`], with where each range of its top bits starts: an id is
/// looked up in the few values of its range (two cache lines, about), not by a search over
/// the run (the hashes are uniform).
struct Run {
    ids: Vec<u64>,
    /// `dir[k]..dir[k + 1]`: the values whose top `bits` bits are `k`; 2 to 4 bits per id.
    /// Empty for a run too long for `u32` indices (searched whole).
    dir: Vec<u32>,
    bits: u32,
}

/// The top `bits` bits of `x` (0 for none).
fn top_bits(x: u64, bits: u32) -> usize {
    usize::try_from(x.checked_shr(64 - bits).unwrap_or(0)).unwrap_or(0)
}

impl Run {
    /// The run of the sorted `ids`, with its directory: one range per 8 to 16 values, about.
    fn new(ids: Vec<u64>) -> Run {
        let ranges = (ids.len() / 16).max(1).next_power_of_two();
        let bits = ranges.trailing_zeros();
        let mut dir = Vec::new();
        if u32::try_from(ids.len()).is_ok() {
            dir.reserve_exact(ranges + 1);
            let mut at = 0;
            for k in 0..ranges {
                while ids.get(at).is_some_and(|&v| top_bits(v, bits) < k) {
                    at += 1;
                }
                dir.push(u32::try_from(at).unwrap_or(u32::MAX));
            }
            dir.push(u32::try_from(ids.len()).unwrap_or(u32::MAX));
        }
        Run { ids, dir, bits }
    }

    /// Does the run hold `x`?
    fn holds(&self, x: u64) -> bool {
        let k = top_bits(x, self.bits);
        let (lo, hi) = match (self.dir.get(k), self.dir.get(k + 1)) {
            (Some(&lo), Some(&hi)) => (lo as usize, hi as usize),
            _ => (0, self.ids.len()),
        };
        self.ids
            .get(lo..hi)
            .is_some_and(|r| r.binary_search(&x).is_ok())
    }

    /// Merge the run `b` into this one.
    fn merge(&mut self, b: &Run) {
        merge_into(&mut self.ids, &b.ids);
        *self = Run::new(std::mem::take(&mut self.ids));
    }
}

/// Merge the sorted `b` into the sorted `a`, in place from the end (a large vector grows by
/// remapping, not copying).
fn merge_into(a: &mut Vec<u64>, b: &[u64]) {
    let old = a.len();
    a.reserve_exact(b.len());
    a.resize(old + b.len(), 0);
    let (mut i, mut j) = (old, b.len());
    // without a branch on which side is taken (the hashes interleave at random)
    while i > 0 && j > 0 {
        let (x, y) = (a[i - 1], b[j - 1]);
        let from_a = x > y;
        a[i + j - 1] = if from_a { x } else { y };
        i -= usize::from(from_a);
        j -= usize::from(!from_a);
    }
    // what is left of `b` goes first (what is left of `a` is in place)
    a[..j].copy_from_slice(&b[..j]);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The runs answer as one set would: every id of a chunk met before is found, no other,
    /// over chunks of many sizes (merges of every shape), and the runs stay few; with
    /// hashes spread over the 64 bits (the filter and the runs' ranges at work) and with
    /// small ones (every id in the first range, the filter's first word).
    #[test]
    fn seen_ids_answer_as_a_set() {
        for spread in [0x9E37_79B9_7F4A_7C15u64, 1] {
            seen_ids_as_a_set(spread);
        }
    }

    fn seen_ids_as_a_set(spread: u64) {
        let mut seen = SeenIds::default();
        let mut all = std::collections::HashSet::new();
        let mut x = 0x2545_f491_4f6c_dd1du64;
        for chunk in 0..300usize {
            let n = [1, 7, 100, 1000, 3][chunk % 5] + chunk;
            let h: Vec<u64> = (0..n)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 7;
                    x ^= x << 17;
                    // repeats within and across chunks (an odd factor keeps them)
                    (x % 200_000).wrapping_mul(spread)
                })
                .collect();
            let expect: foldhash::HashSet<u64> =
                h.iter().copied().filter(|v| all.contains(v)).collect();
            assert_eq!(
                seen.check_and_add_hashes(h.clone()),
                expect,
                "chunk {chunk}"
            );
            all.extend(h);
            assert!(seen.runs.len() <= 24, "{} runs", seen.runs.len());
            assert!(seen.runs.iter().all(|r| r.ids.is_sorted()));
            // the filter: 8 to 16 bits per id held (at least one word); the ranges: one per
            // 8 to 16 ids
            let held: usize = seen.runs.iter().map(|r| r.ids.len()).sum();
            for r in &seen.runs {
                let ranges = r.dir.len() - 1;
                let (lo, hi) = (8 * ranges, 16 * (ranges + 1));
                assert!(
                    ranges == 1 || (lo..hi).contains(&r.ids.len()),
                    "{ranges} ranges"
                );
            }
            assert_eq!(seen.len, held);
            let bits = seen.filter.len() * 64;
            assert!(
                bits >= 8 * held && bits <= (16 * held).max(64),
                "{bits} bits, {held} ids"
            );
        }
        assert!(all.iter().all(|&v| seen.contains(v)));
        assert!(!seen.contains(200_001u64.wrapping_mul(spread)));
    }
}
