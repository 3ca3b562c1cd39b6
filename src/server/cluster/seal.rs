//! Proof that a bus message comes from a node of this cluster. With `cluster_key` set
//! (`[bus_auth]`), every frame, audio chunk and end a node publishes carries
//! `Facewire-Mac`: HMAC-SHA256 under the key over the subject, every other `Facewire-*`
//! header (sorted by name) and the payload. A node with the key drops what does not carry
//! a valid one, so a client on the bus without the key changes nothing a viewer sees.
//! Without a key every message is taken as it comes (a warning says so at start).
//!
//! What the buckets hold (head records, tombstones, producer leases) and the answers to
//! liveness checks are sealed the same way, the proof in the value itself ([`Seal::seal`]:
//! a first line `mac:<hex>`, then the value) over the value and where it is kept (bucket
//! and key), so a value cannot be moved to another key nor changed in place.

use async_nats::HeaderMap;
use hmac::{Hmac, Mac};
use sha2::Sha256;

use super::CredentialError;
use crate::server::config::Secret;

/// The header holding the proof, lowercase hex.
pub const MAC_HEADER: &str = "Facewire-Mac";
/// The first line of a sealed value starts with this; the proof follows, in hex.
const VALUE_MAC: &[u8] = b"mac:";
/// Shortest cluster key accepted, bytes.
const MIN_KEY_BYTES: usize = 16;

pub struct Seal {
    key: Option<Hmac<Sha256>>,
}

impl Seal {
    /// The seal of `key`; `None` seals nothing and admits everything.
    pub fn new(key: Option<&Secret>) -> Result<Seal, CredentialError> {
        let key = match key {
            None => None,
            Some(key) if key.expose().len() < MIN_KEY_BYTES => {
                return Err(CredentialError::Invalid {
                    field: "cluster_key",
                    message: format!(
                        "{} bytes; use at least {MIN_KEY_BYTES} (e.g. `openssl rand -hex 32`)",
                        key.expose().len()
                    ),
                })
            }
            Some(key) => Some(Hmac::<Sha256>::new_from_slice(key.expose().as_bytes()).expect("any length")),
        };
        Ok(Seal { key })
    }

    pub fn is_keyed(&self) -> bool {
        self.key.is_some()
    }

    /// Adds the proof of `subject`, `headers` and `payload` to `headers`.
    pub fn sign(&self, subject: &str, headers: &mut HeaderMap, payload: &[u8]) {
        if let Some(mac) = self.mac(subject, headers, payload) {
            headers.insert(MAC_HEADER, hex(&mac).as_str());
        }
    }

    /// Whether the message carries a valid proof (always, without a key).
    pub fn admits(&self, subject: &str, headers: Option<&HeaderMap>, payload: &[u8]) -> bool {
        let Some(key) = &self.key else {
            return true;
        };
        let Some(headers) = headers else {
            return false;
        };
        let Some(given) = headers.get(MAC_HEADER).and_then(|v| unhex(v.as_str())) else {
            return false;
        };
        let mut mac = key.clone();
        feed(&mut mac, subject, headers, payload);
        mac.verify_slice(&given).is_ok()
    }

    /// `value` as kept at `place` (e.g. `kv/facewire_heads/<id>`): with a key, a first line
    /// holding the proof of both, then the value; without, the value as it is.
    pub fn seal(&self, place: &str, value: &[u8]) -> Vec<u8> {
        let Some(key) = &self.key else {
            return value.to_vec();
        };
        let mut mac = key.clone();
        feed_value(&mut mac, place, value);
        let mut sealed = VALUE_MAC.to_vec();
        sealed.extend_from_slice(hex(&mac.finalize().into_bytes()).as_bytes());
        sealed.push(b'\n');
        sealed.extend_from_slice(value);
        sealed
    }

    /// The value [`Seal::seal`] sealed for `place`, or `None` when its proof is missing or
    /// wrong. Without a key every value is taken (a proof line, if any, is skipped).
    pub fn open<'a>(&self, place: &str, sealed: &'a [u8]) -> Option<&'a [u8]> {
        let proof_and_value = sealed.strip_prefix(VALUE_MAC).and_then(|rest| {
            let newline = rest.iter().position(|&b| b == b'\n')?;
            Some((
                unhex(std::str::from_utf8(&rest[..newline]).ok()?)?,
                &rest[newline + 1..],
            ))
        });
        let Some(key) = &self.key else {
            return Some(proof_and_value.map_or(sealed, |(_, value)| value));
        };
        let (proof, value) = proof_and_value?;
        let mut mac = key.clone();
        feed_value(&mut mac, place, value);
        mac.verify_slice(&proof).is_ok().then_some(value)
    }

    fn mac(&self, subject: &str, headers: &HeaderMap, payload: &[u8]) -> Option<Vec<u8>> {
        let mut mac = self.key.clone()?;
        feed(&mut mac, subject, headers, payload);
        Some(mac.finalize().into_bytes().to_vec())
    }
}

