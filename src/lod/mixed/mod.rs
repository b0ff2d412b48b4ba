//! Mixed level-of-detail CityGML writer (DESIGN.md "Output", paper 4.6).
//!
//! [`write_mixed`] writes one source document of a [`CityModel`] again, every asset at the
//! level chosen for it:
//!
//! * **level 2**: the asset is copied verbatim;
//! * **level 1**: the asset's geometry is replaced by its rough geometry
//!   ([`RoughGeometry`]), in the same LoD property, so that a tool reading one LoD sees the
//!   whole model;
//! * **level 0**: the asset is dropped.
//!
//! The output keeps the version, the namespaces and everything the edits do not touch byte
//! for byte (it is written through [`write_document`]). It is schema-valid when the input is.
//!
//! # Rules and decisions
//!
//! **Level 1.** Which property gets what is decided by [`crate::lod::level::properties`], the one
//! definition the report, the traced LoD scene and `evaluate` share. Let `L` be the LoD of the rough geometry (`rough.lod`, the LoD its input was
//! taken from). Every polygonal LoD property of the asset at LoD `L` *and above* gets the rough
//! geometry: a property left at a higher LoD with its full detail would make the asset full
//! detail for a tool reading that LoD. Properties *below* `L` are kept verbatim (they are
//! already coarser and describe the same object). The encoding follows the property's schema
//! type: `lodNSolid` gets a `gml:Solid` whose exterior is a `gml:CompositeSurface` (GML 3.1.1,
//! CityGML 1.0/2.0) or a `gml:Shell` (GML 3.2, CityGML 3.0) of the rough polygons (the six faces
//! of an oriented box for installations, openings and other objects: a closed shell; a body's
//! polygons generalised to their planes);
//! `lodNMultiSurface`, `lodNGeometry`, `lod0FootPrint`, `lod0RoofEdge` get a `gml:MultiSurface`;
//! other `lodNSurface` properties (a `gml:_Surface`) get a `gml:CompositeSurface`. Properties
//! whose type admits none of these (`lodNImplicitRepresentation`, relief `tin`/`grid`) are
//! kept verbatim: an implicit geometry is a shared prototype and cannot hold world
//! coordinates. When the rough geometry *is* the property's own geometry (a shell surface whose
//! LoD2 is used unchanged beside its LoD3) that property is kept verbatim too, ids included.
//! A property given by reference (`<bldg:lod2MultiSurface xlink:href="#x"/>`) is rewritten as a
//! property holding the rough geometry. If the rough geometry is empty the asset is kept verbatim.
//! A property is never given *more* polygons than it holds: when the rough geometry has more
//! polygons (the six faces of the box of a window that is a single quad, degenerate when the
//! window is flat), the property is kept verbatim, as it is already as rough as it gets; its
//! polygons lie inside the box the rough stage traced, so the selection stays conservative.
//!
//! New geometry gets deterministic `gml:id`s `skylod_<asset id or a<index>>_g<property>` with
//! `_<n>` per polygon (and `_s` for a shell or composite surface), in the document's GML
//! prefix, with `srsDimension="3"` on every `posList`. Characters that an `xs:ID` cannot hold
//! are replaced by `_`; a candidate that meets any id of the document, or one already
//! generated, gets a `_<k>` suffix until it is unique.
//!
//! **Level 0.** The asset's element is removed with its enclosing property element
//! (`bldg:boundedBy`, `bldg:opening`, `bldg:outerBuildingInstallation`, `con:fillingSurface`,
//! `core:cityObjectMember`, ...) because an empty property is invalid. Generally: when an
//! element is removed, its parent goes too if it is a property (lower-case local name) or a GML
//! object that is left without child elements; features (upper-case, non-GML) stop the climb,
//! the document root is never removed. A *Body* asset (a building's own geometry) at level 0
//! loses its geometry properties. A level-0 asset that contains kept assets (a wall with a
//! level-2 window) is kept as a container without geometry: its LoD properties are removed, the
//! rest stays, and it carries `skylod_level` 0 (a reader sees no asset there: it has no
//! geometry). A building or building part that held assets or geometry and is left with no kept
//! asset, no own geometry and no kept part is removed as a whole, with its `cityObjectMember` /
//! `consistsOfBuildingPart` / `buildingPart` wrapper; a building's own geometry that is not an
//! asset (e.g. an `lod1Solid` beside LoD2 thematic surfaces) counts as kept geometry.
//!
//! **Level attribute.** Every kept asset carries its level as a generic attribute named
//! `skylod_level`: `gen:intAttribute` in CityGML 1.0/2.0, `core:genericAttribute/gen:IntAttribute`
//! in 3.0, inserted after the feature's leading GML and core CityObject properties (description,
//! name, boundedBy, creationDate, terminationDate, externalReference, generalizesTo,
//! relativeToTerrain, relativeToWater, appearance, other generic attributes; in 3.0 also
//! validFrom/validTo, relatedTo), which is where the XSD admits it. The document's prefixes are
//! used when the root declares them (and no element redeclares them); otherwise the namespaces
//! are declared on the inserted element. A `skylod_level` already present (output written
//! again) is replaced. For a Body asset the attribute goes on the building.
//!
//! **References.** After the edits, every `xlink:href="#id"` in content that is kept is checked:
//! when its target lies in removed or replaced content, the referencing element is pruned. A
//! member of a *connected* structure (`Solid`, `Shell`, `CompositeSurface`, `CompositeSolid`,
//! `CompositeCurve`, `OrientableSurface`, `Surface`, `TriangulatedSurface`, `Tin`) makes the
//! outermost such structure broken: it is removed as a whole (a solid missing faces is not a
//! solid; the level-1 faces written instead do not form a shell), e.g. a building's `lod3Solid`
//! made of references to the polygons of level-1 surfaces. Members of aggregates (`MultiSurface`,
//! `MultiGeometry`, ...) are removed one by one, and an aggregate or property left empty is
//! removed by the climbing rule above. Non-geometry references (`bldg:opening xlink:href`,
//! `core:generalizesTo`, ...) whose target is gone are removed likewise. This runs to a fixed
//! point together with the building rule, since a pruned property can empty a building.
//!
//! **Appearances.** `app:target` (text `#id`, or `uri="#id"` on a 2.0 ParameterizedTexture
//! target; in 3.0 the `TextureAssociation` holding it) pointing into removed or replaced content
//! is removed; a surface data object (`ParameterizedTexture`, `X3DMaterial`,
//! `GeoreferencedTexture`) left without targets is removed with its `surfaceDataMember` /
//! `surfaceData`; an `Appearance` left without surface data is removed with its
//! `appearanceMember` / `appearance`.
//!
//! **Envelopes.** Every `gml:Envelope` whose owner's geometry the reader knew is recomputed
//! from the geometry actually written (kept polygons, minus pruned references, plus rough
//! geometry); an envelope whose owner is left without geometry is removed with its
//! `gml:boundedBy` (optional everywhere). [`WriteOptions::keep_envelopes`] keeps them as they are.
//!
//! # Implementation
//!
//! The reader records the spans of assets, buildings and LoD properties but not the enclosing
//! property elements, appearances, references or every `gml:id`. A second streaming pass
//! (`index`, namespace-aware, with the reader's limits) records a compact index of the
//! elements (spans, parent, name, id, reference) and every decision above is taken on it
//! (`plan`); new geometry is written by `encode`. The pass costs what is kept, not what is
//! read: the content of each element that goes whole (a level-0 asset with nothing kept
//! below it) is not parsed but scanned for its `gml:id`s only, so writing a district where a
//! few hundred of 57,000 assets are kept costs little more than copying its bytes. Memory is
//! about 40 bytes per indexed element plus the ids.
//!
//! **Memory follows the chunk** on a hollow read ([`MixedSource::Hollow`]; a model read
//! whole is planned as one chunk, on the index of the whole document: with every polygon in
//! memory, a chunked plan would lower no peak). A plain (uncompressed) source file is
//! indexed, planned and its index dropped one chunk of whole top-level members at a time: the chunks of the
//! streamed read (about 16 MiB each, cut at the ends of top-level `cityObjectMember`s), each
//! indexed as the prolog, the chunk and the root's end tag. The edits are the whole index's
//! wherever nothing outside a chunk decides anything in it; what could is checked, and the
//! writer indexes the whole document instead (its index of the whole source, ~0.31x the file) where a
//! chunk holds a reference (`xlink:href`, appearance target) whose target is not in the chunk
//! (a cross-member XLink, an appearance at the root targeting members), looks up (as a
//! reference's target or a polygon's id) a gml:id that an earlier chunk holds too, holds a
//! gml:id that a fresh `skylod_` id of an earlier chunk took, or redeclares a namespace
//! prefix the first chunk does not. Fresh ids are checked against the chunk's ids and the
//! hashes of the ids of the chunks before; the root's envelopes are written last, from the
//! union of what every chunk writes; the summary is the sum of the chunks'. What grows with
//! the document is the hashes of its gml:ids (7 to 7.75 bytes an id, ~28 MB per GB of LoD3)
//! and the edits. A compressed or in-memory source, or one chunk, is indexed whole.
//!
//! # Example
//! ```
//! use skylod::io::citygml::{WriteOptions, read_file};
//! use skylod::lod::write_mixed;
//! use skylod::lod::rough::{rough_model, RoughOptions};
//! let dir = tempfile::tempdir().unwrap();
//! let src = dir.path().join("in.gml");
//! std::fs::write(&src, br#"<CityModel xmlns="http://www.opengis.net/citygml/2.0"
//!  xmlns:gml="http://www.opengis.net/gml" xmlns:bldg="http://www.opengis.net/citygml/building/2.0">
//!  <cityObjectMember><bldg:Building gml:id="b"><bldg:boundedBy><bldg:RoofSurface gml:id="r">
//!  <bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember><gml:Polygon><gml:exterior>
//!  <gml:LinearRing><gml:posList>0 0 5 2 0 5 2 4 5 0 4 5 0 0 5</gml:posList></gml:LinearRing>
//!  </gml:exterior></gml:Polygon></gml:surfaceMember><gml:surfaceMember><gml:Polygon><gml:exterior>
//!  <gml:LinearRing><gml:posList>2 0 5 4 0 5 4 4 5 2 4 5 2 0 5</gml:posList></gml:LinearRing>
//!  </gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface>
//!  </bldg:RoofSurface></bldg:boundedBy><bldg:boundedBy><bldg:WallSurface gml:id="w">
//!  <bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember><gml:Polygon><gml:exterior>
//!  <gml:LinearRing><gml:posList>0 0 0 4 0 0 4 0 5 0 0 5 0 0 0</gml:posList></gml:LinearRing>
//!  </gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface>
//!  </bldg:WallSurface></bldg:boundedBy></bldg:Building></cityObjectMember></CityModel>"#).unwrap();
//! let model = read_file(&src).unwrap();
//! let rough = rough_model(&model, &RoughOptions::default());
//! let out = dir.path().join("out.gml");
//! // roof rough (level 1), wall dropped (level 0)
//! let s = write_mixed((&model, 0), &rough, &[1, 0], &out, &WriteOptions::default()).unwrap();
//! assert_eq!(s.levels, [1, 1, 0]);
//! assert_eq!((s.polygons_in, s.polygons_out), (3, 1)); // two roof halves merged, wall dropped
//! let text = std::fs::read_to_string(&out).unwrap();
//! assert!(!text.contains("WallSurface"));
//! assert!(text.contains(r#"<gen:intAttribute xmlns:gen="http://www.opengis.net/citygml/generics/2.0" name="skylod_level"><gen:value>1</gen:value></gen:intAttribute>"#));
//! assert!(text.contains(r#"<gml:MultiSurface gml:id="skylod_r_g0">"#));
//! let again = read_file(&out).unwrap();
//! assert_eq!(again.assets.len(), 1);
//! ```

