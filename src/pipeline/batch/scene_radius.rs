//! `--scene-radius`: which inputs come within reach of the POIs, found without parsing them.
//!
//! A file's horizontal extent comes from the `gml:boundedBy/gml:Envelope` of its
//! `CityModel` (read from the first bytes of the document), or, when the model has none, from
//! a fast pre-scan of every `gml:pos`/`gml:posList` in it (numbers only, no geometry is
//! built). An input is needed when its extent comes within the radius of at least one POI
//! (horizontal distance from the point to the rectangle, in the CRS's units).
//!
//! # Example
//! ```
//! use glam::{DVec2, DVec3};
//! use skylod::pipeline::batch::Extent;
//! let tile = Extent { min: DVec2::new(0.0, 0.0), max: DVec2::new(100.0, 100.0) };
//! assert!(tile.within(&[DVec3::new(150.0, 50.0, 10.0)], 60.0));
//! assert!(!tile.within(&[DVec3::new(150.0, 150.0, 10.0)], 60.0));
//! ```

use glam::{DVec2, DVec3};
use quick_xml::events::Event;
use std::io::BufRead;
use std::path::{Path, PathBuf};

/// A horizontal rectangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extent {
    /// Lower corner (x, y).
    pub min: DVec2,
    /// Upper corner (x, y).
    pub max: DVec2,
}

/// Where an [`Extent`] came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExtentSource {
    /// The model's `gml:boundedBy` envelope.
    Envelope,
    /// A pre-scan of every coordinate.
    Scan,
}

/// Errors finding a file's extent.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExtentError {
    /// The file cannot be read.
    #[error("{}: {source}", crate::model::shown(.file))]
    Io {
        /// File.
        file: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// The XML is malformed.
    #[error("{}: byte {at}: {message}", crate::model::shown(.file))]
    Xml {
        /// File.
        file: PathBuf,
        /// Byte offset (decompressed).
        at: u64,
        /// What the XML parser says.
        message: String,
    },
}

impl Extent {
    /// Horizontal distance from `p` to the rectangle (0 inside).
    pub fn distance(&self, p: DVec3) -> f64 {
        let q = p.truncate();
        let d = (self.min - q).max(q - self.max).max(DVec2::ZERO);
        d.length()
    }

    /// Whether some point of `pois` is within `radius` of the rectangle.
    pub fn within(&self, pois: &[DVec3], radius: f64) -> bool {
        pois.iter().any(|&p| self.distance(p) <= radius)
    }

    fn grow(&mut self, p: DVec2) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    fn empty() -> Extent {
        Extent {
            min: DVec2::splat(f64::INFINITY),
            max: DVec2::splat(f64::NEG_INFINITY),
        }
    }

    fn is_valid(&self) -> bool {
        self.min.is_finite() && self.max.is_finite() && self.min.cmple(self.max).all()
    }
}

fn open(path: &Path) -> Result<Box<dyn BufRead>, ExtentError> {
    // standard input is held in memory and read from there (it is read again later)
    let (r, _) = crate::io::files::open_decoded(path).map_err(|source| ExtentError::Io {
        file: path.to_path_buf(),
        source,
    })?;
    Ok(r)
}

/// True for a CityJSON input (JSON by content, [`crate::io::cityjson::sniff`]).
fn is_json(path: &Path) -> bool {
    let Ok(mut r) = open(path) else {
        return false;
    };
    r.fill_buf()
        .is_ok_and(|h| crate::io::cityjson::sniff(h) == crate::io::cityjson::Sniffed::Json)
}

fn numbers(text: &[u8]) -> impl Iterator<Item = f64> + '_ {
    text.split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
        .filter_map(|t| std::str::from_utf8(t).ok()?.parse::<f64>().ok())
}

/// The horizontal extent of a CityGML file (`.gz` recognised by content) and where it came
/// from; `None` when the file holds no coordinate at all.
///
/// # Errors
/// [`ExtentError`] when the file cannot be read or its XML is malformed.
pub fn file_extent(path: &Path) -> Result<Option<(Extent, ExtentSource)>, ExtentError> {
    if let Some(e) = envelope(path)? {
        return Ok(Some((e, ExtentSource::Envelope)));
    }
    Ok(scan(path)?.map(|e| (e, ExtentSource::Scan)))
}

