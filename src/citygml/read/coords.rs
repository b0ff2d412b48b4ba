//! Coordinates and other captured text: `gml:posList`, `gml:pos`, `gml:coordinates`,
//! transformation matrices, codes; numbers parsed with `fast-float2`.

use super::state::{Capture, CoordKind, Parser};
use super::MAX_COORDINATE;
use crate::citygml::error::ReadError;
use glam::DVec3;

#[derive(Debug, Clone, Copy, Default)]
pub(super) struct CoordAttrs {
    pub(super) dim: Option<u8>,
    pub(super) cs: u8,
    pub(super) ts: u8,
    pub(super) decimal: u8,
}

impl Parser {
    /// Append captured character data (coordinates, codes), within the token size limit.
    pub(super) fn capture_text(&mut self, t: &[u8], pos: u64) -> Result<(), ReadError> {
        if self.text.len() + t.len() > self.opts.max_event_bytes {
            return Err(self.token_limit(pos));
        }
        self.text.extend_from_slice(t);
        Ok(())
    }

    /// An entity or character reference inside captured text: the five predefined entities
    /// and character references are resolved; DTD-declared entities are never expanded.
    pub(super) fn capture_ref(
        &mut self,
        r: &quick_xml::events::BytesRef,
        pos: u64,
    ) -> Result<(), ReadError> {
        let predefined: Option<&[u8]> = match r.as_ref() {
            b"lt" => Some(b"<"),
            b"gt" => Some(b">"),
            b"amp" => Some(b"&"),
            b"apos" => Some(b"'"),
            b"quot" => Some(b"\""),
            _ => None,
        };
        if let Some(b) = predefined {
            return self.capture_text(b, pos);
        }
        match r.resolve_char_ref() {
            Ok(Some(c)) => {
                let mut tmp = [0u8; 4];
                let s = c.encode_utf8(&mut tmp);
                self.capture_text(s.as_bytes(), pos)
            }
            Ok(None) => Err(ReadError::Xml {
                loc: self.loc_at(pos),
                message: format!(
                    "entity reference &{};: entities declared in a DTD are not expanded",
                    String::from_utf8_lossy(&r[..r.len().min(40)])
                ),
            }),
            Err(e) => Err(ReadError::Xml {
                loc: self.loc_at(pos),
                message: format!("bad character reference: {e}"),
            }),
        }
    }

    pub(super) fn finish_capture(&mut self, c: Capture) -> Result<(), ReadError> {
        let text = std::mem::take(&mut self.text);
        let result = match c {
            Capture::RingCoords(k) => {
                let dim = self.capture_attrs.dim.unwrap_or_else(|| self.current_dim());
                let mut ring = std::mem::take(&mut self.ring);
                let r = match k {
                    CoordKind::PosList => parse_pos_list(&text, dim, &mut ring),
                    CoordKind::Pos => parse_pos(&text, &mut ring),
                    CoordKind::Coordinates => {
                        parse_coordinates(&text, self.capture_attrs, &mut ring)
                    }
                };
                self.ring = ring;
                r
            }
            Capture::RefPoint => {
                let mut pts = Vec::with_capacity(1);
                let r = parse_pos(&text, &mut pts);
                if r.is_ok() {
                    if let Some(idx) = self.current_implicit() {
                        self.implicits[idx].ref_point = pts.first().copied();
                    }
                }
                r
            }
            Capture::Matrix => {
                let mut vals = Vec::with_capacity(16);
                let r = parse_numbers(&text, &mut vals);
                if r.is_ok() {
                    if vals.len() == 16 {
                        let mut m = [0.0; 16];
                        m.copy_from_slice(&vals);
                        if let Some(idx) = self.current_implicit() {
                            self.implicits[idx].matrix = Some(m);
                        }
                    } else {
                        self.warn(format!(
                            "transformationMatrix has {} values, 16 expected: identity used",
                            vals.len()
                        ));
                    }
                }
                r
            }
            Capture::Library => {
                let s = String::from_utf8_lossy(&text).trim().to_string();
                if !s.is_empty() {
                    self.library_objects.push(s);
                }
                Ok(())
            }
            Capture::Function(a) => {
                let s = String::from_utf8_lossy(&text).trim().to_string();
                if let Some(x) = self.assets.get_mut(a) {
                    x.function = Some(s);
                }
                Ok(())
            }
            Capture::ReliefLod => {
                if let Ok(v) = String::from_utf8_lossy(&text).trim().parse::<u8>() {
                    self.relief_lod = v.min(4);
                }
                Ok(())
            }
            Capture::None => Ok(()),
        };
        self.text = text;
        self.text.clear();
        result.map_err(|e| self.coord_error(e))
    }

    pub(super) fn coord_error(&self, e: CoordError) -> ReadError {
        match e {
            CoordError::Token(t) => ReadError::Coordinate {
                loc: self.loc(),
                token: t,
            },
            CoordError::Count { count, dimension } => ReadError::CoordinateCount {
                loc: self.loc(),
                count,
                dimension,
            },
        }
    }
}

#[derive(Debug)]
pub(super) enum CoordError {
    Token(String),
    Count { count: usize, dimension: u8 },
}

