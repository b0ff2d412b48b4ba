//! Several inputs merged into one output (`-o FILE` with several inputs): one plan for every
//! format, the formats writing only the bytes.
//!
//! # The plan
//!
//! A first pass over each input gives its head: its version, its CRS, its ids in document
//! order and its box. From the heads, in input order, the plan decides once:
//!
//! * **refused**: inputs of different versions (CityGML: the root's namespace; CityJSON:
//!   `version`), and inputs whose CRSs differ ([`crate::model::crs::same_crs`]; an input
//!   naming none agrees with any), naming the files, before anything is written;
//! * **identifiers**: ids must be unique in the output. The first input keeps its own. In the
//!   `k`-th input (1-based, k ≥ 2) an id an earlier input used is renamed `<id>__<k>`
//!   (`wall-1` in the 2nd input becomes `wall-1__2`); should that name be taken too (by any
//!   input), `<id>__<k>_2`, `<id>__<k>_3`, ... is the first free one ([`renamed_id`]). Inside
//!   that input every reference to a renamed id follows. The rule depends only on the inputs
//!   and their order, so the same inputs always give the same bytes;
//! * **one CRS**, that of the first input naming one, and **one box**, the union of the
//!   inputs' boxes.
//!
//! The formats write the bytes: [`merge_named`] copies CityGML members, [`merge_cityjson`]
//! CityJSON city objects, and [`write_merged`] writes the inputs of a model in memory as one
//! OBJ or CityJSON file. A merge of CityGML into another format is the CityGML merge
//! converted, so every format holds the same ids.
//!
//! ```
//! use std::collections::HashSet;
//! use skylod::export::renamed_id;
//! let taken: HashSet<String> = ["w".into(), "w__2".into()].into();
//! assert_eq!(renamed_id("w", 3, &taken), "w__3");
//! assert_eq!(renamed_id("w", 2, &taken), "w__2_2");
//! ```

mod citygml;
mod cityjson;
mod model;

pub use citygml::{check_mergeable, merge_named};
pub use cityjson::merge_cityjson;
pub(crate) use model::model_label;
pub use model::write_merged;

use crate::io::citygml::error::{ReadError, WriteError};
use crate::model::crs::same_crs;
use crate::model::Bbox;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

/// Why documents cannot be merged.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MergeError {
    /// An input cannot be read or is not well-formed.
    #[error(transparent)]
    Read(#[from] ReadError),
    /// Writing the merged document failed (nothing is left behind).
    #[error(transparent)]
    Write(#[from] WriteError),
    /// Nothing to merge.
    #[error("no document to merge")]
    NoInput,
    /// Inputs of different versions of their format.
    #[error("cannot merge {format} {first_version} ({first}) with {format} {other_version} ({other})", first = crate::model::shown(.first), other = crate::model::shown(.other))]
    Version {
        /// `CityGML` or `CityJSON`.
        format: &'static str,
        /// The first input.
        first: PathBuf,
        /// Its version.
        first_version: String,
        /// An input of another version.
        other: PathBuf,
        /// Its version.
        other_version: String,
    },
    /// Inputs in different CRSs.
    #[error("cannot merge inputs in different CRSs: {} ({first_srs}) and {} ({other_srs})", crate::model::shown(.first), crate::model::shown(.other))]
    Crs {
        /// The first input naming a CRS.
        first: PathBuf,
        /// Its srsName.
        first_srs: String,
        /// An input in another CRS.
        other: PathBuf,
        /// Its srsName.
        other_srs: String,
    },
}

impl From<crate::io::files::FileError> for MergeError {
    fn from(e: crate::io::files::FileError) -> Self {
        MergeError::Write(e.into())
    }
}

/// What was merged.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub struct MergeSummary {
    /// Input documents.
    pub files: usize,
    /// Members copied (CityGML: children of the root after its header; CityJSON: top-level
    /// city objects).
    pub members: usize,
    /// Ids renamed to keep ids unique.
    pub ids_renamed: usize,
    /// References (`xlink:href`, appearance targets, `parents` / `children`) rewritten to
    /// follow a renamed id.
    pub refs_rewritten: usize,
    /// Bytes written (before compression).
    pub bytes: u64,
}

/// What the plan needs of one input, from its first pass.
#[derive(Debug, Clone, Default)]
pub(crate) struct Head {
    /// What the inputs must share: the CityGML root's namespace, the CityJSON `version`.
    pub version: String,
    /// The version as a refusal names it (`2.0`).
    pub shown: String,
    /// The input's CRS, if it names one.
    pub srs: Option<String>,
    /// Every id, in document order, each once.
    pub ids: Vec<String>,
    /// Its box, per axis (an axis it does not give stays empty).
    pub bbox: Bbox,
}

/// The decisions of a merge (module docs).
#[derive(Debug)]
pub(crate) struct Plan {
    /// Per input, its ids that are renamed and their new names.
    pub renames: Vec<HashMap<String, String>>,
    /// The CRS written: that of the first input naming one.
    pub srs: Option<String>,
    /// The union of the inputs' boxes, per axis.
    pub bbox: Bbox,
}

