//! gml:id uniqueness. A document in memory logs every gml:id (hash, offset, warnings before it,
//! enclosing id) and finds the repeated ones once after the last event, by sorting the
//! hashes: each "duplicate gml:id" warning is then inserted where a check per id would have
//! given it (same message, location, gml:id and place among the warnings). While streaming
//! (no document to read the ids back from) each id goes into a hash set as it is met.
//!
//! A gml:id that is not a valid `xs:ID` (it must start with a letter or `_`) is listed as a
//! warning up to [`INVALID_IDS_LISTED`] times per document; the last one listed tells how
//! many more follow ([`Parser::invalid_id`], [`Parser::invalid_id_summary`]). Some exporters
//! give every element such an id (an Ingolstadt tile: 9,315): one line per element is noise
//! in a log, and building them was a sixth of reading such a tile (GDAL caps repeated
//! errors the same way).

use super::position::newlines;
use super::state::{IdRec, LineMark, Parser, NO_REC};
use crate::model::Warning;
use foldhash::HashSet;
use quick_xml::events::Event;
use rayon::slice::ParallelSliceMut;

/// Invalid `xs:ID`s listed one by one per document (see the module docs).
pub(super) const INVALID_IDS_LISTED: usize = 100;

/// What the warning on an invalid `xs:ID` says after the id.
const INVALID_ID: &str = " is not a valid xs:ID (must start with a letter or '_')";

/// Whether `w` is the warning of [`Parser::invalid_id`] listing an invalid `xs:ID`.
pub(super) fn is_listed_invalid_id(w: &crate::model::Warning) -> bool {
    w.message.starts_with("gml:id \"") && w.message.ends_with(INVALID_ID)
}

