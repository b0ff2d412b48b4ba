//! The rules of the mixed-LoD writer (see the module docs of [`super`]): which element goes,
//! which property gets rough geometry, where `skylod_level` goes, which references and
//! appearance targets are pruned, which buildings go with nothing kept, and the envelopes,
//! all decided on the element index ([`super::index`]) and turned into span [`Edit`]s.

use super::doc::{Doc, Name, NsKind, RefKind};
use super::encode::{encoding, Encoder, IdPool};
use super::MixedSummary;
use crate::io::citygml::ns::CORE_LEADING;
use crate::io::citygml::write::{envelope_xml, Edit};
use crate::lod::rough::RoughGeometry;
use crate::lod::select::FullFacts;
use crate::model::{Asset, AssetKind, Bbox, CityGmlVersion, CityModel, Polygon, Span};
use foldhash::{HashMap, HashMapExt, HashSet};
use std::fmt::Write as _;

const CONNECTED: &[&str] = &[
    "Solid",
    "Shell",
    "CompositeSurface",
    "CompositeSolid",
    "CompositeCurve",
    "OrientableSurface",
    "Surface",
    "TriangulatedSurface",
    "Tin",
];

struct Replacement {
    node: u32,
    /// Content span of the property in the source.
    content: crate::model::Span,
    /// Rewrite the whole element (it was a reference or empty), else only its content.
    whole: bool,
    xml: String,
    polygons: Vec<Polygon>,
}

/// What of a file's model the plans of its parts share: the containers ([`containers`]) and
/// per building its parts and the assets of the file it owns.
pub(super) struct Shared {
    pub(super) containers: Vec<bool>,
    parts: Vec<Vec<usize>>,
    owned: Vec<Vec<usize>>,
}

impl Shared {
    /// `containers` from [`containers`] for the same file and levels.
    pub(super) fn new(model: &CityModel, file: usize, containers: Vec<bool>) -> Self {
        let mut parts = vec![Vec::new(); model.buildings.len()];
        for (i, b) in model.buildings.iter().enumerate() {
            if let Some(p) = b.parent.filter(|&p| p < parts.len()) {
                parts[p].push(i);
            }
        }
        let mut owned = vec![Vec::new(); model.buildings.len()];
        for (i, a) in model.assets.iter().enumerate() {
            if let Some(b) = a.building.filter(|&b| b < owned.len() && a.file == file) {
                owned[b].push(i);
            }
        }
        Shared {
            containers,
            parts,
            owned,
        }
    }
}

/// What one plan covers: the whole document, or one chunk of its top-level members
/// (`super::plan_chunked`). The lists hold the indices, ascending, of the file's assets,
/// buildings and envelopes (of [`crate::model::SourceFile::envelopes`]) whose elements
/// start in it.
pub(super) struct Scope<'a> {
    pub(super) assets: &'a [u32],
    pub(super) buildings: &'a [u32],
    pub(super) envelopes: &'a [u32],
    pub(super) shared: &'a Shared,
    /// The polygons of each asset in the full model ([`FullFacts::polygons`]: the model's,
    /// or a hollow read's).
    pub(super) facts: &'a dyn FullFacts,
    /// Leave the envelopes of the root to the caller ([`Plan::root_sites`], [`Plan::written_box`]):
    /// they bound what every chunk writes.
    pub(super) defer_root: bool,
    /// Is a gml:id in the document outside the index (a fresh id must not meet it)?
    pub(super) elsewhere: &'a dyn Fn(&str) -> bool,
}

/// The indices of the file's assets, buildings and envelopes ([`Scope`]) whose elements start
/// in each of the ranges `bounds` (sorted, adjoining `[start, end)` byte ranges).
pub(super) fn scope_lists(
    model: &CityModel,
    file: usize,
    bounds: &[(u64, u64)],
) -> [Vec<Vec<u32>>; 3] {
    let part = |start: u64| {
        let k = bounds.partition_point(|b| b.1 <= start);
        (k < bounds.len() && start >= bounds[k].0).then_some(k)
    };
    let group = |starts: &mut dyn Iterator<Item = (usize, u64)>| {
        let mut v = vec![Vec::new(); bounds.len()];
        for (i, start) in starts {
            if let Some(k) = part(start) {
                v[k].push(i as u32);
            }
        }
        v
    };
    let src = &model.files[file];
    [
        group(
            &mut (model.assets.iter().enumerate())
                .filter(|(_, a)| a.file == file)
                .map(|(i, a)| (i, a.span.start)),
        ),
        group(
            &mut (model.buildings.iter().enumerate())
                .filter(|(_, b)| b.file == file)
                .map(|(i, b)| (i, b.span.start)),
        ),
        group(
            &mut src
                .envelopes
                .iter()
                .enumerate()
                .map(|(i, e)| (i, e.span.start)),
        ),
    ]
}

