//! The mixed writer's plan ([`plan`]), made one chunk of whole top-level members at a time: each chunk is indexed ([`index::scan_chunk`]), planned and its index
//! dropped, so that the writer's memory follows the chunk, not the document. The chunks are
//! those of the streamed read ([`crate::io::citygml::read::member_chunks`]). While a chunk is
//! filled and planned, the next one is indexed on a thread of its own (`skylod-plan`): one
//! chunk's index more in memory (about a chunk's share of the writer's 32 bytes an element and
//! 16 an id), every check against the chunks before still made in document order.
//!
//! A chunk's plan is the whole document's restricted to the chunk where nothing of the
//! document outside the chunk decides anything in it. What could, and how it is handled:
//!
//! * a reference (`xlink:href`, appearance target `#id`) whose target is not in its chunk
//!   (in another member, at the root, or nowhere): the plan declines;
//! * a gml:id of a chunk also met in an earlier one (the whole index resolves an id to its
//!   first element): the plan declines. The hashes of the ids of the chunks before are kept
//!   ([`SeenIds`], 7 to 7.75 bytes an id: the one part that grows with the document);
//! * a fresh `skylod_` id must not meet any id of the document: a candidate is checked against
//!   its chunk's ids and the hashes of the chunks before, and a chunk holding an id handed out
//!   before declines;
//! * a namespace prefix redeclared below the root (where `skylod_level` takes its prefixes
//!   from): a chunk redeclaring one the first chunk does not declines;
//! * the root's envelopes bound what every chunk writes: they are planned last, from the
//!   union of the chunks' written boxes;
//! * the counts of the summary are summed.
//!
//! A declined plan (`None`) is made again on the whole index, as is a plan whose chunk does
//! not index alone (a chunk that does not end between two members of the root, a read error:
//! the whole index reports it).

use super::encode::IdPool;
use super::id_table::IdTable;
use super::plan::{self, Plan, Scope, Shared};
use super::plan_model::PlanModel;
use super::{index, MixedSummary};
use crate::io::citygml::error::WriteError;
use crate::io::citygml::read::{member_chunks, ReadOptions, SeenIds};
use crate::io::citygml::source::{self, Bytes, Loaded};
use crate::io::citygml::write::{envelope_xml, Edit};
use crate::lod::rough::RoughGeometry;
use crate::model::{Bbox, CityModel, Source};
use foldhash::HashSet;

/// The edits that write `file` of `m` at `levels`, and what they do: planned a chunk of
/// about `chunk_bytes` at a time, each chunk's assets and buildings given their polygons
/// ([`PlanModel::fill`]) while it is planned (module docs); where the document is one chunk,
/// or a chunk's plan declines, on the index of the whole document with every asset and
/// building given its polygons (for a hollow read, the memory of the whole read).
///
/// # Errors
/// The document cannot be indexed; a hollow read's polygons cannot be read back.
pub(super) fn plan(
    m: &mut dyn PlanModel,
    parts: (usize, &[RoughGeometry], &[u8]),
    keep_envelopes: bool,
    chunk_bytes: u64,
) -> Result<(Vec<Edit>, MixedSummary), WriteError> {
    let planned = plan_in_chunks(m, parts, keep_envelopes, chunk_bytes, true);
    m.empty();
    if let Some(p) = planned {
        return Ok(p);
    }
    let (n, b) = (m.model().assets.len(), m.model().buildings.len());
    let all = |n: usize| (0..n).map(|i| u32::try_from(i).unwrap_or(u32::MAX));
    let (assets, buildings): (Vec<u32>, Vec<u32>) = (all(n).collect(), all(b).collect());
    if !m.fill(&assets, &buildings, parts.2) {
        return Err(WriteError::Invalid(format!(
            "{}: the polygons to write could not be read again",
            m.model().files[parts.0].path.display()
        )));
    }
    let p = super::plan_file_with(m.model(), m.facts(), parts, keep_envelopes, true);
    m.empty();
    p
}

