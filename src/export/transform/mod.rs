//! The edits of a document, streamed, for CityGML and CityJSON alike: `subset` (top-level
//! city objects by box, ids or types), `filter-lods` (LoD representations kept or removed),
//! `upgrade` (CityGML 1.0/2.0 → 3.0, CityJSON 1.x → 2.0) and `reproject` (coordinates into
//! another CRS). Each rule is one type ([`Subset`], [`Lods`], [`UpgradeOptions`],
//! [`CrsTransform`]) that both formats apply: `citygml` edits the document's bytes by
//! span, `cityjson` rewrites its objects and vertices.

pub(crate) mod citygml;
pub(crate) mod cityjson;

pub use citygml::edit::{subset, BboxMode, LodMode, Lods, Subset};
#[cfg(feature = "proj")]
pub use citygml::reproject::reproject_file;
pub use citygml::reproject::{
    reproject_with, rewrite_file, CrsTransform, ReprojectError, ReprojectSummary, RewriteSource,
    RewriteSummary,
};
pub use citygml::upgrade::UpgradeOptions;
pub use cityjson::{reproject_cityjson, subset as subset_cityjson};
