//! Rewriting every coordinate of a CityGML document through a point transform, span-preserving
//! (the machinery of `skylod reproject`; the PROJ transform itself is `crate::model::crs::proj`).
//!
//! One streaming pass over the source ([`quick_xml::NsReader`]) finds every coordinate in the
//! GML namespace and replaces the text of its element; everything else is copied byte for byte
//! by [`write_document`](super::write::write_document):
//!
//! * `posList`, `pos`, `coordinates` (its `cs`, `ts` and `decimal` kept), `lowerCorner` /
//!   `upperCorner` outside envelopes, and the `X`, `Y`, `Z` of a GML 2 `coord`. The dimension
//!   of a `posList` is its `srsDimension`, else the nearest ancestor's, else 3; a `pos` or a
//!   corner holds one point of 2 or 3 numbers. Transformed numbers are written as the writer
//!   writes numbers ([`push_num`]: the shortest decimal that reads back to the same `f64`);
//!   the third number (the height) is passed to the transform and written as it comes back,
//!   its original text kept when its value did not change.
//! * Implicit geometries: the `referencePoint` is a `pos` like any other; the translation of
//!   the `transformationMatrix` (elements 4, 8, 12 of the row-major 4×4) is a displacement of
//!   the template's origin from the reference point and becomes `T(r + d) - T(r)`, so that the
//!   template's origin lands where the transform sends it. The matrix's linear part and the
//!   template geometry (`relativeGMLGeometry` / `relativeGeometry`, left untouched) stay in
//!   the template's own units: for a geographic target this is reported as a warning.
//! * Every `srsName` attribute gets the target's name; a document that names no CRS gets it
//!   on its first envelope.
//! * A coordinate element holding anything but text (a comment, an entity reference) is an
//!   error, never left in the old CRS; what is not a coordinate list but depends on the CRS
//!   (a grid's `offsetVector`, a georeferenced texture's `orientation`) is left as it is with a
//!   warning.
//! * Every `gml:Envelope` is recomputed from the transformed coordinates inside its owner (the
//!   element whose `boundedBy` holds it) and the geometry its owner references by
//!   `xlink:href="#id"` (resolved at the end, forward references included), and written as
//!   the writer writes envelopes ([`envelope_xml`]); an owner with no coordinate at all gets
//!   the bounding box of its old envelope's eight corners, transformed.
//!
//! Memory: [`rewrite_edits`] holds the replacement texts until the end (envelopes come before
//! what they bound), about the size of the document's coordinate text; from [`STREAM_BYTES`]
//! on, [`rewrite_file`] rewrites in passes instead and holds the envelopes and the boxes of
//! the ids that references name ([`RewriteSource`]), not the coordinate text.
//!
//! # Example
//! ```
//! use glam::DVec3;
//! use skylod::export::transform::rewrite_file;
//! use skylod::io::citygml::WriteOptions;
//! let dir = tempfile::tempdir().unwrap();
//! let src = dir.path().join("in.gml");
//! std::fs::write(&src, br#"<CityModel xmlns="http://www.opengis.net/citygml/2.0"
//!  xmlns:gml="http://www.opengis.net/gml" xmlns:bldg="http://www.opengis.net/citygml/building/2.0">
//!  <gml:boundedBy><gml:Envelope srsName="EPSG:25832" srsDimension="3">
//!  <gml:lowerCorner>0 0 0</gml:lowerCorner><gml:upperCorner>2 1 3</gml:upperCorner>
//!  </gml:Envelope></gml:boundedBy>
//!  <cityObjectMember><bldg:Building gml:id="b"><bldg:lod1Solid><gml:Solid><gml:exterior>
//!  <gml:CompositeSurface><gml:surfaceMember><gml:Polygon><gml:exterior><gml:LinearRing>
//!  <gml:posList>0 0 0 2 0 0 2 1 3 0 0 0</gml:posList></gml:LinearRing></gml:exterior>
//!  </gml:Polygon></gml:surfaceMember></gml:CompositeSurface></gml:exterior></gml:Solid>
//!  </bldg:lod1Solid></bldg:Building></cityObjectMember></CityModel>"#).unwrap();
//! let out = dir.path().join("out.gml");
//! // A shift of 1000 m east, as a stand-in for a real CRS transform.
//! let shift = |pts: &mut [DVec3]| -> Result<(), String> {
//!     pts.iter_mut().for_each(|p| p.x += 1000.0);
//!     Ok(())
//! };
//! let s = rewrite_file(&src, &out, &shift, "EPSG:9999", &WriteOptions::default()).unwrap();
//! assert_eq!((s.points, s.envelopes, s.srs_names), (4, 1, 1));
//! let text = std::fs::read_to_string(&out).unwrap();
//! assert!(text.contains("<gml:posList>1000 0 0 1002 0 0 1002 1 3 1000 0 0</gml:posList>"));
//! assert!(text.contains(r#"<gml:Envelope srsName="EPSG:9999" srsDimension="3"><gml:lowerCorner>1000 0 0</gml:lowerCorner>"#));
//! ```