/// The next event of `r` into `buf`; malformed XML is [`ExtentError::Xml`] at the byte it
/// starts at.
fn next_event<'b>(
    r: &mut quick_xml::Reader<Box<dyn BufRead>>,
    buf: &'b mut Vec<u8>,
    path: &Path,
) -> Result<Event<'b>, ExtentError> {
    let at = r.buffer_position();
    r.read_event_into(buf).map_err(|e| ExtentError::Xml {
        file: path.to_path_buf(),
        at,
        message: e.to_string(),
    })
}

/// The root's `boundedBy/Envelope`, read until the root's first other child.
fn envelope(path: &Path) -> Result<Option<Extent>, ExtentError> {
    let mut r = quick_xml::Reader::from_reader(open(path)?);
    let mut buf = Vec::new();
    let mut stack: Vec<Vec<u8>> = Vec::new();
    let (mut lower, mut upper): (Option<Vec<f64>>, Option<Vec<f64>>) = (None, None);
    let mut corner: Option<bool> = None;
    loop {
        let ev = next_event(&mut r, &mut buf, path)?;
        match ev {
            Event::Start(e) => {
                let name = e.local_name().as_ref().to_vec();
                // Depth 1: children of the CityModel; anything but boundedBy, name,
                // description or metaDataProperty ends the search.
                if stack.len() == 1
                    && !matches!(
                        name.as_slice(),
                        b"boundedBy" | b"name" | b"description" | b"metaDataProperty"
                    )
                {
                    break;
                }
                let in_envelope = stack.len() == 3
                    && stack.get(1).is_some_and(|s| s == b"boundedBy")
                    && stack.get(2).is_some_and(|s| s == b"Envelope");
                corner = match name.as_slice() {
                    b"lowerCorner" if in_envelope => Some(true),
                    b"upperCorner" if in_envelope => Some(false),
                    _ => None,
                };
                stack.push(name);
            }
            Event::Text(t) => {
                if let Some(low) = corner {
                    let v: Vec<f64> = numbers(t.as_ref()).collect();
                    if low {
                        lower = Some(v);
                    } else {
                        upper = Some(v);
                    }
                }
            }
            Event::End(_) => {
                corner = None;
                stack.pop();
                if stack.is_empty() {
                    break;
                }
            }
            Event::Eof => break,
            _ => {}
        }
        buf.clear();
    }
    let (Some(l), Some(u)) = (lower, upper) else {
        return Ok(None);
    };
    let (Some(&[lx, ly]), Some(&[ux, uy])) = (l.get(..2), u.get(..2)) else {
        return Ok(None);
    };
    let e = Extent {
        min: DVec2::new(lx, ly),
        max: DVec2::new(ux, uy),
    };
    Ok(e.is_valid().then_some(e))
}

/// Every `pos`/`posList` of the file, numbers only (dimension from `srsDimension`, 3 by
/// default).
fn scan(path: &Path) -> Result<Option<Extent>, ExtentError> {
    let mut r = quick_xml::Reader::from_reader(open(path)?);
    let mut buf = Vec::new();
    let mut ext = Extent::empty();
    let mut dim: Option<usize> = None;
    loop {
        match next_event(&mut r, &mut buf, path)? {
            Event::Start(e) => {
                dim = match e.local_name().as_ref() {
                    b"pos" | b"posList" => Some(
                        e.try_get_attribute("srsDimension")
                            .ok()
                            .flatten()
                            .and_then(|a| std::str::from_utf8(&a.value).ok()?.trim().parse().ok())
                            .filter(|d| (2..=3).contains(d))
                            .unwrap_or(3),
                    ),
                    _ => None,
                };
            }
            Event::Text(t) => {
                if let Some(d) = dim {
                    let v: Vec<f64> = numbers(t.as_ref()).collect();
                    for c in v.chunks_exact(d) {
                        if let [x, y, ..] = c {
                            ext.grow(DVec2::new(*x, *y));
                        }
                    }
                }
            }
            Event::End(_) => dim = None,
            Event::Eof => break,
            _ => {}
        }
        buf.clear();
    }
    Ok(ext.is_valid().then_some(ext))
}