/// The chunked plan of [`plan`] (`None` where it declines), the index of chunk k + 1 made
/// while chunk k is filled and planned
/// where `ahead` (on a thread named `skylod-plan`; where none is to be had, in its turn). Only
/// the index moves: it reads nothing the plan of an earlier chunk decides (the bytes, the
/// skip spans, the options), so it is the same index; every check of a chunk against the
/// chunks before it (ids met or handed out before, prefixes redeclared, references that
/// dangle) is made in document order as without `ahead`. At most one index more than
/// without `ahead` is held: the next chunk's, made while the current one is planned.
fn plan_in_chunks(
    m: &mut dyn PlanModel,
    (file, rough, levels): (usize, &[RoughGeometry], &[u8]),
    keep_envelopes: bool,
    chunk_bytes: u64,
    ahead: bool,
) -> Option<(Vec<Edit>, MixedSummary)> {
    let model = m.model();
    let src = &model.files[file];
    let Source::File(path) = &src.source else {
        return None;
    };
    if chunk_bytes >= src.len {
        return None;
    }
    let Ok(Loaded::Plain(bytes @ Bytes::Mapped(_))) = source::load_source(&src.source, path) else {
        return None;
    };
    if bytes.len() as u64 != src.len {
        return None;
    }
    let src_path = src.path.clone();
    let opts = ReadOptions::default();
    let chunks = member_chunks(&bytes, &src_path, &opts, chunk_bytes).ok()?;
    if chunks.ranges.len() < 2 {
        return None;
    }
    let fh = std::fs::File::open(path).ok()?;
    // the first chunk holds the prolog
    let bounds: Vec<(u64, u64)> = (chunks.ranges.iter().enumerate())
        .map(|(k, &(a, b))| (if k == 0 { 0 } else { a as u64 }, b as u64))
        .collect();
    let containers = plan::containers(model, file, levels);
    let skip = plan::skip_spans(model, file, levels, &containers);
    // the index of chunk k, its bytes let go after it (they are not read again: a private
    // read-only map reads the file again if they are)
    let scan = |k: usize| {
        let (from, to) = bounds[k];
        let lo = skip.partition_point(|s| s.start < from);
        let hi = skip.partition_point(|s| s.start < to);
        let doc = index::scan_chunk(&bytes, &fh, &src_path, &chunks, k, &skip[lo..hi], &opts);
        bytes.release_range(chunks.ranges[k].0, chunks.ranges[k].1);
        doc
    };
    let shared = Shared::new(model, file, containers);
    let [assets, buildings, envelopes] = plan::scope_lists(model, file, &bounds);
    let mut seen = SeenIds::default();
    let mut handed_out: HashSet<u64> = HashSet::default();
    let mut ids = IdPool::logging();
    let mut redeclared = None;
    let (mut edits, mut summary) = (Vec::new(), MixedSummary::default());
    let (mut root_sites, mut root_box) = (Vec::new(), Bbox::EMPTY);
    // a plan that declines leaves the scope once the index made ahead is done
    std::thread::scope(|threads| {
        let mut next = None;
        for k in 0..bounds.len() {
            let doc = match next.take() {
                // a thread that panicked: planned whole
                Some(made) => std::thread::ScopedJoinHandle::join(made).ok()?,
                None => scan(k),
            };
            if ahead && k + 1 < bounds.len() {
                let thread = std::thread::Builder::new().name("skylod-plan".into());
                // no thread to be had: the next chunk is indexed in its turn
                next = thread.spawn_scoped(threads, move || scan(k + 1)).ok();
            }
            let mut doc = doc.ok()?;
            let hashes: Vec<u64> = doc.ids.hashes().collect();
            if hashes.iter().any(|h| handed_out.contains(h)) {
                return None;
            }
            let before = seen.check_and_add_hashes(hashes);
            if !m.fill(&assets[k], &buildings[k], levels) {
                return None;
            }
            let model = m.model();
            if !before.is_empty() && looks_up(model, &doc, (&assets[k], &buildings[k]), &before) {
                return None;
            }
            let dangling = (doc.refs.iter()).any(|(_, _, target)| {
                target
                    .strip_prefix('#')
                    .is_some_and(|id| doc.id_node(id).is_none())
            });
            if dangling {
                return None;
            }
            match &redeclared {
                None => redeclared = Some(doc.redeclared.clone()),
                Some(first) if doc.redeclared.is_subset(first) => doc.redeclared = first.clone(),
                Some(_) => return None,
            }
            let elsewhere = |id: &str| seen.contains(IdTable::hash(id.as_bytes()));
            let scope = Scope {
                assets: &assets[k],
                buildings: &buildings[k],
                envelopes: &envelopes[k],
                shared: &shared,
                facts: m.facts(),
                defer_root: true,
                elsewhere: &elsewhere,
            };
            let mut plan = Plan::new(model, (file, rough, levels), scope, &doc, ids);
            plan.run(keep_envelopes);
            edits.append(&mut plan.edits());
            summary.add(&plan.summary);
            root_sites.append(&mut plan.root_sites);
            root_box.union(&plan.written_box);
            ids = plan.ids;
            handed_out.extend(ids.take_log());
            m.empty();
        }
        Some(())
    })?;
    let src = &m.model().files[file];
    for (e, bb) in root_sites {
        let env = &src.envelopes[e];
        if root_box.is_empty() {
            edits.push(Edit {
                span: bb,
                replacement: Vec::new(),
            });
            continue;
        }
        let mut site = env.clone();
        site.bbox = root_box;
        if let Some(xml) = envelope_xml(&site) {
            edits.push(Edit {
                span: env.span.clone(),
                replacement: xml.into_bytes(),
            });
        }
    }
    Some((edits, summary))
}