mod file;
mod streamed;

#[cfg(feature = "proj")]
pub use file::reproject_file;
pub use file::{reproject_with, CrsTransform, ReprojectError, ReprojectSummary};
pub use streamed::RewriteSource;

use crate::io::citygml::error::WriteError;
use crate::io::citygml::ns::{self, Module, Ns};
use crate::io::citygml::source;
use crate::io::citygml::write::{envelope_xml, escape_attr, push_num, Edit, WriteOptions};
use crate::model::{Bbox, EnvelopeSite};
use foldhash::{HashMap, HashMapExt, HashSet, HashSetExt};
use glam::DVec3;
use quick_xml::events::{BytesStart, Event};
use quick_xml::name::ResolveResult;
use quick_xml::NsReader;
use std::io::BufRead;
use std::path::Path;

/// A transform of points in the document's axis order, in place; `Err` names the problem.
pub type PointsFn<'a> = dyn Fn(&mut [DVec3]) -> Result<(), String> + 'a;

/// What [`rewrite_file`] did.
#[derive(Debug, Clone, PartialEq, Default)]
#[non_exhaustive]
pub struct RewriteSummary {
    /// Bytes written (before compression).
    pub bytes: u64,
    /// Points transformed (envelope corners not counted).
    pub points: usize,
    /// Elements whose coordinate text was replaced.
    pub elements: usize,
    /// `srsName` attributes replaced (on envelopes too).
    pub srs_names: usize,
    /// Envelopes recomputed.
    pub envelopes: usize,
    /// Implicit geometries whose matrix translation was transformed.
    pub implicit: usize,
    /// The distinct `srsName` values of the source, in order of appearance.
    pub source_srs_names: Vec<String>,
    /// Things not transformed, or transformed only in part.
    pub warnings: Vec<String>,
}

/// Write `src` to `out` with every coordinate passed through `transform` and every `srsName`
/// set to `target_srs` (module docs): [`RewriteSource::read`] then
/// [`RewriteSource::rewrite`] (in passes from `STREAM_BYTES` on). `opts.keep_envelopes` is
/// ignored (envelopes are always recomputed: the old ones are in the old CRS).
pub fn rewrite_file(
    src: &Path,
    out: &Path,
    transform: &PointsFn<'_>,
    target_srs: &str,
    opts: &WriteOptions,
) -> Result<RewriteSummary, WriteError> {
    RewriteSource::read(src)?.rewrite(out, transform, target_srs, opts, |_| Ok(()))
}

/// What the text of an element is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Carrier {
    PosList,
    Pos,
    Corner,
    Coordinates,
    /// `X`, `Y` or `Z` of a GML 2 `coord` (0, 1, 2).
    CoordPart(usize),
    Matrix,
}

/// An open element.
struct El {
    dim: Option<usize>,
    gml: bool,
    local: Vec<u8>,
}

/// A bounding-box frame: an element with a `gml:id` in the GML namespace, or an envelope owner.
struct Track {
    depth: usize,
    bbox: Bbox,
    refs: Vec<String>,
    id: Option<String>,
    envelopes: Vec<usize>,
}

struct Env {
    span: std::ops::Range<u64>,
    prefix: String,
    srs: bool,
    dim: u8,
    corners: Vec<DVec3>,
    bbox: Bbox,
    refs: Vec<String>,
}

struct Capture {
    carrier: Carrier,
    start: u64,
    text: Vec<u8>,
    dim: Option<usize>,
    cs: u8,
    ts: u8,
    decimal: u8,
    broken: bool,
}

/// A GML 2 `coord` being read: its depth, the values and texts of X, Y, Z and their spans.
type OpenCoord = (usize, [Option<(f64, String)>; 3], [std::ops::Range<u64>; 3]);

#[derive(Default)]
struct Implicit {
    matrix: Option<(std::ops::Range<u64>, Vec<String>)>,
    reference: Option<DVec3>,
}

