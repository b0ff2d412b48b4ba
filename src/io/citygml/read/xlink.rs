//! `xlink:href` geometry references: recorded as parts of the arena while reading, resolved
//! after the last event (forward references work) within depth and work limits.

use super::state::{HrefRef, Parser, Part, NO_REC};
use crate::io::citygml::error::ReadError;
use crate::model::Polygon;
use foldhash::{HashMap, HashMapExt, HashSet};
use glam::DVec3;

/// The gml:ids of geometry elements and the range of geometry parts each stands for.
///
/// Reading only appends (one list, and while streaming one text arena: no allocation per id,
/// no hash table); after the last event, [`Registry::index`] indexes just the ids that
/// references name. A document in memory keeps no id text and no second copy of what the
/// parser's gml:id log holds: each entry names its element's entry in that log
/// ([`Parser::id_log`]: hash and file offset), 12 bytes, and the id is read back from the
/// document for the ids that references name ([`Parser::id_text`]), as the duplicate check
/// does. The first registration of an id wins.
#[derive(Debug, Default)]
pub(super) struct Registry {
    text: String,
    entries: Vec<RegEntry>,
    /// Registrations by their entry in the id log, before every one of [`Registry::entries`]
    /// (a document in memory logs every id: see [`IdAt::Log`]).
    logged: Vec<LogEntry>,
}

/// 24 bytes. `at`: the element's file offset (a document in memory whose id could not be
/// logged), or where the id's text ends in [`Registry::text`] (streaming: it starts where the
/// previous entry's ends).
#[derive(Debug)]
struct RegEntry {
    hash: u64,
    at: u64,
    range: (u32, u32),
}

/// 12 bytes: the element's entry in the id log, its parts.
#[derive(Debug)]
struct LogEntry {
    rec: u32,
    range: (u32, u32),
}

/// Where a registered id is: its element's entry in the id log of the document in memory
/// and its file offset (kept instead when there is no entry, [`NO_REC`], or registrations by
/// offset came first), or its text (streaming).
pub(super) enum IdAt<'a> {
    Log { rec: u32, pos: u64 },
    Text(&'a str),
}

impl Registry {
    /// Record the id at `id` (with its `hash`) for the parts `range`.
    pub(super) fn add(&mut self, hash: u64, id: IdAt<'_>, range: (u32, u32)) {
        let at = match id {
            IdAt::Log { rec, .. } if rec != NO_REC && self.entries.is_empty() => {
                return self.logged.push(LogEntry { rec, range });
            }
            IdAt::Log { pos, .. } => pos,
            IdAt::Text(t) => {
                self.text.push_str(t);
                self.text.len() as u64
            }
        };
        self.entries.push(RegEntry { hash, at, range });
    }

    /// The ids whose hash is in `wanted`, each with its first registered range (the text is
    /// compared, so two ids with the same hash stay apart); `read_back(offset, hash)` reads
    /// an id back from the document in memory (entries without text), `logged(rec)` is the
    /// hash and file offset of entry `rec` of the id log.
    pub(super) fn index(
        &self,
        wanted: &HashSet<u64>,
        read_back: impl Fn(u64, u64) -> Option<String>,
        logged: impl Fn(u32) -> Option<(u64, u64)>,
    ) -> HashMap<String, (u32, u32)> {
        let mut map = HashMap::with_capacity(wanted.len());
        if wanted.is_empty() {
            return map;
        }
        for e in &self.logged {
            let Some((hash, pos)) = logged(e.rec) else {
                continue;
            };
            if wanted.contains(&hash) {
                if let Some(t) = read_back(pos, hash) {
                    map.entry(t).or_insert(e.range);
                }
            }
        }
        let in_text = !self.text.is_empty();
        let mut from = 0;
        for e in &self.entries {
            if wanted.contains(&e.hash) {
                let t = match in_text {
                    true => usize::try_from(e.at)
                        .ok()
                        .and_then(|to| self.text.get(from..to))
                        .map(str::to_string),
                    false => read_back(e.at, e.hash),
                };
                if let Some(t) = t {
                    map.entry(t).or_insert(e.range);
                }
            }
            if in_text {
                from = usize::try_from(e.at).unwrap_or(usize::MAX);
            }
        }
        map
    }
}

/// What resolving references needs besides the parser: the ids that references name, and the
/// work left before the expansion limit.
pub(super) struct Walk {
    pub(super) index: HashMap<String, (u32, u32)>,
    pub(super) budget: usize,
}

