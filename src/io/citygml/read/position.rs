//! Positions: byte offsets, line and column numbers, locations of errors and warnings.

use super::state::{LineMark, Parser, MARK_STEP};
use crate::io::citygml::error::{Location, ReadError};
use crate::model::Warning;

impl Parser<'_> {
    /// Advance the line counter over `bytes`, which start at file offset `content_start`
    /// (streaming only: a document in memory counts its lines on demand).
    #[inline]
    pub(super) fn count_lines(&mut self, bytes: &[u8], content_start: u64) {
        if let Some((n, last)) = newlines(bytes) {
            let m = self.lines.get_mut();
            m.line += n;
            m.line_start = content_start + last as u64 + 1;
        }
    }

    /// Line number and offset of the line's start at the current event's start
    /// ([`Parser::event_pos`]). A document in memory counts the newlines since the last call
    /// here (one SIMD count over a long span instead of a count per event).
    pub(super) fn line_mark(&self) -> (u64, u64) {
        let mut m = self.lines.get();
        if self.event_pos > m.counted_to {
            if let Some(moved) = m.advanced(self.doc, self.event_pos) {
                m = moved;
                self.lines.set(m);
                let mut marks = self.marks.borrow_mut();
                if marks
                    .last()
                    .is_none_or(|l| m.counted_to >= l.counted_to + MARK_STEP)
                {
                    marks.push(m);
                }
            }
        }
        (m.line, m.line_start)
    }

    /// Line number of the current event's start.
    pub(super) fn line(&self) -> u64 {
        self.line_mark().0
    }

    pub(super) fn nearest_id(&self) -> Option<String> {
        self.stack
            .iter()
            .rev()
            .find_map(|f| f.id.and_then(|(a, b, _)| self.open_ids.get(a..b)))
            .map(str::to_string)
    }

    pub(super) fn loc_at(&self, pos: u64) -> Location {
        let (line, line_start) = self.line_mark();
        Location {
            file: self.path.clone(),
            line,
            column: pos.saturating_sub(line_start) + 1,
            gml_id: self.nearest_id(),
        }
    }

    pub(super) fn loc(&self) -> Location {
        self.loc_at(self.event_pos)
    }

    pub(super) fn xml_error(&self, at: u64, message: String) -> ReadError {
        ReadError::Xml {
            loc: self.loc_at(at.max(self.line_mark().1)),
            message,
        }
    }

    pub(super) fn token_limit(&self, pos: u64) -> ReadError {
        ReadError::Limit {
            loc: self.loc_at(pos),
            message: format!(
                "one XML token (tag, attribute value, text, comment or DOCTYPE) exceeds the limit of {} bytes",
                self.opts.max_event_bytes
            ),
        }
    }

    pub(super) fn warn(&mut self, message: impl Into<String>) {
        // Warnings share one path (real files can have one per gml:id).
        let (line, line_start) = self.line_mark();
        self.warnings.push(Warning {
            file: self.shared_path.clone(),
            line,
            column: self.event_pos.saturating_sub(line_start) + 1,
            gml_id: self.nearest_id(),
            message: message.into(),
        });
    }
}

impl LineMark {
    /// The mark moved on to offset `to` of `doc` (at or after `counted_to`): the newlines
    /// between counted. `None` where `doc` does not hold those bytes.
    pub(super) fn advanced(mut self, doc: &[u8], to: u64) -> Option<LineMark> {
        let from = usize::try_from(self.counted_to).ok()?;
        let span = doc.get(from..usize::try_from(to).ok()?)?;
        if let Some((n, last)) = newlines(span) {
            self.line += n;
            self.line_start = self.counted_to + last as u64 + 1;
        }
        self.counted_to = to;
        Some(self)
    }
}

/// Number of `\n` in `bytes` and the index of the last one; `None` when there is none.
pub(super) fn newlines(bytes: &[u8]) -> Option<(u64, usize)> {
    if bytes.len() >= 32 {
        // long tokens (coordinate lists, tags with attributes) rarely hold a newline: one SIMD
        // search for the last, then a count before it
        let last = memchr::memrchr(b'\n', bytes)?;
        let n = memchr::memchr_iter(b'\n', &bytes[..last]).count() as u64;
        return Some((n + 1, last));
    }
    // short tokens eight bytes at a time (SWAR), where a SIMD search does not pay
    const LO7: u64 = 0x7f7f_7f7f_7f7f_7f7f;
    const NL: u64 = 0x0a0a_0a0a_0a0a_0a0a;
    let mut count = 0u64;
    let mut last = None;
    let mut chunks = bytes.chunks_exact(8);
    let mut base = 0usize;
    for c in &mut chunks {
        let mut w = [0u8; 8];
        w.copy_from_slice(c);
        let x = u64::from_le_bytes(w) ^ NL;
        // exactly the zero bytes of x (no borrow between bytes) get their high bit set
        let z = !(((x & LO7).wrapping_add(LO7)) | x | LO7);
        if z != 0 {
            count += u64::from(z.count_ones());
            last = Some(base + (63 - z.leading_zeros() as usize) / 8);
        }
        base += 8;
    }
    for (i, &c) in chunks.remainder().iter().enumerate() {
        if c == b'\n' {
            count += 1;
            last = Some(base + i);
        }
    }
    last.map(|l| (count, l))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn newlines_match_a_plain_count() {
        // every length up to 80, newlines (and bytes that could fool a SWAR test: 0x0b, 0x8a,
        // 0x09) at every position
        for len in 0..80usize {
            for seed in 0..len.max(1) {
                let v: Vec<u8> = (0..len)
                    .map(|i| match (i * 7 + seed) % 5 {
                        0 => b'\n',
                        1 => 0x0b,
                        2 => 0x8a,
                        3 => 0x09,
                        _ => b'a',
                    })
                    .collect();
                let n = v.iter().filter(|&&c| c == b'\n').count() as u64;
                let last = v.iter().rposition(|&c| c == b'\n');
                assert_eq!(newlines(&v), last.map(|l| (n, l)), "{v:?}");
            }
        }
    }
}
