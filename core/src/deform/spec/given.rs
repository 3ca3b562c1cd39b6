//! The `key=value` pairs of one spec, read for one algorithm: every reading names the
//! algorithm, the key and the value at fault. Enumerated values are read and written
//! through one name table each ([`Names`]), so a name parses to exactly what prints as it.

use super::SpecError;

/// A name table: each value of an enumerated parameter with the one name it parses from
/// and prints as.
pub type Names<T> = [(&'static str, T)];

/// The name `value` prints as in `table`.
pub fn name_of<T: PartialEq>(table: &Names<T>, value: T) -> &'static str {
    table
        .iter()
        .find(|(_, v)| *v == value)
        .map(|(name, _)| *name)
        .expect("every value has a name in its table")
}

/// The pairs given for `algorithm` (keys lowercase, already checked against its keys).
pub struct Given<'a> {
    pub algorithm: &'static str,
    pub pairs: &'a [(String, String)],
}

impl Given<'_> {
    /// The value given for `key`, if any.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.pairs.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    /// A refusal of `key`'s `value` saying what is wrong.
    pub fn bad(&self, key: &str, value: &str, problem: impl Into<String>) -> SpecError {
        SpecError::BadValue {
            algorithm: self.algorithm,
            key: key.to_string(),
            value: value.to_string(),
            problem: problem.into(),
        }
    }

    /// `key` as a positive finite number, if given.
    pub fn positive(&self, key: &str) -> Result<Option<f32>, SpecError> {
        self.get(key).map(|v| self.number(key, v)).transpose()
    }

    /// `value` of `key` as a positive finite number.
    pub fn number(&self, key: &str, value: &str) -> Result<f32, SpecError> {
        let x: f32 = value.parse().map_err(|_| self.bad(key, value, "not a number"))?;
        if !x.is_finite() || x <= 0.0 {
            return Err(self.bad(key, value, "must be a positive number"));
        }
        Ok(x)
    }

    /// `key` as one of `table`'s names (any case), if given.
    pub fn choice<T: Copy>(&self, key: &str, table: &Names<T>) -> Result<Option<T>, SpecError> {
        let Some(value) = self.get(key) else {
            return Ok(None);
        };
        let lower = value.to_ascii_lowercase();
        match table.iter().find(|(name, _)| *name == lower) {
            Some((_, v)) => Ok(Some(*v)),
            None => {
                let valid: Vec<&str> = table.iter().map(|(name, _)| *name).collect();
                Err(self.bad(key, value, format!("valid: {}", valid.join(", "))))
            }
        }
    }
}
