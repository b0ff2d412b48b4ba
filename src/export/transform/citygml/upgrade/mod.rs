//! `upgrade`: CityGML 1.0 / 2.0 → 3.0, streamed one top-level member at a time (memory
//! follows the largest member, not the file), the mapping of citygml4j / citygml-tools'
//! `upgrade`:
//!
//! - **Namespaces**: every CityGML module moves to its 3.0 namespace (`core`, `bldg`, `con`,
//!   `gen`, `app`, `tran`, `veg`, `wtr`, `luse`, `frn`, `dem`, `grp`, `brid`, `tun`), GML
//!   3.1.1 to GML 3.2 (`gml:coord` / `gml:coordinates` → `gml:pos` / `gml:posList`, a solid's
//!   `gml:CompositeSurface` → `gml:Shell`); the root declares them all with its schema
//!   locations; ADE and other foreign content is copied with its own names.
//! - **Features**: thematic surfaces into `con:` (`RoofSurface`, `WallSurface`, ...;
//!   `ClosureSurface` into `core:`), openings `bldg:opening/bldg:Window` →
//!   `con:fillingSurface/con:WindowSurface` (and `Door` → `DoorSurface`), installations →
//!   `bldg:buildingInstallation/bldg:BuildingInstallation` (interior ones too), LoD4 interiors
//!   as 3.0 spaces (`interiorRoom/Room` → `buildingRoom/BuildingRoom`, furniture,
//!   room installations), `GenericCityObject` → `GenericOccupiedSpace`.
//! - **Properties**: `boundedBy` → `core:boundary`, `lodXSolid` / `lodXMultiSurface` /
//!   `lodXMultiCurve` / `lodXTerrainIntersection` / `lodXImplicitRepresentation` →
//!   `core:lodX...`, `lod0FootPrint` → `core:lod0MultiSurface`, a `lodXGeometry` by its shape
//!   (solid, curves, else one multi-surface), `yearOfConstruction` → `con:dateOfConstruction`,
//!   `measuredHeight` → `con:height`, each feature's properties in the order of its 3.0 XSD.
//! - **Without a 3.0 place** (dropped and counted unless an option maps them, as in
//!   citygml-tools): LoD4 geometry ([`UpgradeOptions::use_lod4_as_lod3`]: LoD4 becomes LoD3,
//!   and a city object with LoD4 loses its LoD3), LoD0 roof edges
//!   ([`UpgradeOptions::map_lod0_roof_edge`]: a `con:RoofSurface` with `lod0MultiSurface`),
//!   the LoD1 multi-surface of a space ([`UpgradeOptions::map_lod1_multi_surfaces`]: a
//!   `gen:GenericThematicSurface` boundary with `lod1MultiSurface`).
//! - **Generic attributes** `gen:stringAttribute name="n"` → `core:genericAttribute/
//!   gen:StringAttribute/gen:name` (int, double, date, uri, measure, sets); **appearances**
//!   `app:appearance` / `app:appearanceMember` → `core:appearance` / `core:appearanceMember`,
//!   `surfaceDataMember` → `surfaceData`, a texture's `target uri=` → `TextureAssociation`,
//!   `textureCoordinates ring=` → `textureCoordinates` + `ring`; target URIs kept;
//!   **addresses** xAL 2.0 → xAL 3.0 (country, area, locality, street, number, post code).
//!
//! Memory: one member, and the `app:TexCoordList`s that have a `gml:id` (3.0 has no ids on
//! them, so a texture target that refers to one gets a copy).
//!
//! A CityGML 3.0 document is refused (nothing to upgrade). A root `gml:metaDataProperty`
//! (GML 3.1.1 metadata such as a local `EngineeringCRS`) is kept as a comment.

mod dom;
mod extras;
mod feature;
mod geometry;
mod names;

use crate::export::transform::citygml::edit::walk::{self, Piece};
use crate::io::citygml::error::{ReadError, WriteError};
use crate::io::citygml::write::{check_target, WriteOptions};
use dom::{El, Node};
use names::{Module, Src};
use std::io::Write;
use std::path::Path;

