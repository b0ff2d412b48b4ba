//! Shards for a cluster scheduler: which part of the work one process of an array job does.
//!
//! skylod never schedules machines; it is the unit of work that Kubernetes Indexed Jobs,
//! Slurm job arrays, AWS Batch array jobs or GNU parallel run N times. Each run gets a
//! [`Shard`] `I/N` (I from 0) from `--shard I/N` or from the scheduler's environment
//! ([`Shard::from_env`]), and does its part:
//!
//! * **files** ([`Shard::files`]): per-file commands take the inputs in path order and cut
//!   them into N contiguous runs of (nearly) equal length;
//! * **POIs** ([`Shard::pois`]): commands that trace points of interest keep the POIs in
//!   their order (the CSV's, or the order `--facade`/`--region` generate them) and cut
//!   them into N contiguous groups of nearly equal size, each cut moved to the largest
//!   jump between neighbouring POIs near it, so that a facade or a street stays in one
//!   shard and each shard's scene stays small. Contiguous groups keep the output order:
//!   the shards' outputs, concatenated in shard order, are the serial run's.
//!
//! A POI's rays are seeded from the POI itself ([`crate::model::Poi::ray_seed`]), so its
//! result does not depend on which shard traces it.
//!
//! # Example
//! ```
//! use skylod::pipeline::batch::Shard;
//! use std::collections::HashMap;
//! let s: Shard = "1/3".parse()?;
//! assert_eq!(s.files(7), 2..4); // 7 files: 0..2, 2..4, 4..7
//! // A Slurm array `--array=4-6`: task 5 is shard 1 of 3.
//! let env: HashMap<&str, &str> = [
//!     ("SLURM_ARRAY_TASK_ID", "5"),
//!     ("SLURM_ARRAY_TASK_MIN", "4"),
//!     ("SLURM_ARRAY_TASK_COUNT", "3"),
//! ]
//! .into();
//! let got = Shard::from_env(|k| env.get(k).map(|v| v.to_string()), None)?;
//! assert_eq!(got, Some(s));
//! # Ok::<(), skylod::pipeline::batch::ShardError>(())
//! ```

use glam::DVec3;
use std::ops::Range;

/// One part of an array job: index `I` (from 0) of `N` parts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Shard {
    index: usize,
    count: usize,
}

/// Environment variables a scheduler sets for the index of an array task.
pub const ENV_VARS: [&str; 5] = [
    "JOB_COMPLETION_INDEX",
    "SLURM_ARRAY_TASK_ID",
    "SLURM_ARRAY_TASK_MIN",
    "SLURM_ARRAY_TASK_COUNT",
    "AWS_BATCH_JOB_ARRAY_INDEX",
];

/// Where a shard setting came from, as errors name it.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum Setting {
    /// The shard given as text, `I/N`.
    Given(String),
    /// The shard count given.
    Count(usize),
    /// A setting named by the caller, e.g. a scheduler's environment variable.
    Named(String),
}

impl std::fmt::Display for Setting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Setting::Given(s) => write!(f, "shard {s}"),
            Setting::Count(n) => write!(f, "shard count {n}"),
            Setting::Named(n) => f.write_str(n),
        }
    }
}

