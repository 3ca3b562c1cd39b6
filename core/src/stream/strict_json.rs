//! JSON text to a `serde_json::Value`, refusing an object that names a key twice.
//! serde_json keeps the last of two equal keys without a word, so `{"seq":1,"seq":2}`
//! would pass as frame 2 and `{"au":{"jaw_drop":0.1,"jaw_drop":0.9}}` as 0.9; a JSONL
//! frame names each key once, and a repeated one is an error that names it.

use std::cell::RefCell;
use std::fmt;

use serde::de::{self, DeserializeSeed, MapAccess, SeqAccess, Visitor};
use serde_json::{Map, Number, Value};

/// Why a text is not a JSON frame.
#[derive(Debug)]
pub(crate) enum StrictJsonError {
    /// Not JSON at all (serde_json's message).
    Syntax(serde_json::Error),
    /// An object names the key at this path (`seq`, `au.jaw_drop`, `x[2].k`) twice.
    RepeatedKey(String),
}

/// Parses `text` as one JSON value, every object's keys distinct. serde_json's nesting
/// limit (128) still applies.
pub(crate) fn parse(text: &str) -> Result<Value, StrictJsonError> {
    let repeated = RefCell::new(None);
    let mut deserializer = serde_json::Deserializer::from_str(text);
    let seed = Strict {
        path: &Path::Root,
        repeated: &repeated,
    };
    let result = seed
        .deserialize(&mut deserializer)
        .and_then(|value| deserializer.end().map(|()| value));
    match (result, repeated.into_inner()) {
        (_, Some(path)) => Err(StrictJsonError::RepeatedKey(path)),
        (Ok(value), None) => Ok(value),
        (Err(e), None) => Err(StrictJsonError::Syntax(e)),
    }
}

/// Where a value sits in the document, built on the stack and rendered only on error.
enum Path<'a> {
    Root,
    Key(&'a Path<'a>, &'a str),
    Index(&'a Path<'a>, usize),
}

impl fmt::Display for Path<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Path::Root => Ok(()),
            Path::Key(Path::Root, key) => write!(f, "{key}"),
            Path::Key(parent, key) => write!(f, "{parent}.{key}"),
            Path::Index(parent, index) => write!(f, "{parent}[{index}]"),
        }
    }
}

/// Deserializes one value at `path`, recording the first repeated key in `repeated`.
struct Strict<'a> {
    path: &'a Path<'a>,
    repeated: &'a RefCell<Option<String>>,
}

impl<'de> DeserializeSeed<'de> for Strict<'_> {
    type Value = Value;

    fn deserialize<D: de::Deserializer<'de>>(self, deserializer: D) -> Result<Value, D::Error> {
        deserializer.deserialize_any(self)
    }
}

impl<'de> Visitor<'de> for Strict<'_> {
    type Value = Value;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a JSON value")
    }

    fn visit_bool<E>(self, v: bool) -> Result<Value, E> {
        Ok(Value::Bool(v))
    }

    fn visit_i64<E>(self, v: i64) -> Result<Value, E> {
        Ok(Value::Number(v.into()))
    }

    fn visit_u64<E>(self, v: u64) -> Result<Value, E> {
        Ok(Value::Number(v.into()))
    }

    fn visit_f64<E>(self, v: f64) -> Result<Value, E> {
        Ok(Number::from_f64(v).map_or(Value::Null, Value::Number))
    }

    fn visit_str<E>(self, v: &str) -> Result<Value, E> {
        Ok(Value::String(v.to_string()))
    }

    fn visit_string<E>(self, v: String) -> Result<Value, E> {
        Ok(Value::String(v))
    }

    fn visit_unit<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Value, A::Error> {
        let mut items = Vec::new();
        loop {
            let path = Path::Index(self.path, items.len());
            let seed = Strict {
                path: &path,
                repeated: self.repeated,
            };
            match seq.next_element_seed(seed)? {
                Some(item) => items.push(item),
                None => return Ok(Value::Array(items)),
            }
        }
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Value, A::Error> {
        let mut object = Map::new();
        while let Some(key) = map.next_key::<String>()? {
            let path = Path::Key(self.path, &key);
            if object.contains_key(&key) {
                *self.repeated.borrow_mut() = Some(path.to_string());
                return Err(de::Error::custom(format_args!("the key {path} appears twice")));
            }
            let value = map.next_value_seed(Strict {
                path: &path,
                repeated: self.repeated,
            })?;
            object.insert(key, value);
        }
        Ok(Value::Object(object))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn repeated(text: &str) -> Option<String> {
        match parse(text) {
            Err(StrictJsonError::RepeatedKey(path)) => Some(path),
            _ => None,
        }
    }

    #[test]
    fn reads_what_serde_json_reads() {
        let text = r#"{"a":[1,-2,0.5,1e300,"s",null,true,{"b":{}}],"c":18446744073709551615}"#;
        assert_eq!(parse(text).unwrap(), serde_json::from_str::<Value>(text).unwrap());
        assert!(matches!(parse("{} x"), Err(StrictJsonError::Syntax(_))));
        assert!(matches!(parse(&"[".repeat(200)), Err(StrictJsonError::Syntax(_))));
    }

    #[test]
    fn names_the_repeated_key_with_its_path() {
        assert_eq!(repeated(r#"{"seq":1,"seq":2}"#).as_deref(), Some("seq"));
        assert_eq!(
            repeated(r#"{"seq":1,"au":{"jaw_drop":0.1,"jaw_drop":0.2}}"#).as_deref(),
            Some("au.jaw_drop")
        );
        assert_eq!(repeated(r#"[0,{"k":1,"k":1}]"#).as_deref(), Some("[1].k"));
        assert_eq!(repeated(r#"{"a":{"k":1},"b":{"k":1}}"#), None);
    }
}
