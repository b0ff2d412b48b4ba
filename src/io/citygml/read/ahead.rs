//! Chunks of a stream parsed ahead on other threads ([`Ahead`]), while the stream's caller
//! handles the chunk before them: the stream's parse was one thread's, the largest part of
//! `stats`, `convert` and `lod`'s hollow read of a large file.
//!
//! A chunk's parse depends on the document-wide state the serial read reaches at its start
//! ([`DocState`]), which is known only when the chunks before it are parsed. A chunk parsed
//! ahead is seeded with the latest state known when it starts (the one after the last chunk
//! parsed) and its line counted up to its start exactly; when its turn comes, the parse is
//! taken only if that seed is the state the serial read stands in there (everything a parse
//! reads of it: [`DocState::seeds_as`]), else the chunk is parsed again from the right state.
//! That state rarely changes after the first chunk (it holds the version, CRS, `gml:` prefix,
//! relief LoD, the foreign namespaces and unknown prefixes already warned about and how many
//! invalid gml:ids were listed), so the chunks read are the serial read's, in its order, and
//! the stream's results are the same to the bit, whatever the number of threads.
//!
//! Memory: each chunk parsed ahead holds its parser (about its bytes again) until its turn.

use super::state::{LineMark, Parser};
use super::stream::{parse_chunk, DocState};
use super::ReadOptions;
use std::collections::VecDeque;
use std::path::Path;
use std::thread::{Scope, ScopedJoinHandle};

/// The document a stream parses, as [`parse_chunk`] takes it.
#[derive(Clone, Copy)]
pub(super) struct ChunkSource<'d> {
    /// The whole document (byte-order mark included).
    pub(super) doc: &'d [u8],
    /// Bytes of the byte-order mark.
    pub(super) bom: usize,
    /// The prolog and the root's start tag (body offsets `..root_end`).
    pub(super) prolog: &'d [u8],
    pub(super) path: &'d Path,
    pub(super) opts: &'d ReadOptions,
}

/// A chunk being parsed ahead.
struct Pending<'s, 'd> {
    /// Body offsets of the chunk.
    range: (usize, usize),
    /// The state it is parsed from, but for the line.
    seed: DocState,
    /// The parse, and the line mark it started from.
    parse: ScopedJoinHandle<'s, (Option<Parser<'d>>, LineMark)>,
}

/// Up to `depth` chunks after the current one, parsed on threads of `scope`.
pub(super) struct Ahead<'s, 'd> {
    depth: usize,
    src: ChunkSource<'d>,
    pending: VecDeque<Pending<'s, 'd>>,
}

impl<'s, 'd: 's> Ahead<'s, 'd> {
    /// Chunks of `src` parsed ahead, `depth` at most at once (0: none).
    pub(super) fn new(depth: usize, src: ChunkSource<'d>) -> Self {
        Ahead {
            depth,
            src,
            pending: VecDeque::new(),
        }
    }

    /// Start parsing the chunks that follow `after` (body offsets of a chunk, each next one
    /// from `next(start)`), up to the depth, from `state` (the serial read's state after
    /// `after`, its line counted to `after`'s end).
    pub(super) fn fill(
        &mut self,
        scope: &'s Scope<'s, '_>,
        after: (usize, usize),
        state: &DocState,
        next: impl Fn(usize) -> usize,
    ) {
        let body_len = self.src.doc.len().saturating_sub(self.src.bom);
        let mut start = self.pending.back().map_or(after.1, |p| p.range.1);
        while self.pending.len() < self.depth && start < body_len {
            let range = (start, next(start));
            let src = self.src;
            let seed = state.clone();
            let mut job = state.clone();
            let thread = std::thread::Builder::new().name("skylod-chunk".into());
            // no thread to be had: the chunk is parsed in its turn
            let Ok(parse) = thread.spawn_scoped(scope, move || {
                let at = (range.0 + src.bom) as u64;
                job.line = job.line.advanced(src.doc, at).unwrap_or(job.line);
                let (doc, bom, prolog) = (src.doc, src.bom, src.prolog);
                let (from, to) = range;
                let p = parse_chunk(doc, bom, prolog, from, to, false, &job, src.path, src.opts);
                (p, job.line)
            }) else {
                break;
            };
            self.pending.push_back(Pending { range, seed, parse });
            start = range.1;
        }
    }

    /// The chunk at body offsets `range` parsed from `state`, if it was parsed ahead from
    /// that state (`None`: parse it now). Parses ahead of another range (the stream went
    /// another way) are dropped.
    pub(super) fn take(&mut self, range: (usize, usize), state: &DocState) -> Option<Parser<'d>> {
        let p = self.pending.pop_front()?;
        if p.range != range {
            self.pending.clear();
            return None;
        }
        let (parsed, line) = p.parse.join().ok()?;
        let seed = DocState { line, ..p.seed };
        seed.seeds_as(state).then_some(parsed?)
    }
}

impl DocState {
    /// Whether a chunk parsed from `self` is the chunk parsed from `other`: the two agree on
    /// everything but the counts of invalid gml:ids, which only the stream's summary reads
    /// (a field added to the state counts unless it is masked here).
    pub(super) fn seeds_as(&self, other: &DocState) -> bool {
        let read = |s: &DocState| DocState {
            invalid_ids: 0,
            invalid_last: None,
            ..s.clone()
        };
        read(self) == read(other)
    }
}
