//! The levels a `lod` shard writes, and the reduce step that combines them.
//!
//! A shard of `skylod lod --shard I/N` traces only its POIs; instead of a model it writes a
//! **levels file**: JSON lines (one JSON object per line, `"type"` says which), UTF-8:
//!
//! 1. `{"type":"header", "format":"skylod-levels", "version":1, "shard":"I/N", "index":I,
//!    "count":N, "inputs":[{"path","len"}], "rays", "seed", "threshold_deg",
//!    "roof_tolerance_m", "angle_deg", "thickness_m", "prefer_lod2", "cells", "triangles",
//!    "pois", "assets"}`: the options the levels were made with (the reduce step uses
//!    them) and the inputs read (`len`: decompressed bytes);
//! 2. one `{"type":"poi", "id", "position":[x,y,z], "normal":[..]|null, "rays",
//!    "sky_rays", "assets_hit", "silhouette_assets", "polygons", "seconds", "flags"}` per
//!    POI of the shard, in order (model CRS);
//! 3. one `{"type":"asset", "file", "span":[start,end], "id", "level", "hits"}` per asset
//!    that a POI of the shard hit: the asset is named by its input file and its byte span
//!    there (and its gml:id when it has one), not by its index in a list.
//!
//! [`combine`] reads the files of all N shards and gives what one serial run would have
//! selected: levels combine by maximum, hits add up, POIs follow in shard order (the order
//! of the serial run, [`crate::pipeline::batch::shard`]); [`crate::pipeline::batch::reduce`] makes the
//! selection of it.

use crate::export::report::report::PoiSeen;
use crate::io::citygml::write::{atomic_write, check_target, is_stdout, WriteOptions};
use crate::io::citygml::WriteError;
use crate::io::files::Protected;
use crate::lod::poi::checks::PoiFlag;
use crate::lod::rough::RoughOptions;
use crate::lod::select::{PoiSelection, Selection};
use crate::lod::{LodOptions, LodResult};
use crate::model::CityModel;
use crate::model::Poi;
use crate::pipeline::batch::shard::Shard;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};

/// `format` of the header line.
pub const FORMAT: &str = "skylod-levels";
/// `version` of the header line.
pub const VERSION: u32 = 1;

/// An input a shard read.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputRecord {
    /// Path as given to the shard.
    pub path: String,
    /// Length of the decompressed document in bytes.
    pub len: u64,
}

/// First line of a levels file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// Always [`FORMAT`].
    pub format: String,
    /// Always [`VERSION`].
    pub version: u32,
    /// `I/N`.
    pub shard: String,
    /// I.
    pub index: usize,
    /// N.
    pub count: usize,
    /// Inputs read, in input order.
    pub inputs: Vec<InputRecord>,
    /// `--rays`.
    pub rays: usize,
    /// `--seed`.
    pub seed: u64,
    /// The silhouette threshold used, degrees.
    pub threshold_deg: f64,
    /// `--roof-tolerance`.
    pub roof_tolerance_m: f64,
    /// `--angle`.
    pub angle_deg: f64,
    /// `--thickness`.
    pub thickness_m: f64,
    /// Not `--no-lod2`.
    pub prefer_lod2: bool,
    /// Cells of the sky partition (rays per POI before the normal's half).
    pub cells: usize,
    /// Triangles of the selection scene.
    pub triangles: usize,
    /// POI lines that follow.
    pub pois: usize,
    /// Assets of the model the shard read.
    pub assets: usize,
}

/// One POI of a shard and what it saw.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoiRecord {
    /// Where the POI is (model CRS) and what its rays saw.
    #[serde(flatten)]
    pub seen: PoiSeen,
    /// [`PoiSelection::polygons`].
    pub polygons: usize,
    /// [`PoiSelection::seconds`].
    pub seconds: f64,
    /// Trust flags.
    pub flags: Vec<PoiFlag>,
}

/// One asset hit by the shard's POIs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AssetRecord {
    /// Input file (as in the header).
    pub file: String,
    /// Byte span of the asset's element in the decompressed file.
    pub span: [u64; 2],
    /// gml:id, when the asset has one.
    pub id: Option<String>,
    /// Level 0, 1 or 2 from this shard's POIs.
    pub level: u8,
    /// Ray hits from this shard's POIs.
    pub hits: u64,
}