/// What `upgrade` maps beyond the default (citygml-tools' `upgrade` options).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[non_exhaustive]
pub struct UpgradeOptions {
    /// LoD4 geometry becomes LoD3 (replacing the LoD3 of a city object that has LoD4);
    /// without it LoD4 geometry is dropped (3.0 has no LoD4).
    pub use_lod4_as_lod3: bool,
    /// A building's LoD0 roof edge becomes a `con:RoofSurface` with `lod0MultiSurface`.
    pub map_lod0_roof_edge: bool,
    /// A space's LoD1 multi-surface becomes a `gen:GenericThematicSurface` boundary.
    pub map_lod1_multi_surfaces: bool,
}

impl UpgradeOptions {
    /// Options from the three flags.
    pub fn new(use_lod4_as_lod3: bool, map_lod0_roof_edge: bool, map_lod1: bool) -> Self {
        UpgradeOptions {
            use_lod4_as_lod3,
            map_lod0_roof_edge,
            map_lod1_multi_surfaces: map_lod1,
        }
    }
}

/// What an upgrade did.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
#[non_exhaustive]
pub struct UpgradeSummary {
    /// The source's CityGML version (`1.0` or `2.0`).
    pub from: String,
    /// Top-level members written.
    pub members: usize,
    /// City objects written (nested ones too).
    pub city_objects: usize,
    /// Generic attributes written.
    pub generic_attributes: usize,
    /// Appearances written.
    pub appearances: usize,
    /// Appearance targets written.
    pub appearance_targets: usize,
    /// LoD4 properties written as LoD3.
    pub lod4_as_lod3: usize,
    /// LoD3 properties removed because LoD4 replaced them.
    pub lod3_replaced: usize,
    /// LoD0 roof edges and LoD1 multi-surfaces mapped onto thematic surfaces.
    pub mapped: usize,
    /// `gml:id`s made (for inline group members, which 3.0 refers to).
    pub ids_made: usize,
    /// Inline group members written as top-level members (3.0 groups refer to theirs).
    pub lifted: usize,
    /// Properties without a 3.0 place, dropped (`bldg:lod4Solid`, ...), in document order.
    pub dropped: Vec<String>,
    /// Bytes of the (decompressed) source.
    pub bytes_in: u64,
    /// Bytes written (before compression).
    pub bytes_out: u64,
}

impl UpgradeSummary {
    /// `a.gml -> b.gml: CityGML 2.0 -> 3.0, 12 city object(s) in 3 member(s), ...`.
    pub fn describe(&self, input: &Path, out: &Path) -> String {
        let mut s = format!(
            "CityGML {} -> 3.0, {} city object(s) in {} member(s), {} generic attribute(s), {} appearance target(s)",
            self.from,
            self.city_objects,
            self.members,
            self.generic_attributes,
            self.appearance_targets,
        );
        if self.lod4_as_lod3 > 0 {
            s += &format!(
                ", {} LoD4 propert(ies) as LoD3 ({} LoD3 replaced)",
                self.lod4_as_lod3, self.lod3_replaced
            );
        }
        if self.lifted > 0 {
            s += &format!(
                ", {} inline group member(s) made top-level ({} gml:id(s) made)",
                self.lifted, self.ids_made
            );
        }
        if self.mapped > 0 {
            s += &format!(", {} mapped onto thematic surfaces", self.mapped);
        }
        if !self.dropped.is_empty() {
            let mut kinds: Vec<&str> = self.dropped.iter().map(String::as_str).collect();
            kinds.sort_unstable();
            kinds.dedup();
            s += &format!(
                ", {} propert(ies) without a 3.0 place dropped ({}; see --use-lod4-as-lod3, --map-lod0-roof-edge, --map-lod1-multi-surfaces)",
                self.dropped.len(),
                kinds.join(", ")
            );
        }
        s += &format!(", {} -> {} bytes", self.bytes_in, self.bytes_out);
        crate::model::made_line(input, out, &s)
    }
}

