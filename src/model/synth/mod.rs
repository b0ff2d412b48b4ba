//! Deterministic procedural Barcelona-Eixample district written as CityGML 2.0 (LoD3), the
//! test bed of every skylod stage and the README's demo fixture.
//!
//! # What it makes
//!
//! A grid of `blocks_x` x `blocks_y` Eixample blocks (pitch 133.3 m, streets 20 m, 45 degree
//! chamfers with 15 m legs) in EPSG:25831 with the south-west street corner at
//! (430000, 4581000), ground at z = 12 m. Each block is a ring of 24–28 perimeter buildings of
//! 4–9 storeys (3.1 m each) around a courtyard (`layout`). Each `bldg:Building` has
//! `bldg:WallSurface`s (street, courtyard and two party walls), a `bldg:GroundSurface` and a
//! `bldg:RoofSurface` (flat with a parapet, or about 12% gabled), each with
//! `bldg:lod3MultiSurface`. Facade openings are `bldg:Window`/`bldg:Door` with their own
//! `lod3MultiSurface` (the pane/leaf, recessed 0.15/0.2 m); the wall polygon has a matching
//! interior ring per opening and four reveal polygons (`building`). With `with_lod2` every
//! surface also carries its LoD2 shell as `bldg:lod2MultiSurface` (walls without holes, the
//! flat roof at parapet height). `lod = 2` writes only the LoD2 shells.
//!
//! # Installation function codes
//!
//! Every `bldg:BuildingInstallation` is an `outerBuildingInstallation` with one
//! `bldg:function` and a `bldg:lod3Geometry` MultiSurface. Codes follow the PLATEAU
//! codelist `BuildingInstallation_function.xml` (i-UR / MLIT Japan, copy in
//! `shared/data/plateau/codelists/`) where it has an entry; the two kinds it lacks get
//! codes outside its 1000–1070 range:
//!
//! | code | kind | PLATEAU entry |
//! |---|---|---|
//! | 1000 | balcony (slab + railing) | 1000 バルコニー (balcony) |
//! | 1030 | chimney | 1030 煙突 (chimney) |
//! | 1033 | antenna (0.1 m mast, 3–7 m) | 1033 アンテナ (antenna) |
//! | 1041 | stair tower (box with its own roof) | 1041 塔屋 (rooftop penthouse) |
//! | 9010 | water tank (box or 12-sided prism) | none (skylod code) |
//! | 9020 | solar panel (slab tilted 30 degrees toward the roof axis nearest south) | none (skylod code) |
//!
//! Building `bldg:roofType` uses the SIG3D CityGML 2.0 codelist: 1000 flat, 1030 gabled.
//!
//! # Identifiers and precision
//!
//! Buildings are `B{bx}_{by}_{lot}`; inside a building `_i{k}` installations, `_s{k}`
//! surfaces, `_o{k}` openings, `_p{k}` polygons (numbered in document order). Coordinates
//! have 3 decimals. Each building draws from its own ChaCha8 stream seeded from
//! (seed, block, lot), so output depends only on the options.
//!
//! # Example
//!
//! ```rust
//! use skylod::model::synth::{generate, Preset};
//!
//! let opts = Preset::Small.defaults();
//! let mut out = Vec::new();
//! let summary = generate(&opts, &mut out).unwrap();
//! let text = String::from_utf8(out).unwrap();
//! assert_eq!(text.matches("<gml:Polygon ").count() as u64, summary.polygons);
//! assert!(summary.windows > 0 && summary.buildings == 3);
//! ```

pub(crate) mod boxes;
pub(crate) mod building;
pub(crate) mod gml;
pub(crate) mod layout;
pub(crate) mod mesh;
pub(crate) mod poi;
pub use boxes::{boxes_citygml, BoxBuilding};
pub use building::{build, BuildingGeom, SurfaceKind};
pub use gml::push_num;
pub use layout::{block_lots, LotEdge};
pub use mesh::Mesh;

pub use poi::{pois, pois_path, write_pois_csv, SynthPoi};

use crate::model::Bbox;
use std::collections::BTreeMap;
use std::io::Write;

