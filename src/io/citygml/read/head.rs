//! The start of a document read in chunks ([`super::stream`]): the prolog and the root's
//! start tag ([`parse_head`]), and where a top-level member ends ([`is_end_tag`]).

use super::events::{start_root, BOM, RELEASE_STEP};
use super::state::{Parser, NO_REC};
use super::ReadOptions;
use std::path::Path;

/// Where a document's prolog and root start tag end ([`parse_head`]).
pub(super) struct Head<'d> {
    /// Bytes of the byte-order mark (0 or 3).
    pub(super) bom: usize,
    /// The document after the byte-order mark.
    pub(super) body: &'d [u8],
    /// Offset in `body` after the root's start tag: `body[..root_end]` is the prolog.
    pub(super) root_end: usize,
}

/// Parse the prolog and the root's start tag of `doc` (a whole uncompressed document), for a
/// read that goes on in chunks ([`super::stream`]). `Err` with why a part-wise read
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
        bom,
        body,
        root_end,
    })
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

impl Parser<'_> {
    /// Forget what reading the root's start tag produced besides the state every part needs
    /// (the first chunk keeps it); `None` if it produced more than a `CityModel` root can.
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
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn member_end_tags_of_any_prefix() {
        assert!(is_end_tag(b"</a:cityObjectMember>", 4));
        assert!(is_end_tag(b"</cityObjectMember>", 2));
        assert!(!is_end_tag(b"< /a:cityObjectMember>", 5));
        assert!(!is_end_tag(b"<a:cityObjectMember>", 3));
        assert!(!is_end_tag(b"</:cityObjectMember>", 3));
    }
}
