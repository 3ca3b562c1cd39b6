//! How a node proves itself to NATS, as NATS users expect to configure it: a user and
//! password, a token, an nkey seed or a `.creds` (JWT) file, from `[bus_auth]`, the
//! environment or the bus URL's user part (`nats://user:password@host`, `nats://token@host`);
//! TLS with the server's CA and, for mutual TLS, a client certificate. Secrets are never
//! printed: the URL appears in logs and errors as [`crate::server::bus_url::redacted`] shows
//! it.

use std::path::{Path, PathBuf};

use crate::server::bus_url::{split_url, UrlCredentials};
use crate::server::config::BusAuth;

#[derive(Debug, thiserror::Error)]
pub enum CredentialError {
    #[error(
        "bus_auth: give one way to authenticate, found {0} (user and password, token, \
         nkey_seed, nkey_seed_file, creds_file, or credentials in the bus URL)"
    )]
    SeveralMethods(String),
    #[error("bus_auth: user needs a password, and a password a user")]
    UserWithoutPassword,
    #[error("bus_auth: tls_cert and tls_key go together (mutual TLS needs both)")]
    CertWithoutKey,
    #[error("bus_auth.{field} = {path:?}: {message}")]
    File {
        field: &'static str,
        path: PathBuf,
        message: String,
    },
    #[error("bus_auth.{field}: {message}")]
    Invalid { field: &'static str, message: String },
}

/// The connect options `auth` and `url` ask for, and the URLs to connect to: `url` may
/// list several servers of a NATS cluster, comma-separated; a user part in one of them
/// moves into the options.
pub async fn connect_options(
    auth: &BusAuth,
    url: &str,
) -> Result<(async_nats::ConnectOptions, Vec<String>), CredentialError> {
    let mut bare = Vec::new();
    let mut from_url = None;
    for entry in url.split(',') {
        let (entry, credentials) = split_url(entry.trim());
        bare.push(entry);
        from_url = from_url.or(credentials);
    }
    let mut methods = Vec::new();
    if auth.user.is_some() || auth.password.is_some() {
        methods.push("user and password");
    }
    for (set, name) in [
        (auth.token.is_some(), "token"),
        (auth.nkey_seed.is_some(), "nkey_seed"),
        (auth.nkey_seed_file.is_some(), "nkey_seed_file"),
        (auth.creds_file.is_some(), "creds_file"),
        (from_url.is_some(), "credentials in the bus URL"),
    ] {
        if set {
            methods.push(name);
        }
    }
    if methods.len() > 1 {
        return Err(CredentialError::SeveralMethods(methods.join(", ")));
    }
    let mut options = async_nats::ConnectOptions::new();
    match (&auth.user, &auth.password) {
        (Some(user), Some(password)) => {
            options = options.user_and_password(user.clone(), password.expose().to_string())
        }
        (None, None) => {}
        _ => return Err(CredentialError::UserWithoutPassword),
    }
    match from_url {
        Some(UrlCredentials::UserPassword(user, password)) => {
            options = options.user_and_password(user, password)
        }
        Some(UrlCredentials::Token(token)) => options = options.token(token),
        None => {}
    }
    if let Some(token) = &auth.token {
        options = options.token(token.expose().to_string());
    }
    let seed = match (&auth.nkey_seed, &auth.nkey_seed_file) {
        (Some(seed), _) => Some(("nkey_seed", seed.expose().trim().to_string())),
        (None, Some(path)) => Some(("nkey_seed_file", read("nkey_seed_file", path)?.trim().to_string())),
        (None, None) => None,
    };
    if let Some((field, seed)) = seed {
        // Checked here, so that a bad seed is named at start rather than as a refused
        // connection.
        nkeys::KeyPair::from_seed(&seed).map_err(|e| CredentialError::Invalid {
            field,
            message: format!("not an nkey seed: {e}"),
        })?;
        options = options.nkey(seed);
    }
    if let Some(path) = &auth.creds_file {
        let creds = read("creds_file", path)?;
        options = options
            .credentials(&creds)
            .map_err(|e| CredentialError::Invalid {
                field: "creds_file",
                message: format!("{}: not a NATS credentials file: {e}", path.display()),
            })?;
    }
    if let Some(ca) = &auth.tls_ca {
        exists("tls_ca", ca)?;
        options = options.add_root_certificates(ca.clone()).require_tls(true);
    }
    match (&auth.tls_cert, &auth.tls_key) {
        (Some(cert), Some(key)) => {
            exists("tls_cert", cert)?;
            exists("tls_key", key)?;
            options = options
                .add_client_certificate(cert.clone(), key.clone())
                .require_tls(true);
        }
        (None, None) => {}
        _ => return Err(CredentialError::CertWithoutKey),
    }
    if auth.tls_required {
        options = options.require_tls(true);
    }
    Ok((options, bare))
}

fn read(field: &'static str, path: &Path) -> Result<String, CredentialError> {
    crate::input::read_text(path, crate::input::MAX_TEXT_BYTES).map_err(|e| CredentialError::File {
        field,
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

fn exists(field: &'static str, path: &Path) -> Result<(), CredentialError> {
    match path.is_file() {
        true => Ok(()),
        false => Err(CredentialError::File {
            field,
            path: path.to_path_buf(),
            message: "no such file".into(),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::server::config::Secret;

    #[tokio::test]
    async fn one_way_to_authenticate_each_checked_before_connecting() {
        let both = BusAuth {
            token: Some(Secret::from("t")),
            ..BusAuth::default()
        };
        let error = connect_options(&both, "nats://u:p@h:1").await.unwrap_err();
        assert!(
            error.to_string().contains("token, credentials in the bus URL"),
            "{error}"
        );
        let half = BusAuth {
            user: Some("u".into()),
            ..BusAuth::default()
        };
        assert!(matches!(
            connect_options(&half, "nats://h:1").await,
            Err(CredentialError::UserWithoutPassword)
        ));
        let bad_seed = BusAuth {
            nkey_seed: Some(Secret::from("SUnot-a-seed")),
            ..BusAuth::default()
        };
        let error = connect_options(&bad_seed, "nats://h:1").await.unwrap_err();
        assert!(
            error
                .to_string()
                .starts_with("bus_auth.nkey_seed: not an nkey seed"),
            "{error}"
        );
        assert!(!error.to_string().contains("SUnot-a-seed"), "{error}");
        let missing = BusAuth {
            tls_ca: Some("/nowhere/ca.pem".into()),
            ..BusAuth::default()
        };
        let error = connect_options(&missing, "tls://h:1").await.unwrap_err();
        assert!(
            error
                .to_string()
                .contains("tls_ca = \"/nowhere/ca.pem\": no such file"),
            "{error}"
        );
        let (_, urls) = connect_options(&BusAuth::default(), "nats://u:p@h:1")
            .await
            .unwrap();
        assert_eq!(urls, ["nats://h:1"]);
        let (_, urls) = connect_options(&BusAuth::default(), "nats://h:1, nats://u:p@h:2")
            .await
            .unwrap();
        assert_eq!(urls, ["nats://h:1", "nats://h:2"]);
    }
}
