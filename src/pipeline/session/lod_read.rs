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
//! says why (for the info line of the command); where the hollow read
//! itself declines ([`super::Study::read_hollow`] gives `None`) the command reads whole too.
//!
//! **Whole where it fits.** The hollow read holds a chunk and what the selection keeps, the
//! whole read about the file's size (measured: 0.73 to 1.0 times it, LoD3 files of 225 MB to
//! 4 GB) in about the same wall time but less CPU. So a file that qualifies is read hollow
//! when the whole read would not fit in the memory `lod` may take ([`memory_budget`]): the
//! user's budget where one is given, else [`DEFAULT_BUDGET`] or half of what the system and
//! the job's control group have left ([`available_bytes`]: a Slurm job's `--mem`, a Kubernetes
//! container's memory limit), whichever is less. A district or a city tile is read whole as
//! before; a file of gigabytes is read hollow without being asked, its memory following the
//! chunk and not the file.

use super::site::head_model;
use crate::model::crs::{model_crs, Crs, LocalFrame};
use crate::model::runtime::available::available_bytes;
#[cfg(doc)]
use crate::pipeline::batch::convert::chunk_for;
use crate::pipeline::batch::convert::len_and_chunk;
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
    /// The whole read fits: the file's `bytes` within the memory `lod` may take
    /// (`memory_budget`).
    Fits {
        /// The file's size.
        bytes: u64,
        /// The memory `lod` may take, and whether the user set it (given).
        budget: Budget,
    },
    /// Compressed, CityJSON, or a document whose first chunk does not stream.
    NotPlain,
    /// The tracing frame is not the identity (its CRS named).
    Frame(String),
    /// An option the hollow read does not serve.
    Option(Unserved),
    /// An output other than CityGML (OBJ and CityJSON are written from the whole read; the
    /// levels, bound, report and CityGML writer run on the hollow read:
    /// [`super::Study::read_hollow`]).
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
            WholeWhy::Fits { bytes, budget } => {
                write!(f, "{} fit in {budget}", mib(*bytes))
            }
            WholeWhy::NotPlain => write!(
                f,
                "not a plain CityGML file (compressed, CityJSON, or its first objects do not stream)"
            ),
            WholeWhy::Frame(crs) => write!(f, "{crs} is not traced in its own coordinates"),
            WholeWhy::Option(o) => write!(f, "{o} are asked for"),
            WholeWhy::NotServed => write!(
                f,
                "OBJ and CityJSON outputs are written from the whole read"
            ),
        }
    }
}

/// The memory `lod` may take for its read when the user sets none: the whole read of a file
/// of up to about this size (a district, a city's tile, the 1 GB bench city) keeps its lower
/// CPU; a larger file is read hollow.
pub const DEFAULT_BUDGET: u64 = 1 << 30;

/// The memory `lod` may take (`memory_budget`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Budget {
    /// Set by the user, in bytes.
    Given(u64),
    /// Not set: `DEFAULT_BUDGET`, or half of what was available ([`available_bytes`]) where
    /// that is less, in bytes.
    Default(u64),
}

impl Budget {
    /// The bytes.
    pub fn bytes(self) -> u64 {
        match self {
            Budget::Given(b) | Budget::Default(b) => b,
        }
    }
}

impl std::fmt::Display for Budget {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Budget::Given(b) => write!(f, "the {} given", mib(*b)),
            Budget::Default(b) => write!(
                f,
                "the {} lod may take by default (1 GiB, or half the memory available where that is less)",
                mib(*b)
            ),
        }
    }
}

/// `b` bytes in MiB, for a message.
pub fn mib(b: u64) -> String {
    format!("{:.1} MiB", b as f64 / f64::from(1u32 << 20))
}

/// The memory `lod` may take: `given` (the user's), else [`DEFAULT_BUDGET`] or half of
/// what the system and the job's control group have left ([`available_bytes`]), whichever is
/// less (where what is left is not known, [`DEFAULT_BUDGET`]).
pub fn memory_budget(given: Option<u64>) -> Budget {
    match given {
        Some(b) => Budget::Given(b),
        None => Budget::Default(
            available_bytes().map_or(DEFAULT_BUDGET, |b| (b / 2).min(DEFAULT_BUDGET)),
        ),
    }
}

/// A size of memory: bytes, or with a unit of 1024s (`2G`, `2GB`
/// and `2GiB` are all 2^31 bytes; decimals allowed: `1.5G`).
///
/// # Errors
/// The text, and why it is not a size.
///
/// ```
/// use skylod::pipeline::session::memory_size;
/// assert_eq!(memory_size("1.5GiB"), Ok(3 << 29));
/// assert_eq!(memory_size("512M"), memory_size("536870912"));
/// assert!(memory_size("lots").is_err());
/// ```
pub fn memory_size(text: &str) -> Result<u64, String> {
    let config = parse_size::Config::new().with_binary();
    config
        .parse_size(text)
        .map_err(|e| format!("{e}: {text:?}"))
}

/// What the hollow read does not serve, each of which makes `lod` read whole.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unserved {
    /// POIs in another CRS than the model's.
    PoiCrs,
    /// POIs sampled over a facade or a region.
    Region,
    /// The reduce step of shards' levels.
    Reduce,
}