/// Byte spans of the values of the attributes of a start tag (`raw` = the tag's bytes without
/// `<` and `>`; offsets relative to `raw`), with their raw names.
fn attribute_spans(raw: &[u8]) -> Vec<(&[u8], std::ops::Range<usize>)> {
    let mut out = Vec::new();
    let mut i = raw
        .iter()
        .position(|c| c.is_ascii_whitespace())
        .unwrap_or(raw.len());
    loop {
        while i < raw.len() && raw[i].is_ascii_whitespace() {
            i += 1;
        }
        let start = i;
        while i < raw.len() && raw[i] != b'=' && !raw[i].is_ascii_whitespace() {
            i += 1;
        }
        let name = &raw[start..i];
        while i < raw.len() && raw[i].is_ascii_whitespace() {
            i += 1;
        }
        if i >= raw.len() || raw[i] != b'=' {
            break;
        }
        i += 1;
        while i < raw.len() && raw[i].is_ascii_whitespace() {
            i += 1;
        }
        let Some(&q) = raw.get(i) else { break };
        if q != b'"' && q != b'\'' {
            break;
        }
        let vs = i + 1;
        let Some(len) = raw[vs..].iter().position(|&c| c == q) else {
            break;
        };
        out.push((name, vs..vs + len));
        i = vs + len + 1;
    }
    out
}

fn tokens(text: &[u8]) -> impl Iterator<Item = &[u8]> {
    text.split(|c| c.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
}

fn number(tok: &[u8]) -> Option<f64> {
    let v: f64 = fast_float2::parse(tok).ok()?;
    v.is_finite().then_some(v)
}

/// A number as written: the original token when the value did not change.
fn push_value(s: &mut String, new: f64, old: f64, old_text: &str) {
    if new == old {
        s.push_str(old_text);
    } else {
        push_num(s, new);
    }
}

/// What a pass over the document does (the streamed rewrite makes two: [`streamed`]).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Mode {
    /// Boxes and edits, all held until the end: [`rewrite_edits`].
    Whole,
    /// Boxes and envelopes only (every point transformed, no text kept).
    Boxes,
    /// Edits only, handed over as they come; no box is tracked.
    Write,
}

struct Scanner<'t, 'a> {
    path: &'a Path,
    mode: Mode,
    /// The ids worth a box (hashed by [`streamed::id_hash`]): those some `xlink:href` names;
    /// `None`: every id.
    wanted: Option<HashSet<u64>>,
    transform: &'t PointsFn<'t>,
    target_srs: &'a str,
    edits: Vec<Edit>,
    summary: RewriteSummary,
    stack: Vec<El>,
    tracks: Vec<Track>,
    ids: HashMap<String, (Bbox, Vec<String>)>,
    envs: Vec<Env>,
    env_open: Option<(usize, usize)>,
    template_depth: Option<usize>,
    ref_point_depth: Option<usize>,
    implicit: Option<(usize, Implicit)>,
    coord: Option<OpenCoord>,
    capture: Option<Capture>,
    srs_seen: HashSet<String>,
    warned: HashSet<&'static str>,
}

impl<'t, 'a> Scanner<'t, 'a> {
    fn new(path: &'a Path, transform: &'t PointsFn<'t>, target_srs: &'a str, mode: Mode) -> Self {
        Scanner {
            path,
            mode,
            wanted: None,
            transform,
            target_srs,
            edits: Vec::new(),
            summary: RewriteSummary::default(),
            stack: Vec::with_capacity(64),
            tracks: Vec::new(),
            ids: HashMap::new(),
            envs: Vec::new(),
            env_open: None,
            template_depth: None,
            ref_point_depth: None,
            implicit: None,
            coord: None,
            capture: None,
            srs_seen: HashSet::new(),
            warned: HashSet::new(),
        }
    }

    /// Whether boxes are tracked (not in [`Mode::Write`]).
    fn tracking(&self) -> bool {
        self.mode != Mode::Write
    }

    /// Whether edits are made (not in [`Mode::Boxes`]).
    fn recording(&self) -> bool {
        self.mode != Mode::Boxes
    }

    /// Whether the element with gml:id `id` gets a box of its own.
    fn wants(&self, id: &str) -> bool {
        self.tracking()
            && self
                .wanted
                .as_ref()
                .is_none_or(|w| w.contains(&streamed::id_hash(id)))
    }

    fn warn(&mut self, key: &'static str, message: String) {
        if self.warned.insert(key) {
            self.summary.warnings.push(message);
        }
    }

    fn apply(&self, pts: &mut [DVec3], at: u64) -> Result<(), WriteError> {
        (self.transform)(pts).map_err(|m| {
            WriteError::xml_at_byte(self.path, at, format!("cannot transform coordinates: {m}"))
        })
    }

