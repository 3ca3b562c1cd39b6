//! Head ids and stream names: what a client may name, so that every name is a safe folder
//! name, a readable log field and a bounded map key.

/// Lowercase letters, digits, `-` and `_`, 1 to 64 of them.
pub fn valid_id(id: &str) -> bool {
    (1..=64).contains(&id.len())
        && id
            .bytes()
            .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-' || b == b'_')
}

#[cfg(test)]
mod tests {
    use super::valid_id;

    #[test]
    fn ids_are_short_lowercase_names() {
        for good in ["a", "scan", "call-17", "x_y", &"z".repeat(64)] {
            assert!(valid_id(good), "{good}");
        }
        for bad in ["", "Scan", "a b", "a/b", "..", "é", &"z".repeat(65)] {
            assert!(!valid_id(bad), "{bad}");
        }
    }
}
