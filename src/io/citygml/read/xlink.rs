//! `xlink:href` geometry references: recorded as parts of the arena while reading, resolved
//! after the last event (forward references work) within depth and work limits.

use super::state::{HrefRef, Parser, Part};
use crate::io::citygml::error::ReadError;
use crate::model::Polygon;
use foldhash::{HashMap, HashMapExt, HashSet};
use glam::DVec3;

/// The gml:ids of geometry elements and the range of geometry parts each stands for.
///
/// Reading only appends (one text arena, one list: no allocation per id, no hash table);
/// after the last event, [`Registry::index`] indexes just the ids that references name.
/// The first registration of an id wins.
#[derive(Debug, Default)]
pub(super) struct Registry {
    text: String,
    entries: Vec<RegEntry>,
}

/// 24 bytes: an id's text starts where the previous entry's ends (the text only grows).
#[derive(Debug)]
struct RegEntry {
    hash: u64,
    to: usize,
    range: (u32, u32),
}

impl Registry {
    /// Record `id` (with its `hash`) for the parts `range`.
    pub(super) fn add(&mut self, hash: u64, id: &str, range: (u32, u32)) {
        self.text.push_str(id);
        self.entries.push(RegEntry {
            hash,
            to: self.text.len(),
            range,
        });
    }

    /// Append the registrations of a later part of the document whose parts start at
    /// `parts_offset` in the merged arena (a split read).
    pub(super) fn append(&mut self, other: Registry, parts_offset: u32) {
        let base = self.text.len();
        self.text.push_str(&other.text);
        self.entries
            .extend(other.entries.into_iter().map(|e| RegEntry {
                hash: e.hash,
                to: e.to + base,
                range: (e.range.0 + parts_offset, e.range.1 + parts_offset),
            }));
    }

    /// The ids whose hash is in `wanted`, each with its first registered range (the text is
    /// compared, so two ids with the same hash stay apart).
    pub(super) fn index(&self, wanted: &HashSet<u64>) -> HashMap<&str, (u32, u32)> {
        let mut map = HashMap::with_capacity(wanted.len());
        if wanted.is_empty() {
            return map;
        }
        let mut from = 0;
        for e in &self.entries {
            if wanted.contains(&e.hash) {
                if let Some(t) = self.text.get(from..e.to) {
                    map.entry(t).or_insert(e.range);
                }
            }
            from = e.to;
        }
        map
    }
}

/// What resolving references needs besides the parser: the ids that references name, and the
/// work left before the expansion limit.
pub(super) struct Walk<'a> {
    pub(super) index: HashMap<&'a str, (u32, u32)>,
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
        walk: &mut Walk<'_>,
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
        r.add(7, "a", (0, 1));
        r.add(7, "b", (1, 2)); // same hash, other id: kept apart
        r.add(7, "a", (5, 6)); // a duplicate id: the first range stays
        r.add(9, "c", (2, 3));
        let wanted: HashSet<u64> = [7u64].into_iter().collect();
        let idx = r.index(&wanted);
        assert_eq!(idx.get("a"), Some(&(0, 1)));
        assert_eq!(idx.get("b"), Some(&(1, 2)));
        assert_eq!(idx.get("c"), None, "not wanted, not indexed");
        assert!(r.index(&HashSet::default()).is_empty());
    }
}
