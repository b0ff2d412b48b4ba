//! A reader that can be given bytes back ([`PushBack`]), under the XML reader of the index
//! pass ([`super::index`]).

use crate::io::citygml::source::{Limited, SkipAhead};
use std::io::{BufRead, Read};

/// A [`BufRead`] that can be given bytes back: the index reads a skipped element's content
/// and returns its end tag (or all of it, when the content cannot be skipped) to the XML
/// reader, so that namespace scopes and end-tag checks stay the reader's.
pub(super) struct PushBack<R> {
    front: Vec<u8>,
    at: usize,
    pub(super) inner: R,
}

impl<R: BufRead> PushBack<R> {
    pub(super) fn new(inner: R) -> Self {
        PushBack {
            front: Vec::new(),
            at: 0,
            inner,
        }
    }

    /// Put `bytes` before whatever is still to be read.
    pub(super) fn push_back(&mut self, bytes: &[u8]) {
        if self.at == self.front.len() {
            self.front.clear();
            self.front.extend_from_slice(bytes);
        } else {
            let rest = self.front.split_off(self.at);
            self.front.clear();
            self.front.extend_from_slice(bytes);
            self.front.extend_from_slice(&rest);
        }
        self.at = 0;
    }
}

impl<R: BufRead> Read for PushBack<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        crate::io::files::read_through_buf(self, buf)
    }
}

impl<R: BufRead> BufRead for PushBack<R> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        if self.at < self.front.len() {
            Ok(&self.front[self.at..])
        } else {
            self.inner.fill_buf()
        }
    }

    fn consume(&mut self, amt: usize) {
        if self.at < self.front.len() {
            self.at = (self.at + amt).min(self.front.len());
            if self.at == self.front.len() {
                self.front.clear();
                self.at = 0;
            }
        } else {
            self.inner.consume(amt);
        }
    }
}

pub(super) type Source<R> = PushBack<Limited<R>>;

impl<R: SkipAhead> SkipAhead for PushBack<R> {
    fn skip_ahead(&mut self, n: u64) -> std::io::Result<()> {
        let front = (self.front.len() - self.at).min(usize::try_from(n).unwrap_or(usize::MAX));
        self.consume(front);
        self.inner.skip_ahead(n - front as u64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn push_back_comes_first() {
        let mut r = PushBack::new(&b"world"[..]);
        let mut two = [0u8; 2];
        r.read_exact(&mut two).unwrap();
        r.push_back(b"hello ");
        r.push_back(b">");
        let mut s = String::new();
        r.read_to_string(&mut s).unwrap();
        assert_eq!(s, ">hello rld");
    }
}
