//! The bus URL (`nats://user:password@host:4222`): its user part taken out, so that the
//! credentials go to the connection's options, and the URL as it may be shown in logs and
//! errors, secrets replaced by `***`. Apart from the cluster, so that the configuration can
//! name a bus it refuses without depending on the bus's adapter.

/// A URL's user part, with the URL left without it.
#[derive(Debug, PartialEq, Eq)]
pub enum UrlCredentials {
    UserPassword(String, String),
    Token(String),
}

/// `url` with its user part taken out, and what that part held.
pub fn split_url(url: &str) -> (String, Option<UrlCredentials>) {
    let Some((scheme, rest)) = url.split_once("://") else {
        return (url.to_string(), None);
    };
    let (authority, path) = rest.split_at(rest.find('/').unwrap_or(rest.len()));
    let Some((user_part, host)) = authority.rsplit_once('@') else {
        return (url.to_string(), None);
    };
    let decode = |s: &str| {
        percent_encoding::percent_decode_str(s)
            .decode_utf8_lossy()
            .into_owned()
    };
    let credentials = match user_part.split_once(':') {
        Some((user, password)) => UrlCredentials::UserPassword(decode(user), decode(password)),
        None => UrlCredentials::Token(decode(user_part)),
    };
    (format!("{scheme}://{host}{path}"), Some(credentials))
}

/// `url` as it may be shown: a password or token in it (in each of a comma-separated
/// list) replaced by `***`.
pub fn redacted(url: &str) -> String {
    url.split(',').map(redacted_one).collect::<Vec<_>>().join(",")
}

fn redacted_one(url: &str) -> String {
    let (bare, credentials) = split_url(url);
    let Some((scheme, rest)) = bare.split_once("://") else {
        return bare;
    };
    match credentials {
        Some(UrlCredentials::UserPassword(user, _)) => format!("{scheme}://{user}:***@{rest}"),
        Some(UrlCredentials::Token(_)) => format!("{scheme}://***@{rest}"),
        None => bare,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_user_part_of_a_url_is_taken_out_and_never_shown() {
        assert_eq!(
            split_url("nats://facewire:p%40ss@127.0.0.1:4222"),
            (
                "nats://127.0.0.1:4222".into(),
                Some(UrlCredentials::UserPassword("facewire".into(), "p@ss".into()))
            )
        );
        assert_eq!(
            split_url("tls://s3cret@nats.example:4222/"),
            (
                "tls://nats.example:4222/".into(),
                Some(UrlCredentials::Token("s3cret".into()))
            )
        );
        assert_eq!(
            split_url("nats://127.0.0.1:4222"),
            ("nats://127.0.0.1:4222".into(), None)
        );
        assert_eq!(
            redacted("nats://facewire:p%40ss@127.0.0.1:4222"),
            "nats://facewire:***@127.0.0.1:4222"
        );
        assert_eq!(redacted("nats://s3cret@h:1"), "nats://***@h:1");
        assert_eq!(redacted("nats://h:1"), "nats://h:1");
        // A cluster's servers, the credentials in any of them.
        assert_eq!(
            redacted("nats://h:1,nats://u:s3cret@h:2,nats://h:3"),
            "nats://h:1,nats://u:***@h:2,nats://h:3"
        );
    }
}
