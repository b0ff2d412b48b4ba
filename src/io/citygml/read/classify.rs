//! Element classification: what a GML or CityGML element is to the reader (building, asset,
//! geometry property, polygon, ring, coordinates, ...), from its namespace and local name.

use super::coords::CoordAttrs;
use super::state::{Attrs, Capture, CoordKind, EnvOwner, Implicit, Kind, Parser, Part};
use crate::io::citygml::error::ReadError;
use crate::io::citygml::ns::{Module, Ns};
use crate::model::{AssetKind, Bbox, Building, CityGmlVersion, EnvelopeSite};

pub(super) const SHELL_NAMES: &[(&[u8], AssetKind)] = &[
    (b"RoofSurface", AssetKind::Roof),
    (b"WallSurface", AssetKind::Wall),
    (b"GroundSurface", AssetKind::Ground),
    (b"ClosureSurface", AssetKind::Closure),
    (b"OuterCeilingSurface", AssetKind::OuterCeiling),
    (b"OuterFloorSurface", AssetKind::OuterFloor),
];

pub(super) const INTERIOR_NAMES: &[&[u8]] = &[
    b"IntBuildingInstallation",
    b"Room",
    b"BuildingRoom",
    b"BuildingFurniture",
    b"InteriorWallSurface",
    b"CeilingSurface",
    b"FloorSurface",
];

/// `lodN...` property name -> N.
pub(super) fn is_lod_property(local: &[u8]) -> Option<u8> {
    if local.len() > 4 && local.starts_with(b"lod") {
        let d = local[3];
        if (b'0'..=b'4').contains(&d) && local[4].is_ascii_uppercase() {
            return Some(d - b'0');
        }
    }
    None
}