/// Could the plan of a chunk look up one of the ids `before` (hashes of ids of the chunk
/// met in an earlier one, where the whole index finds their first element)? The plan looks up
/// the targets of references and the ids of the polygons of its assets and buildings.
fn looks_up(
    model: &CityModel,
    doc: &super::doc::Doc,
    (assets, buildings): (&[u32], &[u32]),
    before: &HashSet<u64>,
) -> bool {
    let met = |id: &str| before.contains(&IdTable::hash(id.as_bytes()));
    let geometries = (assets.iter())
        .flat_map(|&a| &model.assets[a as usize].geometries)
        .chain(
            buildings
                .iter()
                .flat_map(|&b| &model.buildings[b as usize].geometries),
        );
    (doc.refs.iter()).any(|(_, _, t)| t.strip_prefix('#').is_some_and(met))
        || geometries
            .flat_map(|g| &g.polygons)
            .any(|p| p.id.as_deref().is_some_and(met))
}

#[cfg(test)]
mod tests {
    use super::super::tests::{citygml_files, house, patterns, read_in, real_files};
    use super::super::{plan_file, write_mixed_to};
    use super::*;
    use crate::io::citygml::read::read_file;
    use crate::io::citygml::write::{write_document_to, WriteOptions};
    use crate::lod::rough::{rough_model, RoughOptions};
    use std::path::{Path, PathBuf};

    /// The chunked plan of `model` read whole, `None` where it declines.
    fn plan_chunked(
        model: &CityModel,
        parts: (usize, &[RoughGeometry], &[u8]),
        keep_envelopes: bool,
        chunk_bytes: u64,
    ) -> Option<(Vec<Edit>, MixedSummary)> {
        let m = &mut super::super::plan_model::Whole(model);
        plan_in_chunks(m, parts, keep_envelopes, chunk_bytes, true)
    }

    /// The document `model` writes with `edits`.
    fn written(model: &CityModel, edits: Vec<Edit>) -> Vec<u8> {
        let mut v = Vec::new();
        let opts = WriteOptions {
            keep_envelopes: true,
            ..WriteOptions::default()
        };
        write_document_to(model, 0, edits, &mut v, &opts).unwrap();
        v
    }

    /// `f` as a plain file (a gzip-compressed one decompressed into `dir`: chunks are planned
    /// on plain files only).
    fn plain(f: &Path, dir: &Path, n: usize) -> Option<PathBuf> {
        if f.extension().is_none_or(|e| e != "gz") {
            return Some(f.to_path_buf());
        }
        let (mut r, _) = source::open(f).ok()?;
        let mut v = Vec::new();
        std::io::Read::read_to_end(&mut r, &mut v).ok()?; // a broken fixture
        let out = dir.join(format!("{n}.gml"));
        std::fs::write(&out, v).unwrap();
        Some(out)
    }

    /// Every real file and fixture, and the Ingolstadt street ([`street`]) made in `dir`.
    fn real_and_street(dir: &Path) -> Vec<PathBuf> {
        let mut files = real_files();
        files.extend(street(Path::new("../shared/data"), dir));
        files
    }

    /// `f` called with each of `files` that reads (as a plain file in `dir`) to a model with
    /// assets, and its rough geometry.
    fn each_model(
        files: &[PathBuf],
        dir: &Path,
        mut f: impl FnMut(&Path, &CityModel, &[RoughGeometry]),
    ) {
        for (n, file) in files.iter().enumerate() {
            let Some(Ok(model)) = plain(file, dir, n).map(|p| read_file(&p)) else {
                continue;
            };
            if model.files.is_empty() || model.assets.is_empty() {
                continue;
            }
            let rough = rough_model(&model, &RoughOptions::default());
            f(file, &model, &rough);
        }
    }

