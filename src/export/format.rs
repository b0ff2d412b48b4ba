//! Output format from the output's name (DESIGN.md "Batch, streams and scale"): `.gml`/`.xml`
//! (+`.gz`; also `.citygml`, as some datasets are named) CityGML, `.obj` OBJ, `.city.json`
//! CityJSON 2.0, `.city.jsonl` CityJSONSeq, `tileset.json` 3D Tiles 1.1 (the folder holding
//! it is the tileset). Any other name is refused unless the format is named explicitly
//! (`--format`).
//!
//! # Example
//! ```
//! use skylod::export::Format;
//! use std::path::Path;
//! assert_eq!(Format::from_path(Path::new("a/b.city.jsonl")), Some(Format::CityJsonSeq));
//! assert_eq!(Format::from_path(Path::new("model.OBJ")), Some(Format::Obj));
//! assert_eq!(Format::from_path(Path::new("x.json")), None);
//! assert_eq!(Format::from_path(Path::new("web/tileset.json")), Some(Format::Tiles));
//! assert_eq!(Format::resolve(Path::new("x.json"), Some(Format::CityJson)).unwrap(), Format::CityJson);
//! assert!(Format::resolve(Path::new("x.json"), None).is_err());
//! assert_eq!("cityjsonseq".parse::<Format>().unwrap(), Format::CityJsonSeq);
//! ```

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// A format skylod writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// CityGML, same version as the input (`.gml`, `.xml`, `.citygml`; `.gz` compresses).
    CityGml,
    /// Wavefront OBJ, triangles (`.obj`).
    Obj,
    /// CityJSON 2.0 (`.city.json`).
    CityJson,
    /// CityJSON Text Sequences (`.city.jsonl`): a CityJSON header line, then one
    /// CityJSONFeature per line.
    CityJsonSeq,
    /// 3D Tiles 1.1 (`DIR/tileset.json`, the tiles as glTF binary beside it).
    Tiles,
}

/// The output name does not tell the format.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "{}: unknown output format; name it .gml/.xml (+.gz) for CityGML, .obj, .city.json or \
     .city.jsonl, DIR/tileset.json for 3D Tiles, or give the format",
    .0.display()
)]
pub struct UnknownFormat(pub PathBuf);

/// `--format` names, in the order of [`Format::ALL`].
const NAMES: [&str; 5] = ["citygml", "obj", "cityjson", "cityjsonseq", "3dtiles"];

impl Format {
    /// Every format.
    pub const ALL: [Format; 5] = [
        Format::CityGml,
        Format::Obj,
        Format::CityJson,
        Format::CityJsonSeq,
        Format::Tiles,
    ];