impl Parser<'_> {
    /// Warn that gml:id `id` is not a valid `xs:ID`, unless [`INVALID_IDS_LISTED`] were
    /// listed already (then it is only counted).
    pub(super) fn invalid_id(&mut self, id: &str) {
        self.invalid_ids += 1;
        if self.invalid_listed.len() >= INVALID_IDS_LISTED {
            return;
        }
        self.invalid_listed.push(self.warnings.len());
        self.warn(format!("gml:id \"{id}\"{INVALID_ID}"));
    }

    /// After the last event (of the whole document, parts merged): the last invalid id
    /// listed tells how many more there are.
    pub(super) fn invalid_id_summary(&mut self) {
        if self.streamed {
            return;
        }
        let listed = self.invalid_listed.len() as u64;
        let more = self.invalid_ids.saturating_sub(listed);
        if more == 0 {
            return;
        }
        if let Some(w) = self
            .invalid_listed
            .last()
            .and_then(|&i| self.warnings.get_mut(i))
        {
            w.message.push_str(&format!(
                "; {more} more gml:ids after it are not valid xs:IDs either (not listed one by one)"
            ));
        }
    }

    /// Size the gml:id table or log for a document of about `bytes` bytes (real files hold
    /// about one gml:id per 300 bytes; the table grows beyond the estimate when needed).
    pub(super) fn expect_bytes(&mut self, bytes: u64) {
        let ids = (bytes / 400).min(1 << 24) as usize;
        if self.doc.is_empty() {
            self.seen_ids.reserve(ids);
        } else {
            self.id_log.reserve(ids);
        }
    }

    /// Check the gml:id (hashed: `hash`) of the element starting at `pos`: warn at once if it
    /// was met before while streaming, else log it; the log entry ([`NO_REC`]: none).
    pub(super) fn check_id(&mut self, id: &str, hash: u64, pos: u64) -> u32 {
        if self.doc.is_empty() {
            if !self.seen_ids.insert(hash) {
                self.warn(format!("duplicate gml:id \"{id}\""));
            }
            return NO_REC;
        }
        self.log_id(hash, pos)
    }

    /// Log a gml:id (see [`Parser::id_log`]); its entry.
    fn log_id(&mut self, hash: u64, pos: u64) -> u32 {
        let parent = self
            .stack
            .iter()
            .rev()
            .find(|f| f.id.is_some())
            .map_or(NO_REC, |f| f.rec);
        let warnings = u32::try_from(self.warnings.len()).unwrap_or(u32::MAX);
        let at = u32::try_from(self.id_log.len()).unwrap_or(NO_REC);
        self.id_log.push(IdRec {
            hash,
            pos,
            warnings,
            parent,
        });
        at
    }

    /// Insert the "duplicate gml:id" warnings of the logged ids (every occurrence of an id
    /// after its first), after the last event.
    pub(super) fn duplicate_warnings(&mut self) {
        let log = std::mem::take(&mut self.id_log);
        let before = std::mem::take(&mut self.dup_before);
        if log.len() < 2 && before.is_empty() {
            return;
        }
        let mut repeated: HashSet<u64> = match self.dup_within.take() {
            Some(r) => r,
            None => {
                let mut hashes: Vec<u64> = log.iter().map(|r| r.hash).collect();
                hashes.par_sort_unstable();
                repeats(&hashes)
            }
        };
        repeated.extend(before.iter().copied());
        if repeated.is_empty() {
            return;
        }
        // an id met in an earlier chunk of a streamed read: every occurrence repeats it
        let mut met = before;
        met.reserve(repeated.len());
        let marks = std::mem::take(self.marks.get_mut());
        let mut lines = LineMark {
            line: 1,
            line_start: 0,
            counted_to: 0,
        };
        let mut dups: Vec<(u32, Warning)> = Vec::new();
        for r in &log {
            if !repeated.contains(&r.hash) || met.insert(r.hash) {
                continue;
            }
            // lines up to the element, counted from the last one or the nearest mark before it
            let near = marks.partition_point(|m| m.counted_to <= r.pos);
            if let Some(m) = near.checked_sub(1).and_then(|i| marks.get(i)) {
                if m.counted_to > lines.counted_to {
                    lines = *m;
                }
            }
            let from = usize::try_from(lines.counted_to).unwrap_or(usize::MAX);
            let to = usize::try_from(r.pos).unwrap_or(usize::MAX);
            if let Some((n, last)) = self.doc.get(from..to).and_then(newlines) {
                lines.line += n;
                lines.line_start = lines.counted_to + last as u64 + 1;
            }
            lines.counted_to = r.pos.max(lines.counted_to);
            let gml_id = match r.parent {
                NO_REC if self.stream_tail => self.root_id.clone(),
                p => log.get(p as usize).and_then(|p| self.id_text(p)),
            };
            let id = self.id_text(r).unwrap_or_default();
            dups.push((
                r.warnings,
                Warning {
                    file: self.shared_path.clone(),
                    line: lines.line,
                    column: r.pos.saturating_sub(lines.line_start) + 1,
                    gml_id,
                    message: format!("duplicate gml:id \"{id}\""),
                },
            ));
        }
        let old = std::mem::take(&mut self.warnings);
        self.warnings = Vec::with_capacity(old.len() + dups.len());
        let mut dups = dups.into_iter().peekable();
        for (i, w) in old.into_iter().enumerate() {
            while let Some((_, d)) = dups.next_if(|(at, _)| *at as usize <= i) {
                self.warnings.push(d);
            }
            self.warnings.push(w);
        }
        self.warnings.extend(dups.map(|(_, d)| d));
    }

    /// The text of a logged gml:id: the attribute of the element's start tag whose value has
    /// the logged hash.
    pub(super) fn id_text(&self, r: &IdRec) -> Option<String> {
        self.id_text_at(r.pos, r.hash)
    }

    /// The gml:id with hash `hash` of the element whose start tag is at file offset `pos` in
    /// the document in memory.
    pub(super) fn id_text_at(&self, pos: u64, hash: u64) -> Option<String> {
        let tag = self.doc.get(usize::try_from(pos).ok()?..)?;
        let mut reader = quick_xml::Reader::from_reader(tag);
        let e = match reader.read_event().ok()? {
            Event::Start(e) | Event::Empty(e) => e,
            _ => return None,
        };
        e.attributes().with_checks(false).find_map(|a| {
            let a = a.ok()?;
            if a.key.local_name().as_ref() != b"id" {
                return None;
            }
            let v = a.unescape_value().ok()?;
            let h = std::hash::BuildHasher::hash_one(&self.id_hasher, v.as_ref() as &str);
            (h == hash).then(|| v.into_owned())
        })
    }
}