/// Upgrade the CityGML 1.0 / 2.0 document at `input` to CityGML 3.0 at `out` (see the module
/// docs).
///
/// # Errors
/// The source cannot be read, is not well-formed, is not CityGML 1.0 / 2.0 (a 3.0 document
/// is refused: nothing to upgrade); the output cannot be written.
pub fn upgrade(
    input: &Path,
    out: &Path,
    options: &UpgradeOptions,
    opts: &WriteOptions,
) -> Result<UpgradeSummary, WriteError> {
    check_target(out, opts, std::iter::once(input))?;
    let mut counts = UpgradeSummary::default();
    let io = |e| WriteError::Io {
        file: out.to_path_buf(),
        source: e,
    };
    let mut root = Vec::new();
    let mut root_name = String::new();
    let mut held: Vec<u8> = Vec::new();
    let mut seqs = Default::default();
    let mut texcoords = Default::default();
    let mut buf = Vec::new();
    let bytes_in = std::cell::Cell::new(0u64);
    let bytes_out = crate::io::citygml::write::atomic_write(out, |w| {
        let n = std::cell::Cell::new(0u64);
        let put = |w: &mut dyn Write, b: &[u8]| -> Result<(), WriteError> {
            w.write_all(b).map_err(io)?;
            n.set(n.get() + b.len() as u64);
            Ok(())
        };
        let read = walk::walk::<WriteError>(input, &mut |piece| {
            match piece {
                Piece::Verbatim(b) if root.is_empty() => held.extend_from_slice(b),
                Piece::Verbatim(b) => put(w, &end_tag(b, &root_name))?,
                Piece::Root(b) => {
                    root = b.to_vec();
                    let start = held.len().saturating_sub(b.len());
                    let (tag, name, from) = root_tag(input, &root)?;
                    root_name = name;
                    counts.from = from;
                    put(w, &held[..start])?;
                    put(w, tag.as_bytes())?;
                    held = Vec::new();
                }
                Piece::Child { local, bytes, line } => {
                    let e = dom::parse(&root, bytes).map_err(|e| ReadError::Xml {
                        loc: walk::location(input, line - 1, &bytes[..e.at.min(bytes.len())]),
                        message: e.message,
                    })?;
                    if crate::export::transform::citygml::edit::is_member(local) {
                        counts.members += 1;
                    }
                    let mut ctx = feature::Ctx {
                        opts: options,
                        counts: &mut counts,
                        drop_lod3: options.use_lod4_as_lod3 && feature::has_lod4(&e),
                        seqs: &mut seqs,
                        extra: Vec::new(),
                        texcoords: &mut texcoords,
                    };
                    feature::texcoord_lists(&e, ctx.texcoords);
                    let node = root_child(e, &mut ctx);
                    let extra = std::mem::take(&mut ctx.extra);
                    match node {
                        Node::El(e) => {
                            let k = e.write_to(w, &mut buf).map_err(io)?;
                            n.set(n.get() + k);
                        }
                        Node::Raw(b) | Node::Text(b) => put(w, &b)?,
                    }
                    for f in extra {
                        counts.members += 1;
                        counts.lifted += 1;
                        put(w, b"\n")?;
                        let m = El::new("core:cityObjectMember").with(f);
                        let k = m.write_to(w, &mut buf).map_err(io)?;
                        n.set(n.get() + k);
                    }
                }
            }
            Ok(())
        })?;
        bytes_in.set(read);
        Ok(n.get())
    })?;
    counts.bytes_in = bytes_in.get();
    counts.bytes_out = bytes_out;
    Ok(counts)
}