/// The edits that write one source document (or one chunk of it: [`Scope`]) at its levels.
pub(super) struct Plan<'a> {
    model: &'a CityModel,
    file: usize,
    rough: &'a [RoughGeometry],
    levels: &'a [u8],
    doc: &'a Doc,
    scope: Scope<'a>,
    version: CityGmlVersion,
    encoder: Encoder,
    removed: Vec<bool>,
    replaced: Vec<bool>,
    replacements: Vec<Replacement>,
    inserts: Vec<Edit>,
    envelope_edits: Vec<Edit>,
    containers: &'a [bool],
    /// The fresh ids handed out (by this plan and those of the chunks before).
    pub(super) ids: IdPool,
    ref_nodes: HashSet<u32>,
    /// Per building: its parts, and the assets of the file it owns.
    parts: &'a [Vec<usize>],
    owned: &'a [Vec<usize>],
    /// With [`Scope::defer_root`]: the root's envelopes (index in the file's envelopes, and
    /// the span of their `gml:boundedBy`).
    pub(super) root_sites: Vec<(usize, Span)>,
    /// With [`Scope::defer_root`]: the box of every geometry written.
    pub(super) written_box: Bbox,
    pub(super) summary: MixedSummary,
}

impl<'a> Plan<'a> {
    /// A plan of `scope` on its index `doc`, handing out fresh ids from `ids`.
    pub(super) fn new(
        model: &'a CityModel,
        (file, rough, levels): (usize, &'a [RoughGeometry], &'a [u8]),
        scope: Scope<'a>,
        doc: &'a Doc,
        ids: IdPool,
    ) -> Self {
        let src = &model.files[file];
        Plan {
            model,
            file,
            rough,
            levels,
            doc,
            version: src.version,
            encoder: Encoder::new(src.version, &src.gml_prefix),
            removed: vec![false; doc.nodes.len()],
            replaced: vec![false; doc.nodes.len()],
            replacements: Vec::new(),
            inserts: Vec::new(),
            envelope_edits: Vec::new(),
            containers: &scope.shared.containers,
            ids,
            ref_nodes: doc.refs.iter().map(|r| r.0).collect(),
            parts: &scope.shared.parts,
            owned: &scope.shared.owned,
            root_sites: Vec::new(),
            written_box: Bbox::EMPTY,
            scope,
            summary: MixedSummary::default(),
        }
    }

    fn level(&self, a: usize) -> u8 {
        self.levels[a].min(2)
    }