mod chunked;
mod content_ids;
mod doc;
mod encode;
mod id_table;
mod index;
mod plan;
mod plan_model;
mod push_back;

use crate::io::citygml::error::WriteError;
use crate::io::citygml::read::ReadOptions;
use crate::io::citygml::read::Reread;
use crate::io::citygml::write::{
    check_target, write_document, write_document_to, Edit, WriteOptions,
};
use crate::lod::hollow::Hollow;
use crate::lod::rough::RoughGeometry;
use crate::model::CityModel;
use plan::{Plan, Scope, Shared};
use std::path::Path;

/// What [`write_mixed`] wrote.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct MixedSummary {
    /// Bytes written (before compression).
    pub bytes: u64,
    /// Assets of the file per level `[level 0, level 1, level 2]`.
    pub levels: [usize; 3],
    /// Level-0 assets kept as containers of kept assets (no geometry of their own).
    pub containers: usize,
    /// Asset polygons of the file in the input (all LoDs, references counted per use).
    pub polygons_in: usize,
    /// Asset polygons written (kept verbatim plus rough; references counted per use).
    pub polygons_out: usize,
    /// Buildings (top-level, not parts) removed because nothing of them was kept.
    pub buildings_dropped: usize,
    /// Building parts removed because nothing of them was kept (a part removed with its
    /// dropped building is not counted).
    pub parts_dropped: usize,
    /// `xlink:href` references found pointing into removed or replaced content (each one
    /// pruned; references that vanish with a structure such a pruning removed, e.g. the other
    /// faces of a broken `gml:Solid`, are not counted again).
    pub hrefs_pruned: usize,
    /// Appearance targets pruned.
    pub appearance_targets_pruned: usize,
}