    /// A transformed point inside the document's content: counts for the innermost frame.
    fn add_point(&mut self, p: DVec3) {
        if let Some(t) = self.tracks.last_mut() {
            t.bbox.add(p);
        }
    }

    fn start(
        &mut self,
        reader: &NsReader<Box<dyn BufRead + Send>>,
        e: &BytesStart,
        pos: u64,
        content_start: u64,
        empty: bool,
    ) -> Result<(), WriteError> {
        let (res, _) = reader.resolve_element(e.name());
        let kind = match res {
            ResolveResult::Bound(n) => ns::classify(n.0),
            _ => Ns::None,
        };
        let gml = kind == Ns::Gml;
        let core = matches!(kind, Ns::CityGml(Module::Core, _));
        let local = e.local_name().as_ref().to_vec();
        let depth = self.stack.len();
        if let Some(c) = &mut self.capture {
            c.broken = true;
        }
        // Attributes: srsName (replaced), srsDimension, cs/ts/decimal, gml:id, xlink:href.
        let raw: &[u8] = e;
        let mut dim = None;
        let (mut cs, mut ts, mut decimal) = (b',', b' ', b'.');
        let mut id = None;
        let mut had_srs = false;
        for (name, span) in attribute_spans(raw) {
            let value = &raw[span.clone()];
            let local_name = name.rsplit(|&c| c == b':').next().unwrap_or(name);
            let prefixed = name.contains(&b':');
            match local_name {
                b"srsName" if !prefixed => {
                    had_srs = true;
                    let v = String::from_utf8_lossy(value).into_owned();
                    if self.srs_seen.insert(v.clone()) {
                        self.summary.source_srs_names.push(v);
                    }
                    // +1: the tag's bytes start after '<'.
                    let at = pos + 1 + span.start as u64;
                    if self.recording() {
                        self.edits.push(Edit {
                            span: at..at + span.len() as u64,
                            replacement: escape_attr(self.target_srs).into_bytes(),
                        });
                    }
                    self.summary.srs_names += 1;
                }
                b"srsDimension" if !prefixed => {
                    dim = std::str::from_utf8(value)
                        .ok()
                        .and_then(|v| v.trim().parse::<usize>().ok())
                        .filter(|d| (2..=3).contains(d));
                }
                b"cs" | b"ts" | b"decimal" if !prefixed && value.len() == 1 => match local_name {
                    b"cs" => cs = value[0],
                    b"ts" => ts = value[0],
                    _ => decimal = value[0],
                },
                b"id" if prefixed && gml => {
                    id = Some(String::from_utf8_lossy(value).into_owned());
                }
                b"href" if prefixed => {
                    if let Some(r) = value.strip_prefix(b"#") {
                        let r = String::from_utf8_lossy(r).trim().to_string();
                        if self.env_open.is_none() {
                            if let Some(t) = self.tracks.last_mut() {
                                t.refs.push(r);
                            }
                        }
                    }
                }
                _ => {}
            }
        }
        let inherited = dim.or_else(|| self.stack.last().and_then(|p| p.dim));
        let in_template = self.template_depth.is_some();
        // Envelopes: the owner is the parent of the enclosing boundedBy.
        if gml && local == b"Envelope" && self.env_open.is_none() && !in_template && !empty {
            let owner_depth = depth.checked_sub(2);
            let under_bounded_by = depth >= 2
                && self
                    .stack
                    .last()
                    .is_some_and(|p| p.local == b"boundedBy" && p.gml);
            if let (Some(od), true) = (owner_depth, under_bounded_by) {
                if self.tracking() && self.tracks.last().is_none_or(|t| t.depth != od) {
                    self.tracks.push(Track {
                        depth: od,
                        bbox: Bbox::EMPTY,
                        refs: Vec::new(),
                        id: None,
                        envelopes: Vec::new(),
                    });
                }
                let qname = e.name();
                let qname = qname.as_ref();
                let prefix = match qname.iter().position(|&c| c == b':') {
                    Some(i) => String::from_utf8_lossy(&qname[..=i]).into_owned(),
                    None => String::new(),
                };
                let idx = self.envs.len();
                self.envs.push(Env {
                    span: pos..pos,
                    prefix,
                    srs: had_srs,
                    dim: dim.map_or(0, |d| d as u8),
                    corners: Vec::new(),
                    bbox: Bbox::EMPTY,
                    refs: Vec::new(),
                });
                if let Some(t) = self.tracks.last_mut() {
                    t.envelopes.push(idx);
                }
                self.env_open = Some((idx, depth));
            } else {
                self.warn(
                    "envelope",
                    "an Envelope outside a boundedBy was transformed corner by corner".into(),
                );
            }
        }
        let wanted = id.as_deref().is_some_and(|id| self.wants(id));
        if !empty && gml && wanted && !in_template && self.env_open.is_none() {
            self.tracks.push(Track {
                depth,
                bbox: Bbox::EMPTY,
                refs: Vec::new(),
                id,
                envelopes: Vec::new(),
            });
        }
        if core && (local == b"relativeGMLGeometry" || local == b"relativeGeometry") && !empty {
            self.template_depth.get_or_insert(depth);
        }
        if core && local == b"ImplicitGeometry" && !empty {
            self.implicit = Some((depth, Implicit::default()));
        }
        if core && local == b"referencePoint" && !empty {
            self.ref_point_depth = Some(depth);
        }
        if gml && local == b"coord" && !empty && !in_template {
            self.coord = Some((depth, [None, None, None], [0..0, 0..0, 0..0]));
        }
        if gml && local == b"offsetVector" {
            self.warn(
                "grid",
                "a gml grid's origin was transformed, its offsetVectors were left as they are"
                    .into(),
            );
        }
        if matches!(kind, Ns::CityGml(Module::Appearance, _)) && local == b"GeoreferencedTexture" {
            self.warn(
                "texture",
                "georeferenced textures: the reference point was transformed, the orientation \
                 was left as it is"
                    .into(),
            );
        }
        let carrier = match (gml, core, local.as_slice()) {
            (true, _, b"posList") => Some(Carrier::PosList),
            (true, _, b"pos") => Some(Carrier::Pos),
            (true, _, b"lowerCorner" | b"upperCorner") => Some(Carrier::Corner),
            (true, _, b"coordinates") => Some(Carrier::Coordinates),
            (true, _, b"X") => Some(Carrier::CoordPart(0)),
            (true, _, b"Y") => Some(Carrier::CoordPart(1)),
            (true, _, b"Z") => Some(Carrier::CoordPart(2)),
            (_, true, b"transformationMatrix") => Some(Carrier::Matrix),
            _ => None,
        };
        if let (Some(carrier), false) = (carrier, empty) {
            let wanted = match carrier {
                Carrier::Matrix => self.implicit.is_some() && !in_template,
                Carrier::CoordPart(_) => self.coord.is_some(),
                _ => !in_template,
            };
            if wanted {
                self.capture = Some(Capture {
                    carrier,
                    start: content_start,
                    text: Vec::new(),
                    dim: if carrier == Carrier::PosList {
                        inherited
                    } else {
                        dim
                    },
                    cs,
                    ts,
                    decimal,
                    broken: false,
                });
            }
        }
        if !empty {
            self.stack.push(El {
                dim: inherited,
                gml,
                local,
            });
        }
        Ok(())
    }

