//! Several CityGML documents merged into one ([`merge_named`]) by the plan of
//! [`crate::export::merge`]: the members' XML copied, their start tags rewritten where an id
//! is renamed or a reference follows one (`xlink:href="#id"`, an appearance target's
//! `uri="#id"` attribute and the `#id` text of an `app:target` element). The merged document
//! has
//!
//! * the XML declaration and the `CityModel` start tag of the **first** input, with the
//!   namespace declarations of every input added: a prefix the root does not declare yet is
//!   declared on the root; a prefix an input binds to another URI than the root does is
//!   declared again on each member copied from that input, so every element keeps its
//!   namespace. `xsi:schemaLocation` pairs of later inputs whose namespace the first does not
//!   list are appended;
//! * the first input's leading `gml:metaDataProperty`, `gml:description`, `gml:name` (and the
//!   other GML header properties before `gml:boundedBy`); those of later inputs, and every
//!   input's root `gml:location`, are left out;
//! * one `gml:boundedBy` envelope over all inputs: the union of the inputs' root envelopes (the
//!   skylod writers recompute them), or, for an input without one, of its `gml:pos` /
//!   `gml:posList` coordinates; in the `srsName` of the first input that names one;
//! * the members of every input (each child of the root after the header), in input order,
//!   grouped by member element (`cityObjectMember`, then `appearanceMember`, ... in the order
//!   they first appear), so that the CityGML 3.0 content model, which orders them, holds.
//!
//! # Example
//! ```
//! use skylod::export::merge_named;
//! use skylod::io::citygml::WriteOptions;
//! let dir = tempfile::tempdir().unwrap();
//! let doc = |x: f64| format!(r##"<core:CityModel xmlns:core="http://www.opengis.net/citygml/2.0"
//!  xmlns:gml="http://www.opengis.net/gml" xmlns:bldg="http://www.opengis.net/citygml/building/2.0"
//!  xmlns:xlink="http://www.w3.org/1999/xlink">
//!  <gml:boundedBy><gml:Envelope srsName="EPSG:25832"><gml:lowerCorner>{x} 0 0</gml:lowerCorner>
//!  <gml:upperCorner>{} 1 1</gml:upperCorner></gml:Envelope></gml:boundedBy>
//!  <core:cityObjectMember><bldg:Building gml:id="b"/></core:cityObjectMember>
//!  <core:cityObjectMember><bldg:Building gml:id="c"><bldg:consistsOfBuildingPart xlink:href="#b"/>
//!  </bldg:Building></core:cityObjectMember></core:CityModel>"##, x + 1.0);
//! let (a, b) = (dir.path().join("a.gml"), dir.path().join("b.gml"));
//! std::fs::write(&a, doc(0.0)).unwrap();
//! std::fs::write(&b, doc(5.0)).unwrap();
//! let out = dir.path().join("merged.gml");
//! let inputs = [a, b];
//! let s = merge_named(&inputs, &inputs, &out, &WriteOptions::default()).unwrap();
//! assert_eq!((s.members, s.ids_renamed, s.refs_rewritten), (4, 2, 1));
//! let text = std::fs::read_to_string(&out).unwrap();
//! assert!(text.contains(r#"gml:id="b__2""#) && text.contains(r##"xlink:href="#b__2""##));
//! assert!(text.contains("<gml:lowerCorner>0 0 0</gml:lowerCorner>"));
//! assert!(text.contains("<gml:upperCorner>6 1 1</gml:upperCorner>"));
//! ```

mod copy;
mod scan;

use super::{Head, MergeError, MergeSummary, Plan};
use crate::io::citygml::error::{ReadError, WriteError};
use crate::io::citygml::ns::{classify, Ns};
use crate::io::citygml::write::{check_target, WriteOptions};
use crate::io::files::CountingWriter;
use copy::{copy_children, xmlns_key, CopyError, Rewrite};
use quick_xml::escape::escape;
use quick_xml::events::attributes::Attribute;
use quick_xml::events::{BytesStart, Event};
use quick_xml::name::QName;
use quick_xml::Writer;
use std::io::Write;
use std::path::{Path, PathBuf};

use scan::{is_header, next_event, ns_of, open, scan, xml_err, Key};