    fn file_assets(&self) -> impl Iterator<Item = usize> + '_ {
        self.scope.assets.iter().map(|&a| a as usize)
    }

    /// Element of an asset (the building for a Body).
    fn asset_node(&self, a: &Asset) -> Option<u32> {
        self.doc.node_at(a.span.start)
    }

    fn is_dead(&self, n: u32) -> bool {
        let mut x = n;
        let mut first = true;
        loop {
            if self.removed[x as usize] || (!first && self.replaced[x as usize]) {
                return true;
            }
            first = false;
            match self.doc.parent(x) {
                Some(p) => x = p,
                None => return false,
            }
        }
    }

    fn has_living_child(&self, p: u32, pred: impl Fn(&Name) -> bool) -> bool {
        self.doc
            .children(p)
            .any(|c| !self.removed[c as usize] && pred(self.doc.name(c)))
    }

    /// Should `p` go after losing a child?
    fn empty_after_loss(&self, p: u32) -> bool {
        if self.doc.parent(p).is_none() || self.replaced[p as usize] {
            return false;
        }
        let name = self.doc.name(p);
        match (name.ns, name.local.as_str()) {
            (NsKind::App, "ParameterizedTexture" | "X3DMaterial" | "GeoreferencedTexture") => !self
                .has_living_child(p, |n| {
                    n.local == "target" || n.local == "textureParameterization"
                }),
            (NsKind::App, "Appearance") => !self.has_living_child(p, |n| {
                n.local == "surfaceDataMember" || n.local == "surfaceData"
            }),
            (NsKind::App, "TextureAssociation") => {
                !self.has_living_child(p, |n| n.local == "target")
            }
            // CityGML 3.0: a relation must name the object it relates to.
            (_, "CityObjectRelation") => !self.has_living_child(p, |n| n.local == "relatedTo"),
            (NsKind::Gml, _) => !self.has_living_child(p, |_| true),
            _ if !name.upper => !self.has_living_child(p, |_| true),
            _ => false,
        }
    }

    /// Remove `n` and climb (see the module docs). The root is never removed.
    fn remove(&mut self, n: u32) {
        if self.doc.parent(n).is_none() {
            return;
        }
        self.removed[n as usize] = true;
        let mut x = n;
        while let Some(p) = self.doc.parent(x) {
            if self.empty_after_loss(p) {
                self.removed[p as usize] = true;
                x = p;
            } else {
                break;
            }
        }
    }

    /// Take every decision (see the module docs of [`super`]); then [`Plan::edits`].
    pub(super) fn run(&mut self, keep_envelopes: bool) {
        let assets: Vec<usize> = self.file_assets().collect();
        for &a in &assets {
            let l = self.level(a);
            self.summary.levels[l as usize] += 1;
            self.summary.polygons_in += self.scope.facts.polygons(a);
            if self.containers[a] {
                self.summary.containers += 1;
            }
        }
        // level 0 and 1
        for &a in &assets {
            let asset = &self.model.assets[a];
            match self.level(a) {
                0 => {
                    if asset.kind == AssetKind::Body || self.containers[a] {
                        for g in &asset.geometries {
                            if let Some(n) = self.doc.node_at(g.span.start) {
                                self.remove(n);
                            }
                        }
                    } else if let Some(n) = self.asset_node(asset) {
                        self.remove(n);
                    }
                }
                1 => self.roughen(a),
                _ => {}
            }
        }
        // references and buildings, to a fixed point
        loop {
            let mut changed = self.prune_refs();
            if !changed {
                changed = self.drop_buildings();
            }
            if !changed {
                break;
            }
        }
        // level attributes
        for &a in &assets {
            let l = self.level(a);
            if l == 0 && !self.containers[a] {
                continue;
            }
            let asset = &self.model.assets[a];
            let Some(n) = self.asset_node(asset) else {
                continue;
            };
            if self.is_dead(n) {
                continue;
            }
            self.insert_level(n, l);
        }
        // written geometry: polygon counts and envelopes
        let written = self.written();
        self.summary.polygons_out = written.iter().filter(|w| w.asset).map(|w| w.polygons).sum();
        if !keep_envelopes {
            self.envelopes(&written);
        }
    }

    fn roughen(&mut self, a: usize) {
        let asset = &self.model.assets[a];
        let r = &self.rough[a];
        if r.is_empty() {
            return;
        }
        let base = match &asset.id {
            Some(id) => format!("skylod_{id}"),
            None => format!("skylod_a{a}"),
        };
        for (j, out) in crate::lod::level::properties(asset, Some(r), 1)
            .iter()
            .enumerate()
        {
            if !out.rough {
                continue;
            }
            let g = out.geometry;
            let enc = encoding(&g.property);
            let Some(n) = self.doc.node_at(g.span.start) else {
                continue;
            };
            let (doc, elsewhere) = (self.doc, self.scope.elsewhere);
            let id = self
                .ids
                .fresh(&format!("{base}_g{j}"), out.polygons.len(), |s| {
                    doc.has_id(s) || elsewhere(s)
                });
            let geom = self.encoder.geometry(enc, &id, &out.polygons);
            let node = self.doc.nodes[n as usize];
            let has_ref = self.ref_nodes.contains(&n);
            let whole = has_ref || node.end == node.content_start() || g.content.is_empty();
            let xml = if whole {
                let q = &self.doc.name(n).qname;
                format!("<{q}>{geom}</{q}>")
            } else {
                geom
            };
            self.replaced[n as usize] = true;
            self.replacements.push(Replacement {
                node: n,
                content: g.content.clone(),
                whole,
                xml,
                polygons: out.polygons.to_vec(),
            });
        }
    }

    /// Prune references into removed or replaced content; true when something changed.
    fn prune_refs(&mut self) -> bool {
        let mut changed = false;
        for i in 0..self.doc.refs.len() {
            let (r, kind, ref target) = self.doc.refs[i];
            if self.replaced[r as usize] || self.is_dead(r) {
                continue;
            }
            let Some(id) = target.strip_prefix('#') else {
                continue;
            };
            let Some(t) = self.doc.id_node(id) else {
                continue;
            };
            if !self.is_dead(t) {
                continue;
            }
            changed = true;
            match kind {
                RefKind::AppTarget => {
                    self.summary.appearance_targets_pruned += 1;
                    let victim = match self.doc.parent(r) {
                        Some(p)
                            if self.doc.name(p).ns == NsKind::App
                                && self.doc.name(p).local == "TextureAssociation" =>
                        {
                            p
                        }
                        _ => r,
                    };
                    self.remove(victim);
                }
                RefKind::Href => {
                    self.summary.hrefs_pruned += 1;
                    let mut victim = r;
                    let mut x = r;
                    if self.doc.name(r).ns == NsKind::Gml {
                        while let Some(p) = self.doc.parent(x) {
                            let name = self.doc.name(p);
                            if name.ns != NsKind::Gml {
                                break;
                            }
                            if CONNECTED.contains(&name.local.as_str()) {
                                victim = p;
                            }
                            x = p;
                        }
                    }
                    self.remove(victim);
                }
            }
        }
        changed
    }

    /// Remove buildings left with nothing; true when something changed.
    fn drop_buildings(&mut self) -> bool {
        let m = self.model;
        let mut changed = false;
        for b in self.scope.buildings.iter().rev().map(|&b| b as usize) {
            let bd = &m.buildings[b];
            if bd.file != self.file {
                continue;
            }
            let Some(n) = self.doc.node_at(bd.span.start) else {
                continue;
            };
            if self.is_dead(n) || self.doc.parent(n).is_none() {
                continue;
            }
            let parts = &self.parts[b];
            let own = &self.owned[b];
            let had = !own.is_empty() || !bd.geometries.is_empty() || !parts.is_empty();
            if !had {
                continue;
            }
            let geom_alive = |gs: &[crate::model::LodGeometry]| {
                gs.iter().any(|g| {
                    self.doc
                        .node_at(g.span.start)
                        .is_some_and(|x| !self.is_dead(x))
                })
            };
            let asset_kept = own.iter().any(|&a| {
                let asset = &m.assets[a];
                if self.level(a) == 0 {
                    return false;
                }
                if asset.kind == AssetKind::Body {
                    geom_alive(&asset.geometries)
                } else {
                    self.asset_node(asset).is_some_and(|x| !self.is_dead(x))
                }
            });
            let part_kept = parts.iter().any(|&p| {
                self.doc
                    .node_at(m.buildings[p].span.start)
                    .is_some_and(|x| !self.is_dead(x))
            });
            if !asset_kept && !part_kept && !geom_alive(&bd.geometries) {
                self.remove(n);
                if bd.is_part {
                    self.summary.parts_dropped += 1;
                } else {
                    self.summary.buildings_dropped += 1;
                }
                changed = true;
            }
        }
        changed
    }

    /// Insert (or replace) the `skylod_level` attribute of the feature at node `n`.
    fn insert_level(&mut self, n: u32, level: u8) {
        let doc = self.doc;
        let mut pos = doc.nodes[n as usize].content_start();
        for c in doc.children(n) {
            let name = doc.name(c);
            let leading = match name.ns {
                NsKind::Gml => true,
                NsKind::Core => CORE_LEADING.contains(&name.local.as_str()),
                NsKind::App => name.local == "appearance",
                // generic attributes, not the properties of a gen:GenericCityObject
                NsKind::Gen => {
                    name.local.ends_with("Attribute") || name.local == "genericAttributeSet"
                }
                _ => false,
            };
            if !leading {
                break;
            }
            pos = doc.nodes[c as usize].end;
            if self.is_level_attribute(c) && !self.removed[c as usize] {
                self.removed[c as usize] = true;
            }
        }
        let v3 = self.version == CityGmlVersion::V3_0;
        let gen_uri = match self.version {
            CityGmlVersion::V1_0 => "http://www.opengis.net/citygml/generics/1.0",
            CityGmlVersion::V2_0 => "http://www.opengis.net/citygml/generics/2.0",
            CityGmlVersion::V3_0 => "http://www.opengis.net/citygml/generics/3.0",
        };
        let (gen, gen_decl) = match doc.prefix_for(gen_uri).filter(|p| !p.is_empty()) {
            Some(p) => (p, String::new()),
            None => ("gen:".to_string(), format!(" xmlns:gen=\"{gen_uri}\"")),
        };
        let mut s = String::with_capacity(200);
        if v3 {
            let core_uri = "http://www.opengis.net/citygml/3.0";
            let (core, core_decl) = match doc.prefix_for(core_uri) {
                Some(p) if !(p.is_empty() && gen.is_empty()) => (p, String::new()),
                _ => ("core:".to_string(), format!(" xmlns:core=\"{core_uri}\"")),
            };
            let _ = write!(
                s,
                "<{core}genericAttribute{core_decl}{gen_decl}><{gen}IntAttribute><{gen}name>skylod_level</{gen}name><{gen}value>{level}</{gen}value></{gen}IntAttribute></{core}genericAttribute>"
            );
        } else {
            let _ = write!(
                s,
                "<{gen}intAttribute{gen_decl} name=\"skylod_level\"><{gen}value>{level}</{gen}value></{gen}intAttribute>"
            );
        }
        self.inserts.push(Edit {
            span: pos..pos,
            replacement: s.into_bytes(),
        });
    }

    /// A `skylod_level` generic attribute written earlier.
    fn is_level_attribute(&self, c: u32) -> bool {
        let doc = self.doc;
        let name = doc.name(c);
        let is_label = |x: u32| doc.labels.get(&x).is_some_and(|l| &**l == "skylod_level");
        match (name.ns, name.local.as_str()) {
            (NsKind::Gen, "intAttribute") => is_label(c),
            (NsKind::Core, "genericAttribute") => doc.children(c).any(|ia| {
                doc.name(ia).local == "IntAttribute"
                    && doc
                        .children(ia)
                        .any(|x| doc.name(x).local == "name" && is_label(x))
            }),
            _ => false,
        }
    }

    /// Per node, [`Plan::is_dead`] as things stand, in one pass (parents come first).
    fn dead_nodes(&self) -> Vec<bool> {
        let n = self.doc.nodes.len();
        // `gone[i]`: node i or an ancestor removed or replaced
        let mut gone = vec![false; n];
        let mut dead = vec![false; n];
        for i in 0..n {
            let above = self.doc.parent(i as u32).is_some_and(|p| gone[p as usize]);
            dead[i] = self.removed[i] || above;
            gone[i] = dead[i] || self.replaced[i];
        }
        dead
    }

    fn polygon_alive(&self, p: &Polygon, dead: &[bool]) -> bool {
        match &p.id {
            Some(id) => self.doc.id_node(id).is_none_or(|n| !dead[n as usize]),
            None => true,
        }
    }

    /// Geometry properties actually written, with their boxes and polygon counts.
    fn written(&self) -> Vec<Written> {
        let m = self.model;
        let dead = self.dead_nodes();
        let mut out = Vec::new();
        let mut replaced: HashMap<u32, usize> = HashMap::new();
        for (i, r) in self.replacements.iter().enumerate() {
            replaced.insert(r.node, i);
        }
        let mut push = |node: u32, polys: &mut dyn Iterator<Item = &Polygon>, asset: bool| {
            let mut bbox = Bbox::EMPTY;
            let mut count = 0;
            for p in polys {
                count += 1;
                for q in p.points() {
                    bbox.add(*q);
                }
            }
            out.push(Written {
                node,
                bbox,
                polygons: count,
                asset,
            });
        };
        let groups = (self.scope.assets.iter())
            .map(|&a| (&m.assets[a as usize].geometries, true))
            .chain(
                (self.scope.buildings.iter())
                    .map(|&b| (&m.buildings[b as usize].geometries, false)),
            );
        for (geoms, asset) in groups {
            for g in geoms {
                let Some(n) = self.doc.node_at(g.span.start) else {
                    continue;
                };
                if dead[n as usize] {
                    continue;
                }
                match replaced.get(&n) {
                    Some(&i) => push(n, &mut self.replacements[i].polygons.iter(), asset),
                    None => push(
                        n,
                        &mut g.polygons.iter().filter(|p| self.polygon_alive(p, &dead)),
                        asset,
                    ),
                }
            }
        }
        out.sort_by_key(|w| w.node);
        out
    }

    fn envelopes(&mut self, written: &[Written]) {
        let src = &self.model.files[self.file];
        if self.scope.defer_root {
            for w in written {
                self.written_box.union(&w.bbox);
            }
        }
        for &e in self.scope.envelopes {
            let env = &src.envelopes[e as usize];
            if env.bbox.is_empty() {
                continue; // owner unknown: kept verbatim
            }
            let Some(n) = self.doc.node_at(env.span.start) else {
                continue;
            };
            if self.is_dead(n) {
                continue;
            }
            let Some(owner) = self.doc.parent(n).and_then(|p| self.doc.parent(p)) else {
                continue;
            };
            if self.scope.defer_root && self.doc.parent(owner).is_none() {
                if let Some(bb) = self.doc.parent(n) {
                    let bb = self.doc.nodes[bb as usize];
                    self.root_sites.push((e as usize, bb.start..bb.end));
                }
                continue;
            }
            let last = self.doc.nodes[owner as usize].last_desc;
            let lo = written.partition_point(|w| w.node < owner);
            let mut bbox = Bbox::EMPTY;
            for w in written[lo..].iter().take_while(|w| w.node <= last) {
                bbox.union(&w.bbox);
            }
            if bbox.is_empty() {
                if let Some(bb) = self.doc.parent(n) {
                    self.remove(bb);
                }
                continue;
            }
            let mut site = env.clone();
            site.bbox = bbox;
            if let Some(xml) = envelope_xml(&site) {
                self.envelope_edits.push(Edit {
                    span: env.span.clone(),
                    replacement: xml.into_bytes(),
                });
            }
        }
    }

    /// The span edits of the decisions (after [`Plan::run`]).
    pub(super) fn edits(&mut self) -> Vec<Edit> {
        let mut edits = Vec::new();
        for (i, node) in self.doc.nodes.iter().enumerate() {
            if self.removed[i] && self.doc.parent(i as u32).is_none_or(|p| !self.is_dead(p)) {
                edits.push(Edit {
                    span: node.start..node.end,
                    replacement: Vec::new(),
                });
            }
        }
        for r in &self.replacements {
            if self.is_dead(r.node) {
                continue;
            }
            let node = self.doc.nodes[r.node as usize];
            let span = if r.whole {
                node.start..node.end
            } else {
                r.content.clone()
            };
            edits.push(Edit {
                span,
                replacement: r.xml.clone().into_bytes(),
            });
        }
        edits.append(&mut self.envelope_edits);
        edits.append(&mut self.inserts);
        edits
    }
}