impl Plan {
    /// The plan of a merge of `heads` (in input order) in `format`; `name(k)` names the
    /// `k`-th input in a refusal.
    ///
    /// # Errors
    /// [`MergeError::Version`], [`MergeError::Crs`].
    pub fn new(
        heads: &[&Head],
        format: &'static str,
        name: &dyn Fn(usize) -> PathBuf,
    ) -> Result<Plan, MergeError> {
        check(heads, format, name, true)?;
        let ids: Vec<&[String]> = heads.iter().map(|h| h.ids.as_slice()).collect();
        let mut bbox = Bbox::EMPTY;
        for h in heads {
            for i in 0..3 {
                bbox.min[i] = bbox.min[i].min(h.bbox.min[i]);
                bbox.max[i] = bbox.max[i].max(h.bbox.max[i]);
            }
        }
        Ok(Plan {
            renames: rename_ids(&ids),
            srs: heads.iter().find_map(|h| h.srs.clone()),
            bbox,
        })
    }

    /// How many ids are renamed.
    pub fn ids_renamed(&self) -> usize {
        self.renames.iter().map(HashMap::len).sum()
    }
}

/// Refuse `heads` of different versions, and, when `same_crs_needed` (outputs keep their
/// input's CRS; not after a reprojection to one target), in CRSs that differ: the first
/// input naming one against the first naming another.
fn check(
    heads: &[&Head],
    format: &'static str,
    name: &dyn Fn(usize) -> PathBuf,
    same_crs_needed: bool,
) -> Result<(), MergeError> {
    let Some(first) = heads.first() else {
        return Ok(());
    };
    if let Some(k) = heads.iter().position(|h| h.version != first.version) {
        return Err(MergeError::Version {
            format,
            first: name(0),
            first_version: first.shown.clone(),
            other: name(k),
            other_version: heads[k].shown.clone(),
        });
    }
    if !same_crs_needed {
        return Ok(());
    }
    let mut seen: Option<(usize, &str)> = None;
    for (k, srs) in heads.iter().enumerate() {
        let Some(srs) = srs.srs.as_deref() else {
            continue;
        };
        match seen {
            None => seen = Some((k, srs)),
            Some((j, first_srs)) if !same_crs(first_srs, srs) => {
                return Err(MergeError::Crs {
                    first: name(j),
                    first_srs: first_srs.to_string(),
                    other: name(k),
                    other_srs: srs.to_string(),
                })
            }
            _ => {}
        }
    }
    Ok(())
}

/// The renaming of a merge (module docs): for the ids of each input in document order
/// (`ids[k]` those of input `k`, 0-based), the ids of that input that are renamed and their
/// new names. The first input keeps its own; a later input renames what an earlier one used.
///
/// ```
/// use skylod::export::rename_ids;
/// let a = ["b".to_string(), "w".to_string()];
/// let b = ["b".to_string(), "x".to_string()];
/// let r = rename_ids(&[&a[..], &b[..]]);
/// assert!(r[0].is_empty());
/// assert_eq!(r[1].get("b").map(String::as_str), Some("b__2"));
/// assert_eq!(r[1].len(), 1);
/// ```
pub fn rename_ids(ids: &[&[String]]) -> Vec<HashMap<String, String>> {
    let mut taken: HashSet<String> = ids.iter().flat_map(|s| s.iter().cloned()).collect();
    let mut used: HashSet<String> = HashSet::new();
    let mut renames: Vec<HashMap<String, String>> = Vec::with_capacity(ids.len());
    for (k, s) in ids.iter().enumerate() {
        let mut map = HashMap::new();
        for id in s.iter() {
            if used.contains(id) {
                let new = renamed_id(id, k + 1, &taken);
                taken.insert(new.clone());
                used.insert(new.clone());
                map.insert(id.clone(), new);
            } else {
                used.insert(id.clone());
            }
        }
        renames.push(map);
    }
    renames
}

/// The new name of an id of the `k`-th input (1-based) that collides: `<id>__<k>`, or the first
/// of `<id>__<k>_2`, `<id>__<k>_3`, ... that `taken` does not hold.
pub fn renamed_id(id: &str, k: usize, taken: &HashSet<String>) -> String {
    let base = format!("{id}__{k}");
    if !taken.contains(&base) {
        return base;
    }
    (2usize..)
        .map(|n| format!("{base}_{n}"))
        .find(|c| !taken.contains(c))
        .unwrap_or(base)
}

/// How a merge of `n` inputs, the first named `first`, is named where one input's name goes
/// (the OBJ's comment line, the summary): `a.gml and 2 more`.
pub fn label(first: Option<&Path>, n: usize) -> String {
    let first = first.map_or(String::new(), |p| crate::model::shown(p).to_string());
    match n {
        0 | 1 => first,
        n => format!("{first} and {} more", n - 1),
    }
}