impl MixedSummary {
    /// Add the counts of `o` (the summary of another part of the same document).
    fn add(&mut self, o: &MixedSummary) {
        self.bytes += o.bytes;
        for (l, n) in self.levels.iter_mut().zip(o.levels) {
            *l += n;
        }
        self.containers += o.containers;
        self.polygons_in += o.polygons_in;
        self.polygons_out += o.polygons_out;
        self.buildings_dropped += o.buildings_dropped;
        self.parts_dropped += o.parts_dropped;
        self.hrefs_pruned += o.hrefs_pruned;
        self.appearance_targets_pruned += o.appearance_targets_pruned;
    }

    /// The line `skylod rough` says for the file `input` written to `out`: assets, polygons
    /// in and out (and the share kept), references and appearance targets pruned.
    pub fn rough_line(&self, input: &Path, out: &Path) -> String {
        let pct = if self.polygons_in > 0 {
            100.0 * self.polygons_out as f64 / self.polygons_in as f64
        } else {
            100.0
        };
        format!(
            "{} -> {}: {} assets, polygons {} -> {} ({pct:.1}%), {} href(s) and {} appearance target(s) pruned",
            crate::model::shown(input),
            out.display(),
            self.levels[1],
            self.polygons_in,
            self.polygons_out,
            self.hrefs_pruned,
            self.appearance_targets_pruned,
        )
    }
}

