//! The gml:id hashes of a streamed document's chunks read so far ([`SeenIds`]): which ids of
//! the next chunk repeat an earlier one (the stream's "duplicate gml:id" warnings across
//! chunks, the chunked writer's fresh ids).

use super::state::Parser;

/// The gml:id hashes of the chunks read so far: which ids of the next chunk repeat an earlier
/// one. About 7 to 7.75 bytes an id (6 for the [`Base`], 0.75 to 1.1 for the filter, at most
/// 0.5 for the recent runs), and no part of it held twice while it grows: a plain sorted
/// vector takes 8, sorted runs alone 8 and, while the two longest merge, up to half as much
/// again.
///
/// Most ids are in the [`Base`]: sorted, bucketed by their top 16 bits, 6 bytes an id. The
/// ids of the recent chunks are in sorted `runs` (each with a directory of its top bits, each
/// at least twice as long as the next: a run merged into the one before it once it is half as
/// long), at most a sixteenth of the base's ids (or one chunk's); past that they are merged
/// into one run and that into the base, in place. An id is so copied about 16 times on
/// average by the base's merges (block copies: each added id's place found by a walk down its
/// bucket) and a few times among the runs (a single sorted vector merged per chunk would be
/// quadratic in the chunks).
///
/// Before the base and the runs, a filter of a bit per slot of the hashes' scaled values
/// turns most ids away: an id whose bit is clear was never met, so most ids never walk the
/// runs (walking every id through every run steps through most of their cache lines).
#[derive(Default)]
pub(crate) struct SeenIds {
    base: Base,
    runs: Vec<Run>,
    /// Ids held in `runs`.
    recent: usize,
    /// The filter: bit `filter_slot(hash, its bits)` of every hash held is set; 6 to 9 bits
    /// per id held (made anew at 9 where it would hold more than one id per 6 bits: the old
    /// one freed first, the new one filled from the base and the runs), so that about 11 to
    /// 16 % of its bits are set. Empty while no id is held.
    filter: Vec<u64>,
}

/// The filter's slot of hash `h` among `bits`: the hash scaled to them (the hashes are
/// uniform; in the order of the sorted hashes, so that a sorted chunk's lookups and the
/// filter's fills go through it in order, not at random).
fn filter_slot(h: u64, bits: usize) -> usize {
    usize::try_from((u128::from(h) * bits as u128) >> 64).unwrap_or(0)
}

/// Bits of the filter per id held: at least the first (it is made anew past that), with the
/// second when made.
const FILTER_BITS_PER_ID: (usize, usize) = (6, 9);

/// The runs hold at most one in this many of the base's ids (and at least one chunk's).
const RECENT_SHARE: usize = 16;

impl SeenIds {
    /// The ids of chunk `p` met in earlier chunks, and those it holds more than once (found
    /// on the way: the sort that finds them here is the one the chunk's own duplicate check
    /// made again); `p`'s ids are then added.
    #[allow(clippy::type_complexity)]
    pub(super) fn check_and_add(
        &mut self,
        p: &Parser<'_>,
    ) -> (foldhash::HashSet<u64>, foldhash::HashSet<u64>) {
        let mut h: Vec<u64> = p.id_log.iter().map(|r| r.hash).collect();
        h.sort_unstable();
        let repeated = super::ids::repeats(&h);
        h.dedup();
        (self.check_and_add_sorted(h), repeated)
    }

    /// Ids held.
    fn len(&self) -> usize {
        self.base.len() + self.recent
    }

    /// Could an id of hash `h` have been met? `false`: certainly not.
    fn may_hold(&self, h: u64) -> bool {
        let s = filter_slot(h, self.filter.len() * 64);
        self.filter
            .get(s / 64)
            .is_some_and(|w| w >> (s % 64) & 1 == 1)
    }

    /// Set the filter's bits of the sorted `h`, the filter made anew first (the old one freed
    /// first, the new one filled from the base and the runs) where the ids held would pass
    /// one per [`FILTER_BITS_PER_ID`]`.0` bits.
    fn filter_add(&mut self, h: &[u64]) {
        let held = self.len() + h.len();
        let (least, made) = FILTER_BITS_PER_ID;
        if held.saturating_mul(least) > self.filter.len() * 64 {
            // never both held
            self.filter = Vec::new();
            self.filter = vec![0; held.saturating_mul(made).div_ceil(64)];
            let filter = &mut self.filter;
            let bits = filter.len() * 64;
            let mut set = |x: u64| {
                let s = filter_slot(x, bits);
                if let Some(w) = filter.get_mut(s / 64) {
                    *w |= 1 << (s % 64);
                }
            };
            self.base.for_each(&mut set);
            self.runs.iter().flat_map(|r| &r.ids).for_each(|&x| set(x));
        }
        let bits = self.filter.len() * 64;
        for &x in h {
            let s = filter_slot(x, bits);
            if let Some(w) = self.filter.get_mut(s / 64) {
                *w |= 1 << (s % 64);
            }
        }
    }