    fn end(&mut self, pos: u64, end: u64) -> Result<(), WriteError> {
        let depth = self.stack.len().saturating_sub(1);
        self.stack.pop();
        if let Some(c) = self.capture.take() {
            if c.broken {
                // Never leave coordinates in the old CRS under the new srsName.
                return Err(WriteError::xml_at_byte(
                    self.path,
                    c.start,
                    "a coordinate element holding elements, comments or entity references \
                     cannot be rewritten"
                        .into(),
                ));
            }
            self.finish_capture(c, pos)?;
        }
        if let Some((i, d)) = self.env_open {
            if d == depth {
                self.envs[i].span.end = end;
                // Fallback corners: the eight corners of the old box, transformed now.
                let c = std::mem::take(&mut self.envs[i].corners);
                if self.envs[i].dim == 0 {
                    self.envs[i].dim = if c.iter().all(|p| p.z.is_nan()) { 2 } else { 3 };
                }
                if c.len() == 2 && self.tracking() {
                    let (lo, hi) = (c[0], c[1]);
                    let z = |p: DVec3| if p.z.is_nan() { 0.0 } else { p.z };
                    let mut pts: Vec<DVec3> = (0..8)
                        .map(|k| {
                            DVec3::new(
                                if k & 1 == 0 { lo.x } else { hi.x },
                                if k & 2 == 0 { lo.y } else { hi.y },
                                if k & 4 == 0 { z(lo) } else { z(hi) },
                            )
                        })
                        .collect();
                    self.apply(&mut pts, pos)?;
                    self.envs[i].corners = pts;
                }
                self.env_open = None;
                if !self.tracking() {
                    // nothing refers to an envelope of the writing pass once it is read
                    self.envs.clear();
                }
            }
        }
        if self.template_depth == Some(depth) {
            self.template_depth = None;
        }
        if self.ref_point_depth == Some(depth) {
            self.ref_point_depth = None;
        }
        if self.coord.as_ref().is_some_and(|c| c.0 == depth) {
            if let Some((_, vals, spans)) = self.coord.take() {
                self.finish_coord(vals, spans, pos)?;
            }
        }
        if self.implicit.as_ref().is_some_and(|i| i.0 == depth) {
            if let Some((_, imp)) = self.implicit.take() {
                self.finish_implicit(imp, pos)?;
            }
        }
        if self.tracks.last().is_some_and(|t| t.depth == depth) {
            if let Some(t) = self.tracks.pop() {
                for &e in &t.envelopes {
                    let env = &mut self.envs[e];
                    env.bbox = t.bbox;
                    env.refs.clone_from(&t.refs);
                    if !t.bbox.is_empty() {
                        // the fallback corners are for an owner without coordinates
                        env.corners = Vec::new();
                    }
                }
                if let Some(parent) = self.tracks.last_mut() {
                    parent.bbox.union(&t.bbox);
                    parent.refs.extend(t.refs.iter().cloned());
                }
                if let Some(id) = t.id {
                    self.ids.insert(id, (t.bbox, t.refs));
                }
            }
        }
        Ok(())
    }