pub(super) fn parse_f64(tok: &[u8]) -> Result<f64, CoordError> {
    let bad = || CoordError::Token(String::from_utf8_lossy(&tok[..tok.len().min(40)]).into_owned());
    // fast-float2 parses the same grammar as `str::parse::<f64>` (incl. "nan", "inf"), from bytes.
    let v: f64 = fast_float2::parse(tok).map_err(|_| bad())?;
    if v.abs() <= MAX_COORDINATE {
        Ok(v)
    } else {
        Err(bad())
    }
}

pub(super) fn tokens(text: &[u8]) -> impl Iterator<Item = &[u8]> {
    text.split(|c| c.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
}

pub(super) fn parse_numbers(text: &[u8], out: &mut Vec<f64>) -> Result<(), CoordError> {
    for t in tokens(text) {
        out.push(parse_f64(t)?);
    }
    Ok(())
}

pub(super) fn parse_pos_list(text: &[u8], dim: u8, out: &mut Vec<DVec3>) -> Result<(), CoordError> {
    let mut vals = [0.0f64; 3];
    let mut n = 0usize;
    let d = dim as usize;
    for t in tokens(text) {
        vals[n % d] = parse_f64(t)?;
        n += 1;
        if n % d == 0 {
            out.push(DVec3::new(
                vals[0],
                vals[1],
                if d == 3 { vals[2] } else { 0.0 },
            ));
        }
    }
    if n % d != 0 {
        return Err(CoordError::Count {
            count: n,
            dimension: dim,
        });
    }
    Ok(())
}

pub(super) fn parse_pos(text: &[u8], out: &mut Vec<DVec3>) -> Result<(), CoordError> {
    let mut vals = [0.0f64; 3];
    let mut n = 0usize;
    for t in tokens(text) {
        if n >= 3 {
            return Err(CoordError::Count {
                count: n + 1,
                dimension: 3,
            });
        }
        vals[n] = parse_f64(t)?;
        n += 1;
    }
    if n < 2 {
        return Err(CoordError::Count {
            count: n,
            dimension: 3,
        });
    }
    out.push(DVec3::new(
        vals[0],
        vals[1],
        if n == 3 { vals[2] } else { 0.0 },
    ));
    Ok(())
}

pub(super) fn parse_coordinates(
    text: &[u8],
    a: CoordAttrs,
    out: &mut Vec<DVec3>,
) -> Result<(), CoordError> {
    let tuple_sep = |c: &u8| {
        if a.ts == b' ' {
            c.is_ascii_whitespace()
        } else {
            *c == a.ts
        }
    };
    let mut conv = Vec::new();
    for tuple in text
        .split(tuple_sep)
        .filter(|t| !t.iter().all(u8::is_ascii_whitespace))
    {
        let mut vals = [0.0f64; 3];
        let mut n = 0;
        for v in tuple.split(|c| *c == a.cs) {
            let v = v.trim_ascii();
            if v.is_empty() {
                continue;
            }
            if n >= 3 {
                return Err(CoordError::Count {
                    count: n + 1,
                    dimension: 3,
                });
            }
            let v = if a.decimal != b'.' {
                conv.clear();
                conv.extend(v.iter().map(|&c| if c == a.decimal { b'.' } else { c }));
                parse_f64(&conv)?
            } else {
                parse_f64(v)?
            };
            vals[n] = v;
            n += 1;
        }
        if n < 2 {
            return Err(CoordError::Count {
                count: n,
                dimension: 3,
            });
        }
        out.push(DVec3::new(
            vals[0],
            vals[1],
            if n == 3 { vals[2] } else { 0.0 },
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pos_list_dims() {
        let mut v = Vec::new();
        parse_pos_list(b" 1 2 3\n4 5 6 ", 3, &mut v).unwrap();
        assert_eq!(v, vec![DVec3::new(1., 2., 3.), DVec3::new(4., 5., 6.)]);
        v.clear();
        parse_pos_list(b"1 2 3 4", 2, &mut v).unwrap();
        assert_eq!(v.len(), 2);
        assert!(matches!(
            parse_pos_list(b"1 2 3 4", 3, &mut v),
            Err(CoordError::Count {
                count: 4,
                dimension: 3
            })
        ));
        assert!(matches!(
            parse_pos_list(b"1 NaN 3", 3, &mut v),
            Err(CoordError::Token(_))
        ));
        assert!(matches!(
            parse_pos_list(b"1 inf 3", 3, &mut v),
            Err(CoordError::Token(_))
        ));
        assert!(matches!(
            parse_pos_list(b"1 x 3", 3, &mut v),
            Err(CoordError::Token(_))
        ));
        assert!(matches!(
            parse_pos_list(b"1 1e309 3", 3, &mut v),
            Err(CoordError::Token(_))
        ));
    }

    #[test]
    fn coordinates_element() {
        let mut v = Vec::new();
        let a = CoordAttrs {
            dim: None,
            cs: b',',
            ts: b' ',
            decimal: b'.',
        };
        parse_coordinates(b"1,2,3 4,5,6\n7,8", a, &mut v).unwrap();
        assert_eq!(v.len(), 3);
        assert_eq!(v[2], DVec3::new(7., 8., 0.));
        v.clear();
        let a = CoordAttrs {
            dim: None,
            cs: b';',
            ts: b'|',
            decimal: b',',
        };
        parse_coordinates(b"1,5;2;3|4;5;6", a, &mut v).unwrap();
        assert_eq!(v[0], DVec3::new(1.5, 2., 3.));
    }
}