    /// Was an id of hash `h` met in an earlier chunk?
    pub(crate) fn contains(&self, h: u64) -> bool {
        self.may_hold(h) && (self.base.holds(h) || self.runs.iter().any(|r| r.holds(h)))
    }

    /// The hashes of `h` (a chunk's ids, any hash function used throughout) met in earlier
    /// chunks; the others are then added.
    pub(crate) fn check_and_add_hashes(&mut self, mut h: Vec<u64>) -> foldhash::HashSet<u64> {
        h.sort_unstable();
        h.dedup();
        self.check_and_add_sorted(h)
    }

    /// [`SeenIds::check_and_add_hashes`] of `h` sorted, without repeats.
    fn check_and_add_sorted(&mut self, mut h: Vec<u64>) -> foldhash::HashSet<u64> {
        let mut before = foldhash::HashSet::default();
        // the ids the filter does not turn away, still sorted
        let maybe: Vec<u64> = h.iter().copied().filter(|&x| self.may_hold(x)).collect();
        for x in maybe {
            if self.base.holds(x) || self.runs.iter().any(|r| r.holds(x)) {
                before.insert(x);
            }
        }
        if !before.is_empty() {
            h.retain(|x| !before.contains(x));
        }
        if h.is_empty() {
            return before;
        }
        self.filter_add(&h);
        let chunk = h.len();
        self.recent += chunk;
        self.runs.push(Run::new(h));
        let to_base = self.recent > chunk.max(self.base.len() / RECENT_SHARE);
        while let [.., a, b] = &self.runs[..] {
            if !to_base && b.ids.len() * 2 < a.ids.len() {
                break;
            }
            if let Some(b) = self.runs.pop() {
                if let Some(a) = self.runs.last_mut() {
                    a.merge(&b, !to_base);
                }
            }
        }
        if to_base {
            if let Some(r) = self.runs.pop() {
                self.base.absorb(&r.ids);
            }
            self.recent = 0;
        }
        before
    }
}

/// The bulk of [`SeenIds`]: its hashes sorted, bucketed by their top [`BUCKET_BITS`] bits,
/// each stored as its other 48 bits (6 bytes an id, and a directory of 65,537 offsets).
#[derive(Default)]
struct Base {
    /// `starts[k]..starts[k + 1]`: the hashes whose top bits are `k`; empty while none is held.
    starts: Vec<usize>,
    /// The low 48 bits of each hash, little-endian, in order.
    low: Vec<[u8; 6]>,
}

/// The top bits by which [`Base`] buckets its hashes (the others are stored).
const BUCKET_BITS: u32 = 16;

/// The bits of a hash that [`Base`] stores.
const LOW_MASK: u64 = (1 << (64 - BUCKET_BITS)) - 1;

/// The low 48 bits of `x`, stored.
fn low48(x: u64) -> [u8; 6] {
    let b = x.to_le_bytes();
    [b[0], b[1], b[2], b[3], b[4], b[5]]
}

/// The value of stored low bits `l`.
fn from_low48(l: [u8; 6]) -> u64 {
    u64::from_le_bytes([l[0], l[1], l[2], l[3], l[4], l[5], 0, 0])
}

impl Base {
    /// Ids held.
    fn len(&self) -> usize {
        self.low.len()
    }

    /// The hashes' bucket `k` (`starts[k]..starts[k + 1]`).
    fn bucket(&self, k: usize) -> &[[u8; 6]] {
        match (self.starts.get(k), self.starts.get(k + 1)) {
            (Some(&lo), Some(&hi)) => self.low.get(lo..hi).unwrap_or(&[]),
            _ => &[],
        }
    }

    /// Does the base hold `x`?
    fn holds(&self, x: u64) -> bool {
        find(&self.starts, &self.low, x).1
    }

    /// Every hash held, in order.
    fn for_each(&self, f: &mut impl FnMut(u64)) {
        for k in 0..self.starts.len().saturating_sub(1) {
            let top = (k as u64) << (64 - BUCKET_BITS);
            for &v in self.bucket(k) {
                f(top | from_low48(v));
            }
        }
    }

