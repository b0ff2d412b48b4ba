//! Progress as plain-text lines, for a log rather than a bar: which line each call of a
//! [`Progress`](super::progress::Progress) gives, and at which detail. The library never prints:
//! [`ProgressText`] returns the lines, the caller writes those its log level shows (the binary:
//! `--log-level info` for stages and files, `debug` for POIs by tenths).
//!
//! # Example
//! ```
//! use skylod::model::Stage;
//! use skylod::model::{Detail, ProgressText};
//!
//! let text = ProgressText::default();
//! let l = text.start(Stage::Read, 2, 3_000_000);
//! assert_eq!(l.text, "reading inputs: 2 file(s), 3.0 MB");
//! let l = text.advance(Stage::Read, 1, Some("a.gml")).unwrap();
//! assert_eq!((l.detail, l.text.as_str()), (Detail::Info, "reading inputs 1/2: a.gml"));
//! assert!(text.finish(Stage::Read).unwrap().text.starts_with("reading inputs: done, 1 file(s) in "));
//! ```

use super::progress::Stage;
use std::collections::HashMap;
use std::sync::Mutex;
use std::time::Instant;

/// How much detail a line is: shown from `info` (a stage, a file) or `debug` (a tenth of the
/// items of a stage that names none).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Detail {
    /// A stage started or finished, a named item done.
    Info,
    /// A tenth of a stage's items done.
    Debug,
}

/// One line of progress and its detail.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Line {
    /// From which log level the line is shown.
    pub detail: Detail,
    /// The line, without a newline.
    pub text: String,
}

impl Line {
    fn info(text: String) -> Line {
        Line {
            detail: Detail::Info,
            text,
        }
    }
}

/// The stages under way with their counts; each call gives the line it is due, if any.
/// Calls may come from several threads.
#[derive(Debug, Default)]
pub struct ProgressText {
    stages: Mutex<HashMap<Stage, Counts>>,
}

#[derive(Debug)]
struct Counts {
    items: u64,
    done: u64,
    t: Instant,
}

/// Megabytes (10^6 bytes).
fn mb(bytes: u64) -> f64 {
    bytes as f64 / 1e6
}

impl ProgressText {
    /// `stage` starts with `items` items and `bytes` bytes: "reading inputs: 3 file(s), 1.2 MB",
    /// or the stage's name alone for a stage of one item and no bytes.
    pub fn start(&self, stage: Stage, items: u64, bytes: u64) -> Line {
        if let Ok(mut s) = self.stages.lock() {
            let t = Instant::now();
            s.insert(stage, Counts { items, done: 0, t });
        }
        if items <= 1 && bytes == 0 {
            return Line::info(stage.doing().to_string());
        }
        let size = if bytes > 0 {
            format!(", {:.1} MB", mb(bytes))
        } else {
            String::new()
        };
        Line::info(format!(
            "{}: {items} {}(s){size}",
            stage.doing(),
            stage.item()
        ))
    }

    /// `items` more items of `stage` done: a line for a named item (a file), else one per
    /// tenth of a stage of ten items or more ([`Detail::Debug`]); `None` between them or for a
    /// stage not started.
    pub fn advance(&self, stage: Stage, items: u64, name: Option<&str>) -> Option<Line> {
        let mut s = self.stages.lock().ok()?;
        let st = s.get_mut(&stage)?;
        st.done += items;
        let (done, all) = (st.done, st.items);
        if let Some(n) = name {
            return Some(Line::info(format!("{} {done}/{all}: {n}", stage.doing())));
        }
        let tenth = all.div_ceil(10);
        (all >= 10 && (done % tenth == 0 || done == all)).then(|| Line {
            detail: Detail::Debug,
            text: format!("{}: {done}/{all} {}s", stage.doing(), stage.item()),
        })
    }

    /// `stage` is over: "…: done in 0.52 s", with the items done when it counted more than one;
    /// `None` for a stage not started.
    pub fn finish(&self, stage: Stage) -> Option<Line> {
        let st = self.stages.lock().ok()?.remove(&stage)?;
        let secs = st.t.elapsed().as_secs_f64();
        Some(Line::info(if st.items <= 1 {
            format!("{}: done in {secs:.2} s", stage.doing())
        } else {
            let item = stage.item();
            format!(
                "{}: done, {} {item}(s) in {secs:.2} s",
                stage.doing(),
                st.done
            )
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn start_lines_name_the_stage_its_items_and_megabytes() {
        let p = ProgressText::default();
        assert_eq!(p.start(Stage::Bvh, 1, 0).text, "building the scene");
        assert_eq!(
            p.start(Stage::Select, 40, 0).text,
            "selecting levels: 40 POI(s)"
        );
        let l = p.start(Stage::Read, 1, 1_250_000);
        assert_eq!(l, Line::info("reading inputs: 1 file(s), 1.2 MB".into()));
    }

    #[test]
    fn unnamed_items_give_a_debug_line_per_tenth() {
        let p = ProgressText::default();
        p.start(Stage::Trace, 25, 0);
        let due: Vec<String> = (0..25)
            .filter_map(|_| p.advance(Stage::Trace, 1, None))
            .inspect(|l| assert_eq!(l.detail, Detail::Debug))
            .map(|l| l.text)
            .collect();
        // Tenths of 25 are every 3 POIs, and the last one.
        assert_eq!(due.len(), 9, "{due:?}");
        assert_eq!(due[0], "tracing: 3/25 POIs");
        assert_eq!(due[8], "tracing: 25/25 POIs");
        // Fewer than ten items: no tenths.
        p.start(Stage::Select, 9, 0);
        assert!((0..9).all(|_| p.advance(Stage::Select, 1, None).is_none()));
    }

    #[test]
    fn finish_counts_what_was_done_and_forgets_the_stage() {
        let p = ProgressText::default();
        assert!(p.advance(Stage::Write, 1, Some("x")).is_none());
        assert!(p.finish(Stage::Write).is_none());
        p.start(Stage::Write, 3, 0);
        let l = p.advance(Stage::Write, 2, Some("out.gml")).unwrap();
        assert_eq!(l.text, "writing outputs 2/3: out.gml");
        let f = p.finish(Stage::Write).unwrap().text;
        assert!(f.starts_with("writing outputs: done, 2 file(s) in ") && f.ends_with(" s"));
        assert!(p.finish(Stage::Write).is_none());
        p.start(Stage::Sun, 1, 0);
        let f = p.finish(Stage::Sun).unwrap().text;
        assert!(
            f.starts_with("computing the sun's positions: done in "),
            "{f}"
        );
    }
}
