//! A facewire server on an ephemeral loopback port, and the client side of its sockets:
//! what every test of the service needs.

use std::net::SocketAddr;
use std::time::Duration;

use facewire::cli::head_client::HeadClient;
use facewire::server::{serve, AppState, Config};
use facewire_proto::messages::{HeadInfo, ServerMessage};
use facewire_proto::viewer_frame::{decode, ViewerFrame};
use futures_util::StreamExt;
use tokio_tungstenite::tungstenite::Message;

use super::data;

pub type Socket =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

pub struct Server {
    pub addr: SocketAddr,
    runs: Runs,
}

/// Where the server runs: in this test process, or as a `facewire serve` child process of
/// its own, for tests that measure the server's memory while other tests run.
enum Runs {
    InProcess {
        state: AppState,
        task: tokio::task::JoinHandle<std::io::Result<()>>,
    },
    Child {
        child: KilledOnDrop,
        data_dir: tempfile::TempDir,
    },
}

/// A child process killed (and reaped) when dropped, even by a failing test.
struct KilledOnDrop(std::process::Child);

impl Drop for KilledOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The defaults with no data directory (heads in memory).
/// The server's Opus encoder's look-ahead, s (libopus in VoIP mode: 2.5 ms plus 4 ms of
/// delay compensation, at any rate): a packet's `t` is that much before the first sample
/// it was given.
pub const OPUS_LOOKAHEAD_S: f64 = 0.0065;

pub fn memory_config() -> Config {
    Config {
        data_dir: None,
        ..Config::default()
    }
}

impl Server {
    pub async fn start(config: Config) -> Server {
        let state = AppState::new(Config {
            addr: "127.0.0.1:0".parse().unwrap(),
            ..config
        })
        .unwrap();
        let (tx, rx) = tokio::sync::oneshot::channel();
        let task = tokio::spawn(serve(state.clone(), move |addr| {
            let _ = tx.send(addr);
        }));
        let addr = rx.await.unwrap();
        Server {
            addr,
            runs: Runs::InProcess { state, task },
        }
    }