/// A child of the root: members, the envelope, names, metadata.
fn root_child(e: El, ctx: &mut feature::Ctx<'_>) -> Node {
    let name = match (e.ns, e.local.as_str()) {
        (Src::Core, "cityObjectMember") => "core:cityObjectMember",
        (Src::Module(Module::App), "appearanceMember") => "core:appearanceMember",
        (Src::Gml, "featureMember") => "core:featureMember",
        (Src::Gml, "metaDataProperty") => return extras::metadata_comment(&e),
        (Src::Gml, _) => return Node::El(geometry::gml(e)),
        _ => return Node::El(feature::object(e, ctx)),
    };
    let mut m = El::new(name);
    m.attrs = e.attrs.clone();
    for c in e.into_els() {
        m = m.with(feature::object(c, ctx));
    }
    Node::El(m)
}

/// The 3.0 root start tag for the source's `root`, its qualified name and version.
fn root_tag(input: &Path, root: &[u8]) -> Result<(String, String, String), WriteError> {
    let mut r = quick_xml::NsReader::from_reader(root);
    let bad = |m: String| WriteError::Invalid(format!("{}: {m}", crate::model::shown(input)));
    let (ns, ev) = r
        .read_resolved_event()
        .map_err(|e| bad(format!("the root: {e}")))?;
    let quick_xml::events::Event::Start(e) = ev else {
        return Err(bad("no CityModel root".into()));
    };
    let uri: Vec<u8> = match ns {
        quick_xml::name::ResolveResult::Bound(n) => n.0.to_vec(),
        _ => Vec::new(),
    };
    let from = match Src::of(&uri) {
        Src::Core if uri.ends_with(b"1.0") => "1.0",
        Src::Core => "2.0",
        Src::V3 => return Err(bad("already CityGML 3.0: nothing to upgrade".into())),
        _ => {
            return Err(bad(format!(
                "the root is not in a CityGML 1.0 / 2.0 namespace ({})",
                String::from_utf8_lossy(&uri)
            )))
        }
    };
    let name = String::from_utf8_lossy(e.name().into_inner()).into_owned();
    let (decl, mut loc) = names::root_declarations();
    let mut tag = String::from("<core:CityModel");
    tag += &decl;
    for a in e.attributes().with_checks(false).flatten() {
        let key = String::from_utf8_lossy(a.key.into_inner()).into_owned();
        let value = String::from_utf8_lossy(&a.value).into_owned();
        if key == "xmlns" || key.starts_with("xmlns:") {
            let taken = [
                "core", "gml", "xlink", "xsi", "xAL", "bldg", "app", "gen", "grp", "frn", "veg",
                "wtr", "luse", "dem", "tran", "brid", "tun", "con",
            ];
            let prefix = key.strip_prefix("xmlns:").unwrap_or("");
            if !Src::of(value.as_bytes()).rewritten() && !taken.contains(&prefix) {
                tag += &format!(" {key}=\"{value}\"");
            }
        } else if a.key.local_name().into_inner() == b"schemaLocation" {
            // the foreign (ADE) pairs stay
            let words: Vec<&str> = value.split_whitespace().collect();
            for pair in words.chunks(2) {
                if let [ns, at] = pair {
                    if !Src::of(ns.as_bytes()).rewritten() {
                        loc += &format!(" {ns} {at}");
                    }
                }
            }
        } else if a.key.local_name().into_inner() == b"id" {
            tag += &format!(" gml:id=\"{value}\"");
        }
    }
    tag += &format!(" xsi:schemaLocation=\"{loc}\">");
    Ok((tag, name, from.to_string()))
}

/// The bytes after the last member with the root's end tag as `core:CityModel`.
fn end_tag(b: &[u8], root_name: &str) -> Vec<u8> {
    let pat = format!("</{root_name}");
    match memchr::memmem::rfind(b, pat.as_bytes()) {
        Some(i) => {
            let mut v = b[..i].to_vec();
            v.extend_from_slice(b"</core:CityModel");
            v.extend_from_slice(&b[i + pat.len()..]);
            v
        }
        None => b.to_vec(),
    }
}

#[cfg(test)]
mod tests;
