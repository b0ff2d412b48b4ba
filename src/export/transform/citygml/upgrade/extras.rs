//! The 1.0 / 2.0 structures that 3.0 encodes differently: appearances (`app:surfaceDataMember`
//! → `app:surfaceData`, a parameterized texture's `app:target uri=` → `app:TextureAssociation`,
//! `app:textureCoordinates ring=` → `app:textureCoordinates` + `app:ring`), generic
//! attributes (`gen:stringAttribute name=` → `core:genericAttribute/gen:StringAttribute`),
//! external references, implicit geometries, addresses (xAL 2.0 → xAL 3.0), measured heights
//! and group members.

use super::dom::{El, Node};
use super::feature::{generic, object, Ctx};
use super::geometry;
use super::names::{Module, Src};

/// An appearance or one of its parts (`app:` in 1.0 / 2.0).
pub(super) fn appearance(e: El, ctx: &mut Ctx<'_>) -> El {
    match e.local.as_str() {
        "Appearance" => {
            ctx.counts.appearances += 1;
            let mut out = El::new("app:Appearance");
            out.attrs = e.attrs.clone();
            let mut theme = Vec::new();
            let mut data = Vec::new();
            let mut gml = Vec::new();
            for c in e.into_els() {
                match (c.ns, c.local.as_str()) {
                    (Src::Module(Module::App), "surfaceDataMember") => {
                        let mut d = El::new("app:surfaceData");
                        d.attrs = c.attrs.clone();
                        for s in c.into_els() {
                            d = d.with(appearance(s, ctx));
                        }
                        data.push(d);
                    }
                    (Src::Module(Module::App), "theme") => theme.push(generic(c, ctx)),
                    (Src::Gml, _) => gml.push(geometry::gml(c)),
                    _ => data.push(object(c, ctx)),
                }
            }
            out.kids = gml
                .into_iter()
                .chain(theme)
                .chain(data)
                .map(Node::El)
                .collect();
            out
        }
        "ParameterizedTexture" => {
            let mut out = El::new("app:ParameterizedTexture");
            out.attrs = e.attrs.clone();
            for c in e.into_els() {
                if c.ns == Src::Module(Module::App) && c.local == "target" {
                    out = out.with(texture_association(c, ctx));
                } else {
                    out = out.with(object(c, ctx));
                }
            }
            out
        }
        "TexCoordList" => {
            // 3.0 texture coordinates have no gml:id
            let mut out = El::new("app:TexCoordList");
            let mut rings = Vec::new();
            for mut c in e.into_els() {
                if c.local == "textureCoordinates" {
                    if let Some(r) = c.take_attr("ring") {
                        rings.push(El::new("app:ring").text(&r));
                    }
                }
                out = out.with(generic(c, ctx));
            }
            for r in rings {
                out = out.with(r);
            }
            out
        }
        "target" => {
            ctx.counts.appearance_targets += 1;
            generic(e, ctx)
        }
        _ if e.local.starts_with(|c: char| c.is_ascii_uppercase()) => {
            // X3DMaterial, GeoreferencedTexture, TexCoordGen: same names, same order
            generic(e, ctx)
        }
        _ => generic(e, ctx),
    }
}

/// `<app:target uri="#s">` (texture coordinates inside or by `xlink:href`) →
/// `<app:textureParameterization><app:TextureAssociation>`.
fn texture_association(mut t: El, ctx: &mut Ctx<'_>) -> El {
    ctx.counts.appearance_targets += 1;
    let uri = t.take_attr("uri").unwrap_or_default();
    let mut param = El::new("app:textureParameterization");
    let href = t.take_attr("href");
    param.attrs = std::mem::take(&mut t.attrs);
    let mut inline = false;
    for c in t.into_els() {
        param = param.with(object(c, ctx));
        inline = true;
    }
    if let (false, Some(h)) = (inline, href) {
        // 3.0 texture coordinates have no id to refer to: a copy of the referenced list
        match ctx
            .texcoords
            .get(h.strip_prefix(b"#").unwrap_or(&h))
            .cloned()
        {
            Some(list) => param = param.with(appearance(list, ctx)),
            None => param.attrs.push(("xlink:href".into(), h)),
        }
    }
    El::new("app:textureParameterization").with(
        El::new("app:TextureAssociation")
            .with(El::new("app:target").text(&uri))
            .with(param),
    )
}

