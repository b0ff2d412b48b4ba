//! The info line that says which read `lod` takes and why, in the command line's words: the
//! library says why ([`WholeWhy`]), this names the flag that decided it.

use skylod::model::shown;
use skylod::pipeline::session::{mib, Budget, LodRead, Unserved, WholeWhy};
use std::path::PathBuf;

/// The info line of `lod` reading `inputs` (named by the first) as `read`: hollow in chunks,
/// or whole and why; `None` for no input or a file read whole for being under the streaming
/// threshold (the ordinary case, said by nothing).
pub fn read_note(read: &LodRead, inputs: &[PathBuf]) -> Option<String> {
    let input = shown(inputs.first()?);
    match read {
        LodRead::Whole(WholeWhy::Small { .. }) => None,
        LodRead::Whole(why) => Some(format!("{input}: lod reads whole ({})", why_words(why))),
        LodRead::Hollow { chunk } => Some(format!(
            "{input}: lod reads hollow, in chunks of {chunk} bytes (what the selection needs, the rest read again where it is written)"
        )),
    }
}

/// Why `lod` reads whole, the flags named.
fn why_words(why: &WholeWhy) -> String {
    match why {
        WholeWhy::Option(o) => format!("{} is given", flag(*o)),
        WholeWhy::Fits { bytes, budget } => {
            let budget = match budget {
                Budget::Given(b) => format!("the {} of --max-memory", mib(*b)),
                Budget::Default(_) => format!("{budget}; --max-memory sets it"),
            };
            format!("{} fit in {budget}", mib(*bytes))
        }
        why => why.to_string(),
    }
}

/// The flag that asks for what the hollow read does not serve.
fn flag(o: Unserved) -> &'static str {
    match o {
        Unserved::PoiCrs => "--poi-crs",
        Unserved::Region => "--facade or --region",
        Unserved::Reduce => "--reduce",
    }
}
