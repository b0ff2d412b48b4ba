//! The whole read of an uncompressed document: the stream's chunks ([`super::stream`]),
//! parsed ahead on rayon's threads, put back together into the model one parser reading the
//! whole document makes. There is one chunked parser; the whole read is that stream
//! collected, and where the stream declines (a reference from one chunk into another, a
//! DOCTYPE, a root that is no `CityModel`, any error) the document is read as one chunk.
//!
//! A chunk's model differs from the serial read's restricted to its members in three ways,
//! undone here: its building bodies come after its own other assets (the serial read puts
//! every body after all the document's other assets), its root envelope covers the chunk
//! (the serial read's covers the document), and the note on invalid gml:ids and the trailing
//! warnings are the stream's ([`StreamSummary::patch_warnings`]).

use super::stream::{stream_document, Chunk, StreamSummary, Streamed};
use super::ReadOptions;
use crate::io::citygml::source::Bytes;
use crate::model::{content_bbox, Asset, Bbox, Building, CityModel, SourceFile, Warning};
use std::path::Path;

/// The whole model of `doc` (named `name`) read in chunks of about `chunk_bytes`, `passed(n)`
/// told as `n` more bytes are read; `None` where the stream declines (the caller reads the
/// document as one chunk, which reports any error).
pub(super) fn read_collected(
    doc: &Bytes,
    name: &Path,
    opts: &ReadOptions,
    chunk_bytes: u64,
    passed: &dyn Fn(u64),
) -> Option<CityModel> {
    let mut all = Collected::default();
    let each = |c: Chunk| {
        let content = content_bbox(&c.model.assets, &c.model.buildings);
        let none = vec![(); c.model.assets.len()];
        all.add(c, content, none);
        Ok::<(), std::convert::Infallible>(())
    };
    match stream_document(doc, None, name, opts, chunk_bytes, passed, each) {
        Ok(Streamed::Done(sum)) => all.finish(&sum).map(|(model, _)| model),
        Ok(Streamed::Declined(_)) => None,
        Err(never) => match never {},
    }
}

/// The chunks of a document handed over so far, each asset with what its reader made of it
/// (`X`: nothing for the whole read; a hollow read's rough form, boxes, polygon counts).
/// A body's index is not known until every chunk's other assets are counted: until then it
/// is held as `usize::MAX - k` (body `k` of the document).
pub(crate) struct Collected<X> {
    buildings: Vec<Building>,
    assets: Vec<Asset>,
    bodies: Vec<Asset>,
    extras: Vec<X>,
    body_extras: Vec<X>,
    warnings: Vec<Warning>,
    file: Option<SourceFile>,
    /// Indices of the root's envelopes in the file's ([`Chunk::root_envelopes`]).
    root_envelopes: Vec<usize>,
    /// The box of every polygon of the chunks, assets' and buildings' own geometry.
    content: Bbox,
}

impl<X> Default for Collected<X> {
    fn default() -> Self {
        Collected {
            buildings: Vec::new(),
            assets: Vec::new(),
            bodies: Vec::new(),
            extras: Vec::new(),
            body_extras: Vec::new(),
            warnings: Vec::new(),
            file: None,
            root_envelopes: Vec::new(),
            content: Bbox::EMPTY,
        }
    }
}

impl<X> Collected<X> {
    /// Chunk `c` added: `content` the box of its polygons ([`content_bbox`] of its model as
    /// parsed), `extras[i]` going with its asset `i`.
    pub(crate) fn add(&mut self, c: Chunk, content: Bbox, extras: Vec<X>) {
        self.content.union(&content);
        let nb = c.non_body_assets();
        let global = |i: usize| {
            if i < nb {
                c.assets_before + i
            } else {
                usize::MAX - (c.bodies_before + (i - nb))
            }
        };
        let mut model = c.model;
        for mut b in model.buildings.drain(..) {
            b.parent = b.parent.map(|x| x + c.buildings_before);
            b.assets.iter_mut().for_each(|a| *a = global(*a));
            self.buildings.push(b);
        }
        let assets = model.assets.drain(..).zip(extras);
        for (i, (mut a, x)) in assets.enumerate() {
            a.building = a.building.map(|x| x + c.buildings_before);
            a.parent = a.parent.map(global);
            if i < nb {
                self.assets.push(a);
                self.extras.push(x);
            } else {
                self.bodies.push(a);
                self.body_extras.push(x);
            }
        }
        self.warnings.append(&mut model.warnings);
        let Some(f) = model.files.into_iter().next() else {
            return;
        };
        let before = self.file.as_ref().map_or(0, |w| w.envelopes.len());
        (self.root_envelopes).extend(c.root_envelopes.iter().map(|i| before + i));
        match &mut self.file {
            None => self.file = Some(f),
            Some(whole) => add_file(whole, f),
        }
    }