    fn finish_capture(&mut self, c: Capture, pos: u64) -> Result<(), WriteError> {
        let path = self.path;
        let bad = |m: String| WriteError::xml_at_byte(path, c.start, m);
        let text = String::from_utf8_lossy(&c.text).into_owned();
        match c.carrier {
            Carrier::CoordPart(k) => {
                let t = text.trim().to_string();
                let v =
                    number(t.as_bytes()).ok_or_else(|| bad(format!("{t:?} is not a number")))?;
                if let Some((_, vals, spans)) = &mut self.coord {
                    vals[k] = Some((v, t));
                    spans[k] = c.start..pos;
                }
                return Ok(());
            }
            Carrier::Matrix => {
                let toks: Vec<String> = tokens(text.as_bytes())
                    .map(|t| String::from_utf8_lossy(t).into_owned())
                    .collect();
                if toks.len() != 16 || toks.iter().any(|t| number(t.as_bytes()).is_none()) {
                    return Err(bad("transformationMatrix needs 16 numbers".into()));
                }
                if let Some((_, imp)) = &mut self.implicit {
                    imp.matrix = Some((c.start..pos, toks));
                }
                return Ok(());
            }
            _ => {}
        }
        // Points: values and their original texts.
        let mut vals: Vec<(f64, String)> = Vec::new();
        let mut tuples: Vec<usize> = Vec::new(); // numbers per point
        match c.carrier {
            Carrier::Coordinates => {
                let tuple_sep = |ch: &u8| {
                    if c.ts == b' ' {
                        ch.is_ascii_whitespace()
                    } else {
                        *ch == c.ts
                    }
                };
                for tuple in c.text.split(tuple_sep) {
                    let mut n = 0;
                    for v in tuple.split(|ch| *ch == c.cs) {
                        let v = v.trim_ascii();
                        if v.is_empty() {
                            continue;
                        }
                        let conv: Vec<u8> = v
                            .iter()
                            .map(|&ch| if ch == c.decimal { b'.' } else { ch })
                            .collect();
                        let x = number(&conv).ok_or_else(|| {
                            bad(format!("{:?} is not a number", String::from_utf8_lossy(v)))
                        })?;
                        vals.push((x, String::from_utf8_lossy(v).into_owned()));
                        n += 1;
                    }
                    if n > 0 {
                        if !(2..=3).contains(&n) {
                            return Err(bad(format!("a coordinate tuple of {n} numbers")));
                        }
                        tuples.push(n);
                    }
                }
            }
            _ => {
                for t in tokens(&c.text) {
                    let x = number(t).ok_or_else(|| {
                        bad(format!("{:?} is not a number", String::from_utf8_lossy(t)))
                    })?;
                    vals.push((x, String::from_utf8_lossy(t).into_owned()));
                }
                let n = vals.len();
                match c.carrier {
                    Carrier::PosList => {
                        let d = c.dim.unwrap_or(3);
                        if n % d != 0 {
                            return Err(bad(format!("{n} numbers in a posList of dimension {d}")));
                        }
                        tuples = vec![d; n / d];
                    }
                    _ => {
                        if n == 0 {
                            return Ok(());
                        }
                        if !(2..=3).contains(&n) {
                            return Err(bad(format!("a position of {n} numbers")));
                        }
                        tuples = vec![n];
                    }
                }
            }
        }
        // Inside an envelope: corners, not content.
        if let Some((i, _)) = self.env_open {
            if c.carrier == Carrier::Corner || c.carrier == Carrier::Pos {
                let z = if vals.len() == 3 { vals[2].0 } else { f64::NAN };
                if vals.len() >= 2 {
                    self.envs[i]
                        .corners
                        .push(DVec3::new(vals[0].0, vals[1].0, z));
                }
            }
            return Ok(());
        }
        let mut pts: Vec<DVec3> = Vec::with_capacity(tuples.len());
        let mut k = 0;
        for &n in &tuples {
            let z = if n == 3 { vals[k + 2].0 } else { 0.0 };
            pts.push(DVec3::new(vals[k].0, vals[k + 1].0, z));
            k += n;
        }
        let original = pts.clone();
        self.apply(&mut pts, c.start)?;
        if self.ref_point_depth.is_some() {
            if let (Some((_, imp)), Some(p)) = (&mut self.implicit, original.first()) {
                imp.reference = Some(*p);
            }
        }
        for p in &pts {
            self.add_point(*p);
        }
        self.summary.points += pts.len();
        self.summary.elements += 1;
        if !self.recording() {
            return Ok(());
        }
        let mut s = String::with_capacity(c.text.len() + 16);
        let mut k = 0;
        for (i, (&n, p)) in tuples.iter().zip(&pts).enumerate() {
            let parts = [p.x, p.y, p.z];
            if i > 0 {
                if c.carrier == Carrier::Coordinates && c.ts != b' ' {
                    s.push(c.ts as char);
                } else {
                    s.push(' ');
                }
            }
            for j in 0..n {
                if j > 0 {
                    if c.carrier == Carrier::Coordinates {
                        s.push(c.cs as char);
                    } else {
                        s.push(' ');
                    }
                }
                let (old, old_text) = &vals[k + j];
                let before = s.len();
                push_value(&mut s, parts[j], *old, old_text);
                if c.carrier == Carrier::Coordinates && c.decimal != b'.' && *old != parts[j] {
                    let tail = s
                        .split_off(before)
                        .replace('.', &(c.decimal as char).to_string());
                    s.push_str(&tail);
                }
            }
            k += n;
        }
        self.edits.push(Edit {
            span: c.start..pos,
            replacement: s.into_bytes(),
        });
        Ok(())
    }

