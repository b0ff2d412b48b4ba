//! One large document read by several cores: the bytes after the root's start tag are cut
//! at the ends of top-level `cityObjectMember` elements, each part is parsed by its own
//! [`Parser`] (seeded with the root's start tag: namespaces, version, root frame), and the
//! parts' results are merged, in document order, into the state one parser reading the whole
//! document would have reached; the model is then assembled from it as usual.
//!
//! The split is invisible except in speed: wherever its result could differ from the serial
//! read's, it declines and the caller reads serially: for a DOCTYPE (entities), a root that
//! is no `CityModel`, a cut that does not close a child of the root (found when the part
//! before it ends inside an element, a comment or a CDATA section), relief geometry whose LoD
//! depends on an earlier part, and any error (the serial read then reports the first one, as
//! it does). The parts' gml:id logs are merged into one, whose duplicates are then found as
//! the serial read finds them (see `ids`).
//!
//! Lines are counted per part from the part's start (on demand, as the serial read does) and
//! made absolute when the parts are merged: a part's first line continues the line before it.

use super::events::{finish, parse_events, start_root, BOM, RELEASE_STEP};
use super::ids::INVALID_IDS_LISTED;
use super::state::{EnvOwner, IdRec, LineMark, Owner, Parser, Part, NO_REC};
use super::ReadOptions;
use crate::model::CityModel;
use quick_xml::NsReader;
use std::collections::hash_map::Entry;
use std::path::Path;

/// A document's prolog and root start tag, parsed ([`parse_head`]).
pub(super) struct Head<'d> {
    /// The parser that read them (it goes on with the root's first part).
    pub(super) parser: Parser<'d>,
    /// The reader over `body`, standing after the root's start tag.
    pub(super) reader: NsReader<&'d [u8]>,
    /// Bytes of the byte-order mark (0 or 3).
    pub(super) bom: usize,
    /// The document after the byte-order mark.
    pub(super) body: &'d [u8],
    /// Offset in `body` after the root's start tag: `body[..root_end]` is the prolog.
    pub(super) root_end: usize,
}

/// Parse the prolog and the root's start tag of `doc` (a whole uncompressed document), for a
/// read that goes on in parts (the split read, the stream). `Err` with why a part-wise read
/// does not apply: no `CityModel` root (or no well-formed start), or a DOCTYPE (entities).
pub(super) fn parse_head<'d>(
    doc: &'d [u8],
    path: &Path,
    opts: &ReadOptions,
) -> Result<Head<'d>, &'static str> {
    let bom = if doc.starts_with(&BOM) { 3 } else { 0 };
    let body = &doc[bom..];
    let mut parser = Parser::new(path, opts.clone(), doc);
    let reader = start_root(&mut parser, body, bom as u64, RELEASE_STEP)
        .filter(|_| parser.stack.len() == 1 && parser.root_is_model)
        .ok_or("no CityModel root")?;
    let root_end = usize::try_from(reader.buffer_position()).map_err(|_| "no CityModel root")?;
    let prolog = body.get(..root_end).ok_or("no CityModel root")?;
    if memchr::memmem::find(prolog, b"<!DOCTYPE").is_some() {
        return Err("a DOCTYPE");
    }
    Ok(Head {
        parser,
        reader,
        bom,
        body,
        root_end,
    })
}

