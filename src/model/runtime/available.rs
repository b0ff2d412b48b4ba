//! The memory a run may still take: what the system has available, and the limit of the
//! run's control group where a scheduler set one (Slurm's `--mem`, a Kubernetes container's
//! `resources.limits.memory`, `systemd-run -p MemoryMax=`), whichever is less.
//!
//! A scheduler stops a job that passes its limit (the kernel's OOM killer in the job's
//! control group) however much memory the machine has free, so the limit counts first. Both
//! figures leave out the page cache that the kernel gives back on demand:
//! - the system's: `MemAvailable` of `/proc/meminfo`;
//! - the control group's (v2, the unified hierarchy): the least `memory.max` of the group
//!   and its ancestors, less the group's `memory.current` without its `inactive_file`;
//! - (v1): `hierarchical_memory_limit` of `memory.stat` (already the least over the
//!   ancestors), less `memory.usage_in_bytes` without `total_inactive_file`.
//!
//! Where the group's own directory is not visible (a control-group namespace shows the
//! group as the root of the mount), the mount's root is read. Linux only; elsewhere, and
//! where nothing can be read, [`available_bytes`] is `None`.

use std::path::{Path, PathBuf};

/// Bytes the process may still take: the least of the system's available memory and the
/// headroom under its control group's limit (module docs); `None` where neither is known.
///
/// ```
/// if let Some(b) = skylod::model::available_bytes() {
///     assert!(b > 0);
/// }
/// ```
pub fn available_bytes() -> Option<u64> {
    let system = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| meminfo_available(&t));
    let group = std::fs::read_to_string("/proc/self/cgroup")
        .ok()
        .and_then(|t| group_headroom(&t, Path::new("/sys/fs/cgroup")));
    match (system, group) {
        (Some(s), Some(g)) => Some(s.min(g)),
        (s, g) => s.or(g),
    }
}

/// `MemAvailable` of a `/proc/meminfo` text, in bytes.
fn meminfo_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let mut words = line.split_whitespace().skip(1);
    let n: u64 = words.next()?.parse().ok()?;
    match words.next() {
        Some("kB") => n.checked_mul(1024),
        None => Some(n),
        Some(_) => None,
    }
}

/// The headroom under the memory limit of the control group that `/proc/self/cgroup`
/// (`cgroup`) names, read under the mount `root`: v2 first, then v1; `None` without a limit.
fn group_headroom(cgroup: &str, root: &Path) -> Option<u64> {
    for line in cgroup.lines() {
        let mut f = line.splitn(3, ':');
        let (Some(_), Some(controllers), Some(path)) = (f.next(), f.next(), f.next()) else {
            continue;
        };
        let path = path.trim_start_matches('/');
        if controllers.is_empty() {
            if let Some(h) = v2_headroom(&group_dir(&root.join("unified"), path))
                .or_else(|| v2_headroom(&group_dir(root, path)))
            {
                return Some(h);
            }
        } else if controllers.split(',').any(|c| c == "memory") {
            if let Some(h) = v1_headroom(&group_dir(&root.join("memory"), path)) {
                return Some(h);
            }
        }
    }
    None
}

/// The group's directory under `mount`, or the mount's root where it is not there.
fn group_dir(mount: &Path, path: &str) -> PathBuf {
    let dir = mount.join(path);
    if dir.is_dir() {
        dir
    } else {
        mount.to_path_buf()
    }
}

/// A number of a control-group file (`max`: none).
fn number(path: &Path) -> Option<u64> {
    std::fs::read_to_string(path).ok()?.trim().parse().ok()
}

/// The value of `key` in a `memory.stat` text.
fn stat_value(stat: &str, key: &str) -> Option<u64> {
    stat.lines().find_map(|l| {
        let (k, v) = l.split_once(' ')?;
        (k == key).then(|| v.trim().parse().ok())?
    })
}