struct Written {
    node: u32,
    bbox: Bbox,
    polygons: usize,
    asset: bool,
}

/// Per asset: a level-0 asset of `file` with a kept asset below it (through
/// [`Asset::parent`], at most 64 levels down), kept as a container without geometry.
pub(super) fn containers(model: &CityModel, file: usize, levels: &[u8]) -> Vec<bool> {
    let mut children: HashMap<usize, Vec<usize>> = HashMap::new();
    for (a, asset) in model.assets.iter().enumerate() {
        if asset.file == file {
            if let Some(p) = asset.parent {
                children.entry(p).or_default().push(a);
            }
        }
    }
    fn kept_below(
        a: usize,
        children: &HashMap<usize, Vec<usize>>,
        levels: &[u8],
        depth: usize,
    ) -> bool {
        depth < 64
            && children.get(&a).is_some_and(|cs| {
                cs.iter()
                    .any(|&c| levels[c] > 0 || kept_below(c, children, levels, depth + 1))
            })
    }
    let mut out = vec![false; model.assets.len()];
    for (a, asset) in model.assets.iter().enumerate() {
        if asset.file == file && levels[a] == 0 && kept_below(a, &children, levels, 0) {
            out[a] = true;
        }
    }
    out
}

/// Spans of the elements of `file` that go whole with nothing of them kept, sorted by start:
/// level-0 assets that are no container and have no kept asset below them at any depth
/// (a Body asset is the building itself and is never one). Their content need not be
/// parsed ([`super::index`]).
pub(super) fn skip_spans(
    model: &CityModel,
    file: usize,
    levels: &[u8],
    containers: &[bool],
) -> Vec<Span> {
    // a kept asset makes every asset above it unskippable
    let mut keep_above = vec![false; model.assets.len()];
    for (a, asset) in model.assets.iter().enumerate() {
        if asset.file != file || levels[a] == 0 {
            continue;
        }
        let mut p = asset.parent;
        while let Some(q) = p.filter(|&q| q < keep_above.len() && !keep_above[q]) {
            keep_above[q] = true;
            p = model.assets[q].parent;
        }
    }
    let mut spans: Vec<Span> = model
        .assets
        .iter()
        .enumerate()
        .filter(|&(a, asset)| {
            asset.file == file
                && levels[a] == 0
                && !containers[a]
                && !keep_above[a]
                && asset.kind != AssetKind::Body
                && asset.span.end > asset.span.start
        })
        .map(|(_, asset)| asset.span.clone())
        .collect();
    spans.sort_by_key(|s| (s.start, std::cmp::Reverse(s.end)));
    spans.dedup_by_key(|s| s.start);
    spans
}