/// One line of a levels file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum LevelsLine {
    /// The header.
    Header(Header),
    /// A POI.
    Poi(PoiRecord),
    /// An asset.
    Asset(AssetRecord),
}

/// A levels file read back.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelsFile {
    /// Where it was read from.
    pub path: PathBuf,
    /// Its header.
    pub header: Header,
    /// Its POIs in order.
    pub pois: Vec<PoiRecord>,
    /// Its assets.
    pub assets: Vec<AssetRecord>,
}

/// Errors reading or combining levels files.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LevelsError {
    /// The file cannot be read.
    #[error("{}: {source}", .file.display())]
    Io {
        /// File.
        file: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// A line that is not a levels line.
    #[error("{}:{line}: {message}", .file.display())]
    Syntax {
        /// File.
        file: PathBuf,
        /// Line number from 1.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The files do not belong together, or not to these inputs.
    #[error("{0}")]
    Mismatch(String),
    /// Two shards' levels were made with different options.
    #[error(
        "{} and {} were made with different options (rays, seed, threshold, roof tolerance, \
         angle, thickness or whether LoD2 bodies are read)",
        .first.display(),
        .other.display()
    )]
    Options {
        /// The first shard's levels file.
        first: PathBuf,
        /// A shard's levels file made with other options.
        other: PathBuf,
    },
}

/// The header of a shard's levels for `model` with `opts`.
pub fn header(
    shard: Shard,
    model: &CityModel,
    opts: &LodOptions,
    selection: &Selection,
    triangles: usize,
) -> Header {
    Header {
        format: FORMAT.into(),
        version: VERSION,
        shard: shard.to_string(),
        index: shard.index(),
        count: shard.count(),
        inputs: model
            .files
            .iter()
            .map(|f| InputRecord {
                path: f.path.display().to_string(),
                len: f.len,
            })
            .collect(),
        rays: opts.select.rays,
        seed: opts.select.seed,
        threshold_deg: selection.threshold_deg,
        roof_tolerance_m: opts.select.roof_tolerance_m,
        angle_deg: opts.rough.angle_deg,
        thickness_m: opts.rough.thickness_m,
        prefer_lod2: opts.rough.prefer_lod2,
        cells: selection.rays,
        triangles,
        pois: selection.pois.len(),
        assets: model.assets.len(),
    }
}

/// Write a levels file: `header`, then `pois` (model CRS, with the selection's per-POI
/// figures and `flags`), then every asset with a hit.
///
/// # Errors
/// Errors of `w`.
pub fn write_levels(
    w: &mut dyn Write,
    header: &Header,
    model: &CityModel,
    pois: &[Poi],
    selection: &Selection,
    flags: &[Vec<PoiFlag>],
) -> std::io::Result<u64> {
    let mut n = 0u64;
    let mut line = |l: &LevelsLine, w: &mut dyn Write| -> std::io::Result<()> {
        let mut s = serde_json::to_vec(l).map_err(std::io::Error::other)?;
        s.push(b'\n');
        n += s.len() as u64;
        w.write_all(&s)
    };
    line(&LevelsLine::Header(header.clone()), w)?;
    for (i, (p, s)) in pois.iter().zip(&selection.pois).enumerate() {
        line(
            &LevelsLine::Poi(PoiRecord {
                seen: PoiSeen::new(p, s),
                polygons: s.polygons,
                seconds: s.seconds,
                flags: flags.get(i).cloned().unwrap_or_default(),
            }),
            w,
        )?;
    }
    for (i, a) in model.assets.iter().enumerate() {
        let level = selection.levels.get(i).copied().unwrap_or(0);
        let hits = selection.hits.get(i).copied().unwrap_or(0);
        if level == 0 && hits == 0 {
            continue;
        }
        let file = model
            .files
            .get(a.file)
            .map(|f| f.path.display().to_string())
            .unwrap_or_default();
        line(
            &LevelsLine::Asset(AssetRecord {
                file,
                span: [a.span.start, a.span.end],
                id: a.id.as_deref().map(str::to_owned),
                level,
                hits,
            }),
            w,
        )?;
    }
    Ok(n)
}

/// [`write_levels`] into the file `out`, atomically (`-`: standard output).
///
/// # Errors
/// [`WriteError`] of the target or of writing.
pub fn write_levels_file(
    out: &Path,
    header: &Header,
    model: &CityModel,
    pois: &[Poi],
    selection: &Selection,
    flags: &[Vec<PoiFlag>],
) -> Result<u64, WriteError> {
    atomic_write(out, |w| {
        write_levels(w, header, model, pois, selection, flags).map_err(|source| WriteError::Io {
            file: out.to_path_buf(),
            source,
        })
    })
}

