//! Nodes authenticate to NATS as NATS users expect: a user and password (in `[bus_auth]`,
//! the environment or the URL) limited to facewire's subjects and buckets by
//! `deploy/nats-server.conf`, a token, an nkey seed, a `.creds` file on a server in
//! operator mode, TLS with the server's CA and mutual TLS with a client certificate. A node refused says why and never prints its secret.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::nats::NatsServer;
use crate::common::nats_jwt::Operator;
use crate::common::service::{connect, moving_jaw_line, next_json, next_message, Server};
use facewire_proto::messages::ServerMessage;
use futures_util::SinkExt;
use tokio_tungstenite::tungstenite::Message;

const PASSWORD: &str = "pw-7f3a9c";

/// `deploy/nats-server.conf` with this test's password; its storage folder is the test
/// server's own (given on the command line, which may not name it twice).
fn locked_down_config() -> String {
    let shipped = std::fs::read_to_string(crate::common::repo_path("deploy/nats-server.conf")).unwrap();
    let store = "  store_dir: \"/var/lib/nats\"\n";
    assert!(shipped.contains("change-this-password") && shipped.contains(store));
    shipped
        .replace("change-this-password", PASSWORD)
        .replace(store, "")
}

async fn bus_connected(server: &Server) -> bool {
    server.healthz().await["bus"]["connected"] == serde_json::Value::Bool(true)
}