/// `gen:stringAttribute name="n"` (and int, double, date, uri, measure, set) →
/// `gen:StringAttribute` with `gen:name`.
pub(super) fn generic_attribute(mut a: El, ctx: &mut Ctx<'_>) -> El {
    let kind = match a.local.as_str() {
        "stringAttribute" => "StringAttribute",
        "intAttribute" => "IntAttribute",
        "doubleAttribute" => "DoubleAttribute",
        "dateAttribute" => "DateAttribute",
        "uriAttribute" => "UriAttribute",
        "measureAttribute" => "MeasureAttribute",
        "genericAttributeSet" => "GenericAttributeSet",
        _ => "StringAttribute",
    };
    let name = a.take_attr("name").unwrap_or_default();
    let code_space = a.take_attr("codeSpace");
    let mut out = El::new(&format!("gen:{kind}")).with(El::new("gen:name").text(&name));
    if let Some(cs) = code_space {
        out = out.with(El::new("gen:codeSpace").text(&cs));
    }
    for c in a.into_els() {
        if kind == "GenericAttributeSet" {
            ctx.counts.generic_attributes += 1;
            out = out.with(El::new("gen:genericAttribute").with(generic_attribute(c, ctx)));
        } else if c.local == "value" {
            out = out.with(generic(c, ctx));
        }
    }
    out
}

/// `core:externalReference` with `informationSystem` and `externalObject` (a name or a URI)
/// → `core:ExternalReference` with `targetResource`.
pub(super) fn external_reference(e: El) -> El {
    let system = e.child("informationSystem").map(El::own_text);
    let target = e
        .child("externalObject")
        .and_then(|o| o.child("uri").or_else(|| o.child("name")))
        .map(El::own_text)
        .unwrap_or_default();
    let mut r =
        El::new("core:ExternalReference").with(El::new("core:targetResource").text(&target));
    if let Some(s) = system {
        r = r.with(El::new("core:informationSystem").text(&s));
    }
    El::new("core:externalReference").with(r)
}

/// `core:ImplicitGeometry`: `relativeGMLGeometry` → `relativeGeometry`, in 3.0 order.
pub(super) fn implicit(e: El, ctx: &mut Ctx<'_>) -> El {
    const ORDER: &[&str] = &[
        "transformationMatrix",
        "mimeType",
        "libraryObject",
        "referencePoint",
        "relativeGeometry",
    ];
    let mut out = El::new("core:ImplicitGeometry");
    out.attrs = e.attrs.clone();
    let mut kids: Vec<El> = e
        .into_els()
        .map(|mut c| {
            if c.local == "relativeGMLGeometry" {
                c.local = "relativeGeometry".into();
            }
            if c.ns == Src::Core {
                let mut w = El::new(&format!("core:{}", c.local));
                w.attrs = c.attrs.clone();
                for n in c.kids {
                    match n {
                        Node::El(g) => w.kids.push(Node::El(object(g, ctx))),
                        other => w.kids.push(other),
                    }
                }
                w
            } else {
                object(c, ctx)
            }
        })
        .collect();
    if !kids.iter().any(|k| k.local == "transformationMatrix") {
        // required in 3.0: the identity
        kids.push(El::new("core:transformationMatrix").text(b"1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"));
    }
    kids.sort_by_key(|k| {
        ORDER
            .iter()
            .position(|o| *o == k.local)
            .unwrap_or(ORDER.len())
    });
    out.kids = kids.into_iter().map(Node::El).collect();
    out
}

/// `core:Address` with an xAL 2.0 `AddressDetails` → with an xAL 3.0 `Address` (country,
/// locality, thoroughfare name and number, post code, free-text lines).
pub(super) fn address(e: El) -> El {
    let mut out = El::new("core:Address");
    out.attrs = e.attrs.clone();
    for c in e.into_els() {
        match c.local.as_str() {
            "xalAddress" => {
                let mut found = Found::default();
                for d in c.els() {
                    found.walk(d);
                }
                out = out.with(El::new("core:xalAddress").with(found.xal3()));
            }
            "multiPoint" => {
                let mut m = El::new("core:multiPoint");
                m.attrs = c.attrs.clone();
                for g in c.into_els() {
                    m = m.with(geometry::gml(g));
                }
                out = out.with(m);
            }
            _ => {}
        }
    }
    out
}

/// The parts of an xAL 2.0 address that xAL 3.0 has a place for.
#[derive(Default)]
struct Found {
    lines: Vec<Vec<u8>>,
    country: Vec<Vec<u8>>,
    area: Vec<Vec<u8>>,
    locality: Vec<Vec<u8>>,
    street: Vec<Vec<u8>>,
    number: Vec<Vec<u8>>,
    post_code: Vec<Vec<u8>>,
}

