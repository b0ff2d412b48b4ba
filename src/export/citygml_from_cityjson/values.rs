//! Text of the written XML: escaping, `gml:id`s from CityJSON keys, numbers, and attributes
//! as CityGML properties or generic attributes.

use serde_json::Value;
use std::fmt::Write as _;

/// `s` escaped for XML text and attribute values.
pub(super) fn esc(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&apos;"),
            // characters XML 1.0 does not allow
            c if (c as u32) < 0x20 && !matches!(c, '\t' | '\n' | '\r') => o.push(' '),
            c => o.push(c),
        }
    }
    o
}

/// A CityJSON key as an `xs:ID` (an XML NCName): kept when it is one; otherwise every
/// character other than a letter, digit, `_`, `-` or `.` becomes `_xHH_` (its code in hex),
/// and a key that does not start with a letter or `_` gets the prefix `id_`. The second
/// value says whether the key was changed.
///
/// ```
/// use skylod::export::gml_id;
/// assert_eq!(gml_id("b1"), ("b1".to_string(), false));
/// assert_eq!(gml_id("NL.IMBAG.Pand.0503100000000010-0"), ("NL.IMBAG.Pand.0503100000000010-0".to_string(), false));
/// assert_eq!(gml_id("3e2f"), ("id_3e2f".to_string(), true));
/// assert_eq!(gml_id("a b:c"), ("a_x20_b_x3a_c".to_string(), true));
/// ```
pub fn gml_id(key: &str) -> (String, bool) {
    let ok = |c: char| c.is_alphanumeric() || matches!(c, '_' | '-' | '.');
    let mut s = String::with_capacity(key.len() + 3);
    match key.chars().next() {
        Some(c) if c.is_alphabetic() || c == '_' => {}
        _ => s.push_str("id_"),
    }
    for c in key.chars() {
        if ok(c) {
            s.push(c);
        } else {
            let _ = write!(s, "_x{:x}_", c as u32);
        }
    }
    let changed = s != key;
    (s, changed)
}

/// Coordinates as text: with the decimals of the `transform`'s scale (0.001 → 3), so that
/// `84616468 × 0.001` is `84616.468`, not `84616.46800000001`; shortest round trip otherwise.
#[derive(Debug, Clone, Copy)]
pub(super) struct Coords {
    decimals: Option<[usize; 3]>,
}

impl Coords {
    pub fn new(scale: Option<[f64; 3]>) -> Coords {
        let d = |s: f64| {
            let k = -s.abs().log10();
            (s > 0.0 && k.is_finite() && (k - k.round()).abs() < 1e-9 && k.round() <= 12.0)
                .then(|| k.round().max(0.0) as usize)
        };
        let decimals = scale.and_then(|s| Some([d(s[0])?, d(s[1])?, d(s[2])?]));
        Coords { decimals }
    }

    /// `p` appended to `s` as `x y z`.
    pub fn push(&self, s: &mut String, p: [f64; 3]) {
        for (axis, v) in p.iter().enumerate() {
            if axis > 0 {
                s.push(' ');
            }
            push_number(s, *v, self.decimals.map(|d| d[axis]));
        }
    }
}

/// `v` with `decimals` (trailing zeros trimmed), or the shortest round trip.
pub(super) fn push_number(s: &mut String, v: f64, decimals: Option<usize>) {
    let v = if v == 0.0 { 0.0 } else { v };
    match decimals {
        Some(d) if d > 0 => {
            let t = format!("{v:.d$}");
            let t = t.trim_end_matches('0').trim_end_matches('.');
            s.push_str(if t == "-0" { "0" } else { t });
        }
        Some(_) => {
            let _ = write!(s, "{}", v.round());
        }
        None => {
            let _ = write!(s, "{v}");
        }
    }
}

/// How a CityJSON attribute becomes a CityGML property.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Kind {
    /// `gml:CodeType`: a string or number; an array gives one element per item (`function`,
    /// `usage`).
    Code,
    /// `xs:gYear`: an integer 1..=9999 or a string of one.
    Year,
    /// `gml:LengthType`: a number, `uom="m"`.
    Length,
    /// `xs:nonNegativeInteger`.
    Count,
    /// `xs:boolean`.
    Bool,
}