    /// `facewire serve` as a child process with `config_toml` as its configuration file
    /// and a fresh data directory; killed when the `Server` is dropped.
    pub async fn spawn(config_toml: &str) -> Server {
        use std::io::BufRead;
        let data_dir = tempfile::tempdir().unwrap();
        let config = data_dir.path().join("facewire.toml");
        std::fs::write(&config, config_toml).unwrap();
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_facewire"))
            .args(["serve", "--addr", "127.0.0.1:0", "--config"])
            .arg(&config)
            .arg("--data-dir")
            .arg(data_dir.path().join("data"))
            // FACEWIRE_TEST_LOG (a RUST_LOG filter) shows more of the children when a
            // test is looked into.
            .env(
                "RUST_LOG",
                std::env::var("FACEWIRE_TEST_LOG").unwrap_or_else(|_| "warn".into()),
            )
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::inherit())
            .spawn()
            .unwrap();
        let stdout = child.stdout.take().unwrap();
        let line = tokio::task::spawn_blocking(move || {
            let mut line = String::new();
            std::io::BufReader::new(stdout).read_line(&mut line).unwrap();
            line
        })
        .await
        .unwrap();
        let addr = line
            .trim()
            .trim_start_matches("facewire listening on http://")
            .trim_end_matches('/')
            .parse()
            .unwrap_or_else(|e| panic!("{e}: {line:?}"));
        Server {
            addr,
            runs: Runs::Child {
                child: KilledOnDrop(child),
                data_dir,
            },
        }
    }

    /// The data directory of a server run as a child process (`facewire serve --data-dir`).
    pub fn data_dir(&self) -> Option<std::path::PathBuf> {
        match &self.runs {
            Runs::InProcess { .. } => None,
            Runs::Child { data_dir, .. } => Some(data_dir.path().join("data")),
        }
    }

    /// The server's resident memory, KiB (a child process's own; this process's when the
    /// server runs in it).
    pub fn resident_kib(&self) -> u64 {
        match &self.runs {
            Runs::InProcess { .. } => resident_kib("/proc/self/statm"),
            Runs::Child { child, .. } => resident_kib(&format!("/proc/{}/statm", child.0.id())),
        }
    }

    /// The child process's id (`None` when the server runs in this process).
    pub fn pid(&self) -> Option<u32> {
        match &self.runs {
            Runs::InProcess { .. } => None,
            Runs::Child { child, .. } => Some(child.0.id()),
        }
    }

    pub fn http(&self, path: &str) -> String {
        format!("http://{}{path}", self.addr)
    }

    pub fn ws(&self, path: &str) -> String {
        format!("ws://{}{path}", self.addr)
    }

    /// Shuts the server down and waits (at most 10 s) for `serve` to return; a child
    /// process is killed.
    pub async fn stop(self) {
        match self.runs {
            Runs::InProcess { state, task } => {
                state.shutdown.cancel();
                tokio::time::timeout(Duration::from_secs(10), task)
                    .await
                    .expect("serve returns after shutdown")
                    .unwrap()
                    .unwrap();
            }
            Runs::Child { child, .. } => drop(child),
        }
    }

    /// The head client the load generator uses, on this server; `query` is empty or
    /// `?token=...`.
    pub fn heads(&self, query: &str) -> HeadClient {
        HeadClient::new(&self.http(""), query.strip_prefix("?token="))
    }

    /// Registers a shipped head under `id` (`query` carries a token) and waits until it
    /// is ready.
    pub async fn register(&self, id: &str, name: &str, query: &str) -> HeadInfo {
        let body = serde_json::json!({
            "id": id,
            "obj": std::fs::read_to_string(data(&format!("heads/{name}.obj"))).unwrap(),
            "fit": std::fs::read_to_string(data(&format!("heads/{name}.fit.toml"))).unwrap(),
        });
        let status = self.heads(query).register(id, &body).await.unwrap();
        assert_eq!(status, 202);
        self.wait_ready(id, query).await
    }

    /// Waits until head `id` is ready; panics if it fails or takes 30 s.
    pub async fn wait_ready(&self, id: &str, query: &str) -> HeadInfo {
        let info = self.heads(query).wait_ready(id, Duration::from_secs(30)).await;
        serde_json::from_value(info.unwrap_or_else(|e| panic!("{e}"))).unwrap()
    }

    /// Waits until this cluster node has head `id` ready (registered on another node and
    /// followed here: unknown at first); panics if it fails or takes longer than `within`.
    pub async fn wait_ready_in_cluster(&self, id: &str, within: Duration) {
        if let Err(e) = self.heads("").wait_ready(id, within).await {
            panic!("{e}");
        }
    }

    /// `/healthz` as JSON.
    pub async fn healthz(&self) -> serde_json::Value {
        reqwest::get(self.http("/healthz"))
            .await
            .unwrap()
            .json()
            .await
            .unwrap()
    }

    /// `/metrics` as text.
    pub async fn metrics(&self) -> String {
        reqwest::get(self.http("/metrics"))
            .await
            .unwrap()
            .text()
            .await
            .unwrap()
    }

    pub async fn info(&self, id: &str, query: &str) -> HeadInfo {
        reqwest::get(self.http(&format!("/v1/heads/{id}{query}")))
            .await
            .unwrap()
            .json()
            .await
            .unwrap()
    }
}

/// The body of `POST /v1/heads` for the shipped ICT head as `id` with `parts`.
pub fn ict_request(id: &str, parts: serde_json::Value) -> serde_json::Value {
    serde_json::json!({
        "id": id,
        "obj": std::fs::read_to_string(data("heads/ict_head.obj")).unwrap(),
        "fit": std::fs::read_to_string(data("heads/ict_head.fit.toml")).unwrap(),
        "parts": parts,
    })
}

/// The ICT head's shipped parts ([`super::ICT_PARTS`]) as `POST /v1/heads` takes them.
pub fn ict_parts() -> serde_json::Value {
    super::ICT_PARTS
        .iter()
        .map(|&(name, file, role)| {
            let mut part = serde_json::json!({
                "name": name,
                "obj": std::fs::read_to_string(data(&format!("heads/{file}"))).unwrap(),
            });
            if let Some(role) = role {
                part["role"] = serde_json::json!(role);
            }
            part
        })
        .collect()
}

/// A WebSocket to `url`, without Nagle's delay (as browsers and the Python client connect):
/// messages the server does not answer, such as audio chunks, go out at once.
pub async fn connect(url: &str) -> Socket {
    tokio_tungstenite::connect_async_with_config(url, None, true)
        .await
        .unwrap()
        .0
}