impl Parser<'_> {
    /// The gml:ids that references name (hashes of the targets after `#`), for [`Registry::index`].
    pub(super) fn href_targets(&self) -> HashSet<u64> {
        self.hrefs
            .iter()
            .filter_map(|h| h.target.strip_prefix('#'))
            .map(|t| std::hash::BuildHasher::hash_one(&self.id_hasher, t))
            .collect()
    }

    /// Register the geometry element starting at `pos` whose gml:id (hashed: `hash`, entry
    /// `rec` of [`Parser::id_log`]) is at `id` in [`Parser::open_ids`], for the parts
    /// `range`: by its log entry when the document is in memory, else by its text.
    pub(super) fn register(
        &mut self,
        hash: u64,
        id: (usize, usize),
        (pos, rec): (u64, u32),
        range: (u32, u32),
    ) {
        let at = match self.doc.is_empty() {
            false => IdAt::Log { rec, pos },
            true => IdAt::Text(self.open_ids.get(id.0..id.1).unwrap_or("")),
        };
        self.registry.add(hash, at, range);
    }

    pub(super) fn push_href(&mut self, href: &str, _pos: u64) {
        let reversed = self.flips % 2 == 1;
        let loc = self.loc();
        let target = href.trim();
        let idx = self.hrefs.len() as u32;
        self.hrefs.push(HrefRef {
            target: target.into(),
            reversed,
            loc,
        });
        self.parts.push(Part::Href(idx));
    }

    /// Collect the polygons a range of parts stands for (xlinks followed, implicit geometry
    /// marked), as references into the polygon arena.
    pub(super) fn resolve(
        &self,
        range: (u32, u32),
        reversed: bool,
        depth: usize,
        implicit: Option<u32>,
        out: &mut Vec<PolyRef>,
        walk: &mut Walk,
    ) -> Result<(), ReadError> {
        let mut i = range.0 as usize;
        let end = (range.1 as usize).min(self.parts.len());
        while i < end {
            if walk.budget == 0 {
                let loc = match self.parts[i] {
                    Part::Href(h) => self.hrefs.get(h as usize).map(|x| x.loc.clone()),
                    _ => None,
                };
                return Err(ReadError::Limit {
                    loc: loc.unwrap_or_else(|| self.loc_at(0)),
                    message: format!(
                        "xlink:href references expand to more than {} polygons and references",
                        self.opts
                            .max_href_work
                            .saturating_add(self.parts.len().saturating_mul(4))
                    ),
                });
            }
            walk.budget -= 1;
            match self.parts[i] {
                Part::Poly(p) => {
                    out.push(PolyRef {
                        poly: p,
                        reversed,
                        implicit,
                    });
                    i += 1;
                }
                Part::Href(h) => {
                    let Some(href) = self.hrefs.get(h as usize) else {
                        i += 1;
                        continue;
                    };
                    let Some(target) = href.target.strip_prefix('#') else {
                        return Err(ReadError::DanglingHref {
                            loc: href.loc.clone(),
                            href: format!(
                                "{} (only same-document references are supported)",
                                href.target
                            ),
                        });
                    };
                    let Some(&r) = walk.index.get(target) else {
                        return Err(ReadError::DanglingHref {
                            loc: href.loc.clone(),
                            href: href.target.to_string(),
                        });
                    };
                    if depth >= self.opts.max_href_depth {
                        return Err(ReadError::HrefCycle {
                            loc: href.loc.clone(),
                            href: href.target.to_string(),
                        });
                    }
                    self.resolve(r, reversed ^ href.reversed, depth + 1, implicit, out, walk)?;
                    i += 1;
                }
                Part::Implicit { idx, len } => {
                    let inner = (i as u32 + 1, (i as u32 + 1 + len).min(end as u32));
                    self.resolve(inner, reversed, depth + 1, Some(idx), out, walk)?;
                    i = inner.1 as usize;
                }
            }
        }
        Ok(())
    }

    /// Turn references into polygons: a polygon used once is moved out of the arena, one used
    /// several times is cloned (the last use moves it); implicit geometry is transformed.
    /// `uses` counts the uses left: 0 once a polygon is no longer needed.
    pub(super) fn materialise(
        &self,
        refs: &[PolyRef],
        polys: &mut [Polygon],
        uses: &mut [u32],
    ) -> Vec<Polygon> {
        let mut out = Vec::with_capacity(refs.len());
        for r in refs {
            let Some(slot) = polys.get_mut(r.poly as usize) else {
                continue;
            };
            let mut p = if r.implicit.is_none() && uses[r.poly as usize] <= 1 {
                // The last use: moved out; nothing needs the slot any more.
                uses[r.poly as usize] = 0;
                std::mem::take(slot)
            } else {
                uses[r.poly as usize] -= 1;
                slot.clone()
            };
            if r.reversed {
                p.reverse_rings();
            }
            if let Some(idx) = r.implicit {
                let imp = self.implicits.get(idx as usize);
                let m = imp.and_then(|x| x.matrix);
                let rp = imp.and_then(|x| x.ref_point).unwrap_or(DVec3::ZERO);
                let tf = |q: &mut DVec3| {
                    let v = match m {
                        Some(m) => DVec3::new(
                            m[0] * q.x + m[1] * q.y + m[2] * q.z + m[3],
                            m[4] * q.x + m[5] * q.y + m[6] * q.z + m[7],
                            m[8] * q.x + m[9] * q.y + m[10] * q.z + m[11],
                        ),
                        None => *q,
                    };
                    *q = v + rp;
                };
                p.points_mut().iter_mut().for_each(tf);
            }
            out.push(p);
        }
        out
    }
}