    /// Planned a member at a time (`chunk_bytes` 1) or on the whole index, every real file
    /// and fixture writes the same bytes with the same summary, for several level patterns,
    /// envelopes recomputed or kept; the chunks are planned where nothing crosses them (LoD2,
    /// LoD3, CityGML 3.0, appearances) and declined for the cross-member XLink example.
    #[test]
    fn chunks_write_the_bytes_of_the_whole_index() {
        let data = Path::new("../shared/data");
        let dir = tempfile::tempdir().unwrap();
        let (mut chunked, mut declined) = (Vec::new(), Vec::new());
        each_model(
            &real_and_street(dir.path()),
            dir.path(),
            |f, model, rough| {
                for (what, levels) in patterns(model) {
                    for keep in [false, true] {
                        let whole = plan_file(model, 0, rough, &levels, keep, true).unwrap();
                        let Some(parts) = plan_chunked(model, (0, rough, &levels), keep, 1) else {
                            declined.push(f.to_path_buf());
                            continue;
                        };
                        let at = format!("{}: {what}, keep {keep}", f.display());
                        assert_eq!(whole.1, parts.1, "{at}: summaries differ");
                        let (a, b) = (written(model, whole.0), written(model, parts.0));
                        assert!(a == b, "{at}: outputs differ");
                        chunked.push(f.to_path_buf());
                    }
                }
            },
        );
        let named = |v: &[PathBuf], s: &str| v.iter().any(|p| p.to_string_lossy().contains(s));
        if data.is_dir() {
            for s in [
                "street.gml",
                "kit-fzk-haus/citygml3",
                "ogc-citygml3-examples/",
                "ogc-citygml2-examples/appearance",
                "rotterdam",
            ] {
                assert!(named(&chunked, s), "no file of {s} planned in chunks");
            }
            assert!(named(&declined, "XLink_examples"), "cross-member XLinks");
        }
        assert!(chunked.len() >= 20, "{} plans in chunks", chunked.len());
    }

    /// The Ingolstadt street (every LoD3 building of `data/ingolstadt-lod3`, one a tile) as
    /// one document in `dir`, twice with the ids of the second copy renamed (as
    /// `../shared/tools/bench_inputs.py` makes the large files); `None` without the tiles.
    fn street(data: &Path, dir: &Path) -> Option<PathBuf> {
        const OPEN: &str = "<core:cityObjectMember>";
        const CLOSE: &str = "</core:cityObjectMember>";
        let mut tiles = Vec::new();
        citygml_files(&data.join("ingolstadt-lod3"), &mut tiles);
        let (mut head, mut body) = (None, String::new());
        for t in &tiles {
            let (mut r, _) = source::open(t).ok()?;
            let mut s = String::new();
            std::io::Read::read_to_string(&mut r, &mut s).ok()?;
            let (Some(i), Some(j)) = (s.find(OPEN), s.rfind(CLOSE)) else {
                continue;
            };
            head.get_or_insert_with(|| s[..i].to_string());
            body.push_str(&s[i..j + CLOSE.len()]);
            body.push('\n');
        }
        let copy = body
            .replace("gml:id=\"", "gml:id=\"c1_")
            .replace("xlink:href=\"#", "xlink:href=\"#c1_");
        let out = dir.join("street.gml");
        std::fs::write(&out, format!("{}{body}{copy}</core:CityModel>\n", head?)).ok()?;
        Some(out)
    }

    /// The house without its root appearance (whose targets are in both members).
    fn two_members() -> String {
        let h = house();
        let a = h.find("<app:appearanceMember>").unwrap();
        let b = h.find("</CityModel>").unwrap();
        format!("{}{}", &h[..a], &h[b..])
    }

    /// `xml` written at `levels` through `write_mixed_to`: the whole index's bytes, planned in
    /// chunks (`chunked`) or declined. The text, and the summary of the chunks.
    fn same(xml: &str, levels: &[u8], chunked: bool) -> (String, Option<MixedSummary>) {
        let dir = tempfile::tempdir().unwrap();
        let model = read_in(dir.path(), xml);
        let rough = rough_model(&model, &RoughOptions::default());
        let parts = plan_chunked(&model, (0, &rough, levels), false, 1);
        let whole = written(
            &model,
            plan_file(&model, 0, &rough, levels, false, true).unwrap().0,
        );
        let mut out = Vec::new();
        write_mixed_to(
            &model,
            0,
            &rough,
            levels,
            &mut out,
            &WriteOptions::default(),
        )
        .unwrap();
        assert_eq!(parts.is_some(), chunked, "planned in chunks");
        assert!(out == whole, "the bytes of the whole index");
        (String::from_utf8(out).unwrap(), parts.map(|p| p.1))
    }

    #[test]
    fn a_reference_across_members_declines() {
        // the root appearance targets both members
        same(&house(), &[1, 2, 0], false);
        let (text, summary) = same(&two_members(), &[1, 2, 0], true);
        // the root envelope bounds both chunks' geometry: the first member's roof (rough)
        // and wall, the second's roof dropped
        assert!(
            text.contains("<gml:upperCorner>4 4 5</gml:upperCorner>"),
            "{text}"
        );
        assert_eq!(summary.map(|s| s.buildings_dropped), Some(1));
    }