/// What [`write_mixed`] writes: a file of a model read whole, planned on the index of the
/// whole document, or the one file of a document read hollow, planned a chunk of whole
/// top-level members at a time with the polygons each chunk's plan needs read back (the
/// memory follows the chunk). The bytes are the same either way.
#[derive(Debug)]
pub enum MixedSource<'a> {
    /// File `.1` of the model `.0`.
    Whole(&'a CityModel, usize),
    /// A document read hollow ([`crate::lod::hollow::read_hollow`], left as it was given),
    /// the document to read polygons back from ([`Reread`]), and the bytes of a chunk.
    Hollow(&'a mut Hollow, &'a Reread, u64),
}

impl<'a> From<(&'a CityModel, usize)> for MixedSource<'a> {
    fn from((model, file): (&'a CityModel, usize)) -> Self {
        MixedSource::Whole(model, file)
    }
}

/// Write `src` to `out` with every asset at its level (see the module docs).
///
/// `rough[i]` and `levels[i]` belong to the model's `assets[i]`; only the assets of the file
/// written are looked at. Levels above 2 count as 2.
///
/// # Errors
/// The target's checks, I/O; [`WriteError::Invalid`] where the levels or rough forms do not
/// match the assets, or a hollow read's polygons cannot be read back.
pub fn write_mixed<'a>(
    src: impl Into<MixedSource<'a>>,
    rough: &[RoughGeometry],
    levels: &[u8],
    out: &Path,
    opts: &WriteOptions,
) -> Result<MixedSummary, WriteError> {
    let mut src = src.into();
    let (edits, mut summary) = mixed_edits(&mut src, rough, levels, opts, |src| {
        check_target(out, opts, src.source.path())
    })?;
    let (model, file) = match &src {
        MixedSource::Whole(model, file) => (*model, *file),
        MixedSource::Hollow(h, ..) => (&h.model, 0),
    };
    let w = write_document(model, file, edits, out, &kept_envelopes(opts))?;
    summary.bytes = w.bytes;
    Ok(summary)
}