/// Subject, `Facewire-*` headers but the proof (name sorted, lowercase), payload: each
/// part length-prefixed so that no two messages feed the same bytes.
fn feed(mac: &mut Hmac<Sha256>, subject: &str, headers: &HeaderMap, payload: &[u8]) {
    let mut part = |bytes: &[u8]| {
        mac.update(&(bytes.len() as u64).to_le_bytes());
        mac.update(bytes);
    };
    part(subject.as_bytes());
    let mut signed: Vec<(String, String)> = headers
        .iter()
        .filter_map(|(name, values)| {
            let name = name.to_string().to_ascii_lowercase();
            let own = name.starts_with("facewire-") && name != MAC_HEADER.to_ascii_lowercase();
            own.then(|| {
                let values: Vec<&str> = values.iter().map(|v| v.as_str()).collect();
                (name, values.join("\n"))
            })
        })
        .collect();
    signed.sort();
    for (name, value) in &signed {
        part(name.as_bytes());
        part(value.as_bytes());
    }
    part(payload);
}

/// A stored value's place and bytes, told apart from a message's by a leading tag.
fn feed_value(mac: &mut Hmac<Sha256>, place: &str, value: &[u8]) {
    for part in [b"value".as_slice(), place.as_bytes(), value] {
        mac.update(&(part.len() as u64).to_le_bytes());
        mac.update(part);
    }
}

/// Lowercase hex of `bytes`.
pub(super) fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn unhex(text: &str) -> Option<Vec<u8>> {
    if !text.len().is_multiple_of(2) {
        return None;
    }
    (0..text.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(text.get(i..i + 2)?, 16).ok())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn headers(pairs: &[(&str, &str)]) -> HeaderMap {
        let mut map = HeaderMap::new();
        for (name, value) in pairs {
            map.insert(*name, *value);
        }
        map
    }

    #[test]
    fn a_sealed_message_is_admitted_and_any_change_to_it_is_not() {
        let key = Secret::from("0123456789abcdef0123");
        let seal = Seal::new(Some(&key)).unwrap();
        let mut sent = headers(&[("Facewire-Received-Us", "100"), ("Facewire-Lease", "7")]);
        seal.sign("facewire.params.mh.talk", &mut sent, b"{\"seq\":1}");
        assert!(seal.admits("facewire.params.mh.talk", Some(&sent), b"{\"seq\":1}"));
        // Another payload, subject, header value, or no proof: refused.
        assert!(!seal.admits("facewire.params.mh.talk", Some(&sent), b"{\"seq\":2}"));
        assert!(!seal.admits("facewire.params.mh.other", Some(&sent), b"{\"seq\":1}"));
        let mut moved = sent.clone();
        moved.insert("Facewire-Received-Us", "0");
        assert!(!seal.admits("facewire.params.mh.talk", Some(&moved), b"{\"seq\":1}"));
        let mut added = sent.clone();
        added.insert("Facewire-End", "producer_ended");
        assert!(!seal.admits("facewire.params.mh.talk", Some(&added), b"{\"seq\":1}"));
        assert!(!seal.admits("facewire.params.mh.talk", None, b"{\"seq\":1}"));
        // Another key's proof is no proof.
        let other = Seal::new(Some(&Secret::from("another key, long enough"))).unwrap();
        assert!(!other.admits("facewire.params.mh.talk", Some(&sent), b"{\"seq\":1}"));
        // Without a key everything is admitted; a short key is refused by name.
        assert!(Seal::new(None).unwrap().admits("x", None, b""));
        let error = Seal::new(Some(&Secret::from("short"))).err().unwrap();
        assert!(
            error.to_string().starts_with("bus_auth.cluster_key: 5 bytes"),
            "{error}"
        );
    }

    #[test]
    fn a_sealed_value_opens_only_where_it_was_sealed_and_unchanged() {
        let seal = Seal::new(Some(&Secret::from("0123456789abcdef0123"))).unwrap();
        let sealed = seal.seal("kv/facewire_heads/mh", b"{\"tag\":\"a\"}");
        assert!(sealed.starts_with(b"mac:"));
        assert_eq!(
            seal.open("kv/facewire_heads/mh", &sealed),
            Some(&b"{\"tag\":\"a\"}"[..])
        );
        // Moved to another key, changed, unsealed, or sealed under another key: refused.
        assert_eq!(seal.open("kv/facewire_heads/other", &sealed), None);
        let mut changed = sealed.clone();
        *changed.last_mut().unwrap() = b']';
        assert_eq!(seal.open("kv/facewire_heads/mh", &changed), None);
        assert_eq!(seal.open("kv/facewire_heads/mh", b"{\"tag\":\"a\"}"), None);
        let other = Seal::new(Some(&Secret::from("another key, long enough"))).unwrap();
        assert_eq!(other.open("kv/facewire_heads/mh", &sealed), None);
        // Without a key: values are kept as they are, and any value is taken.
        let open = Seal::new(None).unwrap();
        assert_eq!(open.seal("p", b"v"), b"v");
        assert_eq!(open.open("p", b"v"), Some(&b"v"[..]));
        assert_eq!(open.open("p", &sealed), Some(&b"{\"tag\":\"a\"}"[..]));
    }
}
