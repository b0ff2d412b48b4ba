//! Coordinates and other captured text: `gml:posList`, `gml:pos`, `gml:coordinates`,
//! transformation matrices, codes; numbers parsed with `fast-float2`.

use super::state::{Capture, CoordKind, Parser};
use super::MAX_COORDINATE;
use crate::io::citygml::error::ReadError;
use glam::DVec3;

#[derive(Debug, Clone, Copy, Default)]
pub(super) struct CoordAttrs {
    pub(super) dim: Option<u8>,
    pub(super) cs: u8,
    pub(super) ts: u8,
    pub(super) decimal: u8,
}

impl Parser<'_> {
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
                    self.relief_lod_set = true;
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

/// Powers of ten exactly representable in an `f64`.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Plain decimals (`-123.456`: sign, digits, point, digits; no exponent) whose digits fit in
/// 2^53 with at most 22 after the point: the mantissa and the power of ten are exact, so one
/// IEEE division gives the correctly rounded value, bit for bit what a full parser returns
/// (Clinger's fast path). `None` for anything else.
#[inline]
fn parse_plain_decimal(tok: &[u8]) -> Option<f64> {
    let (neg, digits) = match tok.first() {
        Some(b'-') => (true, &tok[1..]),
        Some(b'+') => (false, &tok[1..]),
        _ => (false, tok),
    };
    if digits.is_empty() || digits.len() > 19 {
        return None;
    }
    let mut m = 0u64;
    let mut frac: Option<usize> = None;
    let mut n_digits = 0usize;
    for (i, &c) in digits.iter().enumerate() {
        match c {
            b'0'..=b'9' => {
                m = m * 10 + u64::from(c - b'0');
                n_digits += 1;
            }
            b'.' if frac.is_none() => frac = Some(digits.len() - i - 1),
            _ => return None,
        }
    }
    // at most 19 digits: no overflow above; at least one digit
    let k = frac.unwrap_or(0);
    if n_digits == 0 || m > (1u64 << 53) || k >= POW10.len() {
        return None;
    }
    let v = m as f64 / POW10[k];
    Some(if neg { -v } else { v })
}

pub(super) fn parse_f64(tok: &[u8]) -> Result<f64, CoordError> {
    let bad = || CoordError::Token(String::from_utf8_lossy(&tok[..tok.len().min(40)]).into_owned());
    // fast-float2 parses the same grammar as `str::parse::<f64>` (incl. "nan", "inf"), from bytes.
    let v: f64 = match parse_plain_decimal(tok) {
        Some(v) => v,
        None => fast_float2::parse(tok).map_err(|_| bad())?,
    };
    if v.abs() <= MAX_COORDINATE {
        Ok(v)
    } else {
        Err(bad())
    }
}

/// Whitespace-separated tokens (XML whitespace and form feed, as `u8::is_ascii_whitespace`).
pub(super) fn tokens(text: &[u8]) -> Tokens<'_> {
    Tokens { text, at: 0 }
}

/// Iterator of [`tokens`]: one pass over the bytes, no empty tokens.
pub(super) struct Tokens<'a> {
    text: &'a [u8],
    at: usize,
}

impl<'a> Iterator for Tokens<'a> {
    type Item = &'a [u8];

    #[inline]
    fn next(&mut self) -> Option<&'a [u8]> {
        let t = self.text;
        let mut i = self.at;
        while i < t.len() && t[i].is_ascii_whitespace() {
            i += 1;
        }
        if i >= t.len() {
            self.at = i;
            return None;
        }
        let from = i;
        while i < t.len() && !t[i].is_ascii_whitespace() {
            i += 1;
        }
        self.at = i;
        t.get(from..i)
    }
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
    let d = usize::from(dim).clamp(1, 3);
    let mut k = 0usize;
    for t in tokens(text) {
        vals[k] = parse_f64(t)?;
        n += 1;
        k += 1;
        if k == d {
            k = 0;
            out.push(DVec3::new(
                vals[0],
                vals[1],
                if d == 3 { vals[2] } else { 0.0 },
            ));
        }
    }
    if k != 0 {
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
    push_tuple(&vals, n, out)
}