    fn finish_coord(
        &mut self,
        vals: [Option<(f64, String)>; 3],
        spans: [std::ops::Range<u64>; 3],
        pos: u64,
    ) -> Result<(), WriteError> {
        let (Some(x), Some(y)) = (&vals[0], &vals[1]) else {
            return Err(WriteError::xml_at_byte(
                self.path,
                pos,
                "a coord without X or Y".into(),
            ));
        };
        let z = vals[2].as_ref().map_or(0.0, |v| v.0);
        let mut p = [DVec3::new(x.0, y.0, z)];
        self.apply(&mut p, pos)?;
        let recording = self.recording();
        for (k, v) in vals.iter().enumerate().filter(|_| recording) {
            if let Some((old, text)) = v {
                let mut s = String::new();
                push_value(&mut s, p[0][k], *old, text);
                self.edits.push(Edit {
                    span: spans[k].clone(),
                    replacement: s.into_bytes(),
                });
            }
        }
        self.add_point(p[0]);
        self.summary.points += 1;
        self.summary.elements += 1;
        Ok(())
    }

    fn finish_implicit(&mut self, imp: Implicit, pos: u64) -> Result<(), WriteError> {
        let Some((span, toks)) = imp.matrix else {
            return Ok(());
        };
        let Some(r) = imp.reference else {
            self.warn(
                "implicit-ref",
                "an implicit geometry without a reference point kept its matrix".into(),
            );
            return Ok(());
        };
        let v: Vec<f64> = toks.iter().filter_map(|t| number(t.as_bytes())).collect();
        let d = DVec3::new(v[3], v[7], v[11]);
        let mut pts = [r, r + d];
        self.apply(&mut pts, pos)?;
        let nd = pts[1] - pts[0];
        self.summary.implicit += 1;
        self.warn(
            "implicit",
            "implicit geometries: reference point and matrix translation transformed; the \
             template and the matrix's linear part stay in the template's units"
                .into(),
        );
        if !self.recording() {
            return Ok(());
        }
        let mut s = String::new();
        for (i, t) in toks.iter().enumerate() {
            if i > 0 {
                s.push(' ');
            }
            match i {
                3 => push_value(&mut s, nd.x, d.x, t),
                7 => push_value(&mut s, nd.y, d.y, t),
                11 => push_value(&mut s, nd.z, d.z, t),
                _ => s.push_str(t),
            }
        }
        self.edits.push(Edit {
            span,
            replacement: s.into_bytes(),
        });
        Ok(())
    }

