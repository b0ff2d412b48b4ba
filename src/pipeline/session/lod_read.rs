//! Which read the `lod` command takes (issue 22, "lod keeps only what the selection needs"):
//! the hollow read ([`crate::lod::hollow::read_hollow`]: per chunk of whole top-level
//! members, each asset's rough form and facts, its polygons dropped) or the whole read
//! ([`crate::pipeline::read_inputs`]), decided before any input is read ([`lod_read`]).
//!
//! The hollow read serves one input, a plain (uncompressed) CityGML file at or above the
//! streaming threshold of `stats` and `convert` ([`chunk_for`]: four chunks), whose tracing
//! frame is the identity (a projected CRS in metres: the hollow read makes its rough forms in
//! the document's coordinates). The CRS is told from the first city objects of the file
//! ([`head_model`]) with `--source-crs` over it, as the whole read's frame
//! ([`crate::pipeline::frame`]) tells it, and a CityGML output ([`LodRead::served`]: OBJ and
//! CityJSON are written from the whole read). Anything else is read whole, and [`WholeWhy`]
//! says why, for the info line of the command ([`LodRead::note`]); where the hollow read
//! itself declines ([`LodRead::read_hollow`] gives `None`) the command reads whole too.

use super::site::head_model;
use crate::model::crs::{model_crs, Crs, LocalFrame};
use crate::model::shown;
use crate::pipeline::batch::convert::chunk_for;
use std::path::PathBuf;

/// Bytes of the first chunk whose city objects tell the file's CRS ([`head_model`]).
const HEAD_BYTES: u64 = 64 << 10;

/// The read [`lod_read`] chooses.
#[derive(Debug, Clone, PartialEq)]
pub enum LodRead {
    /// Hollow, in chunks of `chunk` bytes ([`crate::io::citygml::read::Passes`]).
    Hollow {
        /// Bytes of a chunk.
        chunk: u64,
    },
    /// Whole, and why.
    Whole(WholeWhy),
}

/// Why `lod` reads its inputs whole ([`LodRead::Whole`]).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum WholeWhy {
    /// Not exactly one input.
    Inputs(usize),
    /// The streaming chunk is 0 (every file read whole).
    Off,
    /// Standard input (spooled to a temporary file whose name no message should show).
    Stdin,
    /// Under the streaming threshold ([`chunk_for`]): `bytes` against four chunks of `chunk`.
    Small {
        /// The file's size.
        bytes: u64,
        /// The chunk.
        chunk: u64,
    },
    /// Compressed, CityJSON, or a document whose first chunk does not stream.
    NotPlain,
    /// The tracing frame is not the identity (its CRS named).
    Frame(String),
    /// An option the hollow read does not serve (named as the command line names it).
    Option(String),
    /// An output other than CityGML (OBJ and CityJSON are written from the whole read; the
    /// levels, bound, report and CityGML writer run on the hollow read:
    /// [`super::hollow_study`]).
    NotServed,
}

impl std::fmt::Display for WholeWhy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            WholeWhy::Inputs(n) => write!(f, "{n} inputs: only a single input is read hollow"),
            WholeWhy::Off => write!(f, "the streaming chunk is 0"),
            WholeWhy::Stdin => write!(f, "standard input"),
            WholeWhy::Small { bytes, chunk } => write!(
                f,
                "{bytes} bytes, under the streaming threshold of four chunks of {chunk} bytes"
            ),
            WholeWhy::NotPlain => write!(
                f,
                "not a plain CityGML file (compressed, CityJSON, or its first objects do not stream)"
            ),
            WholeWhy::Frame(crs) => write!(f, "{crs} is not traced in its own coordinates"),
            WholeWhy::Option(o) => write!(f, "{o} is given"),
            WholeWhy::NotServed => write!(
                f,
                "OBJ and CityJSON outputs are written from the whole read"
            ),
        }
    }
}

/// The options of `lod` the hollow read does not serve, as [`lod_read`] takes whether each
/// is given: POIs in another CRS than the model's, POIs of a region, the reduce step.
pub const NOT_SERVED: [&str; 3] = ["--poi-crs", "--facade or --region", "--reduce"];

impl LodRead {
    /// This read as the `lod` command takes it for an output in CityGML (`citygml`) or not:
    /// a hollow read is read whole for another format ([`WholeWhy::NotServed`]).
    pub fn served(self, citygml: bool) -> LodRead {
        match self {
            LodRead::Hollow { .. } if !citygml => LodRead::Whole(WholeWhy::NotServed),
            read => read,
        }
    }

    /// The info line of a command that reads `inputs` (named by the first) this way: hollow
    /// in chunks, or whole and why; `None` for no input or a file read whole for being under
    /// the streaming threshold (the ordinary case, said by nothing).
    pub fn note(&self, inputs: &[PathBuf]) -> Option<String> {
        let input = shown(inputs.first()?);
        match self {
            LodRead::Whole(WholeWhy::Small { .. }) => None,
            LodRead::Whole(why) => Some(format!("{input}: lod reads whole ({why})")),
            LodRead::Hollow { chunk } => Some(format!(
                "{input}: lod reads hollow, in chunks of {chunk} bytes (what the selection needs, the rest read again where it is written)"
            )),
        }
    }
}