/// Why a shard's levels file target is refused ([`check_levels_target`]).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LevelsTargetError {
    /// The output is not named as a levels file: it must end in `.jsonl` (not
    /// `.city.jsonl`, a model) and not be standard output.
    #[error(
        "shard {shard} writes its levels, not a model: its output must be a levels file (.jsonl)"
    )]
    NotLevels {
        /// The shard.
        shard: Shard,
    },
    /// The target is refused (an input, or an existing file without `overwrite`).
    #[error(transparent)]
    Target(#[from] WriteError),
}

/// Check `out` as the levels file of `shard` before any work: named `.jsonl` (not a
/// CityJSONSeq model, not standard output), never over one of `inputs`, never over an
/// existing file without `overwrite`.
///
/// # Errors
/// [`LevelsTargetError`].
pub fn check_levels_target(
    out: &Path,
    shard: Shard,
    overwrite: bool,
    inputs: &[PathBuf],
) -> Result<(), LevelsTargetError> {
    let name = out.to_string_lossy().to_ascii_lowercase();
    if !name.ends_with(".jsonl") || name.ends_with(".city.jsonl") || is_stdout(out) {
        return Err(LevelsTargetError::NotLevels { shard });
    }
    let wopts = WriteOptions {
        overwrite,
        protect: Protected::new(inputs),
        ..Default::default()
    };
    check_target(out, &wopts, std::iter::empty())?;
    Ok(())
}

/// What [`write_shard`] wrote: one shard's levels file, and what to say of it.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct ShardWritten {
    /// The shard.
    pub shard: Shard,
    /// Its levels file.
    pub out: PathBuf,
    /// Its POIs.
    pub pois: usize,
    /// Assets at level 0, 1, 2.
    pub levels: [usize; 3],
    /// Milliseconds of the selection.
    pub select_ms: f64,
}

impl ShardWritten {
    /// The closing line of the shard's run, with the reading and total times the caller
    /// measured (ms).
    pub fn line(&self, read_ms: f64, total_ms: f64) -> String {
        let [l0, l1, l2] = self.levels;
        format!(
            "shard {}: {} POI(s) -> {}: assets at level 0/1/2 = {l0}/{l1}/{l2}; read {read_ms:.0} \
             ms, select {:.0} ms, total {total_ms:.0} ms",
            self.shard,
            self.pois,
            self.out.display(),
            self.select_ms
        )
    }
}

/// Write shard `shard`'s levels file `out` (`header` then `write_levels_file`) for
/// `pois` of `model`, selected with `opts` as `lod`.
///
/// # Errors
/// [`WriteError`] of the target or of writing.
pub fn write_shard(
    out: &Path,
    shard: Shard,
    model: &CityModel,
    pois: &[Poi],
    opts: &LodOptions,
    lod: &LodResult,
) -> Result<ShardWritten, WriteError> {
    let header = header(shard, model, opts, &lod.selection, lod.triangles);
    write_levels_file(out, &header, model, pois, &lod.selection, &lod.flags)?;
    Ok(ShardWritten {
        shard,
        out: out.to_path_buf(),
        pois: pois.len(),
        levels: lod.selection.level_counts(),
        select_ms: lod.select_s * 1e3,
    })
}