/// Errors of the generator.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SynthError {
    /// Writing failed.
    #[error("synth: write failed: {0}")]
    Io(#[from] std::io::Error),
    /// The options are out of range.
    #[error("synth: invalid options: {0}")]
    InvalidOptions(String),
}

/// Size/style preset.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Preset {
    /// Three buildings around one street corner of each block (1 block by default), at most
    /// 5 storeys: a fixture small enough to commit (< 300 KB).
    Small,
    /// Full blocks; default 8 x 5 blocks, about 300K polygons like the paper's district.
    Paper,
    /// Full blocks; default 16 x 16 blocks, millions of polygons (streamed).
    City,
}

impl Preset {
    /// Default options of this preset (seed 7, LoD3, no LoD2 shells).
    pub fn defaults(self) -> SynthOptions {
        let (bx, by) = match self {
            Preset::Small => (1, 1),
            Preset::Paper => (8, 5),
            Preset::City => (16, 16),
        };
        SynthOptions {
            blocks_x: bx,
            blocks_y: by,
            seed: 7,
            lod: 3,
            preset: self,
            with_lod2: false,
        }
    }

    /// Buildings generated per block (`None`: the whole ring).
    pub fn buildings_per_block(self) -> Option<usize> {
        match self {
            Preset::Small => Some(3),
            Preset::Paper | Preset::City => None,
        }
    }

    /// Highest storey count drawn (Small keeps its corner low to stay a small fixture).
    pub fn max_storeys(self) -> u32 {
        match self {
            Preset::Small => 5,
            Preset::Paper | Preset::City => 9,
        }
    }

    /// Lower-case name.
    pub fn as_str(self) -> &'static str {
        match self {
            Preset::Small => "small",
            Preset::Paper => "paper",
            Preset::City => "city",
        }
    }
}

/// Generator options.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthOptions {
    /// Blocks east-west (1..=1000).
    pub blocks_x: u32,
    /// Blocks north-south (1..=1000).
    pub blocks_y: u32,
    /// Random seed.
    pub seed: u64,
    /// 3: full LoD3 detail; 2: LoD2 shells only.
    pub lod: u8,
    /// Style preset (buildings per block).
    pub preset: Preset,
    /// Also write LoD2 shells (`lod2MultiSurface`) on the surfaces of LoD3 buildings.
    pub with_lod2: bool,
}

impl Default for SynthOptions {
    fn default() -> Self {
        Preset::Paper.defaults()
    }
}

impl SynthOptions {
    fn validate(&self) -> Result<(), SynthError> {
        if !(1..=1000).contains(&self.blocks_x) || !(1..=1000).contains(&self.blocks_y) {
            return Err(SynthError::InvalidOptions(format!(
                "blocks must be 1..=1000 per axis, got {}x{}",
                self.blocks_x, self.blocks_y
            )));
        }
        if !(2..=3).contains(&self.lod) {
            return Err(SynthError::InvalidOptions(format!(
                "lod must be 2 or 3, got {}",
                self.lod
            )));
        }
        Ok(())
    }
}

/// Kind (function) of a building installation; see the module docs for the codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum InstallationKind {
    /// Facade balcony, code 1000.
    Balcony,
    /// Chimney, code 1030.
    Chimney,
    /// Antenna mast, code 1033.
    Antenna,
    /// Rooftop stair tower, code 1041.
    StairTower,
    /// Water tank, code 9010.
    WaterTank,
    /// Solar panel, code 9020.
    SolarPanel,
}

impl InstallationKind {
    /// All kinds.
    pub const ALL: [InstallationKind; 6] = [
        InstallationKind::Balcony,
        InstallationKind::Chimney,
        InstallationKind::Antenna,
        InstallationKind::StairTower,
        InstallationKind::WaterTank,
        InstallationKind::SolarPanel,
    ];