/// Read `doc` (a whole uncompressed document) split across rayon's threads; `None` where the
/// split does not apply (document smaller than [`ReadOptions::split_min_bytes`], one thread)
/// or could differ from the serial read (see the module's documentation): read serially then.
/// `release(from, upto)` lets the memory of `doc[from..upto]` go (see
/// [`super::events::read_slice`]).
pub(super) fn read_split(
    doc: &[u8],
    path: &Path,
    opts: &ReadOptions,
    release: &(dyn Fn(usize, usize) + Sync),
) -> Option<CityModel> {
    let threads = rayon::current_num_threads();
    let n = match opts.split_parts {
        0 => threads,
        n => n,
    };
    if threads < 2 || n < 2 || (doc.len() as u64) < opts.split_min_bytes {
        return None;
    }
    let Head {
        parser: mut head,
        mut reader,
        bom,
        body,
        root_end,
    } = parse_head(doc, path, opts).ok()?;
    let prolog = &body[..root_end];
    // parts: [root_end, cut 1), [cut 1, cut 2), ..., [cut n-1, end) in body offsets
    let mut bounds = vec![root_end];
    bounds.extend(cuts(body, root_end, n));
    if bounds.len() < 2 {
        return None;
    }
    bounds.push(body.len());
    let ranges: Vec<(usize, usize)> = bounds.windows(2).map(|w| (w[0], w[1])).collect();
    let part_bytes = (body.len() - root_end) as u64 / ranges.len() as u64;
    head.expect_bytes(part_bytes);
    // the parts' resident bytes together as the serial read's
    let step = (RELEASE_STEP / ranges.len() as u64).max(4 << 20);
    // what a part's thread allocates, about (the paper district: 22 MB of its arena for a
    // 62 MB part), made writable in a few steps ahead of the parse
    let heap = usize::try_from(part_bytes / 2).unwrap_or(usize::MAX);
    let reserve = move || crate::model::runtime::mem::reserve_heap(heap);

    let first = ranges[0];
    let (first, rest) = rayon::join(
        move || {
            reserve();
            // the first part continues the parser that read the root's start tag
            *reader.get_mut() = body.get(first.0..first.1)?;
            let mut saw_root = true;
            let rel = |upto: usize| release(0, upto);
            parse_events(
                &mut head,
                &mut reader,
                bom as u64,
                &mut saw_root,
                (&rel, step),
                false,
            )
            .ok()?;
            Some(Done::new(head, 0, (first.1 + bom) as u64))
        },
        || {
            use rayon::prelude::*;
            ranges[1..]
                .par_iter()
                .map(|&(from, to)| {
                    let from_doc = (from + bom) as u64;
                    reserve();
                    let mut p = Parser::new(path, opts.clone(), doc);
                    p.expect_bytes(part_bytes);
                    let mut reader = start_root(&mut p, prolog, bom as u64, RELEASE_STEP)?;
                    let mut saw_root = true;
                    p.forget_root_start()?;
                    p.lines.set(LineMark {
                        line: 1,
                        line_start: from_doc,
                        counted_to: from_doc,
                    });
                    let base = from_doc.checked_sub(reader.buffer_position())?;
                    *reader.get_mut() = body.get(from..to)?;
                    let rel = |upto: usize| release(from + bom, upto);
                    parse_events(
                        &mut p,
                        &mut reader,
                        base,
                        &mut saw_root,
                        (&rel, step),
                        false,
                    )
                    .ok()?;
                    Some(Done::new(p, from_doc, (to + bom) as u64))
                })
                .collect::<Vec<_>>()
        },
    );
    let mut m = first?;
    if m.parser.stack.len() != 1 {
        return None;
    }
    let len = doc.len() as u64;
    let last = rest.len();
    for (i, d) in rest.into_iter().enumerate() {
        let d = d?;
        // every part but the last ends between two children of the root, the last one after it
        let depth = if i + 1 == last { 0 } else { 1 };
        if d.parser.stack.len() != depth {
            return None;
        }
        m.absorb(d)?;
    }
    let mut p = m.parser;
    p.stack.clear();
    p.event_pos = len;
    p.lines.set(LineMark {
        line: m.line,
        line_start: m.line_start,
        counted_to: len,
    });
    // an error (an unresolved xlink, limits) is reported by the serial read
    finish(p, len, true, false).ok()
}

/// The ends of `</…cityObjectMember>` end tags (body offsets after `>`) near the `n - 1` even
/// cut points of `body[from..]`, increasing, each followed by more of the document. A
/// candidate is confirmed by parsing: the part before it must end between two children of
/// the root.
pub(super) fn cuts(body: &[u8], from: usize, n: usize) -> Vec<usize> {
    const NAME: &[u8] = b"cityObjectMember>";
    let finder = memchr::memmem::Finder::new(NAME);
    let span = body.len().saturating_sub(from);
    let mut out: Vec<usize> = Vec::new();
    for i in 1..n {
        let mut at = from + span / n * i;
        if let Some(&prev) = out.last() {
            at = at.max(prev);
        }
        while let Some(hit) = body.get(at..).and_then(|b| finder.find(b)) {
            let m = at + hit;
            at = m + 1;
            if is_end_tag(body, m) {
                let cut = m + NAME.len();
                if cut < body.len() {
                    out.push(cut);
                }
                break;
            }
        }
    }
    out
}