    /// Bounding box of the geometry an id names, with what it references (cycles cut).
    fn resolve(&self, refs: &[String], seen: &mut HashSet<String>, out: &mut Bbox) {
        for r in refs {
            if !seen.insert(r.clone()) {
                continue;
            }
            if let Some((b, more)) = self.ids.get(r) {
                out.union(b);
                self.resolve(more, seen, out);
            }
        }
    }

    /// The edits of every envelope, in document order; counted in the summary.
    fn envelope_edits(&mut self) -> Vec<Edit> {
        let mut edits = Vec::new();
        // A document that named no CRS at all names the new one on its first envelope.
        let unnamed = self.summary.source_srs_names.is_empty();
        for (k, env) in self.envs.iter().enumerate() {
            let mut b = env.bbox;
            let mut seen = HashSet::new();
            self.resolve(&env.refs, &mut seen, &mut b);
            if b.is_empty() {
                b = Bbox::of_points(&env.corners);
            }
            let site = EnvelopeSite {
                span: env.span.clone(),
                bbox: b,
                srs_name: (env.srs || (unnamed && k == 0)).then(|| self.target_srs.to_string()),
                dimension: env.dim,
                prefix: env.prefix.clone(),
                file: 0,
            };
            if let Some(text) = envelope_xml(&site) {
                edits.push(Edit {
                    span: env.span.clone(),
                    replacement: text.into_bytes(),
                });
            }
        }
        self.summary.envelopes = edits.len();
        edits
    }
}

/// The edits that rewrite the document at `path` (module docs), and what they do, for
/// [`write_document`](super::write::write_document) with [`WriteOptions::keep_envelopes`] set (the envelope edits are among
/// them). [`rewrite_file`] is this plus the write.
pub fn rewrite_edits(
    path: &Path,
    transform: &PointsFn<'_>,
    target_srs: &str,
) -> Result<(Vec<Edit>, RewriteSummary), WriteError> {
    let mut sc = Scanner::new(path, transform, target_srs, Mode::Whole);
    scan(&mut sc, &mut |_, _| Ok(()))?;
    let envelopes = sc.envelope_edits();
    sc.edits.extend(envelopes);
    Ok((sc.edits, sc.summary))
}

/// One pass of `sc` over its document; `after_end(sc, at)` after each end tag (`at`: the
/// byte after it). The document's length (decompressed).
fn scan(
    sc: &mut Scanner<'_, '_>,
    after_end: &mut dyn FnMut(&mut Scanner<'_, '_>, u64) -> Result<(), WriteError>,
) -> Result<u64, WriteError> {
    let path = sc.path;
    let (mut reader, _) = source::open(path)?;
    let base = source::skip_bom(&mut reader, path)?;
    let mut reader = NsReader::from_reader(reader);
    reader.config_mut().trim_text(false);
    reader.config_mut().check_end_names = true;
    let mut buf = Vec::with_capacity(64 * 1024);
    loop {
        let pos = reader.buffer_position() + base;
        let ev = match reader.read_event_into(&mut buf) {
            Ok(ev) => ev,
            Err(e) => {
                return Err(WriteError::xml_at_byte(
                    path,
                    reader.error_position() + base,
                    e.to_string(),
                ))
            }
        };
        let after = reader.buffer_position() + base;
        match ev {
            Event::Start(ref e) => sc.start(&reader, e, pos, after, false)?,
            Event::Empty(ref e) => sc.start(&reader, e, pos, after, true)?,
            Event::End(_) => {
                sc.end(pos, after)?;
                after_end(sc, after)?;
            }
            Event::Text(ref t) => {
                if let Some(c) = &mut sc.capture {
                    c.text.extend_from_slice(t);
                }
            }
            Event::CData(ref t) => {
                if let Some(c) = &mut sc.capture {
                    c.text.extend_from_slice(t);
                }
            }
            Event::Comment(_) | Event::PI(_) | Event::GeneralRef(_) => {
                if let Some(c) = &mut sc.capture {
                    c.broken = true;
                }
            }
            Event::Eof => return Ok(pos),
            _ => {}
        }
        buf.clear();
    }
}

#[cfg(test)]
mod tests;