/// The hashes that occur more than once in the sorted `hashes`.
pub(super) fn repeats(hashes: &[u64]) -> HashSet<u64> {
    (hashes.windows(2).filter(|w| w[0] == w[1]))
        .map(|w| w[0])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::events::{read_from, read_slice};
    use super::super::ReadOptions;
    use crate::model::CityModel;
    use std::path::Path;

    /// Ids repeated at the root, nested in a building, within one polygon's parts, with an
    /// entity and invalid ids (warnings of their own) around them; `n` members.
    fn doc(n: usize) -> String {
        let mut s = String::from(
            "\u{feff}<?xml version=\"1.0\"?>\n<CityModel gml:id=\"root\" xmlns=\"http://www.opengis.net/citygml/2.0\"\n  xmlns:gml=\"http://www.opengis.net/gml\" xmlns:bldg=\"http://www.opengis.net/citygml/building/2.0\">\n",
        );
        for i in 0..n {
            let b = if i % 3 == 2 {
                "root".into()
            } else {
                format!("b{}", i % 4)
            };
            s.push_str(&format!(
                "<cityObjectMember><bldg:Building gml:id=\"{b}\"><bldg:lod2MultiSurface><gml:MultiSurface gml:id=\"9bad\">\n\
                 <gml:surfaceMember><gml:Polygon gml:id=\"p{}&amp;\"><gml:exterior><gml:LinearRing gml:id=\"{b}\">\n\
                 <gml:posList>0 0 5 1 0 5 1 1 5 0 0 5</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon>\n\
                 </gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface></bldg:Building></cityObjectMember>\n",
                i % 2
            ));
        }
        s.push_str("</CityModel>\n");
        s
    }

    fn in_memory(d: &str) -> CityModel {
        read_slice(
            d.as_bytes(),
            Path::new("d.gml"),
            false,
            &ReadOptions::default(),
            &|_| {},
        )
        .unwrap()
    }

    #[test]
    fn logged_ids_warn_as_the_streamed_check_per_id() {
        // 400 members: ids far apart, lines counted from marks (MARK_STEP)
        for n in [0, 1, 2, 5, 9, 400] {
            let d = doc(n);
            let streamed = read_from(
                d.as_bytes(),
                Path::new("d.gml"),
                false,
                &ReadOptions::default(),
            )
            .unwrap();
            let logged = in_memory(&d);
            assert_eq!(logged.warnings, streamed.warnings, "{n} members");
            // in chunks of about a third: the chunks' warnings collected
            let third = (d.len() / 3).max(1) as u64;
            let chunked = super::super::collect::read_in_chunks(d.as_bytes(), "d.gml", third);
            if n >= 5 {
                let chunked = chunked.expect("chunked read");
                let (a, b) = (&chunked.warnings, &streamed.warnings);
                let first = a.iter().zip(b).position(|(x, y)| x != y);
                assert!(
                    first.is_none() && a.len() == b.len(),
                    "{n} members, chunked: {} against {} warnings, first differing: {:?}",
                    a.len(),
                    b.len(),
                    first.map(|i| (&a[i], &b[i]))
                );
            }
            // one invalid id per member ("9bad"): the first hundred listed, then a count
            let invalid: Vec<&str> = logged
                .warnings
                .iter()
                .filter(|w| w.message.contains("xs:ID"))
                .map(|w| w.message.as_str())
                .collect();
            assert_eq!(
                invalid.len(),
                n.min(super::INVALID_IDS_LISTED),
                "{n} members"
            );
            let last = invalid.last().copied().unwrap_or_default();
            assert_eq!(
                last.contains("; 300 more gml:ids after it are not valid xs:IDs"),
                n == 400,
                "{last}"
            );
        }
        let m = in_memory(&doc(5));
        let dups: Vec<String> = m
            .warnings
            .iter()
            .filter(|w| w.message.starts_with("duplicate"))
            .map(|w| {
                format!(
                    "{}:{} [{}] {}",
                    w.line,
                    w.column,
                    w.gml_id.as_deref().unwrap_or(""),
                    w.message
                )
            })
            .collect();
        // member 0: b0 again (its ring, in polygon p0&: column 64 of the member's second line);
        // member 1: 9bad, b1; member 2: root (as a building nested in the root), 9bad, p0&,
        // root (its ring); member 3: 9bad, p1&, b3; member 4: b0, 9bad, p0&, b0
        let first = "5:64 [p0&] duplicate gml:id \"b0\"".to_string();
        assert_eq!(dups.first(), Some(&first), "{dups:#?}");
        let nested = "12:19 [root] duplicate gml:id \"root\"".to_string();
        assert!(dups.contains(&nested), "{dups:#?}");
        assert_eq!(dups.len(), 1 + 2 + 4 + 3 + 4, "{dups:#?}");
        // the id warnings (duplicates and invalid ids) in document order
        let ids: Vec<(u64, u64)> = m
            .warnings
            .iter()
            .filter(|w| w.message.starts_with("duplicate") || w.message.contains("xs:ID"))
            .map(|w| (w.line, w.column))
            .collect();
        assert!(
            ids.len() > dups.len() && ids.windows(2).all(|w| w[0] <= w[1]),
            "{ids:?}"
        );
    }
}
