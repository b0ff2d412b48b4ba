//! The first pass over each input: its prolog, root start tag and namespace declarations,
//! `srsName`, envelope (or coordinate bounds), `gml:id`s and member kinds.

use crate::export::merge::Head;
use crate::io::citygml::error::ReadError;
use crate::io::citygml::ns::{classify, Ns};
use crate::io::citygml::source;
use crate::model::Bbox;
use glam::DVec3;
use quick_xml::events::Event;
use quick_xml::name::ResolveResult;
use quick_xml::{NsReader, Writer};
use std::collections::HashSet;
use std::path::Path;

/// A member element kind: namespace URI and local name.
pub(super) type Key = (Vec<u8>, Vec<u8>);

/// What the first pass learns about one input.
#[derive(Default)]
pub(super) struct Scan {
    /// Events before the root (declaration, comments), raw.
    pub(super) prolog: Vec<Vec<u8>>,
    /// Raw content of the root start tag (name and attributes).
    pub(super) root: Vec<u8>,
    /// Namespace URI of the root.
    pub(super) root_ns: Vec<u8>,
    /// Namespace declarations of the root: prefix ("" = default), URI.
    pub(super) decls: Vec<(Vec<u8>, Vec<u8>)>,
    /// `xsi:schemaLocation` of the root.
    pub(super) schema_location: Option<String>,
    /// What the plan needs: the root's namespace as the version, the root envelope's
    /// srsName (or the first of the document), every gml:id, the bounds of the root envelope
    /// (or of the coordinates when there is none).
    pub(super) head: Head,
    /// Member kinds in order of first appearance.
    pub(super) kinds: Vec<Key>,
}

pub(super) fn xml_err(path: &Path, pos: u64, e: impl std::fmt::Display) -> ReadError {
    ReadError::xml_at_byte(path, pos, e)
}

/// A merge's reader of one document ([`open`]).
pub(super) type Reader = NsReader<Box<dyn std::io::BufRead + Send>>;

/// The next event of `reader` into `buf`, with the byte it starts at; malformed XML is
/// [`ReadError::xml_at_byte`] of `path` there.
pub(super) fn next_event<'b>(
    reader: &mut Reader,
    buf: &'b mut Vec<u8>,
    path: &Path,
) -> Result<(u64, Event<'b>), ReadError> {
    let pos = reader.buffer_position();
    let ev = reader.read_event_into(buf);
    Ok((pos, ev.map_err(|e| xml_err(path, pos, e))?))
}

pub(super) fn open(path: &Path) -> Result<Reader, ReadError> {
    let (mut r, _) = source::open(path)?;
    source::skip_bom(&mut r, path)?;
    let mut reader = NsReader::from_reader(r);
    reader.config_mut().expand_empty_elements = false;
    reader.config_mut().trim_text(false);
    Ok(reader)
}

/// GML properties of a feature collection that come before its members.
pub(super) fn is_header(ns: &[u8], local: &[u8]) -> bool {
    classify(ns) == Ns::Gml
        && matches!(
            local,
            b"metaDataProperty"
                | b"description"
                | b"descriptionReference"
                | b"identifier"
                | b"name"
                | b"boundedBy"
                | b"location"
        )
}

pub(super) fn ns_of(r: ResolveResult<'_>) -> Vec<u8> {
    match r {
        ResolveResult::Bound(ns) => ns.as_ref().to_vec(),
        _ => Vec::new(),
    }
}