/// `facewire serve` with `config_toml`, expected to exit with an error: its stderr.
fn refused_node(config_toml: &str) -> String {
    let folder = tempfile::tempdir().unwrap();
    let config = folder.path().join("facewire.toml");
    std::fs::write(&config, config_toml).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_facewire"))
        .args(["serve", "--addr", "127.0.0.1:0", "--config"])
        .arg(&config)
        .arg("--data-dir")
        .arg(folder.path().join("data"))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            assert!(!status.success());
            let mut stderr = String::new();
            std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut stderr).unwrap();
            return stderr;
        }
        if started.elapsed() > Duration::from_secs(30) {
            let _ = child.kill();
            panic!("the node started although it should have been refused");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_user_held_to_facewire_subjects_runs_a_cluster_and_a_wrong_password_is_named_not_printed() {
    let nats = NatsServer::start_with_config(&locked_down_config());
    let port = nats.port;
    // One node with [bus_auth], the other with the credentials in its URL.
    let n1 = Server::spawn(&format!(
        "bus = \"nats://127.0.0.1:{port}\"\nnode_name = \"n1\"\n\
         [bus_auth]\nuser = \"facewire\"\npassword = \"{PASSWORD}\"\n"
    ))
    .await;
    let n2 = Server::spawn(&format!(
        "bus = \"nats://facewire:{PASSWORD}@127.0.0.1:{port}\"\nnode_name = \"n2\"\n"
    ))
    .await;
    n1.register("mh", "makehuman_head", "").await;
    n2.wait_ready_in_cluster("mh", Duration::from_secs(30)).await;
    // A stream produced on one node is watched on the other: leases, liveness and the
    // relay all pass the user's permissions.
    let mut viewer = connect(&n2.ws("/v1/heads/mh/streams/talk/view")).await;
    assert!(matches!(next_json(&mut viewer).await, ServerMessage::Snapshot(_)));
    let mut producer = connect(&n1.ws("/v1/heads/mh/streams/talk/produce")).await;
    for seq in 0..100 {
        producer
            .send(Message::Text(moving_jaw_line(seq).into()))
            .await
            .unwrap();
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    let relayed = tokio::time::timeout(Duration::from_secs(5), async {
        loop {
            match next_message(&mut viewer).await {
                Some(Message::Binary(_)) => return true,
                Some(_) => continue,
                None => return false,
            }
        }
    })
    .await;
    assert_eq!(relayed, Ok(true), "no frame from n1 reached n2's viewer");
    // A wrong password: refused, named, and never printed.
    let stderr = refused_node(&format!(
        "bus = \"nats://facewire:wrong-{PASSWORD}@127.0.0.1:{port}\"\n"
    ));
    assert!(stderr.contains("nats://facewire:***@127.0.0.1"), "{stderr}");
    assert!(stderr.to_lowercase().contains("authoriz"), "{stderr}");
    assert!(!stderr.contains(PASSWORD), "{stderr}");
    // Two ways at once are refused before connecting.
    let stderr = refused_node(&format!(
        "bus = \"nats://facewire:{PASSWORD}@127.0.0.1:{port}\"\n[bus_auth]\ntoken = \"t\"\n"
    ));
    assert!(stderr.contains("give one way to authenticate"), "{stderr}");
    assert!(!stderr.contains(PASSWORD), "{stderr}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_token_or_an_nkey_seed_file_lets_a_node_in() {
    let token = "tok-91b2";
    let nats = NatsServer::start_with_config(&format!("authorization {{ token: \"{token}\" }}\n"));
    let node = Server::spawn(&format!(
        "bus = \"nats://127.0.0.1:{}\"\n[bus_auth]\ntoken = \"{token}\"\n",
        nats.port
    ))
    .await;
    assert!(bus_connected(&node).await);
    let stderr = refused_node(&format!("bus = \"nats://127.0.0.1:{}\"\n", nats.port));
    assert!(stderr.to_lowercase().contains("authoriz"), "{stderr}");

    let user = nkeys::KeyPair::new_user();
    let nats = NatsServer::start_with_config(&format!(
        "authorization {{ users = [ {{ nkey: \"{}\" }} ] }}\n",
        user.public_key()
    ));
    let seed_file = nats.folder().join("node.nk");
    std::fs::write(&seed_file, user.seed().unwrap()).unwrap();
    let node = Server::spawn(&format!(
        "bus = \"nats://127.0.0.1:{}\"\n[bus_auth]\nnkey_seed_file = \"{}\"\n",
        nats.port,
        seed_file.display()
    ))
    .await;
    assert!(bus_connected(&node).await);
    // Another user's seed is refused.
    let stranger = nats.folder().join("stranger.nk");
    std::fs::write(&stranger, nkeys::KeyPair::new_user().seed().unwrap()).unwrap();
    let stderr = refused_node(&format!(
        "bus = \"nats://127.0.0.1:{}\"\n[bus_auth]\nnkey_seed_file = \"{}\"\n",
        nats.port,
        stranger.display()
    ));
    assert!(stderr.to_lowercase().contains("authoriz"), "{stderr}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_creds_file_from_an_operator_lets_a_node_in_and_a_strangers_is_refused() {
    // nats-server in operator mode (decentralized JWT auth, as `nsc` sets it up): a node
    // with a user's `.creds` file of the trusted account connects and uses JetStream (the
    // registry's buckets); one whose account the operator never signed is refused, and a
    // file that holds no credentials is named before connecting.
    let folder = tempfile::tempdir().unwrap();
    let operator = Operator::new(folder.path());
    let nats = NatsServer::start_with_config(&operator.server_config);
    let creds = |name: &str, text: &str| {
        let path = folder.path().join(name);
        std::fs::write(&path, text).unwrap();
        format!(
            "bus = \"nats://127.0.0.1:{}\"\nnode_name = \"{name}\"\n[bus_auth]\ncreds_file = \"{}\"\n",
            nats.port,
            path.display()
        )
    };
    let n1 = Server::spawn(&creds("n1", &operator.user_creds())).await;
    let n2 = Server::spawn(&creds("n2", &operator.user_creds())).await;
    assert!(bus_connected(&n1).await);
    n1.register("mh", "makehuman_head", "").await;
    n2.wait_ready_in_cluster("mh", Duration::from_secs(30)).await;

    let stranger = Operator::stranger_creds();
    let stderr = refused_node(&creds("stranger", &stranger));
    assert!(stderr.to_lowercase().contains("authoriz"), "{stderr}");
    let seed = stranger.lines().find(|line| line.starts_with("SU")).unwrap();
    assert!(!stderr.contains(seed), "the seed is printed: {stderr}");
    let stderr = refused_node(&creds("garbled", "not a creds file\n"));
    assert!(
        stderr.contains("creds_file") && stderr.contains("not a NATS credentials file"),
        "{stderr}"
    );
}

/// A CA, a server certificate for 127.0.0.1 and a client certificate, as PEM files in
/// `folder`: (ca, server cert, server key, client cert, client key).
fn certificates(folder: &std::path::Path) -> [std::path::PathBuf; 5] {
    use rcgen::{BasicConstraints, CertificateParams, ExtendedKeyUsagePurpose, IsCa, KeyPair};
    let mut ca_params = CertificateParams::new(Vec::<String>::new()).unwrap();
    ca_params.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    let ca_key = KeyPair::generate().unwrap();
    let ca = ca_params.self_signed(&ca_key).unwrap();
    let signed = |names: Vec<String>, purpose| {
        let mut params = CertificateParams::new(names).unwrap();
        params.extended_key_usages = vec![purpose];
        let key = KeyPair::generate().unwrap();
        let cert = params.signed_by(&key, &ca, &ca_key).unwrap();
        (cert.pem(), key.serialize_pem())
    };
    let (server_cert, server_key) = signed(
        vec!["127.0.0.1".into(), "localhost".into()],
        ExtendedKeyUsagePurpose::ServerAuth,
    );
    let (client_cert, client_key) = signed(vec!["facewire-node".into()], ExtendedKeyUsagePurpose::ClientAuth);
    let files = [
        "ca.pem",
        "server.pem",
        "server-key.pem",
        "client.pem",
        "client-key.pem",
    ]
    .map(|name| folder.join(name));
    for (path, text) in files
        .iter()
        .zip([ca.pem(), server_cert, server_key, client_cert, client_key])
    {
        std::fs::write(path, text).unwrap();
    }
    files
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tls_with_the_servers_ca_and_mutual_tls_with_a_client_certificate() {
    let folder = tempfile::tempdir().unwrap();
    let [ca, server_cert, server_key, client_cert, client_key] = certificates(folder.path());
    let tls = |verify: bool| {
        format!(
            "tls {{ cert_file: \"{}\", key_file: \"{}\", ca_file: \"{}\", verify: {verify} }}\n",
            server_cert.display(),
            server_key.display(),
            ca.display()
        )
    };
    let nats = NatsServer::start_with_config(&tls(false));
    let node = Server::spawn(&format!(
        "bus = \"tls://127.0.0.1:{}\"\n[bus_auth]\ntls_ca = \"{}\"\n",
        nats.port,
        ca.display()
    ))
    .await;
    assert!(bus_connected(&node).await);
    // Without the CA the server's certificate is not trusted.
    let stderr = refused_node(&format!("bus = \"tls://127.0.0.1:{}\"\n", nats.port));
    assert!(stderr.contains("cannot connect"), "{stderr}");

    let nats = NatsServer::start_with_config(&tls(true));
    let node = Server::spawn(&format!(
        "bus = \"tls://127.0.0.1:{}\"\n[bus_auth]\ntls_ca = \"{}\"\ntls_cert = \"{}\"\ntls_key = \"{}\"\n",
        nats.port,
        ca.display(),
        client_cert.display(),
        client_key.display()
    ))
    .await;
    assert!(bus_connected(&node).await);
    // Mutual TLS: without a client certificate the server turns the node away.
    let stderr = refused_node(&format!(
        "bus = \"tls://127.0.0.1:{}\"\n[bus_auth]\ntls_ca = \"{}\"\n",
        nats.port,
        ca.display()
    ));
    assert!(stderr.contains("cannot connect"), "{stderr}");
}