    /// The document's model, after its last chunk summed up as `sum`, and each asset's
    /// extras in its order: the model one parser reading the whole document makes (but for
    /// what the caller took out of the chunks).
    pub(crate) fn finish(mut self, sum: &StreamSummary) -> Option<(CityModel, Vec<X>)> {
        let n_plain = self.assets.len();
        let place = |i: &mut usize| {
            if *i > usize::MAX / 2 {
                *i = n_plain + (usize::MAX - *i);
            }
        };
        for b in &mut self.buildings {
            b.assets.iter_mut().for_each(place);
        }
        self.assets.append(&mut self.bodies);
        self.extras.append(&mut self.body_extras);
        for a in &mut self.assets {
            a.parent.as_mut().map(place);
        }
        let mut file = self.file?;
        file.version = sum.version.unwrap_or(file.version);
        file.srs_name.clone_from(&sum.srs_name);
        for &i in &self.root_envelopes {
            if let Some(e) = file.envelopes.get_mut(i) {
                e.bbox = self.content;
            }
        }
        sum.patch_warnings(&mut self.warnings);
        let model = CityModel {
            files: vec![file],
            buildings: self.buildings,
            assets: self.assets,
            warnings: self.warnings,
        };
        Some((model, self.extras))
    }

    /// The box of every polygon of the chunks added.
    pub(crate) fn content(&self) -> Bbox {
        self.content
    }
}

/// `part`'s facts of the document added to `whole`'s (both the same document's, `part` the
/// later members): its envelope sites, counts, library objects and features.
fn add_file(whole: &mut SourceFile, part: SourceFile) {
    whole.envelopes.extend(part.envelopes);
    whole.implicit_geometries += part.implicit_geometries;
    whole.library_objects.extend(part.library_objects);
    whole.objects_without_geometry += part.objects_without_geometry;
    whole.polygon_elements += part.polygon_elements;
    for (name, n) in part.features {
        *whole.features.entry(name).or_default() += n;
    }
}

/// [`read_collected`] of `doc` in chunks of `chunk_bytes` on two threads, whatever its size
/// (for tests).
#[cfg(test)]
pub(super) fn read_in_chunks(doc: &[u8], name: &str, chunk_bytes: u64) -> Option<CityModel> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .ok()?;
    let doc = Bytes::Read(doc.to_vec());
    let opts = ReadOptions::default();
    pool.install(|| read_collected(&doc, Path::new(name), &opts, chunk_bytes, &|_| {}))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A relief LoD set in an earlier chunk only holds in the later ones, as in the serial
    /// read; set in every member or never, the same model too.
    #[test]
    fn relief_lod_of_an_earlier_chunk_holds_in_later_ones() {
        let doc = |lod: &str| {
            let member = |i: usize| {
                format!(
                    r#"<cityObjectMember><dem:ReliefFeature gml:id="r{i}">{lod}<dem:reliefComponent><dem:TINRelief gml:id="t{i}">
<dem:tin><gml:TriangulatedSurface><gml:trianglePatches><gml:Triangle><gml:exterior><gml:LinearRing>
<gml:posList>0 0 0 1 0 0 1 1 0 0 0 0</gml:posList></gml:LinearRing></gml:exterior></gml:Triangle>
</gml:trianglePatches></gml:TriangulatedSurface></dem:tin></dem:TINRelief></dem:reliefComponent>
</dem:ReliefFeature></cityObjectMember>
"#
                )
            };
            let body: String = (0..8).map(member).collect();
            format!(
                r#"<CityModel xmlns="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml"
 xmlns:dem="http://www.opengis.net/citygml/relief/2.0">
{body}</CityModel>
"#
            )
        };
        let path = Path::new("relief.gml");
        let opts = ReadOptions::default();
        let serial = |d: &str| {
            super::super::events::read_slice(d.as_bytes(), path, false, &opts, &|_| {}).unwrap()
        };
        let first_only = doc("").replacen(
            "<dem:reliefComponent>",
            "<dem:lod>1</dem:lod><dem:reliefComponent>",
            1,
        );
        for d in [first_only, doc("<dem:lod>1</dem:lod>"), doc("")] {
            let chunked = read_in_chunks(d.as_bytes(), "relief.gml", 400);
            assert_eq!(chunked.as_ref(), Some(&serial(&d)));
        }
        let m = read_in_chunks(doc("<dem:lod>1</dem:lod>").as_bytes(), "r.gml", 400).unwrap();
        assert!(m.assets.iter().all(|a| a.geometries[0].lod == 1));
    }
}
