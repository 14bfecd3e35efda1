//! A tiny JSON tree with deterministic output: object keys sorted (BTreeMap),
//! floats in one fixed format, so that reruns write byte-identical files
//! whatever features other crates switch on in `serde_json`.

use std::collections::BTreeMap;
use std::fmt::Write;

#[derive(Clone, Debug, PartialEq)]
pub enum Json {
    Null,
    Bool(bool),
    Int(i64),
    Num(f64),
    Str(String),
    Arr(Vec<Json>),
    Obj(BTreeMap<String, Json>),
}

impl Json {
    pub fn obj() -> Self {
        Json::Obj(BTreeMap::new())
    }

    /// Inserts `value` at a dotted path, creating objects on the way.
    /// Panics if a path element is not an object (a programming error).
    pub fn set(&mut self, path: &str, value: impl Into<Json>) {
        let mut cur = self;
        let mut parts = path.split('.').peekable();
        while let Some(p) = parts.next() {
            let Json::Obj(map) = cur else {
                panic!("json path {path}: '{p}' is under a non-object")
            };
            if parts.peek().is_none() {
                map.insert(p.to_string(), value.into());
                return;
            }
            cur = map.entry(p.to_string()).or_insert_with(Json::obj);
        }
    }

    /// Value at a dotted path.
    pub fn get(&self, path: &str) -> Option<&Json> {
        let mut cur = self;
        for p in path.split('.') {
            match cur {
                Json::Obj(m) => cur = m.get(p)?,
                _ => return None,
            }
        }
        Some(cur)
    }

    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Json::Num(v) => Some(*v),
            Json::Int(v) => Some(*v as f64),
            _ => None,
        }
    }

    /// Pretty text, 2-space indent, trailing newline.
    pub fn to_pretty(&self) -> String {
        let mut s = String::new();
        self.write(&mut s, 0);
        s.push('\n');
        s
    }

    fn write(&self, s: &mut String, indent: usize) {
        match self {
            Json::Null => s.push_str("null"),
            Json::Bool(b) => s.push_str(if *b { "true" } else { "false" }),
            Json::Int(i) => {
                let _ = write!(s, "{i}");
            }
            Json::Num(v) => s.push_str(&fmt_float(*v)),
            Json::Str(t) => write_str(s, t),
            Json::Arr(a) => {
                if a.is_empty() {
                    s.push_str("[]");
                    return;
                }
                // Arrays of scalars stay on one line.
                if a.iter().all(|v| !matches!(v, Json::Arr(_) | Json::Obj(_))) {
                    s.push('[');
                    for (i, v) in a.iter().enumerate() {
                        if i > 0 {
                            s.push_str(", ");
                        }
                        v.write(s, indent);
                    }
                    s.push(']');
                    return;
                }
                s.push_str("[\n");
                for (i, v) in a.iter().enumerate() {
                    pad(s, indent + 1);
                    v.write(s, indent + 1);
                    if i + 1 < a.len() {
                        s.push(',');
                    }
                    s.push('\n');
                }
                pad(s, indent);
                s.push(']');
            }
            Json::Obj(m) => {
                if m.is_empty() {
                    s.push_str("{}");
                    return;
                }
                s.push_str("{\n");
                for (i, (k, v)) in m.iter().enumerate() {
                    pad(s, indent + 1);
                    write_str(s, k);
                    s.push_str(": ");
                    v.write(s, indent + 1);
                    if i + 1 < m.len() {
                        s.push(',');
                    }
                    s.push('\n');
                }
                pad(s, indent);
                s.push('}');
            }
        }
    }
}

fn pad(s: &mut String, indent: usize) {
    for _ in 0..indent {
        s.push_str("  ");
    }
}

fn write_str(s: &mut String, t: &str) {
    s.push('"');
    for c in t.chars() {
        match c {
            '"' => s.push_str("\\\""),
            '\\' => s.push_str("\\\\"),
            '\n' => s.push_str("\\n"),
            '\r' => s.push_str("\\r"),
            '\t' => s.push_str("\\t"),
            c if (c as u32) < 0x20 => {
                let _ = write!(s, "\\u{:04x}", c as u32);
            }
            c => s.push(c),
        }
    }
    s.push('"');
}

/// The one float format of metrics.json: 0 as `0`; magnitudes in
/// [1e-3, 1e12) as fixed-point with 9 decimals, trailing zeros trimmed;
/// anything else in scientific notation with 9 decimals; NaN/inf as null.
pub fn fmt_float(v: f64) -> String {
    if !v.is_finite() {
        return "null".into();
    }
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if (1e-3..1e12).contains(&a) {
        let mut t = format!("{v:.9}");
        while t.ends_with('0') {
            t.pop();
        }
        if t.ends_with('.') {
            t.push('0');
        }
        t
    } else {
        format!("{v:.9e}")
    }
}

/// serde's value tree in this format: objects sorted by key, integers kept
/// as integers, non-finite numbers (which serde writes as null) as null.
impl From<serde_json::Value> for Json {
    fn from(v: serde_json::Value) -> Self {
        use serde_json::Value as V;
        match v {
            V::Null => Json::Null,
            V::Bool(b) => Json::Bool(b),
            V::Number(n) => match (n.as_i64(), n.as_u64()) {
                (Some(i), _) => Json::Int(i),
                (None, Some(u)) => Json::Int(u as i64),
                _ => n.as_f64().map_or(Json::Null, Json::from),
            },
            V::String(s) => Json::Str(s),
            V::Array(a) => Json::Arr(a.into_iter().map(Json::from).collect()),
            V::Object(m) => Json::Obj(m.into_iter().map(|(k, v)| (k, Json::from(v))).collect()),
        }
    }
}

impl From<f64> for Json {
    fn from(v: f64) -> Self {
        if v.is_finite() {
            Json::Num(v)
        } else {
            Json::Null
        }
    }
}
impl From<usize> for Json {
    fn from(v: usize) -> Self {
        Json::Int(v as i64)
    }
}
impl From<i64> for Json {
    fn from(v: i64) -> Self {
        Json::Int(v)
    }
}
impl From<u32> for Json {
    fn from(v: u32) -> Self {
        Json::Int(v as i64)
    }
}
impl From<bool> for Json {
    fn from(v: bool) -> Self {
        Json::Bool(v)
    }
}
impl From<&str> for Json {
    fn from(v: &str) -> Self {
        Json::Str(v.to_string())
    }
}
impl From<String> for Json {
    fn from(v: String) -> Self {
        Json::Str(v)
    }
}
impl<T: Into<Json>> From<Option<T>> for Json {
    fn from(v: Option<T>) -> Self {
        v.map_or(Json::Null, Into::into)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn float_format_is_fixed() {
        assert_eq!(fmt_float(0.083), "0.083");
        assert_eq!(fmt_float(1.0), "1.0");
        assert_eq!(fmt_float(2.5e-40), "2.500000000e-40");
        assert_eq!(fmt_float(0.0), "0");
        assert_eq!(fmt_float(f64::NAN), "null");
    }

    #[test]
    fn keys_sorted_and_paths_nest() {
        let mut j = Json::obj();
        j.set("b.y", 1usize);
        j.set("a", "x");
        j.set("b.x", 0.5);
        assert_eq!(
            j.to_pretty(),
            "{\n  \"a\": \"x\",\n  \"b\": {\n    \"x\": 0.5,\n    \"y\": 1\n  }\n}\n"
        );
        assert_eq!(j.get("b.x").and_then(Json::as_f64), Some(0.5));
    }
}