/// The read of `inputs` for `lod` (module docs): hollow in chunks of `chunk` bytes when there
/// is one input, not standard input (`stdin`: the input is its spool), a plain CityGML file
/// of at least four chunks whose frame, with `source_crs` over its `srsName`, is the identity;
/// else whole, with the first reason found (the cheap ones first: the file's first objects
/// are read only for a file large enough); whole too when an option of [`NOT_SERVED`] is
/// given (`given`: whether each is).
pub fn lod_read(
    inputs: &[PathBuf],
    stdin: bool,
    chunk: u64,
    source_crs: Option<&Crs>,
    given: [bool; NOT_SERVED.len()],
) -> LodRead {
    let whole = LodRead::Whole;
    if let Some((_, o)) = given.iter().zip(NOT_SERVED).find(|(g, _)| **g) {
        return whole(WholeWhy::Option(o.to_string()));
    }
    let [path] = inputs else {
        return whole(WholeWhy::Inputs(inputs.len()));
    };
    if chunk == 0 {
        return whole(WholeWhy::Off);
    }
    if stdin {
        return whole(WholeWhy::Stdin);
    }
    let Some(chunk) = chunk_for(path, chunk) else {
        let bytes = std::fs::metadata(path).map_or(0, |m| m.len());
        return whole(WholeWhy::Small { bytes, chunk });
    };
    // a compressed file counts ten times its size in `chunk_for`: told here
    let Some(head) = head_model(path, HEAD_BYTES.min(chunk)) else {
        return whole(WholeWhy::NotPlain);
    };
    let crs = model_crs(&head, source_crs);
    let (frame, _) = LocalFrame::new(&crs, &head.bbox());
    if !frame.is_identity() {
        return whole(WholeWhy::Frame(crs.to_string()));
    }
    LodRead::Hollow { chunk }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::test_support::fixture;

    const N: [bool; 3] = [false; 3];

    /// Each reason in turn on the district fixture and copies of it; the hollow read where
    /// none holds.
    #[test]
    fn lod_reads_hollow_only_one_large_plain_file_in_its_own_coordinates() {
        let path = fixture();
        let len = std::fs::metadata(&path).unwrap().len();
        let one = std::slice::from_ref(&path);
        let small = len / 4;
        assert_eq!(
            lod_read(one, false, small, None, N),
            LodRead::Hollow { chunk: small }
        );
        let two = [path.clone(), path.clone()];
        let why = |r: LodRead| match r {
            LodRead::Whole(w) => w,
            h => panic!("{h:?}"),
        };
        assert_eq!(
            why(lod_read(&two, false, small, None, N)),
            WholeWhy::Inputs(2)
        );
        assert_eq!(why(lod_read(one, false, 0, None, N)), WholeWhy::Off);
        assert_eq!(why(lod_read(one, true, small, None, N)), WholeWhy::Stdin);
        let w = why(lod_read(one, false, len / 4 + 1, None, N));
        assert_eq!(
            w,
            WholeWhy::Small {
                bytes: len,
                chunk: len / 4 + 1
            }
        );
        assert!(
            w.to_string().contains("under the streaming threshold"),
            "{w}"
        );
        // US feet over the file's metres: scaled to metres (a geographic CRS over these
        // coordinates, out of its range, would be taken as it is)
        let feet = Crs::parse_named("EPSG:2263").unwrap();
        let w = why(lod_read(one, false, small, Some(&feet), N));
        assert!(
            matches!(&w, WholeWhy::Frame(c) if c.contains("2263")),
            "{w:?}"
        );
        assert!(
            w.to_string()
                .ends_with("is not traced in its own coordinates"),
            "{w}"
        );
        let dir = tempfile::tempdir().unwrap();
        let gz = dir.path().join("x.gml.gz");
        let bytes = std::fs::read(&path).unwrap();
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        std::io::Write::write_all(&mut enc, &bytes).unwrap();
        std::fs::write(&gz, enc.finish().unwrap()).unwrap();
        assert_eq!(
            why(lod_read(
                std::slice::from_ref(&gz),
                false,
                small / 4,
                None,
                N
            )),
            WholeWhy::NotPlain
        );
        let r = lod_read(std::slice::from_ref(&gz), false, small / 4, None, N);
        let note = r.note(std::slice::from_ref(&gz)).unwrap();
        assert!(note.ends_with("lod reads whole (not a plain CityGML file (compressed, CityJSON, or its first objects do not stream))"), "{note}");
        let note = LodRead::Hollow { chunk: 1 }.note(std::slice::from_ref(&gz));
        assert!(note
            .unwrap()
            .contains("lod reads hollow, in chunks of 1 bytes"));
        assert_eq!(r.note(&[]), None);
        let quiet = LodRead::Whole(WholeWhy::Small { bytes: 1, chunk: 1 });
        assert_eq!(quiet.note(one), None);
        let served = LodRead::Hollow { chunk: 1 }.served(false);
        assert_eq!(served, LodRead::Whole(WholeWhy::NotServed));
        let served = LodRead::Hollow { chunk: 1 }.served(true);
        assert_eq!(served, LodRead::Hollow { chunk: 1 });
        // an option not served, the first named
        let w = why(lod_read(one, false, small, None, [false, true, true]));
        assert_eq!(w.to_string(), "--facade or --region is given");
    }
}