/// [`write_mixed`] of file `file` of `model` into any writer `w` (uncompressed, no target
/// checks; of `opts` only `keep_envelopes` matters).
pub fn write_mixed_to(
    model: &CityModel,
    file: usize,
    rough: &[RoughGeometry],
    levels: &[u8],
    w: &mut dyn std::io::Write,
    opts: &WriteOptions,
) -> Result<MixedSummary, WriteError> {
    let src = &mut MixedSource::Whole(model, file);
    let (edits, mut summary) = mixed_edits(src, rough, levels, opts, |_| Ok(()))?;
    summary.bytes = write_document_to(model, file, edits, w, &kept_envelopes(opts))?.bytes;
    Ok(summary)
}

/// `opts` for the document's writer: the envelopes are the plan's to edit.
fn kept_envelopes(opts: &WriteOptions) -> WriteOptions {
    WriteOptions {
        keep_envelopes: true,
        ..opts.clone()
    }
}

/// One rough geometry and one level per asset of `model`, or [`WriteError::Invalid`] naming
/// the three counts (the mixed writer and the exports).
pub(crate) fn check_per_asset(
    model: &CityModel,
    rough: &[RoughGeometry],
    levels: &[u8],
) -> Result<(), WriteError> {
    if levels.len() != model.assets.len() || rough.len() != model.assets.len() {
        return Err(WriteError::Invalid(format!(
            "{} assets, {} levels and {} rough geometries: one of each per asset expected",
            model.assets.len(),
            levels.len(),
            rough.len()
        )));
    }
    Ok(())
}

/// The arguments checked, `check` passed for the source file, the edits planned
/// ([`chunked::plan`]: a model read whole in one chunk, a hollow read a chunk at a time).
fn mixed_edits(
    src: &mut MixedSource<'_>,
    rough: &[RoughGeometry],
    levels: &[u8],
    opts: &WriteOptions,
    check: impl FnOnce(&crate::model::SourceFile) -> Result<(), WriteError>,
) -> Result<(Vec<Edit>, MixedSummary), WriteError> {
    let (mut whole, mut filled);
    let (m, file, chunk): (&mut dyn plan_model::PlanModel, usize, u64) = match src {
        MixedSource::Whole(model, file) => {
            whole = plan_model::Whole(model);
            (&mut whole, *file, u64::MAX)
        }
        MixedSource::Hollow(hollow, rr, chunk) => {
            filled = plan_model::Filled {
                hollow,
                rr,
                assets: Vec::new(),
                buildings: Vec::new(),
            };
            (&mut filled, 0, *chunk)
        }
    };
    check_per_asset(m.model(), rough, levels)?;
    check(crate::io::citygml::write::source_file(m.model(), file)?)?;
    chunked::plan(m, (file, rough, levels), opts.keep_envelopes, chunk)
}

/// The edits that write `file` at `levels` on the whole index, and what they do. `skip`: do
/// not parse the content of elements that go whole (false only to check that skipping
/// changes nothing).
#[cfg(test)]
fn plan_file(
    model: &CityModel,
    file: usize,
    rough: &[RoughGeometry],
    levels: &[u8],
    keep_envelopes: bool,
    skip: bool,
) -> Result<(Vec<Edit>, MixedSummary), WriteError> {
    plan_file_with(model, model, (file, rough, levels), keep_envelopes, skip)
}

