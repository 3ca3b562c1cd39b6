//! Head ids and stream names: what a client may name, so that every name is a safe folder
//! name, a readable log field and a bounded map key; and the names the server makes for
//! itself (a node's, a registration's tag).

/// Lowercase letters, digits, `-` and `_`, 1 to 64 of them.
pub fn valid_id(id: &str) -> bool {
    (1..=64).contains(&id.len())
        && id
            .bytes()
            .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-' || b == b'_')
}

/// A name nobody else has, for a node (`node-...`) or a registration's tag (`reg-...`):
/// `prefix`, `-` and 10 hex digits from the process id and the clock.
pub fn unique_name(prefix: &str) -> String {
    use sha2::{Digest, Sha256};
    let seed = format!("{}-{}", std::process::id(), super::now_us());
    let digest = Sha256::digest(seed.as_bytes());
    let hex: String = digest[..5].iter().map(|b| format!("{b:02x}")).collect();
    format!("{prefix}-{hex}")
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