/// Read a levels file.
///
/// # Errors
/// [`LevelsError`] naming the file and line of anything that is not a levels line, a
/// missing or repeated header, or a POI count that differs from the header's.
pub fn read_levels(path: &Path) -> Result<LevelsFile, LevelsError> {
    let io = |source| LevelsError::Io {
        file: path.to_path_buf(),
        source,
    };
    let syntax = |line: usize, message: String| LevelsError::Syntax {
        file: path.to_path_buf(),
        line,
        message,
    };
    let f = std::fs::File::open(path).map_err(io)?;
    let mut header = None;
    let (mut pois, mut assets) = (Vec::new(), Vec::new());
    for (i, l) in std::io::BufReader::new(f).lines().enumerate() {
        let l = l.map_err(io)?;
        if l.trim().is_empty() {
            continue;
        }
        let parsed: LevelsLine =
            serde_json::from_str(&l).map_err(|e| syntax(i + 1, e.to_string()))?;
        match parsed {
            LevelsLine::Header(h) if i == 0 => {
                if h.format != FORMAT || h.version != VERSION {
                    return Err(syntax(
                        1,
                        format!(
                            "{} version {}: this skylod reads {FORMAT} version {VERSION}",
                            h.format, h.version
                        ),
                    ));
                }
                let rough = RoughOptions {
                    angle_deg: h.angle_deg,
                    thickness_m: h.thickness_m,
                    prefer_lod2: h.prefer_lod2,
                };
                rough.check().map_err(|m| syntax(1, m))?;
                header = Some(h);
            }
            LevelsLine::Header(_) => return Err(syntax(i + 1, "a second header".into())),
            _ if header.is_none() => {
                return Err(syntax(1, format!("not a levels file: no {FORMAT} header")))
            }
            LevelsLine::Poi(p) => pois.push(p),
            LevelsLine::Asset(a) => assets.push(a),
        }
    }
    let Some(header) = header else {
        return Err(syntax(1, "empty: no header".into()));
    };
    if header.pois != pois.len() {
        return Err(syntax(
            1,
            format!(
                "the header announces {} POIs, the file holds {} (cut short?)",
                header.pois,
                pois.len()
            ),
        ));
    }
    Ok(LevelsFile {
        path: path.to_path_buf(),
        header,
        pois,
        assets,
    })
}

/// What the shards selected together, for `model` (indices of its assets).
#[derive(Debug, Clone, PartialEq)]
pub struct Combined {
    /// The header of shard 0 (options of every shard).
    pub header: Header,
    /// POIs of all shards in shard order (model CRS).
    pub pois: Vec<Poi>,
    /// Their figures.
    pub selections: Vec<PoiSelection>,
    /// Their flags.
    pub flags: Vec<Vec<PoiFlag>>,
    /// Level per asset of `model`: the maximum over the shards.
    pub levels: Vec<u8>,
    /// Hits per asset of `model`: the sum over the shards.
    pub hits: Vec<u64>,
}

