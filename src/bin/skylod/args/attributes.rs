//! `--output-attributes -o OUT` of `irradiance`: with `--facade` or `--region`, the model
//! written again with each thematic surface that holds POIs given the mean annual irradiation
//! of its POIs ([`skylod::pipeline::write_surface_means`]): CityGML by span edits
//! (a generic attribute `skylodAnnualIrradiation`, everything else byte for byte), or
//! CityJSON (an attribute of the surface's semantic object).

use anyhow::bail;
use skylod::export::Format;
use skylod::pipeline::write_surface_means;
use skylod::pipeline::Framed;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct AttributeArgs {
    /// With --facade or --region: write the model (one input) to -o with the mean annual
    /// irradiation (kWh/m²) of the POIs of each wall, roof or other thematic surface that
    /// holds POIs, as its attribute skylodAnnualIrradiation (CityGML: a generic attribute
    /// added in place; CityJSON: on the surface's semantic object; 3D Tiles: the property
    /// `irradiance`).
    #[arg(long, requires = "output")]
    pub output_attributes: bool,
    /// The model written by --output-attributes: .gml, .xml (.gz), .city.json, or
    /// DIR/tileset.json (3D Tiles, the value as each surface's `irradiance`).
    #[arg(short = 'o', long, value_name = "OUT", requires = "output_attributes")]
    pub output: Option<PathBuf>,
    /// With a 3D Tiles output, also write DIR/index.html: the tileset in CesiumJS, coloured
    /// by irradiance.
    #[arg(long, requires = "output")]
    pub viewer: bool,
}

impl AttributeArgs {
    /// Usage checks before any input is read: a region, a format that takes attributes, a
    /// target that may be written (`overwrite`).
    pub fn check(&self, region: bool, overwrite: bool) -> anyhow::Result<()> {
        let Some(out) = &self.output else {
            return Ok(());
        };
        if !region {
            bail!("--output-attributes needs --facade or --region: the POIs of surfaces");
        }
        match Format::from_path(out) {
            Some(Format::CityGml | Format::CityJson | Format::Tiles) | None => {}
            Some(f) => bail!(
                "--output-attributes writes CityGML, CityJSON (.city.json) or 3D Tiles (DIR/tileset.json), not {f:?}: {}",
                out.display()
            ),
        }
        skylod::io::check_target(out, [], overwrite)?;
        Ok(())
    }

    /// Write the model of `framed` (its one input) with the mean of `values` (one per POI)
    /// per surface; the number of surfaces given it.
    pub fn write(
        &self,
        framed: &Framed<'_>,
        values: &[f64],
        overwrite: bool,
    ) -> anyhow::Result<Option<usize>> {
        let Some(out) = &self.output else {
            return Ok(None);
        };
        let model = framed.source;
        if model.files.len() != 1 {
            bail!(
                "--output-attributes writes one model: give one input (got {})",
                model.files.len()
            );
        }
        let n = write_surface_means(framed, values, out, (overwrite, self.viewer))?;
        Ok(Some(n))
    }
}