/// The property elements of attribute value `v` as `kind` (`<name>...</name>` for each),
/// `None` when the value does not fit (then it is written as a generic attribute).
pub(super) fn property(name: &str, v: &Value, kind: Kind, many: bool) -> Option<String> {
    let text = |v: &Value| -> Option<String> {
        match (kind, v) {
            (Kind::Code, Value::String(s)) => Some(esc(s)),
            (Kind::Code, Value::Number(n)) => Some(n.to_string()),
            (Kind::Year, Value::Number(n)) => n
                .as_u64()
                .filter(|y| (1..=9999).contains(y))
                .map(|y| format!("{y:04}")),
            (Kind::Year, Value::String(s)) => {
                let y: u64 = s.trim().parse().ok()?;
                (1..=9999).contains(&y).then(|| format!("{y:04}"))
            }
            (Kind::Length, Value::Number(n)) => n.as_f64().filter(|x| x.is_finite()).map(|x| {
                let mut s = String::new();
                push_number(&mut s, x, None);
                s
            }),
            (Kind::Count, Value::Number(n)) => n.as_u64().map(|c| c.to_string()),
            (Kind::Bool, Value::Bool(b)) => Some(b.to_string()),
            _ => None,
        }
    };
    let uom = if kind == Kind::Length {
        " uom=\"m\""
    } else {
        ""
    };
    let items: Vec<&Value> = match v {
        Value::Array(a) if many && !a.is_empty() => a.iter().collect(),
        v => vec![v],
    };
    let mut out = String::new();
    for item in items {
        let t = text(item)?;
        let _ = write!(out, "<{name}{uom}>{t}</{name}>");
    }
    Some(out)
}

/// `v` as a CityGML 2.0 generic attribute named `name` (integers `gen:intAttribute`, other
/// numbers `gen:doubleAttribute`, strings and booleans `gen:stringAttribute`, arrays and
/// objects `gen:stringAttribute` holding their JSON); `None` for `null` (nothing to write).
pub(super) fn generic(name: &str, v: &Value) -> Option<String> {
    let (el, text) = match v {
        Value::Null => return None,
        Value::Number(n) if n.is_i64() => ("intAttribute", n.to_string()),
        Value::Number(n) => {
            let mut s = String::new();
            push_number(&mut s, n.as_f64().unwrap_or(0.0), None);
            ("doubleAttribute", s)
        }
        Value::String(s) => ("stringAttribute", esc(s)),
        Value::Bool(b) => ("stringAttribute", b.to_string()),
        v => ("stringAttribute", esc(&v.to_string())),
    };
    Some(format!(
        "<gen:{el} name=\"{}\"><gen:value>{text}</gen:value></gen:{el}>",
        esc(name)
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn numbers_ids_and_attributes() {
        let c = Coords::new(Some([0.001, 0.001, 0.01]));
        let mut s = String::new();
        c.push(&mut s, [84616468.0 * 0.001, 0.5, -0.0]);
        assert_eq!(s, "84616.468 0.5 0");
        let mut s = String::new();
        Coords::new(None).push(&mut s, [1.25, 2.0, 3.0]);
        assert_eq!(s, "1.25 2 3");
        assert_eq!(gml_id("").0, "id_");
        assert!(!gml_id("_x").1);
        let p = |v, k| property("bldg:yearOfConstruction", &v, k, false);
        assert_eq!(
            p(json!(1999), Kind::Year).unwrap(),
            "<bldg:yearOfConstruction>1999</bldg:yearOfConstruction>"
        );
        assert_eq!(
            p(json!("1999"), Kind::Year).unwrap(),
            "<bldg:yearOfConstruction>1999</bldg:yearOfConstruction>"
        );
        assert!(p(json!("ca. 1900"), Kind::Year).is_none());
        assert!(p(json!(-3), Kind::Count).is_none());
        let f = property("bldg:function", &json!(["a", "b"]), Kind::Code, true).unwrap();
        assert_eq!(
            f,
            "<bldg:function>a</bldg:function><bldg:function>b</bldg:function>"
        );
        let h = property("bldg:measuredHeight", &json!(12.5), Kind::Length, false).unwrap();
        assert_eq!(
            h,
            "<bldg:measuredHeight uom=\"m\">12.5</bldg:measuredHeight>"
        );
        assert_eq!(
            generic("n", &json!(3)).unwrap(),
            "<gen:intAttribute name=\"n\"><gen:value>3</gen:value></gen:intAttribute>"
        );
        assert!(generic("n", &json!(2.5))
            .unwrap()
            .starts_with("<gen:doubleAttribute"));
        assert!(generic("n", &json!(null)).is_none());
        assert!(generic("a<b", &json!({"x": "<"}))
            .unwrap()
            .contains("a&lt;b"));
    }
}