impl Unserved {
    /// Each, in the order [`lod_read`] takes whether it is given.
    pub const ALL: [Unserved; 3] = [Unserved::PoiCrs, Unserved::Region, Unserved::Reduce];
}

impl std::fmt::Display for Unserved {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Unserved::PoiCrs => "POIs in another CRS than the model's",
            Unserved::Region => "POIs over a facade or a region",
            Unserved::Reduce => "the reduce step of shards' levels",
        })
    }
}

impl LodRead {
    /// This read as the `lod` command takes it for an output in CityGML (`citygml`) or not:
    /// a hollow read is read whole for another format ([`WholeWhy::NotServed`]).
    pub fn served(self, citygml: bool) -> LodRead {
        match self {
            LodRead::Hollow { .. } if !citygml => LodRead::Whole(WholeWhy::NotServed),
            read => read,
        }
    }
}

/// The read of `inputs` for `lod` (module docs): hollow in chunks of `chunk` bytes when there
/// is one input, not standard input (`stdin`: the input is its spool), a plain CityGML file
/// of at least four chunks whose frame, with `source_crs` over its `srsName`, is the identity;
/// else whole, with the first reason found (the cheap ones first: the file's first objects
/// are read only for a file large enough); whole too when something of [`Unserved::ALL`] is
/// given (`given`: whether each of [`Unserved::ALL`] is); whole too when the file's size is within the memory
/// `lod` may take (`max_memory`, the user's, or half of what is available:
/// `memory_budget`; module docs).
pub fn lod_read(
    inputs: &[PathBuf],
    stdin: bool,
    chunk: u64,
    source_crs: Option<&Crs>,
    given: [bool; Unserved::ALL.len()],
    max_memory: Option<u64>,
) -> LodRead {
    let whole = LodRead::Whole;
    if let Some((_, o)) = given.iter().zip(Unserved::ALL).find(|(g, _)| **g) {
        return whole(WholeWhy::Option(o));
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
    // the file's metadata read once: for the threshold, the reason and the memory budget
    let (bytes, streamed) = len_and_chunk(path, chunk);
    let Some(chunk) = streamed else {
        return whole(WholeWhy::Small { bytes, chunk });
    };
    let budget = memory_budget(max_memory);
    if bytes <= budget.bytes() {
        return whole(WholeWhy::Fits { bytes, budget });
    }
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
    use crate::pipeline::test_support::{fixture, gzip_copy};

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
            lod_read(one, false, small, None, N, Some(0)),
            LodRead::Hollow { chunk: small }
        );
        let two = [path.clone(), path.clone()];
        let why = |r: LodRead| match r {
            LodRead::Whole(w) => w,
            h => panic!("{h:?}"),
        };
        assert_eq!(
            why(lod_read(&two, false, small, None, N, Some(0))),
            WholeWhy::Inputs(2)
        );
        assert_eq!(
            why(lod_read(one, false, 0, None, N, Some(0))),
            WholeWhy::Off
        );
        assert_eq!(
            why(lod_read(one, true, small, None, N, Some(0))),
            WholeWhy::Stdin
        );
        let w = why(lod_read(one, false, len / 4 + 1, None, N, Some(0)));
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
        let w = why(lod_read(one, false, small, Some(&feet), N, Some(0)));
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
        let gz = gzip_copy(&path, dir.path());
        assert_eq!(
            why(lod_read(
                std::slice::from_ref(&gz),
                false,
                small / 4,
                None,
                N,
                Some(0)
            )),
            WholeWhy::NotPlain
        );
        let served = LodRead::Hollow { chunk: 1 }.served(false);
        assert_eq!(served, LodRead::Whole(WholeWhy::NotServed));
        let served = LodRead::Hollow { chunk: 1 }.served(true);
        assert_eq!(served, LodRead::Hollow { chunk: 1 });
        // the whole read fits in the budget: whole; one byte short: hollow
        let fits = Budget::Given(len);
        let w = why(lod_read(one, false, small, None, N, Some(len)));
        assert_eq!(
            w,
            WholeWhy::Fits {
                bytes: len,
                budget: fits
            }
        );
        assert!(w.to_string().ends_with("MiB given"), "{w}");
        let r = lod_read(one, false, small, None, N, Some(len - 1));
        assert_eq!(r, LodRead::Hollow { chunk: small });
        let half = Budget::Default(len).to_string();
        assert!(half.contains("half the memory available"), "{half}");
        assert_eq!(memory_budget(Some(7)), Budget::Given(7));
        // by default never more than DEFAULT_BUDGET: a file of gigabytes is read hollow
        let b = memory_budget(None);
        assert!(
            matches!(b, Budget::Default(n) if n <= DEFAULT_BUDGET),
            "{b:?}"
        );
        // an option not served, the first named
        let w = why(lod_read(
            one,
            false,
            small,
            None,
            [false, true, true],
            Some(0),
        ));
        assert_eq!(w, WholeWhy::Option(Unserved::Region));
        assert_eq!(
            w.to_string(),
            "POIs over a facade or a region are asked for"
        );
    }
}