    /// The `bldg:function` code.
    pub fn code(self) -> &'static str {
        match self {
            InstallationKind::Balcony => "1000",
            InstallationKind::Chimney => "1030",
            InstallationKind::Antenna => "1033",
            InstallationKind::StairTower => "1041",
            InstallationKind::WaterTank => "9010",
            InstallationKind::SolarPanel => "9020",
        }
    }

    /// English name.
    pub fn name(self) -> &'static str {
        match self {
            InstallationKind::Balcony => "balcony",
            InstallationKind::Chimney => "chimney",
            InstallationKind::Antenna => "antenna",
            InstallationKind::StairTower => "stair tower",
            InstallationKind::WaterTank => "water tank",
            InstallationKind::SolarPanel => "solar panel",
        }
    }

    /// Stands on the roof (all but balconies).
    pub fn on_roof(self) -> bool {
        self != InstallationKind::Balcony
    }
}

/// Counts of what [`generate`] wrote (each equals the number of the matching start tags).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SynthSummary {
    /// `bldg:Building`.
    pub buildings: u64,
    /// `bldg:RoofSurface`.
    pub roof_surfaces: u64,
    /// `bldg:WallSurface`.
    pub wall_surfaces: u64,
    /// `bldg:GroundSurface`.
    pub ground_surfaces: u64,
    /// `bldg:BuildingInstallation` by function.
    pub installations: BTreeMap<InstallationKind, u64>,
    /// `bldg:Window`.
    pub windows: u64,
    /// `bldg:Door`.
    pub doors: u64,
    /// `gml:Polygon`, every one written.
    pub polygons: u64,
    /// Bytes written.
    pub bytes: u64,
    /// Bounding box of all coordinates (as written, millimetre-rounded); equals the envelope.
    pub bbox: Bbox,
}

impl SynthSummary {
    /// Total number of installations.
    pub fn installations_total(&self) -> u64 {
        self.installations.values().sum()
    }
}

/// Visit every building of the district in document order.
fn for_each_building(
    opts: &SynthOptions,
    g: &mut building::BuildingGeom,
    mut f: impl FnMut(&building::BuildingGeom) -> Result<(), SynthError>,
) -> Result<(), SynthError> {
    let mut lots = Vec::with_capacity(32);
    let limit = opts.preset.buildings_per_block().unwrap_or(usize::MAX);
    for by in 0..opts.blocks_y {
        for bx in 0..opts.blocks_x {
            layout::block_lots(opts.seed, bx, by, &mut lots);
            for lot in lots.iter().take(limit) {
                building::build(lot, opts, g);
                f(g)?;
            }
        }
    }
    Ok(())
}

/// The district's bounding box, computed by generating the geometry without writing it.
pub fn district_bbox(opts: &SynthOptions) -> Result<Bbox, SynthError> {
    opts.validate()?;
    let mut g = building::BuildingGeom::default();
    let mut bbox = Bbox::EMPTY;
    for_each_building(opts, &mut g, |g| {
        for p in &g.mesh.pts {
            bbox.add(p.map(gml::round_mm));
        }
        Ok(())
    })?;
    Ok(bbox)
}

/// Write the district described by `opts` as CityGML 2.0 to `out`, streaming building by
/// building (memory does not grow with the district). The envelope is computed in a first
/// geometry-only pass.
pub fn generate<W: Write>(opts: &SynthOptions, mut out: W) -> Result<SynthSummary, SynthError> {
    let bbox = district_bbox(opts)?;
    let mut sum = SynthSummary {
        bbox,
        ..SynthSummary::default()
    };
    let mut buf: Vec<u8> = Vec::with_capacity(1 << 20);
    let name = format!(
        "skylod synth: Eixample district, preset {}, {}x{} blocks, seed {}, LoD{}{}",
        opts.preset.as_str(),
        opts.blocks_x,
        opts.blocks_y,
        opts.seed,
        opts.lod,
        if opts.with_lod2 && opts.lod == 3 {
            " + LoD2 shells"
        } else {
            ""
        }
    );
    gml::header(&mut buf, &name, &bbox);
    let mut g = building::BuildingGeom::default();
    for_each_building(opts, &mut g, |g| {
        gml::building(&mut buf, g, &mut sum);
        if buf.len() >= 1 << 19 {
            out.write_all(&buf)?;
            sum.bytes += buf.len() as u64;
            buf.clear();
        }
        Ok(())
    })?;
    gml::footer(&mut buf);
    out.write_all(&buf)?;
    sum.bytes += buf.len() as u64;
    out.flush()?;
    Ok(sum)
}