/// v2: the least `memory.max` of `dir` and its ancestors, less its use without the
/// inactive page cache.
fn v2_headroom(dir: &Path) -> Option<u64> {
    let current = number(&dir.join("memory.current"))?;
    let stat = std::fs::read_to_string(dir.join("memory.stat")).unwrap_or_default();
    let cache = stat_value(&stat, "inactive_file").unwrap_or(0);
    let limit = dir
        .ancestors()
        .map_while(|d| {
            d.join("memory.max")
                .is_file()
                .then(|| number(&d.join("memory.max")))
        })
        .flatten()
        .min()?;
    Some(limit.saturating_sub(current.saturating_sub(cache)))
}

/// Limits at or above this are "no limit" in v1 (the kernel writes `PAGE_COUNTER_MAX`
/// pages, about 2^63 bytes).
const V1_UNLIMITED: u64 = 1 << 62;

/// v1: `hierarchical_memory_limit` less the use without the inactive page cache.
fn v1_headroom(dir: &Path) -> Option<u64> {
    let stat = std::fs::read_to_string(dir.join("memory.stat")).ok()?;
    let limit = stat_value(&stat, "hierarchical_memory_limit")
        .or_else(|| number(&dir.join("memory.limit_in_bytes")))?;
    if limit >= V1_UNLIMITED {
        return None;
    }
    let usage = number(&dir.join("memory.usage_in_bytes"))?;
    let cache = stat_value(&stat, "total_inactive_file").unwrap_or(0);
    Some(limit.saturating_sub(usage.saturating_sub(cache)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meminfo_available_in_bytes() {
        let t = "MemTotal:       24000000 kB\nMemFree:  100 kB\nMemAvailable:   22962844 kB\n";
        assert_eq!(meminfo_available(t), Some(22_962_844 * 1024));
        assert_eq!(meminfo_available("MemTotal: 1 kB\n"), None);
        assert_eq!(meminfo_available("MemAvailable: x kB\n"), None);
    }

    fn write(dir: &Path, name: &str, text: &str) {
        std::fs::create_dir_all(dir).unwrap();
        std::fs::write(dir.join(name), text).unwrap();
    }

    /// v2: the least limit on the way up, the inactive page cache not counted as used;
    /// no limit anywhere: none.
    #[test]
    fn v2_headroom_takes_the_least_limit_above_the_group() {
        let t = tempfile::tempdir().unwrap();
        let root = t.path();
        let job = root.join("slurm/job_7/step_0");
        write(&root.join("slurm"), "memory.max", "max\n");
        write(&root.join("slurm/job_7"), "memory.max", "4294967296\n");
        write(&job, "memory.max", "max\n");
        write(&job, "memory.current", "1073741824\n");
        write(
            &job,
            "memory.stat",
            "anon 536870912\ninactive_file 536870912\n",
        );
        let cgroup = "0::/slurm/job_7/step_0\n";
        assert_eq!(group_headroom(cgroup, root), Some((4 << 30) - (512 << 20)));
        std::fs::write(root.join("slurm/job_7/memory.max"), "max\n").unwrap();
        assert_eq!(group_headroom(cgroup, root), None);
    }

    /// v1: the hierarchical limit; the kernel's "unlimited" is none; a group directory
    /// that is not visible (a namespace) falls back to the mount's root.
    #[test]
    fn v1_headroom_reads_the_hierarchical_limit() {
        let t = tempfile::tempdir().unwrap();
        let mem = t.path().join("memory");
        let stat =
            "total_rss 100\nhierarchical_memory_limit 2147483648\ntotal_inactive_file 1073741824\n";
        write(&mem, "memory.stat", stat);
        write(&mem, "memory.usage_in_bytes", "1610612736\n");
        let cgroup = "4:memory:/pod/abc\n3:cpu:/\n";
        assert_eq!(
            group_headroom(cgroup, t.path()),
            Some((2 << 30) - (512 << 20))
        );
        let stat = "hierarchical_memory_limit 9223372036854771712\n";
        std::fs::write(mem.join("memory.stat"), stat).unwrap();
        assert_eq!(group_headroom(cgroup, t.path()), None);
    }
}