impl Parser<'_> {
    pub(super) fn open_geom_prop(&mut self, local: &[u8], name: &mut Option<Box<str>>) -> Kind {
        let lod = match is_lod_property(local) {
            Some(lod) => lod,
            None => self.relief_lod,
        };
        *name = Some(String::from_utf8_lossy(local).into());
        Kind::GeomProp {
            lod,
            start: self.parts.len() as u32,
            owner: self.geom_owner(),
        }
    }

    /// Kinds of GML elements.
    pub(super) fn gml_kind(
        &mut self,
        local: &[u8],
        parent: Option<Kind>,
        attrs: &Attrs,
        pos: u64,
    ) -> Result<Kind, ReadError> {
        match local {
            b"boundedBy" => {
                return Ok(Kind::BoundedBy);
            }
            b"Envelope" if matches!(parent, Some(Kind::BoundedBy)) => {
                // owner: the frame below boundedBy
                let owner = self
                    .stack
                    .len()
                    .checked_sub(2)
                    .and_then(|i| self.stack.get(i))
                    .map(|f| f.kind);
                let env_owner = match owner {
                    Some(Kind::Root) => Some(EnvOwner::Root),
                    Some(Kind::Building(b)) => Some(EnvOwner::Building(b)),
                    Some(Kind::Asset(a)) => Some(EnvOwner::Asset(a)),
                    _ => None,
                };
                if let Some(o) = env_owner {
                    let idx = self.envelopes.len();
                    self.envelopes.push(EnvelopeSite {
                        span: pos..pos,
                        bbox: Bbox::EMPTY,
                        srs_name: attrs.srs_name.as_deref().map(str::to_string),
                        dimension: match attrs.srs_dimension.as_deref().map(str::trim) {
                            Some("2") => 2,
                            _ => 3,
                        },
                        prefix: self.cur_prefix.clone(),
                        file: 0,
                    });
                    self.env_owners.push(o);
                    if matches!(owner, Some(Kind::Root)) {
                        if let Some(s) = &attrs.srs_name {
                            self.srs_name = Some(s.to_string());
                            self.root_srs_set = true;
                        }
                    }
                    return Ok(Kind::Envelope(idx));
                }
                return Ok(Kind::Plain);
            }
            _ => {}
        }
        self.geometry_kind(Ns::Gml, local, attrs, pos)
    }

    /// Geometry element kinds (also used inside skipped interiors so that counts and ids stay right).
    pub(super) fn geometry_kind(
        &mut self,
        ns: Ns,
        local: &[u8],
        _attrs: &Attrs,
        _pos: u64,
    ) -> Result<Kind, ReadError> {
        if ns != Ns::Gml {
            if let Some(_lod) = is_lod_property(local) {
                let mut n = None;
                return Ok(self.open_geom_prop(local, &mut n));
            }
            if local == b"ImplicitGeometry" {
                return Ok(self.open_implicit());
            }
            if local == b"transformationMatrix" && self.top_is_implicit() {
                return Ok(self.begin_capture(Capture::Matrix, CoordAttrs::default()));
            }
            if local == b"libraryObject" && self.top_is_implicit() {
                return Ok(self.begin_capture(Capture::Library, CoordAttrs::default()));
            }
            if local == b"referencePoint" && self.top_is_implicit() {
                return Ok(Kind::RefPointProp);
            }
            if self.skip_depth > 0 && INTERIOR_NAMES.contains(&local) {
                return Ok(Kind::Skip);
            }
            return Ok(Kind::Plain);
        }
        let parent = self.stack.last().map(|f| f.kind);
        Ok(match local {
            b"Polygon" | b"PolygonPatch" | b"Triangle" | b"Rectangle" => Kind::Polygon,
            b"exterior" | b"outerBoundaryIs" if matches!(parent, Some(Kind::Polygon)) => {
                self.ring.clear();
                self.in_ring += 1;
                Kind::Ring { exterior: true }
            }
            b"interior" | b"innerBoundaryIs" if matches!(parent, Some(Kind::Polygon)) => {
                self.ring.clear();
                self.in_ring += 1;
                Kind::Ring { exterior: false }
            }
            b"posList" | b"pos" | b"coordinates" => {
                let k = match local {
                    b"posList" => CoordKind::PosList,
                    b"pos" => CoordKind::Pos,
                    _ => CoordKind::Coordinates,
                };
                let attrs = CoordAttrs {
                    dim: _attrs
                        .srs_dimension
                        .as_deref()
                        .and_then(|d| match d.trim() {
                            "2" => Some(2),
                            "3" => Some(3),
                            _ => None,
                        }),
                    cs: _attrs.cs.unwrap_or(b','),
                    ts: _attrs.ts.unwrap_or(b' '),
                    decimal: _attrs.decimal.unwrap_or(b'.'),
                };
                if self.in_ring > 0 {
                    self.begin_capture(Capture::RingCoords(k), attrs)
                } else if k == CoordKind::Pos && self.in_ref_point() {
                    self.begin_capture(Capture::RefPoint, attrs)
                } else {
                    Kind::Plain
                }
            }
            _ => Kind::Plain,
        })
    }

    pub(super) fn open_implicit(&mut self) -> Kind {
        self.implicit_count += 1;
        let idx = self.implicits.len() as u32;
        self.implicits.push(Implicit::default());
        let at = self.parts.len() as u32;
        self.parts.push(Part::Implicit { idx, len: 0 });
        Kind::Implicit(at)
    }

    pub(super) fn begin_capture(&mut self, c: Capture, attrs: CoordAttrs) -> Kind {
        self.capture = true;
        self.capture_kind = c;
        self.capture_attrs = attrs;
        self.text.clear();
        Kind::Capture(c)
    }

    /// Kinds of CityGML elements: buildings, assets, properties.
    pub(super) fn citygml_kind(
        &mut self,
        module: Module,
        local: &[u8],
        parent: Option<Kind>,
        attrs: &Attrs,
        pos: u64,
        name: &mut Option<Box<str>>,
    ) -> Result<Kind, ReadError> {
        let id = attrs.id.as_deref();
        // members of the CityModel
        if matches!(parent, Some(Kind::Root)) && self.root_is_model {
            if local == b"appearanceMember" || local.starts_with(b"version") {
                return Ok(Kind::Skip);
            }
            if local.ends_with(b"Member") || local.ends_with(b"Members") {
                return Ok(Kind::Member);
            }
        }
        if module == Module::Appearance {
            return Ok(Kind::Skip);
        }
        let is_building_module = matches!(
            module,
            Module::Building | Module::Construction | Module::Core
        );
        let (building, asset) = self.innermost_feature();
        if module == Module::Building && (local == b"Building" || local == b"BuildingPart") {
            let is_part = local == b"BuildingPart";
            let idx = self.buildings.len();
            self.buildings.push(Building {
                id: id.map(str::to_string),
                is_part,
                parent: building,
                span: pos..pos,
                line: self.line(),
                assets: Vec::new(),
                geometries: Vec::new(),
                file: 0,
            });
            return Ok(Kind::Building(idx));
        }
        if is_building_module && INTERIOR_NAMES.contains(&local) {
            return Ok(Kind::Skip);
        }
        let asset_kind = asset.map(|a| self.assets[a].kind);
        if is_building_module {
            if let Some((_, k)) = SHELL_NAMES.iter().find(|(n, _)| *n == local) {
                let k = *k;
                if building.is_some() || asset.is_none() {
                    match asset_kind {
                        Some(ak) if !ak.is_shell_surface() => return Ok(Kind::Plain),
                        _ => {
                            let a = self.new_asset(k, local, id, building, asset, pos);
                            return Ok(Kind::Asset(a));
                        }
                    }
                }
            }
            if local == b"BuildingInstallation" || local == b"BuildingConstructiveElement" {
                if asset.is_none() {
                    let a = self.new_asset(AssetKind::Installation, local, id, building, None, pos);
                    return Ok(Kind::Asset(a));
                }
                return Ok(Kind::Plain);
            }
            let opening = match local {
                b"Window" | b"WindowSurface" => Some(AssetKind::Window),
                b"Door" | b"DoorSurface" => Some(AssetKind::Door),
                _ => None,
            };
            if let Some(k) = opening {
                match asset_kind {
                    None
                    | Some(
                        AssetKind::Roof
                        | AssetKind::Wall
                        | AssetKind::Ground
                        | AssetKind::Closure
                        | AssetKind::OuterCeiling
                        | AssetKind::OuterFloor,
                    ) => {
                        let a = self.new_asset(k, local, id, building, asset, pos);
                        return Ok(Kind::Asset(a));
                    }
                    _ => return Ok(Kind::Plain),
                }
            }
        }
        if local == b"function" && module == Module::Building {
            if let Some(Kind::Asset(a)) = parent {
                if self.assets[a].function.is_none() {
                    return Ok(self.begin_capture(Capture::Function(a), CoordAttrs::default()));
                }
            }
        }
        if module == Module::Relief && local == b"lod" {
            return Ok(self.begin_capture(Capture::ReliefLod, CoordAttrs::default()));
        }
        if module == Module::Relief && (local == b"tin" || local == b"grid") {
            return Ok(self.open_geom_prop(local, name));
        }
        if matches!(parent, Some(Kind::Member))
            || (matches!(parent, Some(Kind::Root)) && !self.root_is_model)
        {
            // A top-level city object that is not a building.
            if local == b"Appearance" {
                return Ok(Kind::Skip);
            }
            let a = self.new_asset(AssetKind::Other, local, id, None, None, pos);
            return Ok(Kind::Asset(a));
        }
        if is_lod_property(local).is_some() {
            return Ok(self.open_geom_prop(local, name));
        }
        self.geometry_kind(Ns::CityGml(module, CityGmlVersion::V2_0), local, attrs, pos)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lod_property_names() {
        assert_eq!(is_lod_property(b"lod3MultiSurface"), Some(3));
        assert_eq!(is_lod_property(b"lod0FootPrint"), Some(0));
        assert_eq!(is_lod_property(b"lod"), None);
        assert_eq!(is_lod_property(b"lod5Solid"), None);
        assert_eq!(is_lod_property(b"lodging"), None);
    }
}