/// Combine the levels files of shards `0..N` for `model` (read from the same inputs).
///
/// # Errors
/// [`LevelsError::Mismatch`] when shards are missing or repeated, were made with other
/// options, or name an input or an asset that `model` does not have.
pub fn combine(mut files: Vec<LevelsFile>, model: &CityModel) -> Result<Combined, LevelsError> {
    let mismatch = |s: String| Err(LevelsError::Mismatch(s));
    files.sort_by_key(|f| f.header.index);
    let Some(first) = files.first() else {
        return mismatch("no levels file to reduce".into());
    };
    let count = first.header.count;
    let same = |a: &Header, b: &Header| {
        a.rays == b.rays
            && a.seed == b.seed
            && a.threshold_deg.to_bits() == b.threshold_deg.to_bits()
            && a.roof_tolerance_m.to_bits() == b.roof_tolerance_m.to_bits()
            && a.angle_deg.to_bits() == b.angle_deg.to_bits()
            && a.thickness_m.to_bits() == b.thickness_m.to_bits()
            && a.prefer_lod2 == b.prefer_lod2
            && a.count == b.count
    };
    for (k, f) in files.iter().enumerate() {
        if f.header.count != count {
            return mismatch(format!(
                "{}: shard {} of a {}-shard run, but {} is of a {count}-shard run",
                f.path.display(),
                f.header.shard,
                f.header.count,
                first.path.display()
            ));
        }
        if f.header.index != k {
            let what = if f.header.index < k {
                format!(
                    "shard {} is given twice ({} and {})",
                    f.header.shard,
                    files[k - 1].path.display(),
                    f.path.display()
                )
            } else {
                format!("shard {k}/{count} is missing")
            };
            return mismatch(what);
        }
        if !same(&f.header, &first.header) {
            return Err(LevelsError::Options {
                first: first.path.clone(),
                other: f.path.clone(),
            });
        }
    }
    if files.len() != count {
        return mismatch(format!(
            "shard {}/{count} is missing ({} of {count} levels files given)",
            files.len(),
            files.len()
        ));
    }
    // Each input a shard names, resolved to a file of the model: the same path, or else
    // the only file of the same name and length (the reduce step may run elsewhere).
    let resolve = |r: &InputRecord| -> Option<usize> {
        if let Some(k) = model
            .files
            .iter()
            .position(|f| f.path.display().to_string() == r.path)
        {
            return Some(k);
        }
        let name = Path::new(&r.path).file_name()?;
        let mut same = model
            .files
            .iter()
            .enumerate()
            .filter(|(_, f)| f.path.file_name() == Some(name) && f.len == r.len);
        let k = same.next()?.0;
        same.next().is_none().then_some(k)
    };
    let mut by_span: HashMap<(usize, u64, u64), usize> = HashMap::new();
    for (i, a) in model.assets.iter().enumerate() {
        by_span.insert((a.file, a.span.start, a.span.end), i);
    }
    let mut levels = vec![0u8; model.assets.len()];
    let mut hits = vec![0u64; model.assets.len()];
    let (mut pois, mut selections, mut flags) = (Vec::new(), Vec::new(), Vec::new());
    for f in &files {
        let mut file_of: HashMap<&str, usize> = HashMap::new();
        for r in &f.header.inputs {
            let Some(k) = resolve(r) else {
                return mismatch(format!(
                    "{}: input {} ({} bytes) is not among the inputs of the reduce step",
                    f.path.display(),
                    r.path,
                    r.len
                ));
            };
            if model.files.get(k).map(|x| x.len) != Some(r.len) {
                return mismatch(format!(
                    "{}: input {} had {} bytes when the shard read it; it has changed",
                    f.path.display(),
                    r.path,
                    r.len
                ));
            }
            file_of.insert(r.path.as_str(), k);
        }
        for a in &f.assets {
            let Some(&k) = file_of.get(a.file.as_str()) else {
                return mismatch(format!(
                    "{}: asset in {}, an input the header does not list",
                    f.path.display(),
                    a.file
                ));
            };
            let found = by_span
                .get(&(k, a.span[0], a.span[1]))
                .copied()
                .filter(|&i| {
                    model
                        .assets
                        .get(i)
                        .is_some_and(|x| x.id.as_deref() == a.id.as_deref())
                });
            let Some(i) = found else {
                return mismatch(format!(
                    "{}: asset {} at bytes {}..{} of {} is not in that input (it has changed \
                     since the shard ran)",
                    f.path.display(),
                    a.id.as_deref().unwrap_or("(no gml:id)"),
                    a.span[0],
                    a.span[1],
                    a.file
                ));
            };
            if let (Some(l), Some(h)) = (levels.get_mut(i), hits.get_mut(i)) {
                *l = (*l).max(a.level.min(2));
                *h += a.hits;
            }
        }
        for p in &f.pois {
            let seen = &p.seen;
            pois.push(seen.poi());
            selections.push(PoiSelection {
                id: seen.id.clone(),
                rays: seen.rays,
                sky_rays: seen.sky_rays,
                assets_hit: seen.assets_hit,
                silhouette_assets: seen.silhouette_assets,
                seconds: p.seconds,
                polygons: p.polygons,
            });
            flags.push(p.flags.clone());
        }
    }
    Ok(Combined {
        header: first.header.clone(),
        pois,
        selections,
        flags,
        levels,
        hits,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lod::lod;
    use crate::model::synth::{generate, pois as synth_pois, Preset};
    use glam::DVec3;

    fn model() -> (CityModel, Vec<Poi>) {
        let opts = Preset::Small.defaults();
        let mut xml = Vec::new();
        generate(&opts, &mut xml).unwrap();
        let m = crate::io::citygml::read::read_bytes(&xml, "small.gml").unwrap();
        let p = synth_pois(&opts).into_iter().map(Into::into).collect();
        (m, p)
    }

    fn write(dir: &Path, shard: Shard, m: &CityModel, pois: &[Poi], o: &LodOptions) -> PathBuf {
        let r = lod(m, pois, o, &crate::Silent).unwrap();
        let path = dir.join(format!("levels-{}.jsonl", shard.index()));
        let w = write_shard(&path, shard, m, pois, o, &r).unwrap();
        let said = (w.pois, w.levels, w.select_ms);
        assert_eq!(
            said,
            (pois.len(), r.selection.level_counts(), r.select_s * 1e3)
        );
        path
    }

    #[test]
    fn a_levels_target_is_a_jsonl_file_never_a_model_nor_an_input() {
        let dir = tempfile::tempdir().unwrap();
        let s: Shard = "1/4".parse().unwrap();
        let input = dir.path().join("in.jsonl");
        std::fs::write(&input, b"x").unwrap();
        let ok = dir.path().join("levels-1.jsonl");
        assert!(check_levels_target(&ok, s, false, std::slice::from_ref(&input)).is_ok());
        for bad in ["m.city.jsonl", "m.gml", "-"] {
            let e = check_levels_target(Path::new(bad), s, false, &[]).unwrap_err();
            assert!(
                matches!(e, LevelsTargetError::NotLevels { shard } if shard == s),
                "{bad}"
            );
        }
        let e = check_levels_target(&input, s, true, std::slice::from_ref(&input)).unwrap_err();
        assert!(matches!(e, LevelsTargetError::Target(_)), "{e}");
        std::fs::write(&ok, b"").unwrap();
        assert!(check_levels_target(&ok, s, false, &[]).is_err());
        assert!(check_levels_target(&ok, s, true, &[]).is_ok());
    }

    #[test]
    fn a_shard_says_its_pois_levels_and_times() {
        let w = ShardWritten {
            shard: "1/4".parse().unwrap(),
            out: "l.jsonl".into(),
            pois: 3,
            levels: [1, 2, 3],
            select_ms: 12.4,
        };
        assert_eq!(
            w.line(5.0, 20.6),
            "shard 1/4: 3 POI(s) -> l.jsonl: assets at level 0/1/2 = 1/2/3; read 5 ms, select \
             12 ms, total 21 ms"
        );
    }

    #[test]
    fn shards_combine_to_the_serial_selection() {
        let (m, pois) = model();
        assert!(pois.len() >= 3);
        let o = LodOptions {
            select: crate::lod::select::SelectOptions {
                rays: 2000,
                ..Default::default()
            },
            ..Default::default()
        };
        let serial = lod(&m, &pois, &o, &crate::Silent).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let pts: Vec<DVec3> = pois.iter().map(|p| p.position).collect();
        for n in 1..=3 {
            let files: Vec<LevelsFile> = (0..n)
                .rev()
                .map(|i| {
                    let s = Shard::new(i, n, "").unwrap();
                    let mine = &pois[s.pois(&pts)];
                    read_levels(&write(dir.path(), s, &m, mine, &o)).unwrap()
                })
                .collect();
            let c = combine(files.clone(), &m).unwrap();
            assert_eq!(c.levels, serial.selection.levels, "{n} shards");
            assert_eq!(c.hits, serial.selection.hits, "{n} shards");
            assert_eq!(c.pois, pois);
            assert_eq!(c.flags, serial.flags);
            if n > 1 {
                let e = combine(files[1..].to_vec(), &m).unwrap_err();
                assert!(e.to_string().contains("missing"), "{e}");
                let mut twice = files.clone();
                twice.push(files[0].clone());
                let e = combine(twice, &m).unwrap_err();
                assert!(e.to_string().contains("twice"), "{e}");
            }
        }
    }

    #[test]
    fn bad_files_are_named_with_their_line() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.jsonl");
        std::fs::write(&p, "{\"type\":\"poi\"}\n").unwrap();
        let e = read_levels(&p).unwrap_err().to_string();
        assert!(e.contains("x.jsonl:1"), "{e}");
        std::fs::write(&p, "not json\n").unwrap();
        assert!(read_levels(&p).unwrap_err().to_string().contains(":1:"));
        assert!(read_levels(&dir.path().join("none.jsonl")).is_err());
    }

    #[test]
    fn a_header_with_rough_options_out_of_range_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let (m, pois) = model();
        let o = LodOptions::default();
        let path = write(dir.path(), "0/1".parse().unwrap(), &m, &pois, &o);
        let text = std::fs::read_to_string(&path).unwrap();
        let (head, rest) = text.split_once('\n').unwrap();
        let mut h: serde_json::Value = serde_json::from_str(head).unwrap();
        for (key, bad) in [("angle_deg", 120.0), ("thickness_m", -1.0)] {
            let mut edited = h.clone();
            edited[key] = serde_json::json!(bad);
            std::fs::write(&path, format!("{edited}\n{rest}")).unwrap();
            let e = read_levels(&path).unwrap_err().to_string();
            assert!(e.contains("levels-0.jsonl:1"), "{e}");
            assert!(e.contains(key.split('_').next().unwrap()), "{e}");
        }
        h["angle_deg"] = serde_json::json!(90.0);
        std::fs::write(&path, format!("{h}\n{rest}")).unwrap();
        assert_eq!(read_levels(&path).unwrap().header.angle_deg, 90.0);
    }
}
