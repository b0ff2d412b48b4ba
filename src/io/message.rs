//! An error and its causes as one message, for a program that shows the library's errors:
//! each cause said once (library errors quote their source), I/O errors in plain words
//! ([`describe_io`]), and whether the chain holds a closed pipe (a reader of standard output
//! that went away: nothing is wrong with the work).

use super::files::describe_io;
use std::error::Error;

/// `e` and its causes (`source()`), first to last.
fn chain<'a>(e: &'a (dyn Error + 'static)) -> impl Iterator<Item = &'a (dyn Error + 'static)> {
    std::iter::successors(Some(e), |&c| c.source())
}

/// The text of one error: an I/O error in plain words ([`describe_io`]: a full disk is "no
/// space left on device"), any other its `Display`.
pub fn plain_text(e: &(dyn Error + 'static)) -> String {
    match e.downcast_ref::<std::io::Error>() {
        Some(io) => describe_io(io),
        None => e.to_string(),
    }
}

/// `e` and its causes joined by ": ", each said by `text` (e.g. [`plain_text`], or a
/// caller's wording with its own option names) and said once: a cause whose text the message
/// already holds is left out, as is an empty one.
///
/// ```
/// use skylod::io::{chain_message, plain_text};
/// let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file");
/// let e = skylod::io::FileError::new("in.gml", io);
/// assert_eq!(chain_message(&e, plain_text), "in.gml: No such file");
/// ```
pub fn chain_message(
    e: &(dyn Error + 'static),
    text: impl Fn(&(dyn Error + 'static)) -> String,
) -> String {
    let mut out = String::new();
    for cause in chain(e) {
        let t = text(cause);
        if t.is_empty() || out.contains(&t) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&t);
    }
    out
}

/// Whether an I/O error somewhere in the chain of `e` is a closed pipe.
pub fn is_broken_pipe(e: &(dyn Error + 'static)) -> bool {
    chain(e).any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fmt;

    /// What a caller adds around an error (as `anyhow`'s context does).
    #[derive(Debug)]
    struct Context(&'static str, Box<dyn Error + 'static>);

    impl fmt::Display for Context {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str(self.0)
        }
    }

    impl Error for Context {
        fn source(&self) -> Option<&(dyn Error + 'static)> {
            Some(&*self.1)
        }
    }

    #[test]
    fn causes_said_once() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file");
        let file = crate::io::files::FileError::new("nope.csv", io);
        let e = Context("reading POIs", Box::new(file));
        assert_eq!(
            chain_message(&e, plain_text),
            "reading POIs: nope.csv: No such file"
        );
        let twice = Context(
            "a",
            Box::new(Context(
                "a",
                Box::new(Context("b", Box::<dyn Error>::from(""))),
            )),
        );
        assert_eq!(chain_message(&twice, plain_text), "a: b");
        assert_eq!(chain_message(&twice, |_| "x".into()), "x");
    }

    #[test]
    fn a_full_disk_is_said_once_in_plain_words() {
        let full = std::io::Error::from_raw_os_error(28);
        let e = crate::io::files::FileError::new("out.gml", full);
        assert_eq!(
            chain_message(&e, plain_text),
            "out.gml: no space left on device"
        );
        let e = Context(
            "writing to standard output",
            Box::new(std::io::Error::from_raw_os_error(28)),
        );
        assert_eq!(
            chain_message(&e, plain_text),
            "writing to standard output: no space left on device"
        );
    }

    #[test]
    fn broken_pipe_found_in_chain() {
        let io = std::io::Error::new(std::io::ErrorKind::BrokenPipe, "pipe");
        let e = Context("writing to stdout", Box::new(io));
        assert!(is_broken_pipe(&e));
        let other = std::io::Error::other("other");
        assert!(!is_broken_pipe(&Context("writing", Box::new(other))));
    }
}