/// Which inputs come within reach of the POIs ([`within_reach`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Reach {
    /// Per input, in order: whether it is read (within reach, or unreadable: kept so that
    /// the reader reports it; a file without any coordinate is left out).
    pub keep: Vec<bool>,
    /// Inputs without an envelope, whose extent came from a pre-scan.
    pub scanned: usize,
}

/// The extents of `inputs` (in parallel) against the points `at`: which come within
/// `radius` (CRS units, horizontally) of one.
pub fn within_reach(inputs: &[PathBuf], at: &[DVec3], radius: f64) -> Reach {
    use rayon::prelude::*;
    let found: Vec<(bool, Option<ExtentSource>)> = inputs
        .par_iter()
        .map(|p| match file_extent(p) {
            // CityJSON has no XML envelope to pre-scan: always read
            _ if is_json(p) => (true, None),
            Ok(Some((e, how))) => (e.within(at, radius), Some(how)),
            // No coordinate at all: nothing of it can occlude.
            Ok(None) => (false, None),
            // Unreadable: kept, so that the reader reports it.
            Err(_) => (true, None),
        })
        .collect();
    Reach {
        scanned: found
            .iter()
            .filter(|(_, h)| *h == Some(ExtentSource::Scan))
            .count(),
        keep: found.into_iter().map(|(k, _)| k).collect(),
    }
}

/// The inputs of a run kept by [`keep_within`], and what to say of them.
#[derive(Debug, Clone, PartialEq)]
pub struct Kept {
    /// The inputs kept, in their order.
    pub inputs: Vec<PathBuf>,
    /// Inputs given.
    pub total: usize,
    /// POIs whose reach was tested (the shard's).
    pub pois: usize,
    /// Inputs without an envelope, whose extent came from a pre-scan.
    pub scanned: usize,
}

impl Kept {
    /// The inputs kept, as messages name them.
    pub fn names(&self) -> Vec<String> {
        (self.inputs.iter())
            .map(|p| crate::model::shown(p).to_string())
            .collect()
    }

    /// What to say of them for a scene of `radius` metres: kept of given, the POIs, the
    /// inputs not read and those pre-scanned, the names kept.
    pub fn line(&self, radius: f64) -> String {
        let kept = self.inputs.len();
        format!(
            "scene radius {radius} m: {kept} of {} input(s) within reach of {} POI(s) ({} not \
             read; {} without an envelope, pre-scanned): {}",
            self.total,
            self.pois,
            self.total - kept,
            self.scanned,
            self.names().join(", ")
        )
    }
}