/// The points of one GML coordinate element's text, for readers outside the model read
/// (`citygml::edit`): `posList` with its `srsDimension` (`dim`), `pos`, or `coordinates` with
/// GML's default separators; the error names the bad token or count.
pub(crate) fn parse_gml_points(
    local: &[u8],
    text: &[u8],
    dim: u8,
    out: &mut Vec<DVec3>,
) -> Result<(), String> {
    let r = match local {
        b"posList" => parse_pos_list(text, dim, out),
        b"pos" => parse_pos(text, out),
        b"coordinates" => parse_coordinates(
            text,
            CoordAttrs {
                dim: None,
                cs: b',',
                ts: b' ',
                decimal: b'.',
            },
            out,
        ),
        _ => Ok(()),
    };
    r.map_err(|e| match e {
        CoordError::Token(t) => format!("bad coordinate {t:?}"),
        CoordError::Count { count, dimension } => {
            format!("{count} coordinate values are not a multiple of srsDimension {dimension}")
        }
    })
}

/// One tuple of 2 or 3 values (`n` of `vals`) as a point (z 0 for 2); fewer than 2 values are
/// an error (more are refused while parsing).
fn push_tuple(vals: &[f64; 3], n: usize, out: &mut Vec<DVec3>) -> Result<(), CoordError> {
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
        push_tuple(&vals, n, out)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_decimals_parse_bit_for_bit_like_std() {
        let fixed = [
            "0",
            "-0",
            "+0",
            "0.0",
            "-0.0",
            ".5",
            "5.",
            "-.5",
            "1",
            "12.5",
            "4463934.786",
            "5404052.00123",
            "0.1",
            "0.2",
            "0.3",
            "-123.456",
            "9007199254740992",
            "9007199254740993",
            "900719925474099.3",
            "1.0000000000000002",
            "0.000000000000000000001",
            "1234567890123456789",
            "12345678901234567.89",
            "3.14159265358979323846",
        ];
        let mut cases: Vec<String> = fixed.iter().map(|s| s.to_string()).collect();
        // pseudo-random decimals of every length and point position
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let digits = format!("{}", x % 10u64.pow((x % 17 + 1) as u32));
            let point = (x >> 40) as usize % (digits.len() + 1);
            let sign = if x & 1 == 1 { "-" } else { "" };
            cases.push(format!("{sign}{}.{}", &digits[..point], &digits[point..]));
        }
        for s in &cases {
            let want: f64 = s.parse().unwrap();
            match parse_plain_decimal(s.as_bytes()) {
                Some(v) => assert_eq!(v.to_bits(), want.to_bits(), "{s}"),
                None if want.abs() <= MAX_COORDINATE => {
                    assert_eq!(
                        parse_f64(s.as_bytes()).unwrap().to_bits(),
                        want.to_bits(),
                        "{s}"
                    )
                }
                None => assert!(parse_f64(s.as_bytes()).is_err(), "{s}"),
            }
        }
        for bad in [
            "",
            "-",
            ".",
            "-.",
            "1.2.3",
            "1e5",
            "1,5",
            "--1",
            "0x10",
            "nan",
            "12345678901234567890",
        ] {
            assert!(parse_plain_decimal(bad.as_bytes()).is_none(), "{bad}");
        }
        assert_eq!(parse_f64(b"1e5").unwrap(), 1e5);
        assert!(parse_f64(b".").is_err());
    }

    #[test]
    fn tokens_split_on_xml_whitespace() {
        let t: Vec<&[u8]> = tokens(b"  1 2\t\n3\r\x0c4  ").collect();
        assert_eq!(t, vec![&b"1"[..], b"2", b"3", b"4"]);
        assert_eq!(tokens(b"   ").count(), 0);
        assert_eq!(tokens(b"").count(), 0);
        assert_eq!(tokens(b"a").collect::<Vec<_>>(), vec![&b"a"[..]]);
    }

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
        for bad in [&b"1 NaN 3"[..], b"1 inf 3", b"1 x 3", b"1 1e309 3"] {
            assert!(
                matches!(parse_pos_list(bad, 3, &mut v), Err(CoordError::Token(_))),
                "{}",
                String::from_utf8_lossy(bad)
            );
        }
    }

    #[test]
    fn coordinates_element() {
        // (cs, ts, decimal), text, points read, (index, point)
        let cases = [
            (
                (b',', b' ', b'.'),
                b"1,2,3 4,5,6\n7,8".as_slice(),
                3,
                (2, DVec3::new(7., 8., 0.)),
            ),
            (
                (b';', b'|', b','),
                b"1,5;2;3|4;5;6".as_slice(),
                2,
                (0, DVec3::new(1.5, 2., 3.)),
            ),
        ];
        for ((cs, ts, decimal), text, n, (i, point)) in cases {
            let mut v = Vec::new();
            let a = CoordAttrs {
                dim: None,
                cs,
                ts,
                decimal,
            };
            parse_coordinates(text, a, &mut v).unwrap();
            assert_eq!((v.len(), v[i]), (n, point));
        }
    }
}