/// Settings that do not name one shard.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ShardError {
    /// Shard text that is not `I/N`.
    #[error("shard {0:?}: expected I/N with 0 <= I < N (e.g. 0/4)")]
    Syntax(String),
    /// An index not below the count.
    #[error("{from}: shard index {index} is not below the shard count {count}")]
    OutOfRange {
        /// Where the pair came from.
        from: Setting,
        /// Index.
        index: usize,
        /// Count.
        count: usize,
    },
    /// A variable that is not a non-negative integer.
    #[error("{var}={value:?} is not a non-negative integer")]
    NotANumber {
        /// The variable (or option).
        var: String,
        /// Its value.
        value: String,
    },
    /// Two variables of the environment that disagree.
    #[error("conflicting shard settings: {0}")]
    Conflict(String),
    /// The scheduler's count and the count given disagree.
    #[error(
        "conflicting shard settings: SLURM_ARRAY_TASK_COUNT={env} but a shard count of \
         {given} was given"
    )]
    CountDisagrees {
        /// SLURM_ARRAY_TASK_COUNT.
        env: usize,
        /// The count given.
        given: usize,
    },
    /// A count given without an index, and no scheduler's index.
    #[error(
        "conflicting shard settings: a shard count of {0} without an index: give the shard \
         I/{0}, or run under a scheduler that sets one of {vars}",
        vars = ENV_VARS.join(", ")
    )]
    CountWithoutIndex(usize),
    /// The shard given and the count given disagree.
    #[error("conflicting shard settings: shard {shard} but a shard count of {count}")]
    ShardCountDisagrees {
        /// The shard given.
        shard: Shard,
        /// The count given.
        count: usize,
    },
    /// The shard given and the scheduler's environment disagree.
    #[error(
        "conflicting shard settings: shard {shard} but the scheduler's environment ({env}) \
         says {says}"
    )]
    EnvDisagrees {
        /// The shard given.
        shard: Shard,
        /// The variables set (`NAME=value, ...`).
        env: String,
        /// The shard of the environment.
        says: Shard,
    },
    /// The shard given, and an environment that names no shard.
    #[error(
        "conflicting shard settings: shard {shard} but the scheduler's environment is not \
         usable: {error}"
    )]
    EnvUnusable {
        /// The shard given.
        shard: Shard,
        /// Why the environment names no shard.
        error: Box<ShardError>,
    },
    /// An index without a count (the setting that gave the index).
    #[error("{0} gives the shard index but not the count")]
    NoCount(String),
    /// A count of zero.
    #[error("{0}: the shard count must be at least 1")]
    ZeroCount(Setting),
}

