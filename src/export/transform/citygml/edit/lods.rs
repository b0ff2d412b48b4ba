//! `filter-lods`: keep or remove LoD representations (citygml-tools' `filter-lods`),
//! streamed (see [`super`]).
//!
//! A LoD representation is a property named `lod<N>...` of a feature (`lod2MultiSurface`,
//! `lod1Solid`, `lod0FootPrint`, `lod3ImplicitRepresentation`, ..., any CityGML version).
//! [`LodMode::Keep`] keeps the listed LoDs, [`LodMode::Remove`] removes them;
//! [`LodMode::Minimum`] / [`LodMode::Maximum`] keep, per top-level city object, only the
//! lowest / highest of the listed LoDs it has (nothing when it has none of them). A feature
//! that held LoD geometry and is left with none in its subtree (a `WallSurface` whose only
//! geometry was LoD3) is removed with its property (`boundedBy`), and a top-level object so
//! emptied is removed with its `cityObjectMember`, unless [`Lods::keep_empty`]. References
//! into what went are pruned ([`super`]).
//!
//! # Example
//! ```
//! use skylod::export::transform::{LodMode, Lods};
//! let keep2 = Lods { lods: vec![2], mode: LodMode::Keep, keep_empty: false };
//! assert_eq!(keep2.kept(&[1, 2, 3]), vec![2]);
//! let max = Lods { lods: vec![1, 2, 3], mode: LodMode::Maximum, keep_empty: false };
//! assert_eq!(max.kept(&[1, 2]), vec![2]);
//! ```

use super::tree::{Kind, Tree};
use super::{run, Context, Decision, EditSummary, Rule};
use crate::io::citygml::write::WriteOptions;
use crate::io::citygml::WriteError;
use std::path::Path;

/// How [`Lods::lods`] is applied.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum LodMode {
    /// Keep the listed LoDs.
    #[default]
    Keep,
    /// Remove the listed LoDs.
    Remove,
    /// Keep the lowest listed LoD of each top-level city object.
    Minimum,
    /// Keep the highest listed LoD of each top-level city object.
    Maximum,
}

/// What `filter_lods` keeps.
#[derive(Debug, Clone, Default)]
pub struct Lods {
    /// LoDs 0 to 4.
    pub lods: Vec<u8>,
    /// How they are applied.
    pub mode: LodMode,
    /// Keep features left without geometry.
    pub keep_empty: bool,
}

impl Lods {
    /// Of the LoDs a top-level city object has (`has`, in any order, repeats allowed), those
    /// that stay (sorted, once each).
    pub fn kept(&self, has: &[u8]) -> Vec<u8> {
        let listed = |n: &u8| self.lods.contains(n);
        let mut out: Vec<u8> = match self.mode {
            LodMode::Keep => has.iter().copied().filter(listed).collect(),
            LodMode::Remove => has.iter().copied().filter(|n| !listed(n)).collect(),
            LodMode::Minimum => has
                .iter()
                .copied()
                .filter(listed)
                .min()
                .into_iter()
                .collect(),
            LodMode::Maximum => has
                .iter()
                .copied()
                .filter(listed)
                .max()
                .into_iter()
                .collect(),
        };
        out.sort_unstable();
        out.dedup();
        out
    }
}

struct LodRule<'a>(&'a Lods);

impl Rule for LodRule<'_> {
    fn member(
        &mut self,
        tree: &Tree,
        _ctx: &Context<'_>,
        counts: &mut EditSummary,
    ) -> Result<Decision, String> {
        let lod = |i: usize| match tree.nodes[i].kind {
            Kind::Lod(n) => Some(n),
            _ => None,
        };
        let has: Vec<u8> = (0..tree.nodes.len()).filter_map(lod).collect();
        let kept = self.0.kept(&has);
        let cut: Vec<usize> = (0..tree.nodes.len())
            .filter(|&i| lod(i).is_some_and(|n| !kept.contains(&n)))
            .collect();
        counts.lod_properties_removed += cut.len();
        if cut.is_empty() || self.0.keep_empty {
            return Ok(Decision::Keep(cut));
        }
        // features that lost geometry and have none left in their subtree
        let is_cut = |i: usize| cut.binary_search(&i).is_ok();
        let mut touched = vec![false; tree.nodes.len()];
        for &i in &cut {
            for a in tree.ancestors(i) {
                touched[a] = true;
            }
        }
        let mut out = cut.clone();
        let mut gone_until = 0usize;
        for (f, n) in tree.nodes.iter().enumerate() {
            if !touched[f] || n.kind != Kind::Feature || n.span.start < gone_until {
                continue;
            }
            let left = (f + 1..tree.nodes.len())
                .take_while(|&j| tree.nodes[j].span.start < n.span.end)
                .any(|j| lod(j).is_some() && !is_cut(j));
            if left {
                continue;
            }
            if f <= 1 {
                // the top-level object itself
                counts.lod_properties_removed -= cut.len();
                return Ok(Decision::Drop);
            }
            counts.features_removed += 1;
            // with its property (`boundedBy`, `opening`, ...) when that holds nothing else
            let wrap = n.parent.filter(|&p| {
                tree.nodes[p].kind == Kind::Other
                    && tree.nodes.iter().filter(|c| c.parent == Some(p)).count() == 1
            });
            let at = wrap.unwrap_or(f);
            gone_until = tree.nodes[at].span.end;
            out.push(at);
        }
        Ok(Decision::Keep(out))
    }
}

/// Write the document at `input` with the LoD representations `rule` keeps to `out`
/// (atomically; `-` for standard output; gzip for a name ending in `.gz`), streamed (see
/// [`super`]).
///
/// # Errors
/// A refused target, a source that cannot be read or is not CityGML, I/O errors.
pub fn filter_lods(
    input: &Path,
    out: &Path,
    rule: &Lods,
    opts: &WriteOptions,
) -> Result<EditSummary, WriteError> {
    run(input, Some(out), opts, &|| Box::new(LodRule(rule)))
}