/// True when the local name at `m` is preceded by `</` or `</prefix:`.
pub(super) fn is_end_tag(body: &[u8], m: usize) -> bool {
    let before = &body[..m];
    if before.ends_with(b"</") {
        return true;
    }
    let Some(without_colon) = before.strip_suffix(b":") else {
        return false;
    };
    let name = |c: &u8| c.is_ascii_alphanumeric() || matches!(c, b'_' | b'-' | b'.');
    let prefix_len = without_colon.iter().rev().take_while(|c| name(c)).count();
    prefix_len > 0 && without_colon[..without_colon.len() - prefix_len].ends_with(b"</")
}

/// One part's parser after its last event, and where lines stand at its end.
struct Done<'d> {
    parser: Parser<'d>,
    /// Line number at the part's end (relative to the part's start but for the first part).
    line: u64,
    /// Start of that line (file offset).
    line_start: u64,
    /// File offset of the part's start (0 for the first part: lines absolute).
    start: u64,
}

impl<'d> Done<'d> {
    fn new(mut parser: Parser<'d>, start: u64, end: u64) -> Self {
        parser.event_pos = end;
        let (line, line_start) = parser.line_mark();
        Done {
            parser,
            line,
            line_start,
            start,
        }
    }

    /// Append the next part.
    fn absorb(&mut self, d: Done<'d>) -> Option<()> {
        let fix = LineFix {
            line: self.line,
            shift: d.start.checked_sub(self.line_start)?,
        };
        self.parser.absorb(d.parser, &fix)?;
        if d.line > 1 {
            self.line_start = d.line_start;
        }
        self.line += d.line - 1;
        Some(())
    }
}

/// Relative lines of a part made absolute: `line` is the line the part starts on, `shift` the
/// part's start minus that line's start (columns on the part's first line).
struct LineFix {
    line: u64,
    shift: u64,
}

impl LineFix {
    fn line(&self, line: &mut u64) -> bool {
        let first = *line == 1;
        *line += self.line - 1;
        first
    }

    fn place(&self, line: &mut u64, column: &mut u64) {
        if self.line(line) {
            *column += self.shift;
        }
    }
}