    /// Merge the sorted `add` in, in place from the end (the stored bits grow by remapping,
    /// not copying, and only `add` is held besides them).
    fn absorb(&mut self, add: &[u64]) {
        const BUCKETS: usize = 1 << BUCKET_BITS;
        if self.starts.is_empty() {
            self.starts = vec![0; BUCKETS + 1];
        }
        let old = self.low.len();
        self.low.reserve_exact(add.len());
        self.low.resize(old + add.len(), [0; 6]);
        // from the end: each added hash goes after the stored ones below it, which move up by
        // the added ones still to go (one block copy for the hashes between two added ones);
        // its place is found by a walk down its bucket from where the one after it went (the
        // hashes walked over are the ones copied next: in cache, in order)
        let mut end = old;
        for (j, &y) in add.iter().enumerate().rev() {
            let k = usize::try_from(y >> (64 - BUCKET_BITS)).unwrap_or(0);
            let l = y & LOW_MASK;
            let bound = |i: usize| self.starts.get(i).map_or(end, |&s| s.min(end));
            let (lo, mut at) = (bound(k), bound(k + 1));
            while at > lo && self.low.get(at - 1).is_some_and(|&v| from_low48(v) > l) {
                at -= 1;
            }
            self.low.copy_within(at..end, at + j + 1);
            if let Some(v) = self.low.get_mut(at + j) {
                *v = low48(y);
            }
            end = at;
        }
        // each bucket's start moves by the added hashes of the buckets before it
        let mut before = 0;
        for (k, s) in self.starts.iter_mut().enumerate() {
            while add
                .get(before)
                .is_some_and(|&y| usize::try_from(y >> (64 - BUCKET_BITS)).unwrap_or(0) < k)
            {
                before += 1;
            }
            *s += before;
        }
    }
}

/// Where hash `x` is, or would go, among the sorted `low` (a [`Base`]'s first hashes, the
/// buckets' `starts` cut at its end), and whether it is there. Looked for first among the
/// [`WINDOW`] hashes either side of where a uniform hash of its bucket would be (its next 16
/// bits give its share of the bucket), the whole bucket searched only if it is not there.
fn find(starts: &[usize], low: &[[u8; 6]], x: u64) -> (usize, bool) {
    let k = usize::try_from(x >> (64 - BUCKET_BITS)).unwrap_or(0);
    let l = x & LOW_MASK;
    let (lo, hi) = match (starts.get(k), starts.get(k + 1)) {
        (Some(&lo), Some(&hi)) => (lo.min(low.len()), hi.min(low.len())),
        _ => return (0, false),
    };
    let b = low.get(lo..hi).unwrap_or(&[]);
    let n = b.len();
    let guess = usize::try_from((l >> 32).saturating_mul(n as u64) >> 16).unwrap_or(n);
    let (a, z) = (
        guess.saturating_sub(WINDOW),
        guess.saturating_add(WINDOW).min(n),
    );
    let below = |i: usize| b.get(i).is_some_and(|&v| from_low48(v) < l);
    let (a, z) = if (a == 0 || below(a - 1)) && (z == n || !below(z)) {
        (a, z)
    } else {
        (0, n)
    };
    let at = a + b
        .get(a..z)
        .map_or(0, |w| w.partition_point(|&v| from_low48(v) < l));
    (lo + at, b.get(at).is_some_and(|&v| from_low48(v) == l))
}