/// Next message of any kind (10 s at most); `None` when the socket closed without a
/// close frame.
pub async fn next_message(socket: &mut Socket) -> Option<Message> {
    tokio::time::timeout(Duration::from_secs(10), socket.next())
        .await
        .expect("a message in time")
        .and_then(Result::ok)
}

/// Next JSON message, skipping binary frames.
pub async fn next_json(socket: &mut Socket) -> ServerMessage {
    loop {
        match next_message(socket).await {
            Some(Message::Text(text)) => return serde_json::from_str(text.as_str()).unwrap(),
            Some(Message::Binary(_)) | Some(Message::Ping(_)) | Some(Message::Pong(_)) => {}
            other => panic!("expected a JSON message, got {other:?}"),
        }
    }
}

/// Next binary frame, skipping JSON messages.
pub async fn next_frame(socket: &mut Socket) -> ViewerFrame {
    loop {
        match next_message(socket).await {
            Some(Message::Binary(bytes)) => return decode(&bytes).unwrap(),
            Some(Message::Text(_)) | Some(Message::Ping(_)) | Some(Message::Pong(_)) => {}
            other => panic!("expected a frame, got {other:?}"),
        }
    }
}

/// Everything a viewer receives until (and including) the next `end`: the frames' seqs
/// and the end's reason.
pub async fn until_end(socket: &mut Socket) -> (Vec<u64>, String) {
    let mut seqs = Vec::new();
    loop {
        match next_message(socket).await {
            Some(Message::Binary(bytes)) => seqs.push(decode(&bytes).unwrap().header.seq),
            Some(Message::Text(text)) => match serde_json::from_str(text.as_str()).unwrap() {
                ServerMessage::End { reason, .. } => return (seqs, reason.to_string()),
                other => panic!("expected a frame or end, got {other:?}"),
            },
            other => panic!("expected a frame or end, got {other:?} after {seqs:?}"),
        }
    }
}

/// The close code the server sends next (skipping other messages).
pub async fn close_code(socket: &mut Socket) -> u16 {
    loop {
        match next_message(socket).await {
            Some(Message::Close(Some(frame))) => return u16::from(frame.code),
            Some(Message::Close(None)) | None => panic!("closed with no close frame"),
            Some(_) => {}
        }
    }
}

/// A JSONL frame line moving the jaw.
pub fn jaw_line(seq: u64, t: f64) -> String {
    format!(r#"{{"seq":{seq},"t":{t},"au":{{"jaw_drop":0.3}}}}"#)
}

/// A JSONL frame line whose jaw opens and closes with `seq` (30 fps timestamps), so every
/// frame differs from the one before.
pub fn moving_jaw_line(seq: u64) -> String {
    let jaw = 0.15 + 0.15 * (seq as f64 * 0.4).sin();
    format!(
        r#"{{"seq":{seq},"t":{},"au":{{"jaw_drop":{jaw}}}}}"#,
        seq as f64 / 30.0
    )
}

/// Resident memory, KiB, from a `/proc/{pid}/statm` file.
fn resident_kib(statm: &str) -> u64 {
    let statm = std::fs::read_to_string(statm).unwrap();
    let pages: u64 = statm.split_whitespace().nth(1).unwrap().parse().unwrap();
    pages * 4
}

/// POSTs `body` to `server`'s `path`: the status and the JSON answer.
pub async fn post(
    server: &Server,
    path: &str,
    body: impl Into<reqwest::Body>,
    content_type: &str,
) -> (u16, serde_json::Value) {
    let response = reqwest::Client::new()
        .post(server.http(path))
        .header("content-type", content_type)
        .body(body)
        .send()
        .await
        .unwrap();
    let status = response.status().as_u16();
    let text = response.text().await.unwrap();
    (
        status,
        serde_json::from_str(&text).unwrap_or_else(|_| panic!("not JSON: {text:?}")),
    )
}

/// A 20 ms chunk of 16 kHz PCM at `t_s`, each sample naming the chunk.
pub fn pcm_chunk(t_s: f64, tag: i16) -> facewire_proto::audio_chunk::AudioChunk {
    facewire_proto::audio_chunk::AudioChunk {
        t_s,
        server_receive_us: 0,
        body: facewire_proto::audio_chunk::AudioBody::Pcm {
            sample_rate: 16_000,
            samples: (0..320).map(|i| tag * 100 + (i % 100) as i16).collect(),
        },
        ignored: Vec::new(),
    }
}