impl Parser<'_> {
    /// Forget what reading the root's start tag produced besides the state every part needs
    /// (the first part keeps it); `None` if it produced more than a `CityModel` root can.
    pub(super) fn forget_root_start(&mut self) -> Option<()> {
        let clean = self.buildings.is_empty()
            && self.assets.is_empty()
            && self.envelopes.is_empty()
            && self.parts.is_empty()
            && self.polygon_elements == 0
            && self.implicit_count == 0;
        if !clean {
            return None;
        }
        self.warnings.clear();
        // the root's gml:id is logged by the first part: here the root encloses "no entry"
        self.id_log.clear();
        self.marks.get_mut().clear();
        for f in &mut self.stack {
            f.rec = NO_REC;
        }
        self.feature_counts.clear();
        self.ade_namespaces.clear();
        self.unknown_prefixes.clear();
        self.invalid_ids = 0;
        self.invalid_listed.clear();
        Some(())
    }

    /// Append the state of the next part of the document, read by `o`: indices offset,
    /// lines made absolute, counts summed, once-per-document warnings kept once. `None` where
    /// the serial read could have read the part differently (relief LoD from an earlier part).
    /// The part's gml:ids are appended to the log as the serial read logs them (warnings
    /// before each counted in the merged list, the root's entry for the root's children).
    fn absorb(&mut self, o: Parser<'_>, fix: &LineFix) -> Option<()> {
        if o.relief_default_used && self.relief_lod != 2 {
            return None;
        }
        let b0 = self.buildings.len();
        let a0 = self.assets.len();
        let p0 = u32::try_from(self.parts.len()).ok()?;
        let poly0 = u32::try_from(self.polys.len()).ok()?;
        let h0 = u32::try_from(self.hrefs.len()).ok()?;
        let i0 = u32::try_from(self.implicits.len()).ok()?;
        for mut b in o.buildings {
            b.parent = b.parent.map(|x| x + b0);
            b.assets.iter_mut().for_each(|x| *x += a0);
            fix.line(&mut b.line);
            self.buildings.push(b);
        }
        for mut a in o.assets {
            a.building = a.building.map(|x| x + b0);
            a.parent = a.parent.map(|x| x + a0);
            fix.line(&mut a.line);
            self.assets.push(a);
        }
        // a foreign namespace or undeclared prefix is warned about once per document
        let mut drop: Vec<usize> = Vec::new();
        for (key, at) in o.ade_namespaces {
            match self.ade_namespaces.entry(key) {
                Entry::Occupied(_) => drop.push(at),
                Entry::Vacant(v) => {
                    v.insert(0);
                }
            }
        }
        for (key, at) in o.unknown_prefixes {
            match self.unknown_prefixes.entry(key) {
                Entry::Occupied(_) => drop.push(at),
                Entry::Vacant(v) => {
                    v.insert(0);
                }
            }
        }
        drop.sort_unstable();
        let marks = self.marks.get_mut();
        for mut m in o.marks.into_inner() {
            if fix.line(&mut m.line) {
                m.line_start = m.line_start.saturating_sub(fix.shift);
            }
            marks.push(m);
        }
        let root_rec = self.stack.first().map_or(NO_REC, |f| f.rec);
        let log0 = u32::try_from(self.id_log.len()).ok()?;
        self.id_log.reserve(o.id_log.len());
        let mut ids = o.id_log.into_iter().peekable();
        // invalid ids are listed up to INVALID_IDS_LISTED per document, not per part
        let mut invalid = o.invalid_listed.into_iter().peekable();
        self.invalid_ids += o.invalid_ids;
        for (i, mut w) in o.warnings.into_iter().enumerate() {
            while let Some(r) = ids.next_if(|r| r.warnings as usize <= i) {
                self.log_merged(r, log0, root_rec);
            }
            if drop.binary_search(&i).is_ok() {
                continue;
            }
            if invalid.next_if_eq(&i).is_some() {
                if self.invalid_listed.len() >= INVALID_IDS_LISTED {
                    continue;
                }
                self.invalid_listed.push(self.warnings.len());
            }
            fix.place(&mut w.line, &mut w.column);
            w.file = self.shared_path.clone();
            self.warnings.push(w);
        }
        for r in ids {
            self.log_merged(r, log0, root_rec);
        }
        self.envelopes.extend(o.envelopes);
        self.env_owners
            .extend(o.env_owners.into_iter().map(|e| match e {
                EnvOwner::Root => EnvOwner::Root,
                EnvOwner::Building(b) => EnvOwner::Building(b + b0),
                EnvOwner::Asset(a) => EnvOwner::Asset(a + a0),
            }));
        self.implicit_count += o.implicit_count;
        self.library_objects.extend(o.library_objects);
        self.objects_without_geometry += o.objects_without_geometry;
        self.polygon_elements += o.polygon_elements;
        for (name, n) in o.feature_counts {
            match self.feature_counts.iter_mut().find(|(x, _)| *x == name) {
                Some((_, c)) => *c += n,
                None => self.feature_counts.push((name, n)),
            }
        }
        // the geometry arena
        self.polys.extend(o.polys);
        self.parts.extend(o.parts.into_iter().map(|p| match p {
            Part::Poly(i) => Part::Poly(i + poly0),
            Part::Href(i) => Part::Href(i + h0),
            Part::Implicit { idx, len } => Part::Implicit { idx: idx + i0, len },
        }));
        for mut h in o.hrefs {
            fix.place(&mut h.loc.line, &mut h.loc.column);
            self.hrefs.push(h);
        }
        self.implicits.extend(o.implicits);
        self.registry.append(o.registry, p0, log0)?;
        self.pending.extend(o.pending.into_iter().map(|mut g| {
            g.owner = match g.owner {
                Owner::Asset(a) => Owner::Asset(a + a0),
                Owner::Building(b) => Owner::Building(b + b0),
            };
            g.range = (g.range.0 + p0, g.range.1 + p0);
            g
        }));
        // document-wide state: as the serial read would have it after this part
        self.gml_prefix = self.gml_prefix.take().or(o.gml_prefix);
        self.version = self.version.or(o.version);
        if o.root_srs_set {
            self.srs_name = o.srs_name;
            self.root_srs_set = true;
        } else {
            self.srs_name = self.srs_name.take().or(o.srs_name);
        }
        if o.relief_lod_set {
            self.relief_lod = o.relief_lod;
            self.relief_lod_set = true;
        }
        Some(())
    }
}

impl Parser<'_> {
    /// Append entry `r` of a later part's gml:id log, whose entries start at `log0` in the
    /// merged log: its warnings counted in the merged list, its enclosing entry made global
    /// (none in the part: the root's, `root_rec`).
    fn log_merged(&mut self, mut r: IdRec, log0: u32, root_rec: u32) {
        r.warnings = u32::try_from(self.warnings.len()).unwrap_or(u32::MAX);
        r.parent = match r.parent {
            NO_REC => root_rec,
            p => p.saturating_add(log0),
        };
        self.id_log.push(r);
    }
}