impl std::str::FromStr for Shard {
    type Err = ShardError;
    fn from_str(s: &str) -> Result<Shard, ShardError> {
        let bad = || ShardError::Syntax(s.to_string());
        let (i, n) = s.trim().split_once('/').ok_or_else(bad)?;
        let index: usize = i.trim().parse().map_err(|_| bad())?;
        let count: usize = n.trim().parse().map_err(|_| bad())?;
        Shard::checked(index, count, Setting::Given(s.to_string()))
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

fn number(var: &str, value: &str) -> Result<usize, ShardError> {
    value.trim().parse().map_err(|_| ShardError::NotANumber {
        var: var.to_string(),
        value: value.to_string(),
    })
}

impl Shard {
    /// Shard `index` of `count`; `from` names the setting in errors.
    ///
    /// # Errors
    /// A zero count or an index not below it.
    pub fn new(index: usize, count: usize, from: &str) -> Result<Shard, ShardError> {
        Shard::checked(index, count, Setting::Named(from.to_string()))
    }

    /// [`Shard::new`] with the setting `from`.
    fn checked(index: usize, count: usize, from: Setting) -> Result<Shard, ShardError> {
        if count == 0 {
            return Err(ShardError::ZeroCount(from));
        }
        if index >= count {
            return Err(ShardError::OutOfRange { from, index, count });
        }
        Ok(Shard { index, count })
    }

    /// The index, from 0.
    pub fn index(&self) -> usize {
        self.index
    }

    /// The number of shards.
    pub fn count(&self) -> usize {
        self.count
    }

    /// Whether this is shard 0 (the one that writes a table's header).
    pub fn is_first(&self) -> bool {
        self.index == 0
    }

    /// The shard a scheduler's environment names, read through `get` (e.g.
    /// `|k| std::env::var(k).ok()`), with `shards` the `--shards N` option:
    ///
    /// * `JOB_COMPLETION_INDEX` (Kubernetes Indexed Job) with `--shards` (the Job's
    ///   `completions`);
    /// * `SLURM_ARRAY_TASK_ID` minus `SLURM_ARRAY_TASK_MIN` (0 when unset), count
    ///   `SLURM_ARRAY_TASK_COUNT` (or `--shards`, which must then agree);
    /// * `AWS_BATCH_JOB_ARRAY_INDEX` with `--shards` (the array `size`).
    ///
    /// `Ok(None)`: no scheduler variable is set.
    ///
    /// # Errors
    /// Two schedulers' indices that disagree, a value that is not a number, an index
    /// without a count, or an index not below the count.
    pub fn from_env(
        get: impl Fn(&str) -> Option<String>,
        shards: Option<usize>,
    ) -> Result<Option<Shard>, ShardError> {
        let var = |k: &str| get(k).filter(|v| !v.trim().is_empty());
        // (source description, index, count if the scheduler gives it)
        let mut found: Vec<(String, usize, Option<usize>)> = Vec::new();
        if let Some(v) = var("JOB_COMPLETION_INDEX") {
            found.push((
                "JOB_COMPLETION_INDEX".into(),
                number("JOB_COMPLETION_INDEX", &v)?,
                None,
            ));
        }
        if let Some(v) = var("SLURM_ARRAY_TASK_ID") {
            let id = number("SLURM_ARRAY_TASK_ID", &v)?;
            let min = match var("SLURM_ARRAY_TASK_MIN") {
                Some(m) => number("SLURM_ARRAY_TASK_MIN", &m)?,
                None => 0,
            };
            let count = var("SLURM_ARRAY_TASK_COUNT")
                .map(|c| number("SLURM_ARRAY_TASK_COUNT", &c))
                .transpose()?;
            let index = id.checked_sub(min).ok_or_else(|| {
                ShardError::Conflict(format!(
                    "SLURM_ARRAY_TASK_ID={id} is below SLURM_ARRAY_TASK_MIN={min}"
                ))
            })?;
            found.push((
                "SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN".into(),
                index,
                count,
            ));
        }
        if let Some(v) = var("AWS_BATCH_JOB_ARRAY_INDEX") {
            found.push((
                "AWS_BATCH_JOB_ARRAY_INDEX".into(),
                number("AWS_BATCH_JOB_ARRAY_INDEX", &v)?,
                None,
            ));
        }
        let Some((from, index, given)) = found.first().cloned() else {
            return Ok(None);
        };
        for (f, i, _) in &found[1..] {
            if *i != index {
                return Err(ShardError::Conflict(format!(
                    "{from} gives index {index} but {f} gives {i}"
                )));
            }
        }
        let count = match (given, shards) {
            (Some(c), Some(n)) if c != n => {
                return Err(ShardError::CountDisagrees { env: c, given: n })
            }
            (Some(c), _) => c,
            (None, Some(n)) => n,
            (None, None) => return Err(ShardError::NoCount(from)),
        };
        Shard::new(index, count, &from).map(Some)
    }

    /// The shard of `--shard` and `--shards` given on the command line, or else of the
    /// environment ([`Shard::from_env`]). `--shard I/N` wins over the environment only when
    /// they agree (a scheduler index that disagrees is a conflict), and `--shards` must
    /// agree with its N.
    ///
    /// # Errors
    /// As [`Shard::from_env`], and conflicts between the options and the environment.
    pub fn resolve(
        option: Option<Shard>,
        shards: Option<usize>,
        get: impl Fn(&str) -> Option<String>,
    ) -> Result<Option<Shard>, ShardError> {
        if let Some(n) = shards {
            if n == 0 {
                return Err(ShardError::ZeroCount(Setting::Count(0)));
            }
        }
        let Some(s) = option else {
            return match (Shard::from_env(get, shards)?, shards) {
                (None, Some(n)) => Err(ShardError::CountWithoutIndex(n)),
                (found, _) => Ok(found),
            };
        };
        if let Some(n) = shards.filter(|&n| n != s.count) {
            return Err(ShardError::ShardCountDisagrees { shard: s, count: n });
        }
        let set: Vec<String> = ENV_VARS
            .iter()
            .filter_map(|k| get(k).map(|v| format!("{k}={v}")))
            .collect();
        match Shard::from_env(&get, Some(s.count)) {
            Ok(Some(e)) if e != s => Err(ShardError::EnvDisagrees {
                shard: s,
                env: set.join(", "),
                says: e,
            }),
            Ok(_) => Ok(Some(s)),
            Err(e) => Err(ShardError::EnvUnusable {
                shard: s,
                error: Box::new(e),
            }),
        }
    }

    /// The range of `n` items in path order that this shard works on: N contiguous runs
    /// whose lengths differ by at most one.
    pub fn files(&self, n: usize) -> Range<usize> {
        even_cut(n, self.count, self.index)..even_cut(n, self.count, self.index + 1)
    }

    /// The range of `points` (in their order) this shard traces: N contiguous groups, each
    /// cut at the largest jump between neighbouring points within a quarter of a group's
    /// size of the even cut (`place_cuts`).
    pub fn pois(&self, points: &[DVec3]) -> Range<usize> {
        let cuts = place_cuts(points, self.count);
        let lo = cuts.get(self.index).copied().unwrap_or(points.len());
        let hi = cuts.get(self.index + 1).copied().unwrap_or(points.len());
        lo..hi
    }

    /// What to say of this shard's part `range` ([`Shard::files`], [`Shard::pois`]) of
    /// `total` items called `what` (`files`, `POIs`).
    pub fn part_line(&self, range: Range<usize>, total: usize, what: &str) -> String {
        let n = range.len().min(total.saturating_sub(range.start));
        let (start, end) = (range.start, range.end);
        format!("shard {self}: {what} {start}..{end} of {total} ({n})")
    }
}

/// `n * k / parts`, rounded down, without overflow for any realistic `n`.
fn even_cut(n: usize, parts: usize, k: usize) -> usize {
    ((n as u128 * k as u128) / parts.max(1) as u128) as usize
}

/// The `parts + 1` cut positions of `points` (first 0, last `points.len()`), one group per
/// shard. Cut `k` starts at the even cut `n k / parts` and moves to the largest horizontal
/// distance between consecutive points within `n / (4 parts)` of it (ties: the first), but
/// never past a neighbouring cut, so no group is empty while there are at least `parts`
/// points. The result depends only on the points and `parts`.
pub fn place_cuts(points: &[DVec3], parts: usize) -> Vec<usize> {
    let n = points.len();
    let parts = parts.max(1);
    let window = n / (4 * parts);
    let mut cuts = vec![0usize; parts + 1];
    cuts[parts] = n;
    for k in 1..parts {
        let even = even_cut(n, parts, k);
        let prev = cuts[k - 1];
        let next = even_cut(n, parts, k + 1);
        // A cut at c splits points[c - 1] from points[c].
        let lo = even.saturating_sub(window).max(prev + 1).max(1);
        let hi = (even + window)
            .min(next.saturating_sub(1))
            .min(n.saturating_sub(1));
        let mut best = even;
        if lo <= hi {
            let mut best_gap = -1.0;
            for c in lo..=hi {
                let (Some(a), Some(b)) = (points.get(c - 1), points.get(c)) else {
                    continue;
                };
                let gap = a.truncate().distance(b.truncate());
                if gap > best_gap {
                    best_gap = gap;
                    best = c;
                }
            }
        }
        cuts[k] = best.clamp(prev, n);
    }
    cuts
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    #[test]
    fn a_shard_says_its_part_and_how_many_it_holds() {
        let s: Shard = "1/4".parse().unwrap();
        assert_eq!(
            s.part_line(2..4, 10, "files"),
            "shard 1/4: files 2..4 of 10 (2)"
        );
        assert_eq!(
            s.part_line(9..12, 10, "POIs"),
            "shard 1/4: POIs 9..12 of 10 (1)"
        );
    }

    fn env(vars: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let m: HashMap<String, String> = vars
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        move |k: &str| m.get(k).cloned()
    }

    #[test]
    fn parses_and_refuses() {
        let s: Shard = "2/5".parse().unwrap();
        assert_eq!((s.index(), s.count()), (2, 5));
        assert_eq!(s.to_string(), "2/5");
        for bad in ["", "1", "5/5", "1/0", "-1/3", "a/b", "1/2/3"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }

    #[test]
    fn schedulers() {
        let k8s = env(&[("JOB_COMPLETION_INDEX", "2")]);
        assert_eq!(
            Shard::from_env(&k8s, Some(3)).unwrap(),
            Some(Shard::new(2, 3, "").unwrap())
        );
        assert!(matches!(
            Shard::from_env(&k8s, None),
            Err(ShardError::NoCount(_))
        ));
        let slurm = env(&[
            ("SLURM_ARRAY_TASK_ID", "11"),
            ("SLURM_ARRAY_TASK_MIN", "10"),
            ("SLURM_ARRAY_TASK_COUNT", "2"),
        ]);
        assert_eq!(
            Shard::from_env(&slurm, None).unwrap(),
            Some(Shard::new(1, 2, "").unwrap())
        );
        assert!(Shard::from_env(&slurm, Some(3))
            .unwrap_err()
            .to_string()
            .contains("SLURM_ARRAY_TASK_COUNT=2"));
        let aws = env(&[("AWS_BATCH_JOB_ARRAY_INDEX", "0")]);
        assert_eq!(
            Shard::from_env(&aws, Some(4)).unwrap(),
            Some(Shard::new(0, 4, "").unwrap())
        );
        assert_eq!(Shard::from_env(env(&[]), None).unwrap(), None);
        assert_eq!(Shard::from_env(env(&[]), Some(2)).unwrap(), None);
        assert!(Shard::resolve(None, Some(2), env(&[])).is_err());
        assert_eq!(Shard::resolve(None, None, env(&[])).unwrap(), None);
    }

    #[test]
    fn invalid_and_conflicting_settings_name_the_variables() {
        let e = Shard::from_env(env(&[("JOB_COMPLETION_INDEX", "x")]), Some(2)).unwrap_err();
        assert!(e.to_string().contains("JOB_COMPLETION_INDEX"), "{e}");
        let e = Shard::from_env(env(&[("AWS_BATCH_JOB_ARRAY_INDEX", "4")]), Some(4)).unwrap_err();
        assert!(e.to_string().contains("AWS_BATCH_JOB_ARRAY_INDEX"), "{e}");
        let both = env(&[
            ("JOB_COMPLETION_INDEX", "1"),
            ("AWS_BATCH_JOB_ARRAY_INDEX", "0"),
        ]);
        let e = Shard::from_env(&both, Some(2)).unwrap_err();
        assert!(
            e.to_string().contains("JOB_COMPLETION_INDEX")
                && e.to_string().contains("AWS_BATCH_JOB_ARRAY_INDEX"),
            "{e}"
        );
        let slurm = env(&[("SLURM_ARRAY_TASK_ID", "1"), ("SLURM_ARRAY_TASK_MIN", "3")]);
        assert!(Shard::from_env(&slurm, Some(2)).is_err());
        // --shard against the environment.
        let opt = Some("1/2".parse().unwrap());
        let k8s = env(&[("JOB_COMPLETION_INDEX", "0")]);
        let e = Shard::resolve(opt, None, &k8s).unwrap_err();
        assert!(e.to_string().contains("JOB_COMPLETION_INDEX"), "{e}");
        assert_eq!(Shard::resolve(opt, None, env(&[])).unwrap(), opt);
        assert!(Shard::resolve(opt, Some(3), env(&[])).is_err());
        assert!(Shard::resolve(None, Some(0), env(&[])).is_err());
        let agrees = env(&[("JOB_COMPLETION_INDEX", "1")]);
        assert_eq!(Shard::resolve(opt, None, &agrees).unwrap(), opt);
    }

    #[test]
    fn files_cover_everything_once() {
        for n in 0..20 {
            for parts in 1..6 {
                let mut next = 0;
                for i in 0..parts {
                    let r = Shard::new(i, parts, "").unwrap().files(n);
                    assert_eq!(r.start, next);
                    assert!(r.len() + 1 >= n / parts);
                    next = r.end;
                }
                assert_eq!(next, n);
            }
        }
    }

    #[test]
    fn pois_cover_everything_once_and_cut_at_gaps() {
        // Two facades of 10 points, 100 m apart, 1 m steps: 3 cuts of 2 parts at index 10.
        let pts: Vec<DVec3> = (0..20)
            .map(|i| {
                let x = if i < 10 { i as f64 } else { 100.0 + i as f64 };
                DVec3::new(x, 0.0, 1.0)
            })
            .collect();
        let mut shifted = pts.clone();
        shifted.rotate_left(2);
        assert_eq!(place_cuts(&pts, 2), vec![0, 10, 20]);
        assert_eq!(place_cuts(&shifted, 2), vec![0, 8, 20]);
        for n in 0..30 {
            let pts: Vec<DVec3> = (0..n)
                .map(|i| DVec3::new(((i * 7919) % 13) as f64, i as f64, 0.0))
                .collect();
            for parts in 1..7 {
                let mut next = 0;
                for i in 0..parts {
                    let r = Shard::new(i, parts, "").unwrap().pois(&pts);
                    assert_eq!(r.start, next, "n {n} parts {parts}");
                    if n >= parts {
                        assert!(!r.is_empty(), "n {n} parts {parts} shard {i}");
                    }
                    next = r.end;
                }
                assert_eq!(next, n);
            }
        }
    }
}
