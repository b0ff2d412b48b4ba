//! The element index of one document ([`Doc`]), as the pass ([`super::index`]) builds it and
//! the rules ([`super::plan`]) read it: one [`Node`] per element, names stored once, ids,
//! references and labels, and the lookups the rules make.

use super::id_table::IdTable;
use foldhash::{HashMap, HashSet};

/// No node (no parent, no descendant).
pub(super) const NONE: u32 = u32::MAX;

/// What the rules need to know of an element's namespace.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum NsKind {
    Gml,
    Core,
    App,
    Gen,
    OtherCityGml,
    Other,
}

/// An element name, stored once per distinct qualified name and namespace.
#[derive(Debug, PartialEq)]
pub(super) struct Name {
    pub(super) qname: String,
    pub(super) local: String,
    pub(super) ns: NsKind,
    /// Local name starts with an upper-case letter (an object, not a property).
    pub(super) upper: bool,
}

/// One element (32 bytes: a city file has millions).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Node {
    pub(super) start: u64,
    pub(super) end: u64,
    /// Length of the start tag: the content starts at `start + tag_len`.
    pub(super) tag_len: u32,
    pub(super) parent: u32,
    /// Last descendant (the node itself when it has none).
    pub(super) last_desc: u32,
    pub(super) name: u32,
}

/// What a reference is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum RefKind {
    Href,
    AppTarget,
}

/// The element index of one document.
#[derive(Debug, Default, PartialEq)]
pub(super) struct Doc {
    /// Elements in document order (start-tag order).
    pub(super) nodes: Vec<Node>,
    pub(super) names: Vec<Name>,
    /// Every `gml:id` with its element; an id inside skipped content maps to the skipped
    /// element. See [`Doc::id_node`].
    pub(super) ids: IdTable,
    /// (node, kind, reference) in document order.
    pub(super) refs: Vec<(u32, RefKind, Box<str>)>,
    /// `name` attribute (2.0 generic attributes) or `gen:name` text (3.0), per node.
    pub(super) labels: HashMap<u32, Box<str>>,
    /// Namespace declarations of the root: prefix ("" = default) -> URI.
    pub(super) root_ns: Vec<(String, String)>,
    /// Prefixes ("" = default) declared again below the root.
    pub(super) redeclared: HashSet<String>,
    /// Elements whose content was skipped, and the bytes of content skipped.
    pub(super) skipped: (usize, u64),
    /// See [`Doc::node_at`]: `starts[b]` is the first node starting at or after
    /// `b << shift` (one more entry at the end).
    starts: Vec<u32>,
    shift: u32,
}

impl Node {
    /// Byte offset of the element's content (after its start tag).
    pub(super) fn content_start(&self) -> u64 {
        self.start + u64::from(self.tag_len)
    }
}

impl Doc {
    /// The element holding `gml:id` `id`: the first in document order when the id repeats
    /// (node indices follow document order, and skipped content has no nodes of its own).
    pub(super) fn id_node(&self, id: &str) -> Option<u32> {
        self.ids.get(id)
    }

    /// Does the document hold `gml:id` `id`?
    pub(super) fn has_id(&self, id: &str) -> bool {
        self.ids.get(id).is_some()
    }

    /// Make the index ready for lookups, once every id is in: [`IdTable::finish`] and the
    /// directory of [`Doc::node_at`].
    pub(super) fn seal(&mut self) {
        self.ids.finish();
        self.index_starts();
    }

    /// The element starting at byte `start`: a directory of start offsets narrows the
    /// search to the few nodes that start in the same `1 << shift` bytes (the plan asks once
    /// per geometry of the file; a binary search of all the nodes missed the cache each step).
    pub(super) fn node_at(&self, start: u64) -> Option<u32> {
        let (lo, hi) = match usize::try_from(start >> self.shift) {
            Ok(b) if b + 1 < self.starts.len() => {
                (self.starts[b] as usize, self.starts[b + 1] as usize)
            }
            _ if self.starts.is_empty() => (0, self.nodes.len()),
            _ => return None,
        };
        self.nodes[lo..hi]
            .binary_search_by(|n| n.start.cmp(&start))
            .ok()
            .map(|i| (lo + i) as u32)
    }

    /// Build the directory of [`Doc::node_at`] (nodes are in start order): about one
    /// entry per node.
    fn index_starts(&mut self) {
        let Some(last) = self.nodes.last().map(|n| n.start) else {
            return;
        };
        let per = (last / self.nodes.len() as u64).max(1);
        self.shift = per.ilog2();
        let buckets = usize::try_from(last >> self.shift).unwrap_or(usize::MAX - 2) + 1;
        self.starts = Vec::with_capacity(buckets + 1);
        let mut i = 0;
        for b in 0..buckets as u64 {
            while self.nodes.get(i).is_some_and(|n| n.start >> self.shift < b) {
                i += 1;
            }
            self.starts.push(i as u32);
        }
        self.starts.push(self.nodes.len() as u32);
    }

    pub(super) fn name(&self, n: u32) -> &Name {
        &self.names[self.nodes[n as usize].name as usize]
    }

    pub(super) fn parent(&self, n: u32) -> Option<u32> {
        let p = self.nodes[n as usize].parent;
        (p != NONE).then_some(p)
    }

    pub(super) fn children(&self, n: u32) -> Children<'_> {
        Children {
            doc: self,
            next: n + 1,
            last: self.nodes[n as usize].last_desc,
        }
    }

    /// Prefix (with colon, or empty for the default namespace) bound to `uri` on the root and
    /// never redeclared.
    pub(super) fn prefix_for(&self, uri: &str) -> Option<String> {
        self.root_ns
            .iter()
            .find(|(p, u)| u == uri && !self.redeclared.contains(p))
            .map(|(p, _)| {
                if p.is_empty() {
                    String::new()
                } else {
                    format!("{p}:")
                }
            })
    }
}

/// Child elements of a node.
pub(super) struct Children<'a> {
    doc: &'a Doc,
    next: u32,
    last: u32,
}

impl Iterator for Children<'_> {
    type Item = u32;
    fn next(&mut self) -> Option<u32> {
        if self.next == NONE || self.next > self.last || self.last == NONE {
            return None;
        }
        let c = self.next;
        self.next = self.doc.nodes[c as usize].last_desc.saturating_add(1);
        Some(c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_node_is_32_bytes() {
        assert_eq!(std::mem::size_of::<Node>(), 32);
    }
}