fn parse_coords(text: &str, dim: usize, lower: &mut [f64; 3], upper: &mut [f64; 3]) {
    let vals: Vec<f64> = text
        .split_ascii_whitespace()
        .filter_map(|t| t.parse().ok())
        .collect();
    if dim < 2 {
        return;
    }
    for p in vals.chunks_exact(dim) {
        for (i, v) in p.iter().take(3).enumerate() {
            lower[i] = lower[i].min(*v);
            upper[i] = upper[i].max(*v);
        }
    }
}
pub(super) fn scan(path: &Path) -> Result<Scan, ReadError> {
    let mut reader = open(path)?;
    let mut s = Scan::default();
    let (mut lower, mut upper) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    let mut has_root_envelope = false;
    let mut env_lower = [f64::INFINITY; 3];
    let mut env_upper = [f64::NEG_INFINITY; 3];
    let mut buf = Vec::new();
    let mut depth = 0usize;
    // Inside the root's gml:boundedBy (depth where it opened).
    let mut in_root_bound = false;
    // Collecting coordinates: the local name and dimension of the open coordinate element.
    let mut coord: Option<(&'static str, usize)> = None;
    let mut coord_text = String::new();
    let mut seen_ids = HashSet::new();
    let mut seen_kinds = HashSet::new();
    loop {
        let (pos, ev) = next_event(&mut reader, &mut buf, path)?;
        match ev {
            Event::Eof => break,
            Event::Decl(_) | Event::Comment(_) | Event::PI(_) | Event::DocType(_)
                if depth == 0 && s.root.is_empty() =>
            {
                let mut w = Writer::new(Vec::new());
                w.write_event(ev.borrow())
                    .map_err(|e| xml_err(path, pos, e))?;
                s.prolog.push(w.into_inner());
            }
            Event::Start(ref e) | Event::Empty(ref e) => {
                let empty = matches!(ev, Event::Empty(_));
                let (ns, local) = reader.resolve_element(e.name());
                let ns = ns_of(ns);
                let local = local.as_ref().to_vec();
                if depth == 0 {
                    s.root = e.to_vec();
                    s.root_ns = ns.clone();
                    s.head.version = String::from_utf8_lossy(&ns).into_owned();
                    s.head.shown = super::version_of(&ns);
                    for a in e.attributes().with_checks(false).flatten() {
                        let key = a.key.as_ref();
                        if key == b"xmlns" {
                            s.decls.push((Vec::new(), a.value.to_vec()));
                        } else if let Some(p) = key.strip_prefix(b"xmlns:") {
                            s.decls.push((p.to_vec(), a.value.to_vec()));
                        }
                    }
                } else if depth == 1 {
                    if !is_header(&ns, &local) && seen_kinds.insert((ns.clone(), local.clone())) {
                        s.kinds.push((ns.clone(), local.clone()));
                    }
                    in_root_bound = !empty && classify(&ns) == Ns::Gml && local == b"boundedBy";
                }
                for a in e.attributes().with_checks(false).flatten() {
                    let (ans, alocal) = reader.resolve_attribute(a.key);
                    let ans = ns_of(ans);
                    let value = || {
                        a.unescape_value()
                            .map(|v| v.into_owned())
                            .map_err(|err| xml_err(path, pos, err))
                    };
                    match alocal.as_ref() {
                        b"id" if classify(&ans) == Ns::Gml => {
                            let v = value()?;
                            if seen_ids.insert(v.clone()) {
                                s.head.ids.push(v);
                            }
                        }
                        b"srsName"
                            if ans.is_empty()
                                && (s.head.srs.is_none()
                                    || (in_root_bound && local == b"Envelope")) =>
                        {
                            s.head.srs = Some(value()?);
                        }
                        b"schemaLocation"
                            if depth == 0
                                && ans == b"http://www.w3.org/2001/XMLSchema-instance" =>
                        {
                            s.schema_location = Some(value()?);
                        }
                        _ => {}
                    }
                }
                if classify(&ns) == Ns::Gml && !empty {
                    let dim = e
                        .try_get_attribute("srsDimension")
                        .ok()
                        .flatten()
                        .and_then(|a| std::str::from_utf8(&a.value).ok()?.trim().parse().ok())
                        .unwrap_or(3usize);
                    coord = match local.as_slice() {
                        b"lowerCorner" if in_root_bound => Some(("lower", dim)),
                        b"upperCorner" if in_root_bound => Some(("upper", dim)),
                        b"pos" | b"posList" if !in_root_bound => Some(("pos", dim)),
                        _ => None,
                    };
                    coord_text.clear();
                }
                if !empty {
                    depth += 1;
                }
            }
            Event::Text(ref t) if coord.is_some() => {
                coord_text.push_str(&t.decode().map_err(|e| xml_err(path, pos, e))?);
            }
            Event::End(_) => {
                if let Some((what, dim)) = coord.take() {
                    match what {
                        "lower" | "upper" => {
                            let mut lo = [f64::INFINITY; 3];
                            let mut hi = [f64::NEG_INFINITY; 3];
                            parse_coords(&coord_text, dim, &mut lo, &mut hi);
                            if lo[0].is_finite() {
                                has_root_envelope = true;
                                let (l, h) = (&mut env_lower, &mut env_upper);
                                for i in 0..3 {
                                    if lo[i].is_finite() {
                                        l[i] = l[i].min(lo[i]);
                                        h[i] = h[i].max(hi[i]);
                                    }
                                }
                            }
                        }
                        _ => parse_coords(&coord_text, dim, &mut lower, &mut upper),
                    }
                }
                depth = depth.saturating_sub(1);
                if depth == 1 {
                    in_root_bound = false;
                }
            }
            _ => {}
        }
        buf.clear();
    }
    if s.root.is_empty() {
        return Err(ReadError::Empty(path.to_path_buf()));
    }
    if has_root_envelope {
        (lower, upper) = (env_lower, env_upper);
    }
    s.head.bbox = Bbox {
        min: DVec3::from_array(lower),
        max: DVec3::from_array(upper),
    };
    Ok(s)
}