    /// The `--format` name: `citygml`, `obj`, `cityjson`, `cityjsonseq`, `3dtiles`.
    pub fn name(self) -> &'static str {
        NAMES[self as usize]
    }

    /// The file name ending written for this format (`.gml`, `.obj`, `.city.json`,
    /// `.city.jsonl`; a tileset: `/tileset.json`, a folder of its own).
    pub fn extension(self) -> &'static str {
        match self {
            Format::Tiles => "/tileset.json",
            Format::CityGml => ".gml",
            Format::Obj => ".obj",
            Format::CityJson => ".city.json",
            Format::CityJsonSeq => ".city.jsonl",
        }
    }

    /// The format a file name asks for, by its ending (case-insensitive); `None` when the
    /// ending is none of the known ones.
    pub fn from_path(path: &Path) -> Option<Format> {
        let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
        let citygml = [
            ".gml",
            ".xml",
            ".citygml",
            ".gml.gz",
            ".xml.gz",
            ".citygml.gz",
        ];
        if citygml.iter().any(|e| name.ends_with(e)) {
            Some(Format::CityGml)
        } else if name.ends_with(".obj") {
            Some(Format::Obj)
        } else if name.ends_with(".city.json") {
            Some(Format::CityJson)
        } else if name.ends_with(".city.jsonl") {
            Some(Format::CityJsonSeq)
        } else if name == "tileset.json" {
            Some(Format::Tiles)
        } else {
            None
        }
    }

    /// The format to write `path` in: `explicit` when given (`--format`), else the one its
    /// name asks for.
    ///
    /// # Errors
    /// [`UnknownFormat`] when no format is given and the name has no known ending.
    pub fn resolve(path: &Path, explicit: Option<Format>) -> Result<Format, UnknownFormat> {
        explicit
            .or_else(|| Format::from_path(path))
            .ok_or_else(|| UnknownFormat(path.to_path_buf()))
    }

    /// Output file name for an input named `input_name` written in this format into an output
    /// directory: the input's name for CityGML (a CityJSON name with `.gml` for its JSON
    /// ending), otherwise the input's name with its CityGML
    /// ending (`.gml`, `.xml`, `.citygml`, each with or without `.gz`) replaced by [`Format::extension`].
    pub fn output_name(self, input_name: &str) -> String {
        if self == Format::CityGml {
            // a CityJSON input's CityGML: `x.city.json` → `x.gml`, `x.city.jsonl.gz` → `x.gml.gz`
            let lower = input_name.to_ascii_lowercase();
            let json = [".city.jsonl", ".city.json", ".jsonl", ".json"];
            for gz in ["", ".gz"] {
                if let Some(e) = json.iter().find(|e| lower.ends_with(&format!("{e}{gz}"))) {
                    let stem = input_name.len() - e.len() - gz.len();
                    return format!("{}.gml{gz}", &input_name[..stem]);
                }
            }
            return input_name.to_string();
        }
        let lower = input_name.to_ascii_lowercase();
        let stem_len = [
            ".gml.gz",
            ".xml.gz",
            ".citygml.gz",
            ".gml",
            ".xml",
            ".citygml",
            ".gz",
        ]
        .iter()
        .find(|e| lower.ends_with(*e))
        .map_or(input_name.len(), |e| input_name.len() - e.len());
        format!("{}{}", &input_name[..stem_len], self.extension())
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Format {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let l = s.to_ascii_lowercase();
        Format::ALL
            .into_iter()
            .find(|f| f.name() == l)
            .ok_or_else(|| format!("{s:?} is not a format; use one of {}", NAMES.join(", ")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn endings() {
        let table = [
            ("a.gml", Some(Format::CityGml)),
            ("a.XML", Some(Format::CityGml)),
            ("dir.d/a.gml.gz", Some(Format::CityGml)),
            ("a.xml.gz", Some(Format::CityGml)),
            ("a.obj", Some(Format::Obj)),
            ("a.city.json", Some(Format::CityJson)),
            ("a.City.JSONL", Some(Format::CityJsonSeq)),
            ("a.json", None),
            ("out/TileSet.json", Some(Format::Tiles)),
            ("mytileset.json", None),
            ("a.jsonl", None),
            ("a.citygml", Some(Format::CityGml)),
            ("a.gz", None),
            ("a.obj.gz", None),
            ("a", None),
            ("-", None),
        ];
        for (name, want) in table {
            assert_eq!(Format::from_path(Path::new(name)), want, "{name}");
        }
    }

    #[test]
    fn names_round_trip() {
        for f in Format::ALL {
            assert_eq!(f.name().parse::<Format>(), Ok(f));
            assert_eq!(
                Format::from_path(Path::new(&format!("x{}", f.extension()))),
                Some(f)
            );
        }
        assert!("json".parse::<Format>().is_err());
    }

    #[test]
    fn directory_names() {
        assert_eq!(Format::Obj.output_name("4018106.xml.gz"), "4018106.obj");
        assert_eq!(Format::CityJsonSeq.output_name("a.GML"), "a.city.jsonl");
        assert_eq!(Format::CityJson.output_name("noext"), "noext.city.json");
        assert_eq!(Format::CityGml.output_name("a.xml.gz"), "a.xml.gz");
        assert_eq!(Format::Tiles.output_name("a.gml"), "a/tileset.json");
    }

    #[test]
    fn unknown_names_the_file() {
        let e = Format::resolve(Path::new("out.txt"), None).unwrap_err();
        assert!(e.to_string().starts_with("out.txt: unknown output format"));
    }
}