/// [`read_split`] of `doc` in `parts` parts on two threads, whatever its size (for tests).
#[cfg(test)]
pub(super) fn read_split_on_two_threads(
    doc: &[u8],
    path: &Path,
    parts: usize,
) -> Option<CityModel> {
    let opts = ReadOptions {
        split_min_bytes: 0,
        split_parts: parts,
        ..ReadOptions::default()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    pool.install(|| read_split(doc, path, &opts, &|_, _| {}))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cuts_follow_member_end_tags_of_any_prefix() {
        let body = b"<M><cityObjectMember>a</cityObjectMember><core:cityObjectMember>b\
            </core:cityObjectMember><x:cityObjectMember/></ cityObjectMember><cityObjectMember>c\
            </cityObjectMember></M>";
        let ends: Vec<usize> = memchr::memmem::find_iter(body, b"Member>")
            .map(|m| m + 7)
            .collect();
        // one cut near the middle: the next end tag at or after it
        let c = cuts(body, 3, 2);
        assert_eq!(c.len(), 1);
        assert!(ends.contains(&c[0]), "{c:?}");
        assert!(
            body[..c[0]].ends_with(b"</core:cityObjectMember>")
                || body[..c[0]].ends_with(b"</cityObjectMember>")
        );
        // many parts asked for: increasing cuts, each at an end tag, none at the very end
        let c = cuts(body, 3, 8);
        assert!(c.windows(2).all(|w| w[0] < w[1]), "{c:?}");
        assert!(
            c.iter()
                .all(|x| *x < body.len() && is_end_tag(body, x - 17)),
            "{c:?}"
        );
        assert!(is_end_tag(b"</a:cityObjectMember>", 4));
        assert!(!is_end_tag(b"< /a:cityObjectMember>", 5));
        assert!(!is_end_tag(b"<a:cityObjectMember>", 3));
        assert!(!is_end_tag(b"</:cityObjectMember>", 3));
        // nothing to cut at
        assert!(cuts(b"<M><a/></M>", 3, 2).is_empty());
    }

    #[test]
    fn relief_lod_from_an_earlier_part_reads_serially() {
        let doc = |lod: &str| {
            let member = |i: usize| {
                format!(
                    r#"<cityObjectMember><dem:ReliefFeature gml:id="r{i}">{lod}<dem:reliefComponent><dem:TINRelief gml:id="t{i}">
<dem:tin><gml:TriangulatedSurface><gml:trianglePatches><gml:Triangle><gml:exterior><gml:LinearRing>
<gml:posList>0 0 0 1 0 0 1 1 0 0 0 0</gml:posList></gml:LinearRing></gml:exterior></gml:Triangle>
</gml:trianglePatches></gml:TriangulatedSurface></dem:tin></dem:TINRelief></dem:reliefComponent>
</dem:ReliefFeature></cityObjectMember>
"#
                )
            };
            let body: String = (0..8).map(member).collect();
            format!(
                r#"<CityModel xmlns="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml"
 xmlns:dem="http://www.opengis.net/citygml/relief/2.0">
{body}</CityModel>
"#
            )
        };
        let path = Path::new("relief.gml");
        let opts = ReadOptions::default();
        let serial = |d: &str| {
            super::super::events::read_slice(d.as_bytes(), path, false, &opts, &|_| {}).unwrap()
        };
        let split_read = |d: &str| read_split_on_two_threads(d.as_bytes(), path, 2);
        // relief LoD 1 set in the first part only: the split declines
        let first_only = doc("").replacen(
            "<dem:reliefComponent>",
            "<dem:lod>1</dem:lod><dem:reliefComponent>",
            1,
        );
        let split = split_read(&first_only);
        assert!(split.is_none());
        let m = serial(&first_only);
        assert!(m.assets.iter().all(|a| a.geometries[0].lod == 1));
        // set in every member: split, and the same model
        let every = doc("<dem:lod>1</dem:lod>");
        let split = split_read(&every);
        assert_eq!(split.as_ref(), Some(&serial(&every)));
        // never set: the default (2) everywhere
        let never = doc("");
        let split = split_read(&never);
        assert_eq!(split.as_ref(), Some(&serial(&never)));
    }
}