/// A version as a refusal names it: the last segment of the root's namespace (`2.0`).
fn version_of(ns: &[u8]) -> String {
    String::from_utf8_lossy(ns.rsplit(|&c| c == b'/').next().unwrap_or(b"?")).into_owned()
}
/// Format a coordinate as the writers do: shortest round-trip decimal.
fn num(v: f64) -> String {
    if v == v.trunc() && v.abs() < 1e15 {
        format!("{}", v as i64)
    } else {
        format!("{v}")
    }
}
/// Refuse, before any work, inputs that cannot be merged once converted: different CityGML
/// versions, and — when `same_crs_needed` (outputs keep their input's CRS; not after a
/// reprojection to one target) — different CRSs. Reads only each document's head: the root
/// element, and up to its first `srsName` (at most [`HEAD_BYTES`] of XML; a document that
/// names none by then is not compared, the merge itself still checks it).
///
/// # Errors
/// [`MergeError::Version`], [`MergeError::Crs`], [`MergeError::Read`] for an input that cannot
/// be opened or whose head is not well-formed.
pub fn check_mergeable(inputs: &[PathBuf], same_crs_needed: bool) -> Result<(), MergeError> {
    let heads = inputs
        .iter()
        .map(|p| head(p))
        .collect::<Result<Vec<_>, _>>()?;
    let heads: Vec<&Head> = heads.iter().collect();
    super::check(&heads, "CityGML", &|k| inputs[k].clone(), same_crs_needed)
}

/// How far [`check_mergeable`] looks for a document's first `srsName`.
pub const HEAD_BYTES: u64 = 8 << 20;

/// The root's namespace and the first `srsName` within [`HEAD_BYTES`] of a document.
fn head(path: &Path) -> Result<Head, ReadError> {
    let mut reader = open(path)?;
    let mut buf = Vec::new();
    let mut root_ns = None;
    loop {
        if reader.buffer_position() > HEAD_BYTES && root_ns.is_some() {
            return Ok(head_named(root_ns, None));
        }
        buf.clear();
        let (pos, ev) = next_event(&mut reader, &mut buf, path)?;
        match ev {
            Event::Eof => return Ok(head_named(root_ns, None)),
            Event::Start(ref e) | Event::Empty(ref e) => {
                if root_ns.is_none() {
                    root_ns = Some(ns_of(reader.resolve_element(e.name()).0));
                }
                for a in e.attributes().with_checks(false).flatten() {
                    let (ans, alocal) = reader.resolve_attribute(a.key);
                    if alocal.as_ref() == b"srsName" && ns_of(ans).is_empty() {
                        let v = a
                            .unescape_value()
                            .map_err(|err| xml_err(path, pos, err))?
                            .into_owned();
                        return Ok(head_named(root_ns, Some(v)));
                    }
                }
            }
            _ => {}
        }
    }
}

/// The head of a document of root namespace `ns` naming `srs` (no ids, no box).
fn head_named(ns: Option<Vec<u8>>, srs: Option<String>) -> Head {
    let ns = ns.unwrap_or_default();
    Head {
        version: String::from_utf8_lossy(&ns).into_owned(),
        shown: version_of(&ns),
        srs,
        ..Head::default()
    }
}

/// Every `gml:id` of the CityGML document at `path` (plain or gzip), in document order, each
/// once: what [`super::rename_ids`] takes for one input of a merge.
///
/// # Errors
/// [`ReadError`] for a document that cannot be read or is not well-formed.
pub(crate) fn document_ids(path: &Path) -> Result<Vec<String>, ReadError> {
    Ok(scan(path)?.head.ids)
}

/// Merge the CityGML documents `inputs` (plain or gzip) into `out` (gzip when it ends in `.gz`;
/// `-` for standard output), written atomically, naming the inputs `names` (same length) in
/// the errors that refuse a merge: for documents staged in temporary files, the files they
/// were made from. See the module docs for the rules.
pub fn merge_named(
    inputs: &[PathBuf],
    names: &[PathBuf],
    out: &Path,
    opts: &WriteOptions,
) -> Result<MergeSummary, MergeError> {
    if inputs.is_empty() {
        return Err(MergeError::NoInput);
    }
    check_target(out, opts, inputs.iter().map(PathBuf::as_path))?;
    let mut summary = None;
    crate::io::files::atomic_write(out, |w| {
        let s = merge_into(inputs, names, w, out)?;
        let n = s.bytes;
        summary = Some(s);
        Ok::<u64, MergeError>(n)
    })?;
    summary.ok_or(MergeError::NoInput)
}