/// [`plan_file`] with the polygons of each asset in the full model from `facts` (`model`'s
/// own, or those of the hollow read `model` is).
fn plan_file_with(
    model: &CityModel,
    facts: &dyn crate::lod::select::FullFacts,
    (file, rough, levels): (usize, &[RoughGeometry], &[u8]),
    keep_envelopes: bool,
    skip: bool,
) -> Result<(Vec<Edit>, MixedSummary), WriteError> {
    let src = &model.files[file];
    let containers = plan::containers(model, file, levels);
    let spans = if skip {
        plan::skip_spans(model, file, levels, &containers)
    } else {
        Vec::new()
    };
    let doc = index::scan(&src.source, &src.path, &spans, &ReadOptions::default())?;
    let shared = Shared::new(model, file, containers);
    let [assets, buildings, envelopes] = plan::scope_lists(model, file, &[(0, u64::MAX)]);
    let scope = Scope {
        assets: &assets[0],
        buildings: &buildings[0],
        envelopes: &envelopes[0],
        shared: &shared,
        facts,
        defer_root: false,
        elsewhere: &|_| false,
    };
    let mut plan = Plan::new(
        model,
        (file, rough, levels),
        scope,
        &doc,
        encode::IdPool::new(),
    );
    plan.run(keep_envelopes);
    Ok((plan.edits(), plan.summary))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::citygml::read::read_file;
    use crate::lod::rough::{rough_model, RoughOptions};

    const HEAD2: &str = r#"<?xml version="1.0"?>
<CityModel xmlns="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml"
 xmlns:bldg="http://www.opengis.net/citygml/building/2.0" xmlns:xlink="http://www.w3.org/1999/xlink"
 xmlns:app="http://www.opengis.net/citygml/appearance/2.0" xmlns:gen="http://www.opengis.net/citygml/generics/2.0">
<gml:boundedBy><gml:Envelope srsName="EPSG:25832"><gml:lowerCorner>0 0 0</gml:lowerCorner><gml:upperCorner>9 9 9</gml:upperCorner></gml:Envelope></gml:boundedBy>
"#;

    fn poly(id: &str, pts: &str) -> String {
        format!(
            "<gml:Polygon gml:id=\"{id}\"><gml:exterior><gml:LinearRing><gml:posList>{pts}</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon>"
        )
    }

    fn surface(kind: &str, id: &str, pid: &str, pts: &str) -> String {
        format!(
            "<bldg:boundedBy><bldg:{kind} gml:id=\"{id}\"><gml:name>n</gml:name><bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember>{}</gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface></bldg:{kind}></bldg:boundedBy>",
            poly(pid, pts)
        )
    }

    pub(super) fn house() -> String {
        let mut s = String::from(HEAD2);
        s.push_str("<cityObjectMember><bldg:Building gml:id=\"b1\">");
        s.push_str("<bldg:lod2Solid><gml:Solid><gml:exterior><gml:CompositeSurface><gml:surfaceMember xlink:href=\"#p1\"/><gml:surfaceMember xlink:href=\"#p2\"/></gml:CompositeSurface></gml:exterior></gml:Solid></bldg:lod2Solid>");
        s.push_str(&surface(
            "RoofSurface",
            "r1",
            "p1",
            "0 0 5 4 0 5 4 4 5 0 4 5 0 0 5",
        ));
        s.push_str(&surface(
            "WallSurface",
            "w1",
            "p2",
            "0 0 0 4 0 0 4 0 5 0 0 5 0 0 0",
        ));
        s.push_str("</bldg:Building></cityObjectMember>");
        s.push_str("<cityObjectMember><bldg:Building gml:id=\"b2\">");
        s.push_str(&surface(
            "RoofSurface",
            "r2",
            "p3",
            "10 0 5 14 0 5 14 4 5 10 4 5 10 0 5",
        ));
        s.push_str("</bldg:Building></cityObjectMember>");
        s.push_str("<app:appearanceMember><app:Appearance><app:surfaceDataMember><app:X3DMaterial><app:diffuseColor>1 0 0</app:diffuseColor><app:target>#p1</app:target></app:X3DMaterial></app:surfaceDataMember><app:surfaceDataMember><app:X3DMaterial><app:target>#p2</app:target><app:target>#p3</app:target></app:X3DMaterial></app:surfaceDataMember></app:Appearance></app:appearanceMember>");
        s.push_str("</CityModel>\n");
        s
    }

    /// `xml` written to `dir/in.gml` and read.
    pub(super) fn read_in(dir: &Path, xml: &str) -> CityModel {
        let src = dir.join("in.gml");
        std::fs::write(&src, xml).unwrap();
        read_file(&src).unwrap()
    }

    fn run(xml: &str, levels: &[u8]) -> (String, MixedSummary) {
        let dir = tempfile::tempdir().unwrap();
        let model = read_in(dir.path(), xml);
        let rough = rough_model(&model, &RoughOptions::default());
        let out = dir.path().join("out.gml");
        let s = write_mixed((&model, 0), &rough, levels, &out, &WriteOptions::default()).unwrap();
        let text = std::fs::read_to_string(&out).unwrap();
        read_file(&out).unwrap();
        (text, s)
    }

    #[test]
    fn all_full_detail_keeps_everything_but_adds_levels() {
        let (text, s) = run(&house(), &[2, 2, 2]);
        assert_eq!(s.levels, [0, 0, 3]);
        assert_eq!(text.matches("skylod_level").count(), 3);
        assert!(text.contains("xlink:href=\"#p1\""));
        assert_eq!(s.hrefs_pruned, 0);
        // level attribute after gml:name, before the geometry
        let i = text.find("<gml:name>n</gml:name><gen:intAttribute name=\"skylod_level\">");
        assert!(i.is_some(), "{text}");
    }

    #[test]
    fn rough_replaces_and_prunes_solid_and_targets() {
        let (text, s) = run(&house(), &[1, 2, 2]);
        // the roof's polygon p1 is replaced: the building solid referencing it is broken
        assert!(!text.contains("lod2Solid"), "{text}");
        assert!(!text.contains("\"p1\""));
        assert!(text.contains("gml:id=\"skylod_r1_g0\""));
        assert_eq!(s.hrefs_pruned, 1);
        assert_eq!(s.appearance_targets_pruned, 1);
        assert!(!text.contains("#p1"));
        assert!(text.contains("<app:target>#p2</app:target>"));
        assert!(
            !text.contains("diffuseColor"),
            "material left without targets is dropped"
        );
    }

    #[test]
    fn level0_drops_wrappers_buildings_and_appearances() {
        let (text, s) = run(&house(), &[2, 0, 0]);
        assert!(!text.contains("w1"));
        assert!(
            !text.contains("b2"),
            "building with nothing kept is dropped"
        );
        assert_eq!(s.buildings_dropped, 1);
        assert_eq!(text.matches("<bldg:boundedBy>").count(), 1);
        assert_eq!(text.matches("<cityObjectMember>").count(), 1);
        assert!(!text.contains("#p3"));
        assert!(!text.contains("#p2"));
        assert!(text.contains("#p1"));
        // envelope recomputed from the roof only
        assert!(
            text.contains("<gml:upperCorner>4 4 5</gml:upperCorner>"),
            "{text}"
        );
        let (text, s) = run(&house(), &[0, 0, 0]);
        assert_eq!(s.buildings_dropped, 2);
        assert!(!text.contains("Building"));
        assert!(!text.contains("appearanceMember"));
        assert!(!text.contains("boundedBy"), "envelope of nothing removed");
    }

    #[test]
    fn writing_twice_replaces_the_level_attribute() {
        let (once, _) = run(&house(), &[1, 1, 1]);
        let (text, _) = run(&once, &[2, 2, 2]);
        assert_eq!(text.matches("skylod_level").count(), 3);
        assert_eq!(text.matches("<gen:value>2</gen:value>").count(), 3);
    }

    #[test]
    fn ids_do_not_collide() {
        let xml = house().replace("gml:id=\"b2\"", "gml:id=\"skylod_r1_g0\"");
        let (text, _) = run(&xml, &[1, 2, 2]);
        assert!(text.contains("gml:id=\"skylod_r1_g0_1\""), "{text}");
    }

    /// Level patterns for the skip check: all dropped, a mix, one building kept.
    pub(super) fn patterns(model: &CityModel) -> Vec<(&'static str, Vec<u8>)> {
        let n = model.assets.len();
        let all0 = vec![0u8; n];
        let mix: Vec<u8> = (0..n)
            .map(|i| match i % 7 {
                0 => 2,
                3 | 5 => 1,
                _ => 0,
            })
            .collect();
        let b = model.assets.iter().filter_map(|a| a.building).max();
        let one: Vec<u8> = model
            .assets
            .iter()
            .enumerate()
            .map(|(i, a)| {
                if a.building.is_some() && a.building == b {
                    1 + (i % 2) as u8
                } else {
                    0
                }
            })
            .collect();
        vec![("all 0", all0), ("mix", mix), ("one building", one)]
    }

    pub(super) fn citygml_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
        let Ok(rd) = std::fs::read_dir(dir) else {
            return;
        };
        let mut entries: Vec<_> = rd.flatten().map(|e| e.path()).collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                citygml_files(&p, out);
            } else if p
                .extension()
                .is_some_and(|e| e == "gml" || e == "xml" || e == "gz")
            {
                out.push(p);
            }
        }
    }

    /// Every CityGML file of `../shared/data` (missing: a failure under `CI=true`, a printed
    /// skip otherwise), `tests/data` and `fixtures`.
    pub(super) fn real_files() -> Vec<std::path::PathBuf> {
        let data = Path::new("../shared/data");
        let mut files = Vec::new();
        if data.is_dir() {
            citygml_files(data, &mut files);
        } else if std::env::var("CI").as_deref() == Ok("true") {
            panic!("../shared/data missing under CI=true");
        } else {
            println!("SKIP: ../shared/data missing; fixtures only");
        }
        citygml_files(Path::new("tests/data"), &mut files);
        citygml_files(Path::new("fixtures"), &mut files);
        files
    }

    /// Skipping the content of what goes whole changes no edit and no count, on every real
    /// file and the nesting fixtures, for several level patterns; and it does skip.
    #[test]
    fn skipping_changes_nothing() {
        let files = real_files();
        let (mut checked, mut skipped_bytes) = (0, 0u64);
        for f in &files {
            let Ok(model) = read_file(f) else { continue };
            if model.files.is_empty() || model.assets.is_empty() {
                continue;
            }
            let rough = rough_model(&model, &RoughOptions::default());
            for (what, levels) in patterns(&model) {
                let full = plan_file(&model, 0, &rough, &levels, false, false).unwrap();
                let fast = plan_file(&model, 0, &rough, &levels, false, true).unwrap();
                assert_eq!(full.1, fast.1, "{}: {what}: summaries differ", f.display());
                assert!(full.0 == fast.0, "{}: {what}: edits differ", f.display());
                let containers = plan::containers(&model, 0, &levels);
                let spans = plan::skip_spans(&model, 0, &levels, &containers);
                let doc = index::scan(
                    &model.files[0].source,
                    &model.files[0].path,
                    &spans,
                    &ReadOptions::default(),
                )
                .unwrap();
                skipped_bytes += doc.skipped.1;
                checked += 1;
            }
        }
        assert!(checked >= 3, "only {checked} files checked");
        assert!(skipped_bytes > 0, "nothing was skipped");
    }

    #[test]
    fn bad_arguments() {
        let dir = tempfile::tempdir().unwrap();
        let model = read_in(dir.path(), &house());
        let e = write_mixed(
            (&model, 0),
            &[],
            &[],
            &dir.path().join("o.gml"),
            &WriteOptions::default(),
        );
        assert!(matches!(e, Err(WriteError::Invalid(_))));
    }
}
