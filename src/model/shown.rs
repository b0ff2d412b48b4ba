//! How messages name inputs and outputs: standard input shown as `<stdin>`, and the
//! `IN -> OUT: what` line of a file made from another.

use std::fmt;
use std::path::Path;

/// The name of standard input among the inputs (`-`, as given on the command line and in
/// JSON outputs); messages show it as [`STDIN_SHOWN`].
pub const STDIN_NAME: &str = "-";

/// How messages (errors, warnings, progress) show standard input: `<stdin>:1:1: ...`.
pub const STDIN_SHOWN: &str = "<stdin>";

/// An input's name as messages show it: [`STDIN_SHOWN`] for standard input (`-`), else the
/// path as given.
///
/// ```
/// use skylod::model::shown;
/// use std::path::Path;
/// assert_eq!(shown(Path::new("-")).to_string(), "<stdin>");
/// assert_eq!(shown(Path::new("a/b.gml")).to_string(), "a/b.gml");
/// ```
pub fn shown(path: &Path) -> Shown<'_> {
    Shown(path)
}

/// `IN -> OUT: what`: the line saying what was made of the file `input` in `out`, both named
/// as [`shown`] names them.
///
/// ```
/// use skylod::model::made_line;
/// use std::path::Path;
/// let line = made_line(Path::new("-"), Path::new("b.gml"), "3 of 4 kept");
/// assert_eq!(line, "<stdin> -> b.gml: 3 of 4 kept");
/// ```
pub fn made_line(input: &Path, out: &Path, what: &str) -> String {
    format!("{} -> {}: {what}", shown(input), shown(out))
}

/// [`shown`]: a path displayed as messages name an input.
#[derive(Debug, Clone, Copy)]
pub struct Shown<'a>(pub &'a Path);

impl fmt::Display for Shown<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.as_os_str() == STDIN_NAME {
            f.write_str(STDIN_SHOWN)
        } else {
            self.0.display().fmt(f)
        }
    }
}