/// `inputs` within `radius` of `pois` (`within_reach`), or of `shard`'s part of them: the
/// others are not read. Nothing kept while POIs are given usually means POIs in another
/// CRS; the caller says so.
pub fn keep_within(
    inputs: Vec<PathBuf>,
    pois: &[crate::model::Poi],
    shard: Option<super::shard::Shard>,
    radius: f64,
) -> Kept {
    let mut at: Vec<DVec3> = pois.iter().map(|p| p.position).collect();
    if let Some(s) = shard {
        at = at[s.pois(&at)].to_vec();
    }
    let total = inputs.len();
    let Reach { keep, scanned } = within_reach(&inputs, &at, radius);
    let inputs = (inputs.into_iter().zip(&keep))
        .filter(|(_, k)| **k)
        .map(|(p, _)| p)
        .collect();
    Kept {
        inputs,
        total,
        pois: at.len(),
        scanned,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kept_inputs_are_said_with_the_ones_left_out_and_scanned() {
        let k = Kept {
            inputs: vec!["t/a.gml".into()],
            total: 3,
            pois: 2,
            scanned: 1,
        };
        assert_eq!(
            k.line(50.0),
            "scene radius 50 m: 1 of 3 input(s) within reach of 2 POI(s) (2 not read; 1 \
             without an envelope, pre-scanned): t/a.gml"
        );
    }

    #[test]
    fn inputs_out_of_reach_of_the_shard_s_pois_are_left_out() {
        let d = tempfile::tempdir().unwrap();
        let env = |x: f64| {
            format!(
                "<gml:boundedBy><gml:Envelope><gml:lowerCorner>{x} 0 0</gml:lowerCorner>\
                 <gml:upperCorner>{} 10 5</gml:upperCorner></gml:Envelope></gml:boundedBy>",
                x + 10.0
            )
        };
        let near = file(d.path(), "near.gml", &env(0.0));
        let far = file(d.path(), "far.gml", &env(1000.0));
        let scan = file(
            d.path(),
            "scan.gml",
            "<core:cityObjectMember><gml:posList>1000 0 0 1010 10 0</gml:posList></core:cityObjectMember>",
        );
        let inputs = vec![near.clone(), far.clone(), scan.clone()];
        let pois = vec![
            crate::model::Poi::at("a", [5.0, 5.0, 1.0]),
            crate::model::Poi::at("b", [1005.0, 5.0, 1.0]),
        ];
        let all = keep_within(inputs.clone(), &pois, None, 20.0);
        assert_eq!(
            (all.inputs.len(), all.total, all.pois, all.scanned),
            (3, 3, 2, 1)
        );
        let one = keep_within(inputs.clone(), &pois[..1], None, 20.0);
        assert_eq!(one.inputs, vec![near.clone()]);
        assert_eq!(one.names(), vec![near.display().to_string()]);
        // Shard 1 of 2 takes the second POI (POIs grouped by place): the far files.
        let s: super::super::shard::Shard = "1/2".parse().unwrap();
        let second = keep_within(inputs.clone(), &pois, Some(s), 20.0);
        assert_eq!((second.inputs, second.pois), (vec![far, scan], 1));
        let none = keep_within(inputs, &pois, None, -1.0);
        assert!(none.inputs.is_empty());
    }

    const HEAD: &str = r#"<?xml version="1.0"?>
<core:CityModel xmlns:core="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml">
"#;

    fn file(dir: &Path, name: &str, body: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, format!("{HEAD}{body}</core:CityModel>\n")).unwrap();
        p
    }

    #[test]
    fn envelope_then_scan() {
        let d = tempfile::tempdir().unwrap();
        let with = file(
            d.path(),
            "a.gml",
            "<gml:boundedBy><gml:Envelope><gml:lowerCorner>10 20 0</gml:lowerCorner>\
             <gml:upperCorner>30 40 5</gml:upperCorner></gml:Envelope></gml:boundedBy>\
             <core:cityObjectMember><gml:posList>0 0 0 1000 1000 0</gml:posList></core:cityObjectMember>",
        );
        let (e, s) = file_extent(&with).unwrap().unwrap();
        assert_eq!(s, ExtentSource::Envelope);
        assert_eq!(
            (e.min, e.max),
            (DVec2::new(10.0, 20.0), DVec2::new(30.0, 40.0))
        );
        let without = file(
            d.path(),
            "b.gml",
            "<core:cityObjectMember><gml:posList>5 6 0 7 -8 1</gml:posList>\
             <gml:pos srsDimension=\"2\">1 9</gml:pos></core:cityObjectMember>",
        );
        let (e, s) = file_extent(&without).unwrap().unwrap();
        assert_eq!(s, ExtentSource::Scan);
        assert_eq!(
            (e.min, e.max),
            (DVec2::new(1.0, -8.0), DVec2::new(7.0, 9.0))
        );
        let nothing = file(d.path(), "c.gml", "");
        assert!(file_extent(&nothing).unwrap().is_none());
        assert!(file_extent(&d.path().join("none.gml")).is_err());
    }

    #[test]
    fn distance_to_a_rectangle() {
        let e = Extent {
            min: DVec2::ZERO,
            max: DVec2::new(10.0, 10.0),
        };
        assert_eq!(e.distance(DVec3::new(5.0, 5.0, 100.0)), 0.0);
        assert_eq!(e.distance(DVec3::new(13.0, 14.0, 0.0)), 5.0);
        assert_eq!(e.distance(DVec3::new(-2.0, 5.0, 0.0)), 2.0);
    }
}