impl Found {
    fn walk(&mut self, e: &El) {
        let t = || e.own_text().trim_ascii().to_vec();
        match e.local.as_str() {
            "AddressLine" => self.lines.push(t()),
            "CountryName" => self.country.push(t()),
            "AdministrativeAreaName" => self.area.push(t()),
            "LocalityName" => self.locality.push(t()),
            "ThoroughfareName" | "ThoroughFareName" => self.street.push(t()),
            "ThoroughfareNumber" | "ThoroughFareNumber" => self.number.push(t()),
            "PostalCodeNumber" => self.post_code.push(t()),
            _ => {}
        }
        for c in e.els() {
            self.walk(c);
        }
    }

    fn xal3(self) -> El {
        let names = |name: &str, child: &str, v: &[Vec<u8>]| {
            v.iter()
                .fold(El::new(name), |e, t| e.with(El::new(child).text(t)))
        };
        let mut a = El::new("xAL:Address");
        if !self.lines.is_empty() {
            a = a.with(names("xAL:FreeTextAddress", "xAL:AddressLine", &self.lines));
        }
        if !self.country.is_empty() {
            a = a.with(names("xAL:Country", "xAL:NameElement", &self.country));
        }
        if !self.area.is_empty() {
            a = a.with(names(
                "xAL:AdministrativeArea",
                "xAL:NameElement",
                &self.area,
            ));
        }
        if !self.locality.is_empty() {
            a = a.with(names("xAL:Locality", "xAL:NameElement", &self.locality));
        }
        if !self.street.is_empty() || !self.number.is_empty() {
            let mut t = names("xAL:Thoroughfare", "xAL:NameElement", &self.street);
            for n in &self.number {
                t = t.with(El::new("xAL:Number").text(n));
            }
            a = a.with(t);
        }
        if !self.post_code.is_empty() {
            a = a.with(names("xAL:PostCode", "xAL:Identifier", &self.post_code));
        }
        a
    }
}

/// `bldg:measuredHeight uom="m"` → `con:height` / `con:Height` (highest roof edge over
/// lowest ground point, measured).
pub(super) fn height(mut p: El) -> El {
    let uom = p.take_attr("uom").unwrap_or_else(|| b"m".to_vec());
    let mut v = El::new("con:value").text(&p.own_text());
    v.attrs.push(("uom".into(), uom));
    El::new("con:height").with(
        El::new("con:Height")
            .with(El::new("con:highReference").text(b"highestRoofEdge"))
            .with(El::new("con:lowReference").text(b"lowestGroundPoint"))
            .with(El::new("con:status").text(b"measured"))
            .with(v),
    )
}

/// `grp:groupMember grp:role="r"` → `grp:groupMember/grp:Role` with `grp:role` and the member.
pub(super) fn group_member(mut p: El, ctx: &mut Ctx<'_>) -> El {
    let role = p.take_attr("role");
    let mut inner = El::new("grp:groupMember");
    inner.attrs = std::mem::take(&mut p.attrs);
    for c in p.into_els() {
        // a 3.0 group refers to its members: an inline member becomes a top-level one
        let mut f = object(c, ctx);
        let id = match f.attr("id") {
            Some(id) => id.to_vec(),
            None => {
                ctx.counts.ids_made += 1;
                let id = format!("skylod-member-{}", ctx.counts.ids_made).into_bytes();
                f.attrs.push(("gml:id".into(), id.clone()));
                id
            }
        };
        let mut href = b"#".to_vec();
        href.extend_from_slice(&id);
        inner.attrs.push(("xlink:href".into(), href));
        ctx.extra.push(f);
    }
    let mut r = El::new("grp:Role");
    if let Some(role) = role {
        r = r.with(El::new("grp:role").text(&role));
    }
    El::new("grp:groupMember").with(r.with(inner))
}

/// A root `gml:metaDataProperty` (GML 3.1.1 content such as a local `EngineeringCRS`, which
/// GML 3.2 encodes differently): kept as a comment, its content unchanged.
pub(super) fn metadata_comment(e: &El) -> Node {
    let mut w = Vec::new();
    e.write(&mut w);
    let text = String::from_utf8_lossy(&w).replace("--", "- -");
    Node::Raw(format!("<!-- GML 3.1.1 metadata of the CityGML 2.0 source: {text} -->").into_bytes())
}