/// The hashes either side of its likely place among which [`find`] looks for one first.
const WINDOW: usize = 16;

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

    /// Merge the run `b` into this one; its directory made again if `dir` (else left empty:
    /// the run is to go into the base).
    fn merge(&mut self, b: &Run, dir: bool) {
        merge_into(&mut self.ids, &b.ids);
        if dir {
            *self = Run::new(std::mem::take(&mut self.ids));
        } else {
            self.dir = Vec::new();
        }
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

    /// The base, the runs and the filter answer as one set would: every id of a chunk met
    /// before is found, no other, over chunks of many sizes (merges of every shape, into the
    /// base and among the runs); with hashes spread over the 64 bits (the filter and the
    /// buckets at work) and with small ones (every id in the first bucket, the filter's first
    /// word).
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
        let mut into_base = 0;
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
            let new = h.iter().collect::<std::collections::HashSet<_>>().len() - expect.len();
            let base_before = seen.base.len();
            assert_eq!(
                seen.check_and_add_hashes(h.clone()),
                expect,
                "chunk {chunk}"
            );
            all.extend(h);
            into_base += usize::from(seen.base.len() > base_before);
            // each id once; the runs at most a sixteenth of the base (or the last chunk)
            assert_eq!(seen.len(), all.len());
            assert!(seen.recent <= new.max(seen.base.len() / RECENT_SHARE));
            assert_eq!(
                seen.recent,
                seen.runs.iter().map(|r| r.ids.len()).sum::<usize>()
            );
            assert!(seen.runs.len() <= 24, "{} runs", seen.runs.len());
            assert!(seen.runs.iter().all(|r| r.ids.is_sorted()));
            let mut base = Vec::new();
            seen.base.for_each(&mut |v| base.push(v));
            assert_eq!(base.len(), seen.base.len());
            assert!(base.is_sorted() && base.windows(2).all(|w| w[0] < w[1]));
            // the runs' ranges: one per 8 to 16 ids
            for r in &seen.runs {
                let ranges = r.dir.len() - 1;
                let (lo, hi) = (8 * ranges, 16 * (ranges + 1));
                assert!(
                    ranges == 1 || (lo..hi).contains(&r.ids.len()),
                    "{ranges} ranges"
                );
            }
            // the filter: 6 to 9 bits per id held (whole words)
            let (bits, held) = (seen.filter.len() * 64, seen.len());
            assert!(
                bits >= 6 * held && bits < 9 * held + 64,
                "{bits} bits, {held} ids"
            );
        }
        // merged into the base many times, not once per chunk
        assert!((10..150).contains(&into_base), "{into_base} merges");
        assert!(all.iter().all(|&v| seen.contains(v)));
        assert!(!seen.contains(200_001u64.wrapping_mul(spread)));
    }

    /// The hashes of `n` ids from `seed`, spread over the 64 bits.
    fn hashes(seed: u64, n: u64) -> Vec<u64> {
        (0..n)
            .map(|k| (seed + k).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ seed)
            .collect()
    }

    /// An id repeated in a later chunk is found wherever the first one went: in the base,
    /// and in a run not yet merged into it; the repeat is not added again.
    #[test]
    fn a_repeat_is_found_in_the_base_and_in_the_runs() {
        let mut seen = SeenIds::default();
        let first = hashes(1, 5000);
        assert!(seen.check_and_add_hashes(first.clone()).is_empty());
        assert_eq!(seen.base.len(), 0, "one chunk stays in the runs");
        assert!(seen.check_and_add_hashes(hashes(50_000_000, 1)).is_empty());
        assert_eq!(
            seen.base.len(),
            5001,
            "the next one takes both into the base"
        );
        // a chunk too small to go into the base
        let small = hashes(7_000_000, 20);
        assert!(seen.check_and_add_hashes(small.clone()).is_empty());
        assert_eq!((seen.base.len(), seen.recent), (5001, 20));
        let again = vec![first[17], small[3], 42, first[4999], small[19]];
        let expect: foldhash::HashSet<u64> = [first[17], small[3], first[4999], small[19]]
            .into_iter()
            .collect();
        assert_eq!(seen.check_and_add_hashes(again.clone()), expect);
        assert_eq!(seen.len(), 5022, "only the new id added");
        assert_eq!(
            seen.check_and_add_hashes(again),
            expect.into_iter().chain([42]).collect()
        );
    }

    /// After the filter is made larger (and filled again from the base and the runs), the
    /// ids held before are still found, whether in the base or in the runs.
    #[test]
    fn ids_are_found_after_the_filter_is_made_larger() {
        let mut seen = SeenIds::default();
        let base = hashes(3, 3000);
        seen.check_and_add_hashes(base.clone());
        seen.check_and_add_hashes(hashes(50_000_000, 1));
        assert_eq!(seen.base.len(), 3001);
        let in_runs = hashes(9_000_000, 100);
        seen.check_and_add_hashes(in_runs.clone());
        assert_eq!(seen.recent, 100);
        let bits = seen.filter.len();
        // enough new ids to make the filter larger
        seen.check_and_add_hashes(hashes(20_000_000, 20_000));
        assert!(seen.filter.len() > bits);
        let old: Vec<u64> = [base[0], base[2999], in_runs[0], in_runs[99]].into();
        assert_eq!(
            seen.check_and_add_hashes(old.clone()),
            old.into_iter().collect()
        );
    }

    /// Ids that share the filter's bit (their top bits), or their stored low 48 bits (the
    /// base's buckets tell them apart), or a base bucket, are not taken for one another.
    #[test]
    fn colliding_ids_stay_apart() {
        let mut seen = SeenIds::default();
        let a = 0xABCD_0123_4567_89A0u64;
        seen.check_and_add_hashes(vec![a, 5, u64::MAX]);
        // into the base
        seen.check_and_add_hashes(vec![1 << 40]);
        assert_eq!(seen.base.len(), 4);
        // same top bits (filter slot and bucket), other low bits
        let near = [a + 1, a - 1, 4, 6, u64::MAX - 1];
        // same low 48 bits, other top bits
        let far = [a ^ 1 << 63, a ^ 1 << 48, 5 | 1 << 48, u64::MAX >> 1];
        for x in near.into_iter().chain(far) {
            assert!(seen.may_hold(x) || far.contains(&x), "{x:x}");
            assert!(!seen.contains(x), "{x:x}");
        }
        let mut all = vec![a, 5, u64::MAX, 1 << 40];
        all.extend(near);
        all.extend(far);
        assert_eq!(
            seen.check_and_add_hashes(all.clone()),
            [a, 5, u64::MAX, 1 << 40].into_iter().collect()
        );
        assert!(all.iter().all(|&x| seen.contains(x)));
    }
}