/// The merge written into `w`; `out` names the output in errors.
fn merge_into(
    inputs: &[PathBuf],
    names: &[PathBuf],
    w: &mut dyn Write,
    out: &Path,
) -> Result<MergeSummary, MergeError> {
    let name = |k: usize| names.get(k).unwrap_or(&inputs[k]).clone();
    if inputs.is_empty() {
        return Err(MergeError::NoInput);
    }
    let scans = inputs
        .iter()
        .map(|p| scan(p))
        .collect::<Result<Vec<_>, _>>()?;
    let heads: Vec<&Head> = scans.iter().map(|s| &s.head).collect();
    let plan = Plan::new(&heads, "CityGML", &name)?;
    let first = &scans[0];

    // Namespaces: the root's, plus what later inputs declare; conflicting prefixes go on the
    // members of the input that binds them differently.
    let mut decls: Vec<(Vec<u8>, Vec<u8>)> = first.decls.clone();
    let mut added: Vec<(Vec<u8>, Vec<u8>)> = Vec::new();
    let mut local_decls: Vec<Vec<(Vec<u8>, Vec<u8>)>> = vec![Vec::new(); scans.len()];
    for (k, s) in scans.iter().enumerate().skip(1) {
        for (p, u) in &s.decls {
            match decls.iter().find(|(q, _)| q == p) {
                None => {
                    decls.push((p.clone(), u.clone()));
                    added.push((p.clone(), u.clone()));
                }
                Some((_, v)) if v != u => local_decls[k].push((p.clone(), u.clone())),
                _ => {}
            }
        }
    }
    let schema_location = first.schema_location.as_ref().map(|sl| {
        let mut pairs: Vec<String> = sl.split_ascii_whitespace().map(str::to_string).collect();
        for s in scans.iter().skip(1) {
            let Some(other) = &s.schema_location else {
                continue;
            };
            let toks: Vec<&str> = other.split_ascii_whitespace().collect();
            for pair in toks.chunks_exact(2) {
                if !pairs.chunks_exact(2).any(|q| q[0] == pair[0]) {
                    pairs.push(pair[0].to_string());
                    pairs.push(pair[1].to_string());
                }
            }
        }
        pairs.join(" ")
    });

    // The root start tag of the first input, declarations added.
    let root = BytesStart::from_content(
        String::from_utf8_lossy(&first.root).into_owned(),
        first
            .root
            .iter()
            .position(|c| c.is_ascii_whitespace() || *c == b'/')
            .unwrap_or(first.root.len()),
    );
    let root_name = root.name().as_ref().to_vec();
    let mut new_root = BytesStart::new(String::from_utf8_lossy(&root_name).into_owned());
    for a in root.attributes().with_checks(false).flatten() {
        if a.key.local_name().as_ref() == b"schemaLocation"
            && a.key.prefix().is_some()
            && schema_location.is_some()
        {
            if let Some(sl) = &schema_location {
                new_root.push_attribute(Attribute {
                    key: a.key,
                    value: escape(sl.as_str()).as_bytes().to_vec().into(),
                });
            }
        } else {
            new_root.push_attribute(a);
        }
    }
    for (p, u) in &added {
        new_root.push_attribute(Attribute {
            key: QName(&xmlns_key(p)),
            value: u.clone().into(),
        });
    }

    // The envelope over all inputs.
    let (lower, upper) = (plan.bbox.min.to_array(), plan.bbox.max.to_array());
    let gml_prefix = decls
        .iter()
        .find(|(_, u)| classify(u) == Ns::Gml)
        .map(|(p, _)| p.clone());
    let envelope = lower[0].is_finite().then(|| {
        let dims = if lower[2].is_finite() { 3 } else { 2 };
        let fmt = |c: &[f64; 3]| c[..dims].iter().map(|v| num(*v)).collect::<Vec<_>>().join(" ");
        let (pre, decl) = match &gml_prefix {
            Some(p) if p.is_empty() => (String::new(), String::new()),
            Some(p) => (format!("{}:", String::from_utf8_lossy(p)), String::new()),
            None => (
                "gml:".to_string(),
                if first.root_ns.ends_with(b"/3.0") {
                    r#" xmlns:gml="http://www.opengis.net/gml/3.2""#.to_string()
                } else {
                    r#" xmlns:gml="http://www.opengis.net/gml""#.to_string()
                },
            ),
        };
        let srs_attr = (plan.srs.as_deref())
            .map(|n| format!(r#" srsName="{}""#, escape(n)))
            .unwrap_or_default();
        format!(
            "\n <{pre}boundedBy{decl}>\n  <{pre}Envelope{srs_attr} srsDimension=\"{dims}\">\n   \
             <{pre}lowerCorner>{}</{pre}lowerCorner>\n   <{pre}upperCorner>{}</{pre}upperCorner>\n  \
             </{pre}Envelope>\n </{pre}boundedBy>",
            fmt(&lower),
            fmt(&upper)
        )
    });

    // Member kinds in order of first appearance over all inputs.
    let mut kinds: Vec<Key> = Vec::new();
    for s in &scans {
        for k in &s.kinds {
            if !kinds.contains(k) {
                kinds.push(k.clone());
            }
        }
    }

    let mut members = 0usize;
    let mut refs_rewritten = 0usize;
    let bytes = {
        let mut cw = CountingWriter::new(w);
        let io = |e: std::io::Error| WriteError::Io {
            file: out.to_path_buf(),
            source: e,
        };
        if first.prolog.is_empty() {
            cw.write_all(br#"<?xml version="1.0" encoding="UTF-8"?>"#)
                .map_err(io)?;
            cw.write_all(b"\n").map_err(io)?;
        }
        for p in &first.prolog {
            cw.write_all(p).map_err(io)?;
            cw.write_all(b"\n").map_err(io)?;
        }
        {
            let mut xw = Writer::new(&mut cw);
            xw.write_event(Event::Start(new_root.borrow()))
                .map_err(io)?;
        }
        // The first input's header (name, description, ...), then the new envelope.
        copy_children(&inputs[0], &mut cw, None, &mut |ns, local| {
            is_header(ns, local) && !matches!(local, b"boundedBy" | b"location")
        })
        .map_err(|e| match e {
            CopyError::Read(r) => WriteError::Read(r),
            CopyError::Io(e) => io(e),
        })?;
        if let Some(env) = &envelope {
            cw.write_all(env.as_bytes()).map_err(io)?;
        }
        for kind in &kinds {
            for (k, p) in inputs.iter().enumerate() {
                if !scans[k].kinds.contains(kind) {
                    continue;
                }
                let ctx = Rewrite {
                    ids: &plan.renames[k],
                    decls: &local_decls[k],
                    rewritten: 0,
                };
                let mut ctx = Some(ctx);
                let n = copy_children(p, &mut cw, ctx.as_mut(), &mut |ns, local| {
                    ns == kind.0.as_slice() && local == kind.1.as_slice()
                })
                .map_err(|e| match e {
                    CopyError::Read(r) => WriteError::Read(r),
                    CopyError::Io(e) => io(e),
                })?;
                members += n;
                refs_rewritten += ctx.map_or(0, |c| c.rewritten);
            }
        }
        cw.write_all(b"\n</").map_err(io)?;
        cw.write_all(&root_name).map_err(io)?;
        cw.write_all(b">\n").map_err(io)?;
        cw.count()
    };
    Ok(MergeSummary {
        files: inputs.len(),
        members,
        ids_renamed: plan.ids_renamed(),
        refs_rewritten,
        bytes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use quick_xml::name::ResolveResult;
    use quick_xml::NsReader;

    fn doc(ns_default: bool, ids: &[&str], x: f64) -> String {
        let members: String = ids
            .iter()
            .map(|id| {
                if ns_default {
                    format!(r##"<cityObjectMember><bldg:Building gml:id="{id}"><bldg:lod1Solid xlink:href="#{id}"/></bldg:Building></cityObjectMember>"##)
                } else {
                    format!(r##"<core:cityObjectMember><bldg:Building gml:id="{id}"><bldg:lod1Solid xlink:href="#{id}"/></bldg:Building></core:cityObjectMember>"##)
                }
            })
            .collect();
        let (open, close) = if ns_default {
            (
                r#"<CityModel xmlns="http://www.opengis.net/citygml/2.0""#,
                "</CityModel>",
            )
        } else {
            (
                r#"<core:CityModel xmlns:core="http://www.opengis.net/citygml/2.0""#,
                "</core:CityModel>",
            )
        };
        format!(
            r#"<?xml version="1.0"?>{open} xmlns:gml="http://www.opengis.net/gml" xmlns:bldg="http://www.opengis.net/citygml/building/2.0" xmlns:xlink="http://www.w3.org/1999/xlink"><gml:name>n{x}</gml:name><gml:boundedBy><gml:Envelope srsName="EPSG:25832"><gml:lowerCorner>{x} 0 0</gml:lowerCorner><gml:upperCorner>{} 2 3</gml:upperCorner></gml:Envelope></gml:boundedBy>{members}{close}"#,
            x + 1.0
        )
    }

    fn merged(docs: &[String]) -> Result<(String, MergeSummary), MergeError> {
        let d = tempfile::tempdir().unwrap();
        let paths: Vec<PathBuf> = docs
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let p = d.path().join(format!("{i}.gml"));
                std::fs::write(&p, t).unwrap();
                p
            })
            .collect();
        let out = d.path().join("m.gml");
        let s = merge_named(&paths, &paths, &out, &WriteOptions::default())?;
        Ok((std::fs::read_to_string(out).unwrap(), s))
    }

    #[test]
    fn ids_and_hrefs_renamed_deterministically() {
        let (text, s) = merged(&[
            doc(false, &["a", "a__2"], 0.0),
            doc(true, &["a", "b"], 10.0),
            doc(false, &["a", "b"], -5.0),
        ])
        .unwrap();
        assert_eq!(s.members, 6);
        // 2nd: a -> a__2 is taken by the 1st, so a__2_2. 3rd: a -> a__3, b -> b__3.
        for id in ["a", "a__2", "a__2_2", "b", "a__3", "b__3"] {
            assert_eq!(
                text.matches(&format!(r#"gml:id="{id}""#)).count(),
                1,
                "{id}\n{text}"
            );
            assert!(text.contains(&format!(r##"xlink:href="#{id}""##)), "{id}");
        }
        assert_eq!(s.ids_renamed, 3);
        assert!(
            text.contains("<gml:lowerCorner>-5 0 0</gml:lowerCorner>"),
            "{text}"
        );
        assert!(
            text.contains("<gml:upperCorner>11 2 3</gml:upperCorner>"),
            "{text}"
        );
        // One header: the first input's name; one envelope.
        assert_eq!(text.matches("<gml:name>").count(), 1);
        assert_eq!(text.matches("boundedBy>").count(), 2);
        // The default namespace of the 2nd input, unbound in the 1st, is declared on the root.
        let root = text.split('>').nth(1).unwrap_or_default();
        assert!(
            root.contains(r#"xmlns="http://www.opengis.net/citygml/2.0""#),
            "{root}"
        );
        // Same bytes again.
        let (again, _) = merged(&[
            doc(false, &["a", "a__2"], 0.0),
            doc(true, &["a", "b"], 10.0),
            doc(false, &["a", "b"], -5.0),
        ])
        .unwrap();
        assert_eq!(text, again);
    }

    #[test]
    fn different_versions_or_crs_are_refused() {
        let v1 = doc(false, &["a"], 0.0).replace("citygml/2.0", "citygml/1.0");
        let e = merged(&[doc(false, &["a"], 0.0), v1]).unwrap_err();
        assert!(
            e.to_string().contains("CityGML 2.0") && e.to_string().contains("CityGML 1.0"),
            "{e}"
        );
        let other = doc(false, &["a"], 0.0).replace("EPSG:25832", "EPSG:4326");
        let e = merged(&[doc(false, &["a"], 0.0), other]).unwrap_err();
        assert!(e.to_string().contains("EPSG:4326"), "{e}");
        // Another spelling of the same CRS is fine.
        let same = doc(false, &["c"], 0.0).replace("EPSG:25832", "urn:ogc:def:crs:EPSG::25832");
        assert!(merged(&[doc(false, &["a"], 0.0), same]).is_ok());
    }

    #[test]
    fn a_prefix_bound_differently_is_declared_on_the_members() {
        let d = |uri: &str, id: &str| {
            format!(
                r#"<core:CityModel xmlns:core="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml" xmlns:x="{uri}"><core:cityObjectMember><x:Thing gml:id="{id}"/></core:cityObjectMember></core:CityModel>"#
            )
        };
        let (text, _) = merged(&[d("urn:one", "a"), d("urn:two", "b")]).unwrap();
        // Resolve every x:Thing with a namespace-aware reader.
        let mut r = NsReader::from_str(&text);
        let mut found = Vec::new();
        loop {
            match r.read_resolved_event().unwrap() {
                (ResolveResult::Bound(ns), Event::Empty(e))
                    if e.local_name().as_ref() == b"Thing" =>
                {
                    found.push(String::from_utf8(ns.as_ref().to_vec()).unwrap());
                }
                (_, Event::Eof) => break,
                _ => {}
            }
        }
        assert_eq!(found, ["urn:one", "urn:two"], "{text}");
    }

    #[test]
    fn envelope_from_coordinates_when_an_input_has_none() {
        let bare = r#"<core:CityModel xmlns:core="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml" xmlns:bldg="http://www.opengis.net/citygml/building/2.0"><core:cityObjectMember><bldg:Building gml:id="z"><gml:posList>100 1 1 101 1 50 100 1 1</gml:posList></bldg:Building></core:cityObjectMember></core:CityModel>"#;
        let (text, _) = merged(&[doc(false, &["a"], 0.0), bare.to_string()]).unwrap();
        assert!(
            text.contains("<gml:upperCorner>101 2 50</gml:upperCorner>"),
            "{text}"
        );
    }
}
