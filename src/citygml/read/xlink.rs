//! `xlink:href` geometry references: recorded as parts of the arena while reading, resolved
//! after the last event (forward references work) within depth and work limits.

use super::state::{HrefRef, Parser, Part};
use crate::citygml::error::ReadError;
use crate::model::Polygon;
use glam::DVec3;

impl Parser {
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
        budget: &mut usize,
    ) -> Result<(), ReadError> {
        let mut i = range.0 as usize;
        let end = (range.1 as usize).min(self.parts.len());
        while i < end {
            if *budget == 0 {
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
            *budget -= 1;
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
                    let Some(&r) = self.registry.get(target) else {
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
                    self.resolve(
                        r,
                        reversed ^ href.reversed,
                        depth + 1,
                        implicit,
                        out,
                        budget,
                    )?;
                    i += 1;
                }
                Part::Implicit { idx, len } => {
                    let inner = (i as u32 + 1, (i as u32 + 1 + len).min(end as u32));
                    self.resolve(inner, reversed, depth + 1, Some(idx), out, budget)?;
                    i = inner.1 as usize;
                }
            }
        }
        Ok(())
    }

    /// Turn references into polygons: a polygon used once is moved out of the arena, one used
    /// several times is cloned (the last use moves it); implicit geometry is transformed.
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
                std::mem::take(slot)
            } else {
                uses[r.poly as usize] -= 1;
                slot.clone()
            };
            if r.reversed {
                p.exterior.reverse();
                p.interiors.iter_mut().for_each(|x| x.reverse());
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
                p.exterior.iter_mut().for_each(tf);
                p.interiors.iter_mut().flatten().for_each(tf);
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
