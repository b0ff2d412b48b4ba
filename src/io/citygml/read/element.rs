//! Start and end of an element: ids checked, the element classified and pushed on the stack;
//! at its end, what it built (polygon, geometry property, building, asset, envelope) is recorded.

use super::classify::is_lod_property;
use super::state::{
    Capture, EnvOwner, Frame, Kind, Owner, Parser, Part, PendingGeom, PolyBuild, NO_REC,
};
use crate::io::citygml::error::ReadError;
use crate::io::citygml::ns::{self, Module, Ns};
use crate::model::{AssetKind, Bbox, LodGeometry};
use quick_xml::events::BytesStart;
use quick_xml::NsReader;

impl Parser<'_> {
    pub(super) fn start<R>(
        &mut self,
        reader: &NsReader<R>,
        uri: Option<&[u8]>,
        e: &BytesStart,
        pos: u64,
        _empty: bool,
    ) -> Result<(), ReadError> {
        if self.stack.len() >= self.opts.max_depth {
            return Err(ReadError::Limit {
                loc: self.loc(),
                message: format!("element nesting deeper than {}", self.opts.max_depth),
            });
        }
        let ns = uri.map(ns::classify).unwrap_or(Ns::None);
        let local_name = e.local_name();
        let local = local_name.as_ref();
        // the prefix text is only needed for the first GML element and for envelopes
        if ns == Ns::Gml && (self.gml_prefix.is_none() || local == b"Envelope") {
            self.cur_prefix.clear();
            if let Some(p) = e.name().prefix() {
                self.cur_prefix
                    .push_str(&String::from_utf8_lossy(p.as_ref()));
                self.cur_prefix.push(':');
            }
            if self.gml_prefix.is_none() {
                self.gml_prefix = Some(self.cur_prefix.clone());
            }
        }
        let ns_decl = self.xmlns.find(e.attributes_raw()).is_some();
        if ns_decl {
            self.attr_ns_cache.clear();
        }
        let attrs = self.parse_attrs(reader, e)?;

        // ids: syntax and uniqueness
        let mut rec = NO_REC;
        let mut id_hash = 0;
        if let Some(id) = &attrs.id {
            if id.is_empty() || !(id.as_bytes()[0].is_ascii_alphabetic() || id.starts_with('_')) {
                self.invalid_id(id);
            }
            let h = std::hash::BuildHasher::hash_one(&self.id_hasher, id.as_ref() as &str);
            rec = self.check_id(id, h, pos);
            id_hash = h;
        }

        if let Ns::CityGml(_, v) = ns {
            if self.version.is_none() {
                self.version = Some(v);
            }
            if local.first().is_some_and(u8::is_ascii_uppercase) {
                match self.feature_counts.iter_mut().find(|(n, _)| **n == *local) {
                    Some((_, c)) => *c += 1,
                    None => self.feature_counts.push((local.into(), 1)),
                }
            }
        }
        if ns == Ns::Foreign {
            if let Some(u) = uri {
                if !ns::is_standard_foreign(u) && !self.ade_namespaces.contains_key(u) {
                    self.ade_namespaces.insert(u.to_vec(), self.warnings.len());
                    let msg = format!(
                        "element {} in namespace {} is not CityGML (ADE or foreign content): kept verbatim, not interpreted",
                        String::from_utf8_lossy(local),
                        String::from_utf8_lossy(u)
                    );
                    self.warn(msg);
                }
            }
        }

        let depth = self.stack.len();
        let parent_kind = self.stack.last().map(|f| f.kind);
        let kind;
        let mut dim = None;
        let mut name: Option<Box<str>> = None;

        if let Some(d) = &attrs.srs_dimension {
            match d.trim() {
                "2" => dim = Some(2),
                "3" => dim = Some(3),
                other => {
                    return Err(ReadError::Dimension {
                        loc: self.loc(),
                        value: other.chars().take(40).collect(),
                    })
                }
            }
        }
        if let Some(s) = &attrs.srs_name {
            if ns != Ns::Gml && depth > 0 {
                self.warn(format!(
                    "srsName on non-geometry element {}",
                    String::from_utf8_lossy(local)
                ));
            }
            if self.srs_name.is_none() {
                self.srs_name = Some(s.to_string());
            }
        }

        if depth == 0 {
            match ns {
                Ns::CityGml(Module::Core, _) if local == b"CityModel" => {
                    self.root_is_model = true;
                    kind = Kind::Root;
                }
                Ns::CityGml(..) => kind = Kind::Root,
                _ => {
                    kind = Kind::Root;
                }
            }
        } else if self.skip_depth > 0 {
            kind = self.geometry_kind(ns, local, &attrs, pos)?;
        } else {
            kind = match ns {
                Ns::Gml => self.gml_kind(local, parent_kind, &attrs, pos)?,
                Ns::CityGml(module, _) => {
                    self.citygml_kind(module, local, parent_kind, &attrs, pos, &mut name)?
                }
                _ => {
                    if matches!(parent_kind, Some(Kind::Root)) && !self.root_is_model {
                        Kind::Plain
                    } else if matches!(parent_kind, Some(Kind::Member)) {
                        // A foreign (ADE) top-level feature: an "Other" asset if it has geometry.
                        let a = self.new_asset(
                            AssetKind::Other,
                            local,
                            attrs.id.as_deref(),
                            None,
                            None,
                            pos,
                        );
                        Kind::Asset(a)
                    } else if is_lod_property(local).is_some() {
                        self.open_geom_prop(local, &mut name)
                    } else {
                        Kind::Plain
                    }
                }
            };
        }

        if let Some(href) = &attrs.href {
            let is_prop = matches!(kind, Kind::GeomProp { .. });
            if is_prop || (self.in_geometry() && (ns == Ns::Gml || self.in_implicit_rel())) {
                self.push_href(href, pos);
            }
        }

        let register = if attrs.id.is_some() && ns == Ns::Gml {
            Some(self.parts.len() as u32)
        } else {
            None
        };
        if let Some(d) = dim {
            self.dims.push(d);
        }
        let flip = attrs.orientation_minus && ns == Ns::Gml;
        if flip {
            self.flips += 1;
        }
        if matches!(kind, Kind::Skip) {
            self.skip_depth += 1;
        }
        if let Kind::Polygon = kind {
            self.polygon_elements += 1;
            self.poly = Some(PolyBuild::default());
        }
        let id = attrs.id.as_deref().map(|s| {
            let from = self.open_ids.len();
            self.open_ids.push_str(s);
            (from, self.open_ids.len(), id_hash)
        });
        self.stack.push(Frame {
            kind,
            start: pos,
            id,
            register,
            dim,
            flip,
            ns_decl,
            content_start: self.content_start,
            name,
            rec,
        });
        Ok(())
    }

    pub(super) fn end(&mut self, end: u64) -> Result<(), ReadError> {
        let Some(mut frame) = self.stack.pop() else {
            return Ok(());
        };
        let id_span = frame.id;
        if frame.ns_decl {
            self.attr_ns_cache.clear();
        }
        if frame.dim.is_some() {
            self.dims.pop();
        }
        match frame.kind {
            Kind::Capture(c) => {
                self.capture = false;
                self.capture_kind = Capture::None;
                self.finish_capture(c)?;
            }
            Kind::Ring { exterior } => {
                self.in_ring = self.in_ring.saturating_sub(1);
                self.finish_ring(exterior, &frame);
            }
            Kind::Polygon => {
                let id = frame.id.take();
                let text = (id.filter(|_| self.opts.polygon_ids))
                    .and_then(|(a, b, _)| self.open_ids.get(a..b));
                let pushed = self.finish_polygon(text.map(compact_str::CompactString::from));
                if let (Some(start), Some((a, b, hash))) = (frame.register, id) {
                    let end = if pushed {
                        self.parts.len() as u32
                    } else {
                        start
                    };
                    self.register(hash, (a, b), (frame.start, frame.rec), (start, end));
                }
            }
            Kind::GeomProp { lod, start, owner } => {
                let range = (start, self.parts.len() as u32);
                if let Some(owner) = owner {
                    if range.1 > range.0 {
                        let property = self.intern(frame.name.as_deref().unwrap_or("").as_bytes());
                        let geom = LodGeometry {
                            lod,
                            property,
                            span: frame.start..end,
                            content: frame.content_start..self.event_pos.max(frame.content_start),
                            polygons: Vec::new(),
                        };
                        let list = match owner {
                            Owner::Asset(a) => self.assets.get_mut(a).map(|x| &mut x.geometries),
                            Owner::Building(b) => {
                                self.buildings.get_mut(b).map(|x| &mut x.geometries)
                            }
                        };
                        if let Some(list) = list {
                            let index = list.len();
                            // exact: a first push would reserve room for four (320 bytes for
                            // the one geometry most of a city's assets have)
                            list.reserve_exact(1);
                            list.push(geom);
                            self.pending.push(PendingGeom {
                                owner,
                                index,
                                range,
                            });
                        }
                    }
                }
            }
            Kind::Implicit(at) => {
                let len = self.parts.len() as u32 - at - 1;
                if let Some(Part::Implicit { len: l, .. }) = self.parts.get_mut(at as usize) {
                    *l = len;
                }
            }
            Kind::Building(b) => {
                if let Some(bb) = self.buildings.get_mut(b) {
                    bb.span.end = end;
                }
            }
            Kind::Asset(a) => {
                let empty = self
                    .assets
                    .get(a)
                    .map(|x| x.geometries.is_empty())
                    .unwrap_or(false);
                let is_last = a + 1 == self.assets.len();
                if let Some(x) = self.assets.get_mut(a) {
                    x.span.end = end;
                }
                if empty && is_last && self.assets[a].kind == AssetKind::Other {
                    self.assets.pop();
                    self.objects_without_geometry += 1;
                    // envelopes owned by the removed asset are left verbatim
                    for (i, o) in self.env_owners.iter_mut().enumerate() {
                        if matches!(o, EnvOwner::Asset(x) if *x == a) {
                            *o = EnvOwner::Root;
                            self.envelopes[i].bbox = Bbox::EMPTY;
                            self.envelopes[i].dimension = 0; // marks "keep as is"
                        }
                    }
                }
            }
            Kind::Envelope(i) => {
                if let Some(env) = self.envelopes.get_mut(i) {
                    env.span.end = end;
                }
            }
            Kind::Skip => self.skip_depth = self.skip_depth.saturating_sub(1),
            _ => {}
        }
        if let (Some(start), Some((a, b, hash))) = (frame.register, frame.id) {
            let end = self.parts.len() as u32;
            self.register(hash, (a, b), (frame.start, frame.rec), (start, end));
        }
        if let Some((a, _, _)) = id_span {
            self.open_ids.truncate(a);
        }
        if frame.flip {
            self.flips = self.flips.saturating_sub(1);
        }
        Ok(())
    }
}