#[derive(Debug, Clone, Copy)]
pub(super) struct PolyRef {
    pub(super) poly: u32,
    pub(super) reversed: bool,
    pub(super) implicit: Option<u32>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn registry_first_registration_wins_and_text_is_compared() {
        let mut r = Registry::default();
        r.add(7, IdAt::Text("a"), (0, 1));
        r.add(7, IdAt::Text("b"), (1, 2)); // same hash, other id: kept apart
        r.add(7, IdAt::Text("a"), (5, 6)); // a duplicate id: the first range stays
        r.add(9, IdAt::Text("c"), (2, 3));
        let wanted: HashSet<u64> = [7u64].into_iter().collect();
        let none = |_: u64, _: u64| -> Option<String> { None };
        let no_log = |_: u32| -> Option<(u64, u64)> { None };
        let idx = r.index(&wanted, none, no_log);
        assert_eq!(idx.get("a"), Some(&(0, 1)));
        assert_eq!(idx.get("b"), Some(&(1, 2)));
        assert_eq!(idx.get("c"), None, "not wanted, not indexed");
        assert!(r.index(&HashSet::default(), none, no_log).is_empty());
    }

    #[test]
    fn registry_of_a_document_reads_ids_back() {
        let doc = ["a", "b", "a", "c", "d"];
        let back = |at: u64, _: u64| doc.get(at as usize).map(|s| s.to_string());
        // the id log of the document: (hash, offset) per entry
        let log = [(7u64, 0u64), (7, 1), (7, 2), (9, 3)];
        let logged = |rec: u32| log.get(rec as usize).copied();
        let mut r = Registry::default();
        r.add(7, IdAt::Log { rec: 0, pos: 0 }, (0, 1));
        r.add(7, IdAt::Log { rec: 1, pos: 1 }, (1, 2));
        // a duplicate later on: the first wins
        r.add(7, IdAt::Log { rec: 2, pos: 2 }, (10, 11));
        r.add(9, IdAt::Log { rec: 3, pos: 3 }, (11, 12));
        assert!(
            r.text.is_empty() && r.entries.is_empty(),
            "no id text, no hashes"
        );
        assert_eq!(r.logged.len(), 4);
        let wanted: HashSet<u64> = [7u64, 9].into_iter().collect();
        let idx = r.index(&wanted, back, logged);
        assert_eq!(idx.get("a"), Some(&(0, 1)));
        assert_eq!(idx.get("b"), Some(&(1, 2)));
        assert_eq!(idx.get("c"), Some(&(11, 12)));
        // without a log entry an id is registered by its offset, and every later one too
        let mut r = Registry::default();
        r.add(
            7,
            IdAt::Log {
                rec: NO_REC,
                pos: 4,
            },
            (0, 1),
        );
        r.add(7, IdAt::Log { rec: 0, pos: 0 }, (1, 2));
        r.add(9, IdAt::Log { rec: 4, pos: 3 }, (2, 3));
        assert_eq!((r.logged.len(), r.entries.len()), (0, 3));
        let idx = r.index(&wanted, back, logged);
        assert_eq!(idx.get("d"), Some(&(0, 1)));
        assert_eq!(idx.get("a"), Some(&(1, 2)));
        assert_eq!(idx.get("c"), Some(&(2, 3)));
    }
}