    #[test]
    fn fresh_ids_meet_the_ids_of_other_chunks() {
        // an id of an earlier chunk: known by its hash
        let xml = two_members().replace("gml:id=\"b1\"", "gml:id=\"skylod_r2_g0\"");
        let (text, _) = same(&xml, &[2, 2, 1], true);
        assert!(text.contains("gml:id=\"skylod_r2_g0_1\""), "{text}");
        // an id of a later chunk: declined, the whole index tells
        let xml = two_members().replace("gml:id=\"b2\"", "gml:id=\"skylod_r1_g0\"");
        let (text, _) = same(&xml, &[1, 2, 2], false);
        assert!(text.contains("gml:id=\"skylod_r1_g0_1\""), "{text}");
    }

    #[test]
    fn an_id_of_two_chunks_declines_where_it_is_looked_up() {
        // a building's id: never looked up
        let xml = two_members().replace("gml:id=\"b2\"", "gml:id=\"b1\"");
        same(&xml, &[1, 2, 0], true);
        // a polygon's id: the whole index finds the first
        let xml = two_members().replace("gml:id=\"p3\"", "gml:id=\"p1\"");
        same(&xml, &[1, 2, 2], false);
    }

    /// With the next chunk indexed ahead, a member a chunk, the plan is the plan of the chunks
    /// indexed in turn (the same edits and summary, or declined alike) on the fixtures
    /// (planned; declined at the first chunk, and at a later one while the next chunk is being
    /// indexed), every real file and the Ingolstadt street (hundreds of chunks).
    #[test]
    fn chunks_indexed_ahead_plan_as_in_turn() {
        let at_later = two_members().replace("gml:id=\"b2\"", "gml:id=\"skylod_r1_g0\"");
        let p1_twice = two_members().replace("gml:id=\"p3\"", "gml:id=\"p1\"");
        let four = {
            let h = two_members();
            let m = h.find("<cityObjectMember>").unwrap();
            let e = h.rfind("</CityModel>").unwrap();
            let copy = h[m..e]
                .replace("gml:id=\"", "gml:id=\"c1_")
                .replace("#", "#c1_");
            format!("{}{copy}{}", &h[..e], &h[e..])
        };
        let dir = tempfile::tempdir().unwrap();
        let mut files = Vec::new();
        // each with the levels its test above writes it at
        let fixtures = [
            (two_members(), vec![1, 2, 0]),
            (house(), vec![1, 2, 0]),
            (at_later, vec![1, 2, 2]),
            (p1_twice, vec![1, 2, 2]),
            (four, vec![1, 2, 0, 2, 1, 1]),
        ];
        let mut given = Vec::new();
        for (n, (xml, levels)) in fixtures.iter().enumerate() {
            let f = dir.path().join(format!("fixture{n}.gml"));
            std::fs::write(&f, xml).unwrap();
            given.push((f.clone(), levels.clone()));
            files.push(f);
        }
        files.extend(real_and_street(dir.path()));
        let (mut planned, mut declined) = (Vec::new(), Vec::new());
        each_model(&files, dir.path(), |f, model, rough| {
            let mut levels = patterns(model);
            let fixed = given.iter().filter(|(g, _)| g == f);
            levels.extend(fixed.map(|(_, l)| ("given", l.clone())));
            for (what, levels) in levels {
                let plan = |ahead| {
                    plan_in_chunks(
                        &mut super::super::plan_model::Whole(model),
                        (0, rough, &levels),
                        false,
                        1,
                        ahead,
                    )
                };
                let (on, off) = (plan(true), plan(false));
                let at = format!("{}: {what}", f.display());
                assert_eq!(on.is_some(), off.is_some(), "{at}: declined once");
                assert!(on == off, "{at}: the plans differ");
                match on {
                    Some(p) if !p.0.is_empty() => planned.push(f.to_path_buf()),
                    Some(_) => {}
                    None => declined.push(f.to_path_buf()),
                }
            }
        });
        let fixture =
            |v: &[PathBuf], n: usize| v.contains(&dir.path().join(format!("fixture{n}.gml")));
        for n in [0, 4] {
            assert!(fixture(&planned, n), "fixture {n} planned");
        }
        for n in [1, 2, 3] {
            assert!(fixture(&declined, n), "fixture {n} declined");
        }
        if Path::new("../shared/data").is_dir() {
            assert!(
                planned.iter().any(|p| p.ends_with("street.gml")),
                "the street"
            );
        }
    }
}
