//! NATS decentralized auth (operator mode) minted for a test: an operator, an account with
//! JetStream and a user, as the JWTs `nsc` would write, signed with fresh nkeys. A JWT is
//! `base64url(header).base64url(claims).base64url(ed25519 signature of the first two)`,
//! its `jti` the base32 SHA-512/256 of the claims without it (nats-io/jwt v2).

use base64::engine::general_purpose::URL_SAFE_NO_PAD;
use base64::Engine;
use nkeys::KeyPair;
use serde_json::{json, Value};
use sha2::{Digest, Sha512_256};

/// An operator and one account under it (and the system account), with the server configuration that trusts them.
pub struct Operator {
    account: KeyPair,
    /// `nats-server.conf` lines: the operator, and the account preloaded into a memory
    /// resolver.
    pub server_config: String,
}

/// A signed JWT for `claims` (a JSON object with `sub`, `name` and `nats`), issued by
/// `issuer`.
fn jwt(issuer: &KeyPair, mut claims: Value) -> String {
    claims["iss"] = json!(issuer.public_key());
    claims["iat"] = json!(std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_secs());
    claims["jti"] = json!("");
    let digest = Sha512_256::digest(serde_json::to_vec(&claims).unwrap());
    claims["jti"] = json!(data_encoding::BASE32_NOPAD.encode(&digest));
    let header = URL_SAFE_NO_PAD.encode(br#"{"typ":"JWT","alg":"ed25519-nkey"}"#);
    let body = URL_SAFE_NO_PAD.encode(serde_json::to_vec(&claims).unwrap());
    let signed = format!("{header}.{body}");
    let signature = issuer.sign(signed.as_bytes()).unwrap();
    format!("{signed}.{}", URL_SAFE_NO_PAD.encode(signature))
}

impl Operator {
    /// A fresh operator with one account allowed JetStream without limits; `folder` keeps
    /// the operator's JWT, which the server configuration names.
    pub fn new(folder: &std::path::Path) -> Operator {
        let operator = KeyPair::new_operator();
        let account = KeyPair::new_account();
        let operator_jwt = jwt(
            &operator,
            json!({"sub": operator.public_key(), "name": "test-operator",
                   "nats": {"type": "operator", "version": 2}}),
        );
        let account_jwt = jwt(
            &operator,
            json!({"sub": account.public_key(), "name": "facewire",
                   "nats": {"type": "account", "version": 2,
                            "limits": {"subs": -1, "data": -1, "payload": -1, "imports": -1,
                                       "exports": -1, "wildcards": true, "conn": -1, "leaf": -1,
                                       "mem_storage": -1, "disk_storage": -1, "streams": -1,
                                       "consumer": -1}}}),
        );
        // JetStream needs the server's system account.
        let system = KeyPair::new_account();
        let system_jwt = jwt(
            &operator,
            json!({"sub": system.public_key(), "name": "SYS",
                   "nats": {"type": "account", "version": 2}}),
        );
        let operator_file = folder.join("operator.jwt");
        std::fs::write(&operator_file, &operator_jwt).unwrap();
        let server_config = format!(
            "operator: \"{}\"\nsystem_account: {}\nresolver: MEMORY\n\
             resolver_preload: {{\n  {}: \"{account_jwt}\"\n  {}: \"{system_jwt}\"\n}}\n",
            operator_file.display(),
            system.public_key(),
            account.public_key(),
            system.public_key()
        );
        Operator {
            account,
            server_config,
        }
    }

    /// A `.creds` file's text for a new user of the account (no permissions set: all).
    pub fn user_creds(&self) -> String {
        creds(&self.account, &KeyPair::new_user())
    }

    /// A `.creds` file's text for a user of an account this operator never signed.
    pub fn stranger_creds() -> String {
        creds(&KeyPair::new_account(), &KeyPair::new_user())
    }
}

/// A user's JWT, issued by `account`, and its seed, in the `.creds` layout.
fn creds(account: &KeyPair, user: &KeyPair) -> String {
    let user_jwt = jwt(
        account,
        json!({"sub": user.public_key(), "name": "facewire-node",
               "nats": {"type": "user", "version": 2, "pub": {}, "sub": {},
                        "subs": -1, "data": -1, "payload": -1}}),
    );
    format!(
        "-----BEGIN NATS USER JWT-----\n{user_jwt}\n------END NATS USER JWT------\n\n\
         -----BEGIN USER NKEY SEED-----\n{}\n------END USER NKEY SEED------\n",
        user.seed().unwrap()
    )
}
