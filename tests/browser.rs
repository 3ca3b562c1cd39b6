//! The web page in a real browser: Debian's Chromium, headless (WebGL2 through SwiftShader),
//! driven over WebDriver by chromedriver, against `facewire demo` started as a process.
//! Checks that the page goes live, that the head moves, that switching the algorithm
//! reconnects with it, that a second view runs beside the first, that a stream which stops
//! sending shows as stalled and a new stream appears in the picker, that the heat-map's
//! scale is picked and kept in the URL, that the lips drawn tinted or in high contrast stand
//! out from the skin at least three times as much as drawn like it, that a head posted with
//! neither a fit nor landmarks is fitted, shown with its fit report and talks, that an
//! unknown head shows the error
//! state, that a page given two cluster nodes moves to the second when the first is
//! killed, and that with the sound on the face is seen when its voice is heard.
//! WebDriver is plain HTTP and JSON, spoken here with reqwest; the test's own producer
//! speaks WebSocket with tokio-tungstenite.

mod common;

use common::service::{jaw_line, moving_jaw_line};

use std::io::{BufRead, BufReader};
use std::panic::AssertUnwindSafe;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use futures_util::{FutureExt, SinkExt, StreamExt};
use serde_json::{json, Value};
use tokio_tungstenite::tungstenite::Message;

/// Kills a child process when the test ends, passed or not.
struct Process(Child);

impl Drop for Process {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn on_path(program: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|path| std::env::split_paths(&path).any(|dir| dir.join(program).is_file()))
}

fn require(program: &str) {
    assert!(
        on_path(program),
        "the browser test needs `{program}` on PATH: install Chromium and its WebDriver \
         (Debian: `apt-get install chromium chromium-driver`), or run without --include-ignored"
    );
}

/// `facewire demo` on a free port; returns the process and the page URL it printed.
fn start_demo() -> (Process, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_facewire"))
        .args(["demo", "--addr", "127.0.0.1:0"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("start facewire demo");
    let mut stdout = BufReader::new(child.stdout.take().expect("piped stdout"));
    let mut line = String::new();
    stdout.read_line(&mut line).expect("read the demo's first line");
    std::thread::spawn(move || std::io::copy(&mut stdout, &mut std::io::sink()));
    let url = line
        .split_whitespace()
        .find(|word| word.starts_with("http://"))
        .unwrap_or_else(|| panic!("no URL in the demo's first line: {line:?}"))
        .to_string();
    (Process(child), url)
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// A WebDriver session.
struct Browser {
    http: reqwest::Client,
    session: String,
    _driver: Process,
    _profile: tempfile::TempDir,
}

impl Browser {
    async fn start() -> Browser {
        require("chromium");
        require("chromedriver");
        let port = free_port();
        let driver = Process(
            Command::new("chromedriver")
                .arg(format!("--port={port}"))
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .expect("start chromedriver"),
        );
        let http = reqwest::Client::new();
        let base = format!("http://127.0.0.1:{port}");
        let started = Instant::now();
        while http.get(format!("{base}/status")).send().await.is_err() {
            assert!(
                started.elapsed() < Duration::from_secs(20),
                "chromedriver did not start in 20 s"
            );
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        let profile = tempfile::tempdir().unwrap();
        let microphone = format!(
            "--use-file-for-fake-audio-capture={}",
            common::repo_path("data/streams/syllables.wav").display()
        );
        let args = [
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--window-size=1280,1000",
            &format!("--user-data-dir={}", profile.path().display()),
            // The microphone is the syllable voice, looped, granted without asking.
            "--use-fake-ui-for-media-stream",
            "--use-fake-device-for-media-stream",
            &microphone,
        ];
        let capabilities = json!({ "capabilities": { "alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": { "args": args },
        }}});
        let reply: Value = http
            .post(format!("{base}/session"))
            .json(&capabilities)
            .send()
            .await
            .expect("chromedriver answers")
            .json()
            .await
            .unwrap();
        let session = reply["value"]["sessionId"]
            .as_str()
            .unwrap_or_else(|| panic!("chromedriver could not start Chromium: {reply}"))
            .to_string();
        Browser {
            http,
            session: format!("{base}/session/{session}"),
            _driver: driver,
            _profile: profile,
        }
    }

    /// A WebDriver command: POST with a JSON body, or GET when `body` is None.
    async fn command(&self, path: &str, body: Option<Value>) -> Value {
        let url = format!("{}{path}", self.session);
        let request = match body {
            Some(body) => self.http.post(url).json(&body),
            None => self.http.get(url),
        };
        let reply: Value = request.send().await.unwrap().json().await.unwrap();
        assert!(reply["value"].get("error").is_none(), "WebDriver {path}: {reply}");
        reply["value"].clone()
    }

    /// A Chrome DevTools Protocol command through chromedriver.
    async fn cdp(&self, cmd: &str, params: Value) -> Value {
        self.command("/goog/cdp/execute", Some(json!({ "cmd": cmd, "params": params })))
            .await
    }

    /// WebDriver input actions (keys, touches), then their release.
    async fn act(&self, actions: Value) {
        self.command("/actions", Some(json!({ "actions": actions })))
            .await;
        let url = format!("{}/actions", self.session);
        self.http.delete(url).send().await.unwrap();
    }

    async fn open(&self, url: &str) {
        self.command("/url", Some(json!({ "url": url }))).await;
    }

    /// Runs `script` (a function body) in the page and returns its result.
    async fn js(&self, script: &str) -> Value {
        self.command("/execute/sync", Some(json!({ "script": script, "args": [] })))
            .await
    }

    /// Waits until `script` returns something truthy; panics with what the page shows.
    async fn wait_for(&self, what: &str, script: &str, timeout: Duration) -> Value {
        let started = Instant::now();
        loop {
            let value = self.js(script).await;
            if !matches!(value, Value::Null | Value::Bool(false)) && value != "" {
                return value;
            }
            if started.elapsed() > timeout {
                let page = self.js("return document.body.innerText").await;
                panic!(
                    "waited {timeout:?} for {what}; the page shows:\n{}",
                    page.as_str().unwrap_or("")
                );
            }
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    }

    /// A PNG of one element, base64, as the compositor shows it.
    async fn screenshot(&self, css: &str) -> String {
        let id = self.element(css).await;
        let shot = self.command(&format!("/element/{id}/screenshot"), None).await;
        shot.as_str().unwrap().to_string()
    }

    /// Whether the element's picture differs from `before` (a [`Browser::screenshot`])
    /// within `limit`, looking every 250 ms.
    async fn picture_changes(&self, css: &str, before: &str, limit: Duration) -> bool {
        let start = Instant::now();
        while start.elapsed() < limit {
            tokio::time::sleep(Duration::from_millis(250)).await;
            if self.screenshot(css).await != before {
                return true;
            }
        }
        false
    }

    /// Clicks the element as a user would (WebDriver's trusted click: it counts as the
    /// user's gesture that lets a page play sound).
    async fn click(&self, css: &str) {
        let id = self.element(css).await;
        self.command(&format!("/element/{id}/click"), Some(json!({})))
            .await;
    }

    /// The WebDriver id of the element `css` selects.
    async fn element(&self, css: &str) -> String {
        let found = self
            .command("/element", Some(json!({ "using": "css selector", "value": css })))
            .await;
        found
            .as_object()
            .and_then(|o| o.values().next())
            .and_then(Value::as_str)
            .unwrap()
            .to_string()
    }

    async fn quit(self) {
        let _ = self.http.delete(&self.session).send().await;
    }
}

fn text_of(id: &str) -> String {
    format!("return document.getElementById('{id}').textContent")
}

/// Whether the element's `data-state` is `state`; false while the element does not exist
/// (the views appear once the page has read the server's lists).
fn state_is(id: &str, state: &str) -> String {
    format!("return document.getElementById('{id}')?.dataset.state === '{state}'")
}

/// The browser tests run one at a time: the A/V sync check times the page and must not
/// share the two cores with another page.
static ONE_BROWSER_AT_A_TIME: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

/// Runs `check` in a fresh Chromium and ends the browser session even when the check fails
/// (killing chromedriver would leave Chromium running).
async fn in_a_browser(check: impl AsyncFnOnce(&Browser)) {
    let _turn = ONE_BROWSER_AT_A_TIME.lock().await;
    let browser = Browser::start().await;
    let outcome = AssertUnwindSafe(check(&browser)).catch_unwind().await;
    browser.quit().await;
    if let Err(panic) = outcome {
        std::panic::resume_unwind(panic);
    }
}

#[tokio::test]
#[ignore = "browser: needs chromium"]
async fn the_page_shows_the_head_talking_live() {
    in_a_browser(check_the_page).await;
}

#[tokio::test]
#[ignore = "browser: needs chromium"]
async fn the_face_is_seen_when_its_voice_is_heard() {
    in_a_browser(async |browser| {
        let (_demo, url) = start_demo();
        check_the_face_is_seen_when_its_voice_is_heard(browser, &url, Duration::from_secs(120)).await;
    })
    .await;
}

/// Two cluster nodes over a real NATS server; the page, served by node 1 and told both
/// nodes (`?nodes=`), watches a stream produced on node 2. Node 1 is killed: the page
/// moves to node 2 by itself and the head keeps talking.
async fn check_failover_across_nodes(browser: &Browser) {
    use common::nats::NatsServer;
    use common::service::Server;
    let nats = NatsServer::start();
    let config = |name: &str| format!("bus = \"{}\"\nnode_name = \"{name}\"\n", nats.url());
    let n1 = Server::spawn(&config("n1")).await;
    let n2 = Server::spawn(&config("n2")).await;
    n1.register("mh", "makehuman_head", "").await;
    n2.wait_ready_in_cluster("mh", Duration::from_secs(60)).await;
    let long = Duration::from_secs(60);

    let (mut producer, _) = tokio_tungstenite::connect_async(n2.ws("/v1/heads/mh/streams/talk/produce"))
        .await
        .unwrap();
    let producing = tokio::spawn(async move {
        let mut ticks = tokio::time::interval(Duration::from_millis(33));
        for seq in 0.. {
            ticks.tick().await;
            let line = common::service::moving_jaw_line(seq);
            if producer.send(Message::Text(line.into())).await.is_err() {
                return;
            }
            let _ = producer.next().await;
        }
    });

    let (one, two) = (n1.http(""), n2.http(""));
    browser
        .open(&format!("{one}/?head=mh&stream=talk&nodes={one},{two}"))
        .await;
    browser
        .wait_for(
            "the view to go live on node 1",
            &state_is("status-0", "live"),
            long,
        )
        .await;
    let status = browser.js(&text_of("status-0")).await;
    assert!(
        status.as_str().unwrap().contains(&n1.addr.to_string()),
        "the status names node 1: {status}"
    );

    drop(n1); // SIGKILL
    let on_n2 = format!(
        "return document.getElementById('status-0').dataset.state === 'live' && \
         document.getElementById('status-0').textContent.includes('{}')",
        n2.addr
    );
    browser
        .wait_for("the view live again, on node 2", &on_n2, Duration::from_secs(20))
        .await;
    let before = browser.screenshot("#head-0").await;
    assert!(
        browser
            .picture_changes("#head-0", &before, Duration::from_secs(3))
            .await,
        "the head did not move after the page moved to node 2"
    );
    producing.abort();
}

async fn check_the_page(browser: &Browser) {
    // One check alone, for work on it: the lips or the element.
    if std::env::var_os("FACEWIRE_LIPS_ONLY").is_some() {
        let (_demo, url) = start_demo();
        check_the_lips_read(browser, &url, Duration::from_secs(120)).await;
        return;
    }
    if std::env::var_os("FACEWIRE_ELEMENT_ONLY").is_some() {
        let (_demo, url) = start_demo();
        check_the_element_embeds(browser, &url, Duration::from_secs(120)).await;
        return;
    }
    if std::env::var_os("FACEWIRE_REPLAY_ONLY").is_some() {
        let (_demo, url) = start_demo();
        check_the_replay(browser, &url, Duration::from_secs(120)).await;
        check_the_replay_voice(browser, &url, Duration::from_secs(120)).await;
        return;
    }
    if std::env::var_os("FACEWIRE_TEXTURE_ONLY").is_some() {
        let (_demo, url) = start_demo();
        check_a_textured_head(browser, &url, Duration::from_secs(120)).await;
        check_a_head_uploaded(browser, &url, Duration::from_secs(120)).await;
        return;
    }
    if std::env::var_os("FACEWIRE_CUTAWAY_ONLY").is_some() {
        let (_demo, url) = start_demo();
        check_the_cut_away_reads_back(browser, &url, Duration::from_secs(120)).await;
        return;
    }
    if std::env::var_os("FACEWIRE_PHONE_ONLY").is_some() {
        let (_demo, url) = start_demo();
        check_the_page_on_a_phone(browser, &url, Duration::from_secs(120)).await;
        return;
    }
    check_failover_across_nodes(browser).await;
    let (_demo, url) = start_demo();
    let long = Duration::from_secs(120);

    browser.open(&url).await;
    browser
        .wait_for("view 1 to go live", &state_is("status-0", "live"), long)
        .await;
    browser
        .wait_for(
            "a syllable",
            "return document.getElementById('syllable-0').textContent !== '–'",
            long,
        )
        .await;
    let default_algorithm = browser.js(&text_of("algorithm-0")).await;
    let listed: Value = reqwest::get(format!("{url}v1/algorithms"))
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    let default_spec = listed
        .as_array()
        .unwrap()
        .iter()
        .find(|a| a["default"] == true)
        .unwrap()["spec"]
        .clone();
    assert_eq!(
        default_algorithm, default_spec,
        "view 1 starts with the server's default algorithm"
    );

    // The syllable stream moves the lips: two pictures a few hundred ms apart differ.
    let first = browser.screenshot("#head-0").await;
    assert!(
        browser
            .picture_changes("#head-0", &first, Duration::from_secs(3))
            .await,
        "the head did not move in 3 s"
    );

    // Another algorithm in the picker: the view reconnects and the snapshot names it.
    let rigid = "geometric:weights=none";
    browser
        .js(&format!(
            "const s = document.getElementById('algo-0'); s.value = '{rigid}'; \
             s.dispatchEvent(new Event('change')); return s.value"
        ))
        .await;
    browser
        .wait_for(
            "the new algorithm's snapshot",
            &format!("{}=== '{rigid}'", text_of("algorithm-0")),
            long,
        )
        .await;
    browser
        .wait_for("view 1 live again", &state_is("status-0", "live"), long)
        .await;
    let address = browser.js("return location.search").await;
    assert!(
        address.as_str().unwrap().contains("algo=E"),
        "the URL keeps the choice: {address}"
    );

    // Side by side: a second socket with its own algorithm.
    browser.js("document.getElementById('compare').click()").await;
    browser
        .wait_for("view 2 to go live", &state_is("status-1", "live"), long)
        .await;
    let second = browser.js(&text_of("algorithm-1")).await;
    assert_ne!(second, rigid, "view 2 starts with another algorithm");
    tokio::time::sleep(Duration::from_secs(2)).await;
    let fps = browser
        .js("return document.getElementById('fps-0').textContent")
        .await;
    let bytes = browser
        .js("return document.getElementById('bytes-0').textContent")
        .await;
    println!("headless Chromium, two views: frames {fps}, bytes per frame {bytes}");

    // Each check's time, printed: where the suite's minutes go.
    macro_rules! timed {
        ($check:ident) => {
            timed(stringify!($check), $check(browser, &url, long)).await
        };
    }
    timed!(check_the_heat_map_scale);
    timed!(check_the_lips_read);
    timed!(check_the_element_embeds);
    timed!(check_the_replay);
    timed!(check_the_replay_voice);
    timed!(check_the_cut_away_reads_back);
    timed!(check_the_inner_mouth_close_up);
    timed!(check_a_stalled_stream);
    timed!(check_a_head_posted_with_no_fit);
    timed!(check_a_textured_head);
    timed!(check_a_head_uploaded);
    timed!(check_the_page_on_a_phone);

    // An unknown head: the server's error and close 4404 end in the error state.
    browser.open(&format!("{url}?head=nosuch")).await;
    browser
        .wait_for("the error state", &state_is("status-0", "error"), long)
        .await;
    let message = browser.js(&text_of("message-0")).await;
    assert!(
        message.as_str().unwrap().contains("nosuch"),
        "the message names the head: {message}"
    );
}

/// Runs `check` and prints how long it took.
async fn timed(name: &str, check: impl std::future::Future<Output = ()>) {
    let started = Instant::now();
    check.await;
    println!("{name}: {:.1} s", started.elapsed().as_secs_f64());
}

/// A producer's socket.
type Producer = tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

/// A producer's socket on stream `stream` of head `head`, served at `url`.
async fn connect_producer(url: &str, head: &str, stream: &str) -> Producer {
    let ws = url.replacen("http://", "ws://", 1);
    // Without Nagle, as a real producer (docs/PERFORMANCE.md "Audio"): the audio chunks the
    // server does not answer would otherwise wait for delayed ACKs.
    let url = format!("{ws}v1/heads/{head}/streams/{stream}/produce");
    let (producer, _) = tokio_tungstenite::connect_async_with_config(url, None, true)
        .await
        .expect("producer connects");
    producer
}

/// One jaw-drop frame as a producer sends it, and the server's ack.
async fn produce<S>(producer: &mut S, seq: u64)
where
    S: SinkExt<Message> + StreamExt<Item = tokio_tungstenite::tungstenite::Result<Message>> + Unpin,
    <S as futures_util::Sink<Message>>::Error: std::fmt::Debug,
{
    produce_line(producer, jaw_line(seq, seq as f64 / 30.0)).await
}

/// One JSONL frame as a producer sends it, and the server's ack.
async fn produce_line<S>(producer: &mut S, line: String)
where
    S: SinkExt<Message> + StreamExt<Item = tokio_tungstenite::tungstenite::Result<Message>> + Unpin,
    <S as futures_util::Sink<Message>>::Error: std::fmt::Debug,
{
    producer.send(Message::Text(line.into())).await.unwrap();
    let reply = producer.next().await.expect("an ack").unwrap();
    assert!(reply.to_text().unwrap().contains("\"ack\""), "{reply:?}");
}

/// Share of the pixels of a screenshot (base64 PNG) that are clearly green (green over 60
/// above red and blue, 0-255): the test texture's colour, which skin never is.
async fn green_share(browser: &Browser, shot: &str) -> f64 {
    browser
        .js(&format!(
            "window.greenShare = null; const img = new Image(); img.onload = () => {{ \
             const c = document.createElement('canvas'); c.width = img.width; c.height = img.height; \
             const g = c.getContext('2d'); g.drawImage(img, 0, 0); \
             const d = g.getImageData(0, 0, c.width, c.height).data; let n = 0; \
             for (let i = 0; i < d.length; i += 4) {{ if (d[i + 1] > d[i] + 60 && d[i + 1] > d[i + 2] + 60) n++; }} \
             window.greenShare = n / (c.width * c.height); }}; img.src = 'data:image/png;base64,{shot}';"
        ))
        .await;
    browser
        .wait_for(
            "the screenshot decoded",
            "return window.greenShare",
            Duration::from_secs(10),
        )
        .await
        .as_f64()
        .unwrap()
}

/// A head registered with a texture (the MakeHuman head with texture coordinates of the
/// test's own and a green and white checkerboard) is drawn with it: a good share of the
/// view green where the shipped MakeHuman head, untextured, shows none.
/// `FACEWIRE_SCREENSHOTS=DIR` keeps the textured head (`DIR/texture.png.base64`;
/// docs/img/texture.png is it).
async fn check_a_textured_head(browser: &Browser, url: &str, long: Duration) {
    let png = common::texture::checker_png(256, 256, 16, [30, 170, 60], [235, 235, 225]);
    let http = reqwest::Client::new();
    let posted = http
        .post(format!("{url}v1/heads"))
        .json(&common::texture::textured_request("textured", &png))
        .send()
        .await
        .unwrap();
    assert!(posted.status().is_success(), "{:?}", posted.text().await);
    wait_ready(url, "textured", long).await;
    for (head, textured) in [("makehuman", false), ("textured", true)] {
        browser.open(&format!("{url}?head={head}&stream=skin")).await;
        let mut producer = connect_producer(url, head, "skin").await;
        produce_line(&mut producer, jaw_line(0, 0.0)).await;
        browser
            .wait_for(&format!("{head} live"), &state_is("status-0", "live"), long)
            .await;
        if textured {
            browser
                .wait_for(
                    "the texture loaded",
                    "return window.facewireViews()[0].renderer.texture !== null",
                    long,
                )
                .await;
        }
        tokio::time::sleep(Duration::from_millis(500)).await;
        let shot = browser.screenshot("#head-0").await;
        let green = green_share(browser, &shot).await;
        println!("{head}: {:.1} % of the view green", green * 100.0);
        if textured {
            if let Some(dir) = std::env::var_os("FACEWIRE_SCREENSHOTS") {
                std::fs::write(std::path::Path::new(&dir).join("texture.png.base64"), &shot).unwrap();
            }
            assert!(
                green > 0.05,
                "the texture is not drawn: {:.2} % green",
                green * 100.0
            );
            let message = browser.js(&text_of("message-0")).await;
            assert_eq!(message, "", "the page complains: {message}");
        } else {
            assert!(green < 0.001, "{:.2} % green without a texture", green * 100.0);
        }
        producer.close(None).await.unwrap();
    }
}

/// "Your own head": a glTF avatar picked from disk (the ICT head with its teeth, tongue
/// and eyes as named meshes and a checkerboard texture), its id made from the file's name,
/// registered and fitted by the server, then shown in view 1 with its texture and its fit
/// report; an image alone is refused in words.
async fn check_a_head_uploaded(browser: &Browser, url: &str, long: Duration) {
    let png = common::texture::checker_png(256, 256, 16, [30, 170, 60], [235, 235, 225]);
    let glb = common::glb::ict_avatar_textured(Some(("image/png".into(), png.clone())));
    let dir = tempfile::tempdir().unwrap();
    let avatar = dir.path().join("My Avatar.glb");
    std::fs::write(&avatar, glb).unwrap();
    let image = dir.path().join("face.png");
    std::fs::write(&image, png).unwrap();
    browser.open(url).await;
    browser
        .wait_for("view 1 to go live", &state_is("status-0", "live"), long)
        .await;
    let pick = async |path: &std::path::Path| {
        browser
            .js("const f = document.getElementById('upload-files'); f.value = ''; return true")
            .await;
        let input = browser.element("#upload-files").await;
        browser
            .command(
                &format!("/element/{input}/value"),
                Some(json!({ "text": path.display().to_string() })),
            )
            .await;
    };
    // Picks `path` with the id field cleared, checks the id the page makes of the file's
    // name, registers, and returns what the page says once `id` is registered.
    let register_picked = async |path: &std::path::Path, id: &str| {
        browser
            .js("document.getElementById('upload-id').value = ''; return true")
            .await;
        pick(path).await;
        let made = browser
            .js("return document.getElementById('upload-id').value")
            .await;
        assert_eq!(made, id, "the id made from the file's name");
        browser.click("#upload-register").await;
        browser
            .wait_for(
                &format!("{id} registered"),
                &format!(
                    "const s = document.getElementById('upload-status'); \
                     return s.dataset.kind === 'error' ? 'error: ' + s.textContent \
                       : s.textContent.includes('\"{id}\" is registered') && s.textContent"
                ),
                long,
            )
            .await
    };
    // An image alone is no head.
    pick(&image).await;
    browser
        .js("document.getElementById('upload-id').value = 'only-an-image'; return true")
        .await;
    browser.click("#upload-register").await;
    let refused = browser
        .wait_for(
            "the refusal",
            "const s = document.getElementById('upload-status'); \
             return s.dataset.kind === 'error' && s.textContent",
            long,
        )
        .await;
    assert!(refused.as_str().unwrap().contains("pick a head"), "{refused}");

    // The avatar: its id from its file name, registered, fitted and shown.
    let said = register_picked(&avatar, "my-avatar").await;
    println!("your own head: {said}");
    assert!(
        said.as_str().unwrap().contains("\"my-avatar\" is registered")
            && said.as_str().unwrap().contains("image/png"),
        "{said}"
    );
    let shown = browser
        .wait_for(
            "the avatar's fit report and view",
            "const v = window.facewireViews()[0]; \
             return !document.getElementById('fit-report').hidden && \
               document.getElementById('head').value === 'my-avatar' && \
               (v?.snapshot?.rest_mesh ?? '').includes('/my-avatar/') && \
               document.getElementById('fit-title').textContent",
            long,
        )
        .await;
    assert_eq!(shown, "Fit of head \"my-avatar\"");
    let mut producer = connect_producer(url, "my-avatar", "main").await;
    produce_line(&mut producer, jaw_line(0, 0.0)).await;
    browser
        .wait_for("the avatar live", &state_is("status-0", "live"), long)
        .await;
    browser
        .wait_for(
            "the avatar's texture and parts drawn",
            "const v = window.facewireViews()[0]; \
             return v.renderer.texture !== null && \
               document.getElementById('inner-0').dataset.loaded > 0",
            long,
        )
        .await;
    tokio::time::sleep(Duration::from_millis(500)).await;
    let green = green_share(browser, &browser.screenshot("#head-0").await).await;
    println!("your own head: {:.1} % of the view green", green * 100.0);
    assert!(
        green > 0.05,
        "the avatar's texture is not drawn: {:.2} % green",
        green * 100.0
    );
    producer.close(None).await.unwrap();

    // The same avatar as "glTF Separate" writes it (a .gltf, its .bin and its texture as
    // files of their own): the page packs them into one .glb, and it registers the same.
    let files = common::glb::write_separate(&std::fs::read(&avatar).unwrap(), dir.path(), "avatar separate");
    let paths: Vec<String> = files.iter().map(|p| p.display().to_string()).collect();
    // One file input, several files: the paths newline-separated.
    let gltf = std::path::PathBuf::from(paths.join("\n"));
    let said = register_picked(&gltf, "avatar-separate").await;
    println!("your own head, separate files: {said}");
    assert!(said.as_str().unwrap().contains("image/png"), "{said}");
    let info: Value = reqwest::get(format!("{url}v1/heads/avatar-separate"))
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    let first: Value = reqwest::get(format!("{url}v1/heads/my-avatar"))
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(
        (
            &info["vertices"],
            &info["triangles"],
            info["parts"].as_array().map(Vec::len)
        ),
        (
            &first["vertices"],
            &first["triangles"],
            first["parts"].as_array().map(Vec::len)
        ),
        "packed from separate files, the avatar is the same head"
    );
}

/// A stream of the test's own: it appears in the stream picker without a reload, shows
/// "Stalled" when its producer stops sending, and "Live" again with the next frame.
async fn check_a_stalled_stream(browser: &Browser, url: &str, long: Duration) {
    browser.open(&format!("{url}?head=scan&stream=quiet")).await;
    browser
        .wait_for(
            "waiting for the new stream",
            &state_is("status-0", "waiting"),
            long,
        )
        .await;
    let mut producer = connect_producer(url, "scan", "quiet").await;
    for seq in 0..3 {
        produce(&mut producer, seq).await;
    }
    browser
        .wait_for("the new stream to go live", &state_is("status-0", "live"), long)
        .await;
    browser
        .wait_for(
            "the stream picker to list it",
            "return [...document.getElementById('stream').options].some((o) => o.text === 'quiet')",
            Duration::from_secs(20),
        )
        .await;
    browser
        .wait_for(
            "the stalled state",
            &state_is("status-0", "stalled"),
            Duration::from_secs(10),
        )
        .await;
    let status = browser.js(&text_of("status-0")).await;
    assert!(status.as_str().unwrap().contains("no frame for"), "{status}");
    produce(&mut producer, 3).await;
    browser
        .wait_for("live again", &state_is("status-0", "live"), long)
        .await;

    // The head's own motion: the same jaw drop with the head turned 0.6 rad. The deltas
    // are those of the frame before, so only a page that applies the motion draws it.
    tokio::time::sleep(Duration::from_millis(500)).await;
    let still = browser.screenshot("#head-0").await;
    produce_line(
        &mut producer,
        r#"{"seq":4,"t":0.2,"au":{"jaw_drop":0.3},"head_rotation_rad":[0,0.6,0]}"#.to_string(),
    )
    .await;
    assert!(
        browser
            .picture_changes("#head-0", &still, Duration::from_secs(5))
            .await,
        "the page did not turn the head in 5 s"
    );
    producer.close(None).await.unwrap();
}

/// A head posted over HTTP with neither a fit nor landmarks (ICT identity 2, which the demo
/// does not hold): fitted automatically, it becomes ready, the page shows its fit report,
/// and it talks there.
async fn check_a_head_posted_with_no_fit(browser: &Browser, url: &str, long: Duration) {
    let obj = std::fs::read_to_string(common::data("heads/ict_identity_2.obj")).unwrap();
    let http = reqwest::Client::new();
    let posted = http
        .post(format!("{url}v1/heads"))
        .json(&json!({"id": "found", "obj": obj}))
        .send()
        .await
        .unwrap();
    assert!(posted.status().is_success(), "{:?}", posted.text().await);
    let started = Instant::now();
    let info = loop {
        let info: Value = http
            .get(format!("{url}v1/heads/found"))
            .send()
            .await
            .unwrap()
            .json()
            .await
            .unwrap();
        if info["status"] != "registering" || started.elapsed() > long {
            break info;
        }
        tokio::time::sleep(Duration::from_millis(200)).await;
    };
    assert_eq!(info["status"], "ready", "{info}");

    browser.open(&format!("{url}?head=found&stream=talk")).await;
    let mut producer = connect_producer(url, "found", "talk").await;
    produce_line(&mut producer, moving_jaw_line(0)).await;
    browser
        .wait_for("the posted head live", &state_is("status-0", "live"), long)
        .await;
    browser
        .wait_for(
            "its fit report shown",
            "return document.getElementById('fit-regions')?.rows.length === 6",
            long,
        )
        .await;
    tokio::time::sleep(Duration::from_millis(500)).await;
    let still = browser.screenshot("#head-0").await;
    for seq in 1..10 {
        produce_line(&mut producer, moving_jaw_line(seq)).await;
    }
    assert!(
        browser
            .picture_changes("#head-0", &still, Duration::from_secs(5))
            .await,
        "the posted head did not move in 5 s"
    );
    producer.close(None).await.unwrap();
}

/// The page on a phone: 390 x 844 CSS pixels with touch (Chromium's mobile emulation).
/// Nothing scrolls sideways; every control shown lies on the screen, has a name a screen
/// reader reads, is at least 24 px a side (WCAG 2.2's minimum target size) and is reached
/// by Tab; one finger orbits the head and two pinch to zoom it. `FACEWIRE_SCREENSHOTS=DIR`
/// keeps the page (`DIR/phone.png.base64`; docs/img/phone.png is it).
async fn check_the_page_on_a_phone(browser: &Browser, url: &str, long: Duration) {
    let (width, height) = (390, 844);
    browser
        .cdp(
            "Emulation.setDeviceMetricsOverride",
            json!({ "width": width, "height": height, "deviceScaleFactor": 2, "mobile": true }),
        )
        .await;
    browser
        .cdp(
            "Emulation.setTouchEmulationEnabled",
            json!({ "enabled": true, "maxTouchPoints": 5 }),
        )
        .await;
    browser.open(url).await;
    browser
        .wait_for(
            "view 1 to go live on a phone",
            &state_is("status-0", "live"),
            long,
        )
        .await;
    let layout = browser.js(PHONE_CONTROLS_JS).await;
    println!("on a phone: {layout}");
    assert_eq!(
        layout["innerWidth"], width,
        "the page is wider than the phone: {}",
        layout["wider"]
    );
    assert!(
        layout["scrollWidth"].as_i64().unwrap() <= width,
        "the page scrolls sideways on a phone: {layout}"
    );
    let controls = layout["controls"].as_array().unwrap();
    assert!(controls.len() >= 10, "the page's controls: {layout}");
    for control in controls {
        assert!(
            control["name"].as_str().is_some_and(|n| !n.is_empty()),
            "a control without a name: {control}"
        );
        assert!(
            control["onScreen"].as_bool().unwrap(),
            "a control off the screen: {control}"
        );
        assert!(
            control["width"].as_f64().unwrap() >= 24.0 && control["height"].as_f64().unwrap() >= 24.0,
            "a control smaller than 24 px: {control}"
        );
    }
    // Tab from the top of the page reaches every control shown.
    browser
        .js("document.activeElement?.blur(); window.scrollTo(0, 0); return true")
        .await;
    let mut reached = std::collections::BTreeSet::new();
    for _ in 0..controls.len() * 2 + 10 {
        let tab = json!([{ "type": "key", "id": "keyboard", "actions": [
            { "type": "keyDown", "value": "\u{E004}" }, { "type": "keyUp", "value": "\u{E004}" }
        ]}]);
        browser.act(tab).await;
        let at = browser
            .js("let at = document.activeElement; \
                 while (at?.shadowRoot?.activeElement) at = at.shadowRoot.activeElement; \
                 return at?.dataset.phoneKey ?? null")
            .await;
        if let Some(key) = at.as_str() {
            reached.insert(key.to_string());
        }
    }
    let missed: Vec<&Value> = controls
        .iter()
        .filter(|c| !reached.contains(c["key"].as_str().unwrap()))
        .collect();
    assert!(missed.is_empty(), "Tab never reaches {missed:?}");
    browser
        .js("document.activeElement?.blur(); window.scrollTo(0, 0); return true")
        .await;
    if let Some(dir) = std::env::var_os("FACEWIRE_SCREENSHOTS") {
        let page = browser.command("/screenshot", None).await;
        std::fs::write(
            std::path::Path::new(&dir).join("phone.png.base64"),
            page.as_str().unwrap(),
        )
        .unwrap();
    }
    // One finger across the head orbits it; two moving apart zoom in.
    let camera = "const c = window.facewireCamera; return { yaw: c.yaw, zoom: c.zoom };";
    let before = browser.js(camera).await;
    // The canvas's centre, in viewport pixels.
    let centre = browser
        .js(
            "const r = document.getElementById('head-0').getBoundingClientRect(); \
             r.top < 0 || r.bottom > innerHeight ? document.getElementById('head-0').scrollIntoView() : 0; \
             const s = document.getElementById('head-0').getBoundingClientRect(); \
             return [Math.round(s.left + s.width / 2), Math.round(s.top + s.height / 2)]",
        )
        .await;
    let (cx, cy) = (centre[0].as_i64().unwrap(), centre[1].as_i64().unwrap());
    let finger = |id: &str, from: (i64, i64), to: (i64, i64)| {
        json!({ "type": "pointer", "id": id, "parameters": { "pointerType": "touch" }, "actions": [
            { "type": "pointerMove", "duration": 0, "origin": "viewport", "x": cx + from.0, "y": cy + from.1 },
            { "type": "pointerDown", "button": 0 },
            { "type": "pointerMove", "duration": 300, "origin": "viewport", "x": cx + to.0, "y": cy + to.1 },
            { "type": "pointerUp", "button": 0 }
        ]})
    };
    browser.act(json!([finger("one", (-60, 0), (60, 0))])).await;
    let orbited = browser.js(camera).await;
    assert!(
        (orbited["yaw"].as_f64().unwrap() - before["yaw"].as_f64().unwrap()).abs() > 0.3,
        "one finger did not orbit: {before} -> {orbited}"
    );
    browser
        .act(json!([
            finger("one", (-20, 0), (-90, 0)),
            finger("two", (20, 0), (90, 0))
        ]))
        .await;
    let pinched = browser.js(camera).await;
    assert!(
        pinched["zoom"].as_f64().unwrap() > orbited["zoom"].as_f64().unwrap() * 1.5,
        "two fingers apart did not zoom in: {orbited} -> {pinched}"
    );
    browser
        .cdp("Emulation.setTouchEmulationEnabled", json!({ "enabled": false }))
        .await;
    browser
        .cdp("Emulation.clearDeviceMetricsOverride", json!({}))
        .await;
}

/// Every control the page shows (buttons, fields, links, anything given a tab stop), each
/// marked with a `data-phone-key` to recognise it when focused, with its name as a screen
/// reader reads it (ARIA label, labelling element, `<label>`, text, title), its size and
/// whether it lies within the screen's width; the page's widths, and the elements that
/// reach past the screen's.
const PHONE_CONTROLS_JS: &str = r#"
const selector = 'button, input, select, textarea, a[href], [role=button], [tabindex]:not([tabindex="-1"])';
const shown = (el) => el.getClientRects().length > 0 && getComputedStyle(el).visibility !== 'hidden'
  && !el.disabled && !el.closest('[hidden], [inert]');
const text = (el) => (el?.textContent ?? '').replace(/\s+/g, ' ').trim();
const nameOf = (el) => {
  if (el.getAttribute('aria-label')) return el.getAttribute('aria-label').trim();
  const by = el.getAttribute('aria-labelledby');
  if (by) return by.split(/\s+/).map((id) => text(document.getElementById(id))).join(' ').trim();
  if (el.labels && el.labels.length) return text(el.labels[0]);
  if (el.tagName !== 'INPUT' && text(el)) return text(el);
  return (el.getAttribute('title') ?? el.getAttribute('placeholder') ?? '').trim();
};
// The controls inside the page's <facewire-head> elements (their canvas) count too.
const all = [...document.querySelectorAll(selector),
  ...[...document.querySelectorAll('facewire-head')].flatMap((h) => [...h.shadowRoot.querySelectorAll(selector)])];
const controls = all.filter(shown).map((el, i) => {
  el.dataset.phoneKey = String(i);
  const r = el.getBoundingClientRect();
  return {
    key: String(i), tag: el.tagName.toLowerCase(), id: el.id, name: nameOf(el),
    width: r.width, height: r.height,
    onScreen: r.left >= -0.5 && r.right <= window.innerWidth + 0.5,
  };
});
const wider = [...document.querySelectorAll('body *')]
  .filter((el) => el.getClientRects().length && el.getBoundingClientRect().right > screen.width + 0.5)
  .map((el) => `${el.tagName.toLowerCase()}#${el.id}.${el.className} ${Math.round(el.getBoundingClientRect().right)}`);
return {
  innerWidth: window.innerWidth,
  scrollWidth: document.documentElement.scrollWidth,
  wider: wider.slice(0, 12),
  controls,
};
"#;

/// The ICT head's teeth, gums and tongue, in the mouth close-up that the URL asks for;
/// the head keeps talking. `FACEWIRE_SCREENSHOTS=DIR` keeps twelve pictures 200 ms apart
/// (`DIR/mouth-N.png.base64`, `base64 -d` decodes them; docs/img/mouth.png is one).
async fn check_the_inner_mouth_close_up(browser: &Browser, url: &str, long: Duration) {
    browser.open(&format!("{url}?head=ict&stream=main&mouth=1")).await;
    browser
        .wait_for("the ict head live", &state_is("status-0", "live"), long)
        .await;
    browser
        .wait_for(
            "the four parts drawn",
            "return document.getElementById('inner-0')?.dataset.loaded === '4'",
            long,
        )
        .await;
    let inner = browser.js(&text_of("inner-0")).await;
    assert!(
        inner.as_str().unwrap().contains("teeth_lower (jaw)"),
        "the view names the parts and their roles: {inner}"
    );
    // The chosen head's fit report: its regions, and pictures that loaded.
    browser
        .wait_for(
            "the fit report shown",
            "return document.getElementById('fit-regions')?.rows.length === 6",
            long,
        )
        .await;
    let overall = browser.js(&text_of("fit-overall")).await;
    assert!(overall.as_str().unwrap().contains("mm"), "{overall}");
    browser
        .wait_for(
            "the fit pictures loaded",
            "return [...document.querySelectorAll('#fit img')].filter(i => i.complete && i.naturalWidth === 800).length === 2",
            long,
        )
        .await;
    let pressed = browser
        .js("return document.getElementById('mouth-view').getAttribute('aria-pressed')")
        .await;
    assert_eq!(pressed, "true", "the close-up button shows the URL's choice");
    let first = browser.screenshot("#head-0").await;
    assert!(
        browser
            .picture_changes("#head-0", &first, Duration::from_secs(3))
            .await,
        "the mouth did not move in 3 s"
    );
    if let Some(dir) = std::env::var_os("FACEWIRE_SCREENSHOTS") {
        for i in 0..12 {
            let shot = browser.screenshot("#head-0").await;
            std::fs::write(
                std::path::Path::new(&dir).join(format!("mouth-{i}.png.base64")),
                shot,
            )
            .unwrap();
            tokio::time::sleep(Duration::from_millis(200)).await;
        }
    }
    check_the_tongue(browser, url, long).await;
    check_the_cut_away(browser, url, long).await;
    check_the_eyes(browser, url, long).await;
    check_the_microphone_talks(browser, url, long).await;
}

/// The Talk button: the microphone (Chromium's fake one, playing the syllable voice) is
/// the producer of the head's `talk` stream, the server derives the face from the voice,
/// and the view shows its visemes, closures and open vowels among them; pressed again, the
/// stream ends.
async fn check_the_microphone_talks(browser: &Browser, url: &str, long: Duration) {
    browser.open(&format!("{url}?head=ict&stream=main")).await;
    browser
        .wait_for("the main stream live", &state_is("status-0", "live"), long)
        .await;
    browser.click("#talk").await;
    browser
        .wait_for(
            "the microphone talking",
            "return window.facewireTalk.state === 'talking'",
            Duration::from_secs(20),
        )
        .await;
    browser
        .js("const shown = document.getElementById('syllable-0');
             window.seenVisemes = new Set();
             new MutationObserver(() => window.seenVisemes.add(shown.textContent))
               .observe(shown, { childList: true, characterData: true, subtree: true });")
        .await;
    assert!(browser
        .js("return location.search")
        .await
        .as_str()
        .unwrap()
        .contains("stream=talk"));
    browser
        .wait_for(
            "closed lips and an open vowel from the microphone",
            "return window.seenVisemes.has('PP') && window.seenVisemes.has('aa')",
            Duration::from_secs(40),
        )
        .await;
    let message = browser
        .js("return document.getElementById('page-message').hidden")
        .await;
    assert_eq!(message, true, "the page complains");
    browser.click("#talk").await;
    browser
        .wait_for(
            "the talk stream to end",
            &state_is("status-0", "ended"),
            Duration::from_secs(20),
        )
        .await;
    assert_eq!(browser.js(&text_of("talk")).await, "Talk");
}

/// The ICT head's eyeballs, listed and drawn; a frame that turns them changes the picture
/// and the page takes it without complaint.
async fn check_the_eyes(browser: &Browser, url: &str, long: Duration) {
    browser.open(&format!("{url}?head=ict&stream=eyes")).await;
    let mut producer = connect_producer(url, "ict", "eyes").await;
    produce_line(&mut producer, r#"{"seq":0,"t":0,"au":{}}"#.to_string()).await;
    browser
        .wait_for("the eyes stream live", &state_is("status-0", "live"), long)
        .await;
    browser
        .wait_for(
            "the two eyes drawn",
            "return document.getElementById('eyes-0')?.dataset.loaded === '2'",
            long,
        )
        .await;
    let eyes = browser.js(&text_of("eyes-0")).await;
    assert_eq!(eyes, "eyes_left (left), eyes_right (right)", "{eyes}");
    tokio::time::sleep(Duration::from_millis(500)).await;
    let ahead = browser.screenshot("#head-0").await;
    produce_line(
        &mut producer,
        r#"{"seq":1,"t":0.1,"fap":{"yaw_l_eyeball":50000,"yaw_r_eyeball":50000,"pitch_l_eyeball":-20000,"pitch_r_eyeball":-20000}}"#
            .to_string(),
    )
    .await;
    assert!(
        browser
            .picture_changes("#head-0", &ahead, Duration::from_secs(5))
            .await,
        "the page did not draw the turned eyes in 5 s"
    );
    let message = browser.js(&text_of("message-0")).await;
    assert_eq!(message, "", "the page complains: {message}");
    producer.close(None).await.unwrap();
}

/// The ICT head's mouth close-up (`?head=ict&stream=STREAM&mouth=1` and `more`) on a
/// stream the test produces, its `first` frame sent, once the view is live and the four
/// parts are drawn; the producer's socket.
async fn watch_the_ict_mouth(
    browser: &Browser,
    url: &str,
    stream: &str,
    more: &str,
    first: &str,
    long: Duration,
) -> Producer {
    browser
        .open(&format!("{url}?head=ict&stream={stream}&mouth=1{more}"))
        .await;
    let mut producer = connect_producer(url, "ict", stream).await;
    produce_line(&mut producer, first.to_string()).await;
    browser
        .wait_for(
            &format!("the {stream} stream live"),
            &state_is("status-0", "live"),
            long,
        )
        .await;
    browser
        .wait_for(
            "the parts drawn",
            "return document.getElementById('inner-0')?.dataset.loaded === '4'",
            long,
        )
        .await;
    producer
}

/// The tongue on a stream of the test's own: the same open jaw with the tongue tip raised
/// changes the close-up's picture (only the tongue's deltas differ), and the page takes
/// them without complaint. The close-up button then turns the close-up off.
async fn check_the_tongue(browser: &Browser, url: &str, long: Duration) {
    let first = r#"{"seq":0,"t":0,"au":{"jaw_drop":0.5}}"#;
    let mut producer = watch_the_ict_mouth(browser, url, "tongue", "", first, long).await;
    tokio::time::sleep(Duration::from_millis(500)).await;
    let open = browser.screenshot("#head-0").await;
    produce_line(
        &mut producer,
        r#"{"seq":1,"t":0.1,"au":{"jaw_drop":0.5},"fap":{"raise_tongue_tip":900,"thrust_tongue_tip":200}}"#
            .to_string(),
    )
    .await;
    assert!(
        browser
            .picture_changes("#head-0", &open, Duration::from_secs(5))
            .await,
        "the page did not draw the raised tongue in 5 s"
    );
    let message = browser.js(&text_of("message-0")).await;
    assert_eq!(message, "", "the page complains: {message}");
    producer.close(None).await.unwrap();

    // The button turns the close-up off, and the URL follows.
    browser.js("document.getElementById('mouth-view').click()").await;
    let address = browser.js("return location.search").await;
    assert!(
        !address.as_str().unwrap().contains("mouth=1"),
        "the URL drops the close-up: {address}"
    );
}

/// Pixels of a screenshot (base64 PNG) within 3 of each of the flat section colours the
/// cut-away draws (web/render.js: skin, tongue, teeth and gums, sRGB), with the topmost y
/// (0 at the top) of the tongue's and the mean x of its pixels in that row and the next
/// two (where the tongue is highest), decoded by the page.
async fn section_pixels(browser: &Browser, shot: &str) -> Value {
    browser
        .js(&format!(
            "window.sectionCount = null; const img = new Image(); img.onload = () => {{ \
             const c = document.createElement('canvas'); c.width = img.width; c.height = img.height; \
             const g = c.getContext('2d'); g.drawImage(img, 0, 0); \
             const d = g.getImageData(0, 0, c.width, c.height).data; \
             const want = {{ skin: [0.72, 0.36, 0.34], tongue: [0.592, 0.264, 0.288], \
               teeth: [0.744, 0.72, 0.656], gums: [0.624, 0.32, 0.336] }}; \
             const out = {{ total: c.width * c.height, topX: 0, tongueTop: null }}; let top = 0; \
             for (const k in want) out[k] = 0; \
             for (let i = 0; i < d.length; i += 4) {{ for (const k in want) {{ \
               if (want[k].every((v, j) => Math.abs(d[i + j] - Math.round(v * 255)) <= 3)) {{ \
                 out[k]++; if (k === 'tongue') {{ const p = i / 4, y = Math.floor(p / c.width); \
                 out.tongueTop ??= y; if (y <= out.tongueTop + 2) {{ out.topX += p % c.width; top++; }} }} }} }} }} \
             out.topX = top ? out.topX / top : null; window.sectionCount = out; }}; \
             img.src = 'data:image/png;base64,{shot}';"
        ))
        .await;
    browser
        .wait_for(
            "the screenshot decoded",
            "return window.sectionCount",
            Duration::from_secs(10),
        )
        .await
}

/// The cut-away (`view=cutaway`): the mouth close-up seen from the side with the half of
/// the head nearest the camera cut away at the midsagittal plane, the skin and the tongue
/// in section, on a stream of the test's own holding "d" (DD) and then "k" (kk): the
/// tongue's section moves back for k. The front look shows no section. The see-through
/// skin and a turned cut draw without complaint, and the URL keeps the look.
async fn check_the_cut_away(browser: &Browser, url: &str, long: Duration) {
    let first = r#"{"seq":0,"t":0,"viseme":{"oculus":"DD"}}"#;
    let mut producer = watch_the_ict_mouth(browser, url, "cut", "&view=cutaway", first, long).await;
    tokio::time::sleep(Duration::from_millis(800)).await;
    let dd = browser.screenshot("#head-0").await;
    let dd_pixels = section_pixels(browser, &dd).await;
    produce_line(
        &mut producer,
        r#"{"seq":1,"t":0.1,"viseme":{"oculus":"kk"}}"#.to_string(),
    )
    .await;
    assert!(
        browser
            .picture_changes("#head-0", &dd, Duration::from_secs(5))
            .await,
        "the cut-away did not draw k in 5 s"
    );
    tokio::time::sleep(Duration::from_millis(800)).await;
    let kk = browser.screenshot("#head-0").await;
    let kk_pixels = section_pixels(browser, &kk).await;
    println!("cut-away section pixels: d {dd_pixels}, k {kk_pixels}");
    for pixels in [&dd_pixels, &kk_pixels] {
        let share = |k: &str| pixels[k].as_f64().unwrap() / pixels["total"].as_f64().unwrap();
        assert!(share("skin") > 0.02, "the skin's section is shown: {pixels}");
        assert!(share("tongue") > 0.002, "the tongue's section is shown: {pixels}");
    }
    // The side view looks from the head's left: its front is on the left of the picture.
    // The tongue is highest at its tip for d, at its back for k.
    let (dd_x, kk_x) = (
        dd_pixels["topX"].as_f64().unwrap(),
        kk_pixels["topX"].as_f64().unwrap(),
    );
    assert!(
        kk_x > dd_x,
        "the tongue is highest further back for k: x {kk_x:.1} against {dd_x:.1} for d"
    );
    let message = browser.js(&text_of("message-0")).await;
    assert_eq!(message, "", "the page complains: {message}");
    let address = browser.js("return location.search").await;
    assert!(address.as_str().unwrap().contains("view=cutaway"), "{address}");

    // A turned cut, the see-through skin, then the front look: no section there.
    for (look, cut) in [("cutaway", "30"), ("see-through", "30"), ("front", "0")] {
        browser
            .js(&format!(
                "const l = document.getElementById('look-0'); l.value = '{look}'; \
                 l.dispatchEvent(new Event('change')); \
                 const c = document.getElementById('cut-0'); c.value = '{cut}'; \
                 c.dispatchEvent(new Event('input'));"
            ))
            .await;
        tokio::time::sleep(Duration::from_millis(500)).await;
        let address = browser.js("return location.search").await;
        let address = address.as_str().unwrap();
        assert_eq!(
            address.contains(&format!("view={look}")),
            look != "front",
            "{address}"
        );
        assert_eq!(address.contains(&format!("cut={cut}")), cut != "0", "{address}");
        let message = browser.js(&text_of("message-0")).await;
        assert_eq!(message, "", "the page complains in {look}: {message}");
    }
    let front = browser.screenshot("#head-0").await;
    let front_pixels = section_pixels(browser, &front).await;
    assert_eq!(
        front_pixels["skin"], 0,
        "no section in the front look: {front_pixels}"
    );
    producer.close(None).await.unwrap();
}

/// The frames of the syllable stream that hold a t or d: its label starts with t or d and
/// the tongue tip is raised to at least 90 % of the alveolar stop's 900 counts (the
/// consonant's closure, not the approach to it or the release into the vowel).
fn alveolar_stop_frames() -> Vec<u64> {
    let text = std::fs::read_to_string(common::data("streams/syllables.jsonl")).unwrap();
    text.lines()
        .map(|line| serde_json::from_str::<Value>(line).unwrap())
        .filter(|f| {
            let label = f["label"].as_str().unwrap_or("");
            let tip = f["fap"]["raise_tongue_tip"].as_f64().unwrap_or(0.0);
            (label.starts_with('t') || label.starts_with('d')) && tip >= 810.0
        })
        .map(|f| f["seq"].as_u64().unwrap())
        .collect()
}

/// Measures the cut-away view 1 shows now, as drawn: draws it, reads its pixels back
/// (`gl.readPixels`, the picture as the screen gets it) and finds the tongue's and the
/// gums' flat section colours (web/render.js; the ICT head's lower gums are in its tongue
/// part, drawn as gums where the server's `tongue.bin` says a vertex is not the tongue).
/// Returns the tongue's tip (its front-most pixel: the side view looks from the head's
/// left, so the front is on the left; x, y from the bottom), the shortest distance in the
/// picture from it to a gums pixel, in pixels, the pixels per mm at the cut, the scale
/// bar's length in pixels and in mm, and both colours' pixel counts.
const TONGUE_TO_GUMS_JS: &str = "const v = window.facewireViews()[0]; v.draw(window.facewireCamera, true); \
     const r = v.renderer; const gl = r.gl; const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight; \
     const d = new Uint8Array(w * h * 4); gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, d); \
     const is = (p, c) => c.every((x, j) => Math.abs(d[p * 4 + j] - Math.round(x * 255)) <= 3); \
     const TONGUE = [0.592, 0.264, 0.288], GUMS = [0.624, 0.32, 0.336]; \
     let tongue = 0, gums = []; let tip = null; \
     for (let y = 0; y < h; y++) for (let x = 0; x < w; x++) { const p = y * w + x; \
       if (is(p, TONGUE)) { tongue++; if (!tip || x < tip[0]) tip = [x, y]; } else if (is(p, GUMS)) gums.push([x, y]); } \
     let best = Infinity; \
     if (tip) for (const [gx, gy] of gums) best = Math.min(best, (tip[0] - gx) ** 2 + (tip[1] - gy) ** 2); \
     return { px: Math.sqrt(best), tip, pxPerMm: r.cssPixelsPerMm * (window.devicePixelRatio || 1), tongue, gums: gums.length, \
       bar: document.getElementById('head-0').shadowRoot.querySelector('.scale .bar').getBoundingClientRect().width, \
       barMm: Number(document.getElementById('head-0').shadowRoot.querySelector('.scale .bar').dataset.mm) };";

/// The cut-away read back: the demo's recording of the syllables replayed in the mouth's
/// cut-away, paused on every frame that holds a t or d, each picture read back: the
/// tongue's tip within 2 mm of the gums behind the upper incisors (the alveolar ridge) in
/// the picture, at the scale bar's scale, and within 1 mm of what the geometry says
/// (`facewire compare`'s `tongue_tip_to_gums_mm` on the same head, stream and default
/// algorithm, under 1 mm on each); on the open "a" after t and after d, the tip seen at
/// least 10 mm lower than on any t or d frame, where the geometry has it over 10 mm from
/// the gums.
/// `FACEWIRE_SCREENSHOTS=DIR` keeps "ta" and "ka" (`DIR/cutaway-{ta,ka}.png.base64`;
/// docs/img/cutaway.png is them side by side).
async fn check_the_cut_away_reads_back(browser: &Browser, url: &str, long: Duration) {
    let stops = alveolar_stop_frames();
    assert_eq!(
        stops.len(),
        12,
        "two frames for each of ta ti tu da di du: {stops:?}"
    );
    // The open a of "ta" and "da", four frames after each's last closure frame.
    let open: Vec<u64> = [stops[1] + 4, stops[7] + 4].to_vec();
    let frames: Vec<u64> = stops.iter().chain(&open).copied().collect();
    // The geometry of those frames alone (each frame deforms on its own), as `facewire
    // compare` measures it: by seq.
    let mut measured = frames.clone();
    measured.sort_unstable();
    let geometry = tokio::task::spawn_blocking(move || {
        let text = std::fs::read_to_string(common::data("streams/syllables.jsonl")).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let dir = tempfile::tempdir().unwrap();
        let stream = dir.path().join("stops.jsonl");
        let picked: Vec<&str> = measured.iter().map(|&seq| lines[seq as usize]).collect();
        std::fs::write(&stream, picked.join("\n") + "\n").unwrap();
        let head = std::sync::Arc::new(common::ict_head());
        let basis = facewire::stream::ArkitBasis::shipped();
        let algorithms = facewire::report::parse_algorithms("V").unwrap();
        let input = facewire::report::CompareInput {
            head: &head,
            stream: &stream,
            basis: &basis,
            algorithms: &algorithms,
            targets: &[],
        };
        let comparison = facewire::report::compare(&input, &mut |_| {}).unwrap();
        let rows = &comparison.algorithms[0].contact;
        assert_eq!(rows.len(), measured.len());
        measured
            .iter()
            .zip(rows)
            .map(|(&seq, row)| (seq, row.contact.tongue_tip_to_gums_mm))
            .collect::<std::collections::HashMap<u64, f32>>()
    });
    open_the_paused_replay(browser, url, "&view=cutaway", long).await;
    let geometry = geometry.await.unwrap();
    let mut lowest_stop_tip = f64::INFINITY;
    for &frame in &frames {
        seek_the_replay(browser, frame, long).await;
        let seen = browser.js(TONGUE_TO_GUMS_JS).await;
        let pixels_per_mm = seen["pxPerMm"].as_f64().unwrap();
        let picture_mm = seen["px"].as_f64().unwrap() / pixels_per_mm;
        let geometry_mm = f64::from(geometry[&frame]);
        println!(
            "cut-away frame {frame}: tongue to ridge {picture_mm:.2} mm in the picture, {geometry_mm:.2} mm in the geometry ({seen})"
        );
        assert!(
            seen["tongue"].as_u64().unwrap() > 100 && seen["gums"].as_u64().unwrap() > 100,
            "frame {frame}: the sections are not in the picture: {seen}"
        );
        // The scale bar says what the picture's scale is.
        let bar_mm = seen["bar"].as_f64().unwrap() / pixels_per_mm;
        assert!(
            (bar_mm - seen["barMm"].as_f64().unwrap()).abs() < 0.1,
            "the scale bar is {bar_mm:.2} mm long, labelled {}",
            seen["barMm"]
        );
        let tip_y = seen["tip"][1].as_f64().unwrap();
        if open.contains(&frame) {
            assert!(geometry_mm > 10.0, "frame {frame}: {geometry_mm} mm");
            let drop_mm = (lowest_stop_tip - tip_y) / pixels_per_mm;
            assert!(
                drop_mm >= 10.0,
                "frame {frame}: an open a, the tip only {drop_mm:.1} mm lower than for t, d"
            );
        } else {
            lowest_stop_tip = lowest_stop_tip.min(tip_y);
            assert!(geometry_mm < 1.0, "frame {frame}: {geometry_mm} mm");
            assert!(
                picture_mm <= 2.0 && (picture_mm - geometry_mm).abs() <= 1.0,
                "frame {frame}: the tongue tip {picture_mm:.2} mm from the ridge in the cut-away, {geometry_mm:.2} in the geometry"
            );
        }
    }
    // docs/img/cutaway.png: "ta" on its first closure frame and "ka" with the tongue's back
    // raised (frame 111, FAP 46 at its 500).
    if let Some(dir) = std::env::var_os("FACEWIRE_SCREENSHOTS") {
        for (name, frame) in [("ta", stops[0]), ("ka", 111)] {
            seek_the_replay(browser, frame, long).await;
            tokio::time::sleep(Duration::from_millis(500)).await;
            let shot = browser.screenshot("#head-0").await;
            let path = std::path::Path::new(&dir).join(format!("cutaway-{name}.png.base64"));
            std::fs::write(path, shot).unwrap();
        }
    }
}

/// The heat-map's scale: hidden until the heat-map is on, then picked, shown in the
/// legend and kept in the URL.
async fn check_the_heat_map_scale(browser: &Browser, url: &str, long: Duration) {
    browser.open(&format!("{url}?head=scan&stream=main")).await;
    browser
        .wait_for("the demo stream live", &state_is("status-0", "live"), long)
        .await;
    let hidden = browser
        .js("return document.getElementById('heatfield-0').hidden")
        .await;
    assert_eq!(hidden, true, "the scale picker waits for the heat-map");
    browser.js("document.getElementById('heat-0').click()").await;
    browser
        .wait_for("the heat-map view live", &state_is("status-0", "live"), long)
        .await;
    browser
        .js(
            "const s = document.getElementById('heatmax-0'); s.value = '0.05'; \
             s.dispatchEvent(new Event('change')); return s.value",
        )
        .await;
    let legend = browser.js(&text_of("legendmax-0")).await;
    assert_eq!(legend, "0.05 or more");
    let address = browser.js("return location.search").await;
    let address = address.as_str().unwrap();
    assert!(
        address.contains("heat=1") && address.contains("heatmax=0.05"),
        "the URL keeps the heat-map and its scale: {address}"
    );

    // Coloured by folds: the view reconnects asking for them, the legend reads degrees,
    // the roughness scale hides, the URL follows; the picture changes as the head talks.
    browser
        .js(
            "const s = document.getElementById('heatkind-0'); s.value = 'folds'; \
             s.dispatchEvent(new Event('change')); return s.value",
        )
        .await;
    browser
        .wait_for("the folds view live", &state_is("status-0", "live"), long)
        .await;
    let legend = browser.js(&text_of("legendmax-0")).await;
    assert_eq!(legend, "90° turned or more");
    let hidden = browser
        .js("return document.getElementById('heatfield-0').hidden")
        .await;
    assert_eq!(hidden, true, "the roughness scale hides for folds");
    let address = browser.js("return location.search").await;
    assert!(
        address.as_str().unwrap().contains("heat=folds"),
        "the URL keeps the folds: {address}"
    );
    let first = browser.screenshot("#head-0").await;
    assert!(
        browser
            .picture_changes("#head-0", &first, Duration::from_secs(3))
            .await,
        "the folds view does not move"
    );
}

/// Seconds of clicks the A/V sync check measures (`FACEWIRE_SYNC_S`, default 60; the
/// drift goal is over 600), so the ten minutes are measured by `FACEWIRE_SYNC_S=600 cargo
/// test --test browser the_face_is_seen -- --include-ignored --nocapture`.
fn sync_seconds() -> u64 {
    std::env::var("FACEWIRE_SYNC_S")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(60)
}

/// How far the offsets (ms) at times `t` (s) moved over the whole span: the least-squares
/// line's slope times the span, ms. Unlike comparing the first and last clicks' medians it
/// uses every click, so a few clicks' spread does not pass for drift.
fn drift_over_span(t: &[f64], offsets: &[f64]) -> f64 {
    let n = t.len() as f64;
    let (mean_t, mean_o) = (t.iter().sum::<f64>() / n, offsets.iter().sum::<f64>() / n);
    let covariance: f64 = t
        .iter()
        .zip(offsets)
        .map(|(t, o)| (t - mean_t) * (o - mean_o))
        .sum();
    let variance: f64 = t.iter().map(|t| (t - mean_t).powi(2)).sum();
    let span = t.last().unwrap_or(&0.0) - t.first().unwrap_or(&0.0);
    covariance / variance * span
}

/// A/V sync: the test's producer sends a voice of silence with a click at `k + 0.5` s and
/// frames (30 fps) whose jaw opens at the same `t` and stays open 0.3 s. With the sound on,
/// for each click, (when the page drew the first open frame) - (when the click's `t` was
/// heard, by the page's audio clock: `getOutputTimestamp`) must be within +/-15 ms
/// (median), under 30 ms at the 95th percentile, and drift under 5 ms from the first
/// clicks to the last.
async fn check_the_face_is_seen_when_its_voice_is_heard(browser: &Browser, url: &str, long: Duration) {
    use facewire_proto::audio_chunk::{AudioBody, AudioChunk};
    const RATE: u32 = 16_000;
    const FPS: f64 = 30.0;
    const OPEN_S: f64 = 0.3;
    let seconds = sync_seconds();
    // Software WebGL draws a smaller window faster; the page is what is measured, not SwiftShader.
    browser
        .command("/window/rect", Some(json!({ "width": 800, "height": 600 })))
        .await;
    wait_ready(url, "makehuman", long).await;
    let total_s = seconds as f64 + 12.0;
    let frames = (total_s * FPS) as u64;
    let chunk = (RATE / 50) as usize;
    let chunks = (total_s * 50.0) as u64;
    // (t, message) in time order, frames before chunks at the same t.
    let mut messages: Vec<(f64, Message)> = Vec::new();
    let mut clicks = Vec::new();
    for i in 0..frames {
        let t = i as f64 / FPS;
        let into = t - t.floor();
        let (jaw, label) = if (0.5..0.5 + OPEN_S).contains(&into) {
            (
                0.5,
                if (into - 0.5).abs() < 1e-9 {
                    "click"
                } else {
                    "open"
                },
            )
        } else {
            (0.0, "rest")
        };
        if label == "click" {
            clicks.push(t);
        }
        let line = format!(r#"{{"seq":{i},"t":{t},"label":"{label}","au":{{"jaw_drop":{jaw}}}}}"#);
        messages.push((t, Message::Text(line.into())));
    }
    let mut voice = vec![0i16; chunks as usize * chunk];
    for &click in &clicks {
        // A 2 ms click from its first sample on.
        let at = (click * f64::from(RATE)).round() as usize;
        let end = (at + 32).min(voice.len());
        voice[at.min(end)..end].fill(24_000);
    }
    for (c, samples) in voice.chunks(chunk).enumerate() {
        let first = c * chunk;
        let body = AudioBody::Pcm {
            sample_rate: RATE,
            samples: samples.to_vec(),
        };
        let t_s = first as f64 / f64::from(RATE);
        let bytes = AudioChunk {
            t_s,
            server_receive_us: 0,
            body,
            ignored: Vec::new(),
        }
        .encode();
        messages.push((t_s, Message::Binary(bytes.into())));
    }
    messages.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Connected once the messages are made: a producer silent for 30 s is closed as idle.
    let producer = connect_producer(url, "makehuman", "clicks").await;
    let (mut tx, mut rx) = producer.split();
    let drain = tokio::spawn(async move {
        let mut refusals = Vec::new();
        while let Some(Ok(message)) = rx.next().await {
            if let Ok(text) = message.to_text() {
                if text.contains("\"error\"") {
                    refusals.push(text.to_string());
                }
            }
        }
        refusals
    });
    let send = tokio::spawn(async move {
        let start = tokio::time::Instant::now();
        for (t, message) in messages {
            tokio::time::sleep_until(start + Duration::from_secs_f64(t)).await;
            if tx.send(message).await.is_err() {
                break;
            }
        }
        let _ = tx.send(Message::Text(r#"{"type":"end"}"#.into())).await;
        tokio::time::sleep(Duration::from_millis(200)).await;
        let _ = tx.close().await;
    });
    browser.open(&format!("{url}?head=makehuman&stream=clicks")).await;
    browser
        .wait_for("the clicks view live", &state_is("status-0", "live"), long)
        .await;
    browser.click("#sound").await;
    let started = browser
        .wait_for(
            "the voice to be heard",
            "return window.facewireSound.heardTime(performance.now())",
            long,
        )
        .await;
    let off_main = browser
        .js("return window.facewireViews().map((v) => v.socket.offMainThread)")
        .await;
    assert_eq!(off_main, json!([true]), "the view's socket runs in a worker");
    // Producer to ear, as the page's panel shows it, every 5 s while the clicks play, less
    // what the voice waited for a page too slow to draw the face in time (the face's extra
    // delay, which the panel shows too): the ear as the default playout delay gives it.
    let mut ears = Vec::new();
    let mut extras = Vec::new();
    // And how far apart the page's chances to draw were (a frame shows up to half of that
    // either side of its sound): SwiftShader's draw rate, which |p95| follows.
    let mut chances = Vec::new();
    // And the pixels a side the face was drawn with (draw-scale.js: fewer while draws are slow).
    let mut scales = Vec::new();
    while !send.is_finished() {
        tokio::time::sleep(Duration::from_secs(5)).await;
        let ear = browser
            .js("const s = window.facewireSound.summary(performance.now()); \
                 const i = [...window.facewireDraw.intervals].sort((a, b) => a - b); \
                 return s && [s.earMs, s.faceMs, i[i.length >> 1], window.facewireDraw.scale.scale]")
            .await;
        if let (Some(ear), Some(extra)) = (ear[0].as_f64(), ear[1].as_f64()) {
            ears.push(ear - extra);
            extras.push(extra);
        }
        chances.extend(ear[2].as_f64());
        scales.extend(ear[3].as_f64());
    }
    send.await.unwrap();
    let refusals = drain.await.unwrap();
    assert!(refusals.is_empty(), "the producer was refused: {refusals:?}");
    let log = browser
        .js("return window.facewireSound.syncLog.filter(e => e.view === 0)")
        .await;
    let log: Vec<(f64, String, f64)> = log
        .as_array()
        .unwrap()
        .iter()
        .map(|e| {
            (
                e["t"].as_f64().unwrap(),
                e["label"].as_str().unwrap_or("").to_string(),
                e["offsetMs"].as_f64().unwrap(),
            )
        })
        .collect();
    // Clicks from 2 s after the sound started (the playout delay settles), to the end.
    let from = started.as_f64().unwrap_or(0.0) + 2.0;
    // (click t, offset ms) for each click seen.
    let seen: Vec<(f64, f64)> = clicks
        .iter()
        .filter(|&&click| click >= from)
        .filter_map(|&click| {
            log.iter()
                .find(|(t, label, _)| *t >= click - 1e-6 && *t < click + OPEN_S && label != "rest")
                .map(|(t, _, offset)| (click, offset + (t - click) * 1e3))
        })
        .collect();
    let (clicked, measured): (Vec<f64>, Vec<f64>) = seen.into_iter().unzip();
    let expected = clicks.iter().filter(|&&c| c >= from).count();
    assert!(
        measured.len() * 10 >= expected * 9 && measured.len() >= seconds as usize * 9 / 10,
        "{} of {expected} clicks were seen",
        measured.len()
    );
    let mut sorted = measured.clone();
    sorted.sort_by(f64::total_cmp);
    let quantile = |p: f64| sorted[((p * sorted.len() as f64) as usize).min(sorted.len() - 1)];
    let mut magnitudes: Vec<f64> = measured.iter().map(|m| m.abs()).collect();
    magnitudes.sort_by(f64::total_cmp);
    let p95_abs = magnitudes[((0.95 * magnitudes.len() as f64) as usize).min(magnitudes.len() - 1)];
    let tenth = (measured.len() / 10).max(1);
    let median_of = |part: &[f64]| {
        let mut part = part.to_vec();
        part.sort_by(f64::total_cmp);
        part[part.len() / 2]
    };
    let drift_tenths = median_of(&measured[measured.len() - tenth..]) - median_of(&measured[..tenth]);
    let drift = drift_over_span(&clicked, &measured);
    let sound = browser.js(&text_of("sound-0")).await;
    ears.sort_by(f64::total_cmp);
    assert!(!ears.is_empty(), "the page never showed its latency to the ear");
    let ear_median = ears[ears.len() / 2];
    extras.sort_by(f64::total_cmp);
    chances.sort_by(f64::total_cmp);
    if let (Some(least), Some(most)) = (chances.first(), chances.last()) {
        println!(
            "Chances to draw while the clicks played: {least:.0} to {most:.0} ms apart (median of the last 31, every 5 s)"
        );
    }
    scales.sort_by(f64::total_cmp);
    if let (Some(least), Some(most)) = (scales.first(), scales.last()) {
        println!(
            "Drawn at {:.0} to {:.0} % of the device's pixels a side (median {:.0} %, every 5 s)",
            least * 100.0,
            most * 100.0,
            scales[scales.len() / 2] * 100.0
        );
    }
    println!(
        "Producer to ear over {} readings, less the face's extra delay: median {ear_median:.0} ms, max {:.0} ms; \
         the face's extra: median {:.0} ms, max {:.0} ms",
        ears.len(),
        ears[ears.len() - 1],
        extras[extras.len() / 2],
        extras[extras.len() - 1]
    );
    println!(
        "A/V sync over {} clicks ({seconds} s): face minus voice median {:+.1} ms, p5 {:+.1}, p95 {:+.1}, \
         |p95| {p95_abs:.1} ms, drift {drift:+.1} ms over the span (the last tenth's median minus the first's \
         {drift_tenths:+.1}); the page: {sound}",
        measured.len(),
        quantile(0.5),
        quantile(0.05),
        quantile(0.95),
    );
    assert!(
        quantile(0.5).abs() <= 15.0,
        "median offset {:+.1} ms",
        quantile(0.5)
    );
    // The median holds the goal. Headless, on two cores shared with the server and the
    // producer, |p95| (goal 30 ms) measured 15.0-17.6 ms over 180-600 s (the page draws
    // fewer pixels while SwiftShader's draws come over 40 ms apart; 23-35 ms before), 24-25
    // ms over 60 s (the first seconds drawn at full resolution, before the scale settles),
    // and the drift over 60 s 1-11 ms (goal 5 ms over 600 s: -1.9 to -4.5 ms measured):
    // these bounds catch a page that loses sync, not the goal.
    assert!(p95_abs < 45.0, "|offset| p95 {p95_abs:.1} ms");
    // The goal: the socket is read in a worker and the voice played on the audio thread, so
    // the page's draws do not lengthen the playout delay (133-144 ms measured since an Opus
    // packet's time is its first decoded sample's, which came with the chunk before;
    // 147-265 ms, counted the old way, when both were on the main thread).
    assert!(ear_median < 150.0, "producer to ear {ear_median:.0} ms");
    assert!(drift.abs() < 30.0, "drift {drift:+.1} ms");
    browser
        .command("/window/rect", Some(json!({ "width": 1280, "height": 1000 })))
        .await;
}

/// The luminance step across the lip border, measured in the page from two screenshots
/// (base64 PNGs of the same frame): `region`, drawn with `lips=region` (lip white, skin
/// black, parts grey, unlit), says where the border is; `shot` is the picture measured.
/// Lip pixels (region weight 0.9 or more) within 12 px of the face outside the lips, and
/// face pixels outside them (weight 0.1 or less, reached from the picture's edge without
/// crossing a lip, so the mouth's opening is left out) within 12 px of a lip: the mean
/// relative luminance (linear sRGB, Rec. 709) of each band in `shot`.
const LIP_STEP_JS: &str = r#"
const [regionB64, shotB64] = arguments;
const load = (b64) => new Promise((done) => {
  const img = new Image();
  img.onload = () => {
    const c = document.createElement('canvas'); c.width = img.width; c.height = img.height;
    const g = c.getContext('2d'); g.drawImage(img, 0, 0);
    done({ w: c.width, h: c.height, d: g.getImageData(0, 0, c.width, c.height).data });
  };
  img.src = 'data:image/png;base64,' + b64;
});
window.lipStep = null;
Promise.all([load(regionB64), load(shotB64)]).then(([region, shot]) => {
  const { w, h } = region; const n = w * h; const BAND = 12;
  // Background: the clear colour (32, 36, 42); parts: grey 128 (within 3).
  const kind = new Uint8Array(n); // 0 background, 1 part, 2 face (weight in lip[])
  const lip = new Float32Array(n);
  for (let p = 0; p < n; p++) {
    const r = region.d[4 * p], g = region.d[4 * p + 1], b = region.d[4 * p + 2];
    if (Math.abs(r - 32) <= 3 && Math.abs(g - 36) <= 3 && Math.abs(b - 42) <= 3) continue;
    if (Math.abs(r - 128) <= 3 && Math.abs(g - 128) <= 3 && Math.abs(b - 128) <= 3) { kind[p] = 1; continue; }
    kind[p] = 2; lip[p] = r / 255;
  }
  // Outside the lips: reached from the edge through pixels that are not lip (< 0.5).
  const outside = new Uint8Array(n); const queue = new Int32Array(n); let head = 0, tail = 0;
  const push = (p) => { if (!outside[p] && !(kind[p] === 2 && lip[p] >= 0.5)) { outside[p] = 1; queue[tail++] = p; } };
  for (let x = 0; x < w; x++) { push(x); push((h - 1) * w + x); }
  for (let y = 0; y < h; y++) { push(y * w); push(y * w + w - 1); }
  while (head < tail) {
    const p = queue[head++]; const x = p % w;
    if (x > 0) push(p - 1); if (x < w - 1) push(p + 1);
    if (p >= w) push(p - w); if (p < n - w) push(p + w);
  }
  // Chessboard distance to the nearest pixel of a set, two passes.
  const distance = (inSet) => {
    const d = new Float32Array(n).fill(1e9);
    for (let p = 0; p < n; p++) if (inSet(p)) d[p] = 0;
    for (let y = 0; y < h; y++) for (let x = 0; x < w; x++) {
      const p = y * w + x; let v = d[p];
      if (x > 0) v = Math.min(v, d[p - 1] + 1);
      if (y > 0) { v = Math.min(v, d[p - w] + 1); if (x > 0) v = Math.min(v, d[p - w - 1] + 1); if (x < w - 1) v = Math.min(v, d[p - w + 1] + 1); }
      d[p] = v;
    }
    for (let y = h - 1; y >= 0; y--) for (let x = w - 1; x >= 0; x--) {
      const p = y * w + x; let v = d[p];
      if (x < w - 1) v = Math.min(v, d[p + 1] + 1);
      if (y < h - 1) { v = Math.min(v, d[p + w] + 1); if (x < w - 1) v = Math.min(v, d[p + w + 1] + 1); if (x > 0) v = Math.min(v, d[p + w - 1] + 1); }
      d[p] = v;
    }
    return d;
  };
  const toLip = distance((p) => kind[p] === 2 && lip[p] >= 0.5);
  const toFace = distance((p) => kind[p] === 2 && outside[p] && lip[p] < 0.5);
  const linear = (c) => { c /= 255; return c <= 0.04045 ? c / 12.92 : Math.pow((c + 0.055) / 1.055, 2.4); };
  const luminance = (p) => 0.2126 * linear(shot.d[4 * p]) + 0.7152 * linear(shot.d[4 * p + 1]) + 0.0722 * linear(shot.d[4 * p + 2]);
  let lipSum = 0, lipCount = 0, skinSum = 0, skinCount = 0;
  for (let p = 0; p < n; p++) {
    if (kind[p] !== 2) continue;
    if (lip[p] >= 0.9 && toFace[p] <= BAND) { lipSum += luminance(p); lipCount++; }
    if (lip[p] <= 0.1 && outside[p] && toLip[p] <= BAND) { skinSum += luminance(p); skinCount++; }
  }
  window.lipStep = { lip: lipSum / lipCount, skin: skinSum / skinCount, lipCount, skinCount };
});
"#;

/// The lips drawn in their own colour: on a still frame of each shipped head in the mouth
/// close-up, the luminance step across the lip border (LIP_STEP_JS) with the lips tinted
/// and in high contrast is at least three times the step with them drawn like the skin
/// (`lips=off`, how the page drew every head before). The lip controls change only the
/// drawing and the URL keeps them.
/// `FACEWIRE_SCREENSHOTS=DIR` keeps the pictures (`DIR/lips-{head}-{mode}.png.base64`).
async fn check_the_lips_read(browser: &Browser, url: &str, long: Duration) {
    for head in ["scan", "makehuman", "ict"] {
        browser
            .open(&format!("{url}?head={head}&stream=still&mouth=1&lips=region"))
            .await;
        wait_ready(url, head, long).await;
        let mut producer = connect_producer(url, head, "still").await;
        produce_line(&mut producer, r#"{"seq":0,"t":0}"#.to_string()).await;
        browser
            .wait_for(
                &format!("{head}'s still stream live"),
                &state_is("status-0", "live"),
                long,
            )
            .await;
        browser
            .wait_for(
                &format!("{head}'s lips loaded"),
                "return document.getElementById('view-0')?.dataset.lips === 'loaded'",
                long,
            )
            .await;
        let mut shots = Vec::new();
        for mode in ["region", "off", "tint", "contrast"] {
            browser
                .js(&format!(
                    "const s = document.getElementById('lips'); s.value = '{mode}'; \
                     s.dispatchEvent(new Event('change'))"
                ))
                .await;
            tokio::time::sleep(Duration::from_millis(600)).await;
            let shot = browser.screenshot("#head-0").await;
            if let Some(dir) = std::env::var_os("FACEWIRE_SCREENSHOTS") {
                let name = format!("lips-{head}-{mode}.png.base64");
                std::fs::write(std::path::Path::new(&dir).join(name), &shot).unwrap();
            }
            shots.push(shot);
        }
        let address = browser.js("return location.search").await;
        assert!(
            address.as_str().unwrap().contains("lips=contrast"),
            "the URL keeps the lips' look: {address}"
        );
        let mut steps = Vec::new();
        for shot in &shots[1..] {
            browser
                .command(
                    "/execute/sync",
                    Some(json!({ "script": LIP_STEP_JS, "args": [shots[0], shot] })),
                )
                .await;
            let step = browser
                .wait_for("the lip step measured", "return window.lipStep", long)
                .await;
            let (lip, skin) = (step["lip"].as_f64().unwrap(), step["skin"].as_f64().unwrap());
            assert!(
                step["lipCount"].as_u64().unwrap() > 1000 && step["skinCount"].as_u64().unwrap() > 1000,
                "{head}: too few pixels either side of the lip border to measure: {step}"
            );
            steps.push((lip - skin).abs());
        }
        let [off, tint, contrast] = steps[..] else {
            unreachable!()
        };
        println!(
            "{head}: luminance step across the lip border: off {off:.4}, tint {tint:.4} ({:.1}x), \
             high contrast {contrast:.4} ({:.1}x)",
            tint / off,
            contrast / off
        );
        assert!(
            tint >= 3.0 * off,
            "{head}: tinted lips step {tint:.4}, off {off:.4}"
        );
        assert!(
            contrast >= 3.0 * off,
            "{head}: high contrast step {contrast:.4}, off {off:.4}"
        );
        drop(producer);
    }
}

/// Waits until the demo's head `head` is registered (a producer is refused before).
async fn wait_ready(url: &str, head: &str, long: Duration) {
    let started = Instant::now();
    loop {
        let info: Value = reqwest::get(format!("{url}v1/heads/{head}"))
            .await
            .unwrap()
            .json()
            .await
            .unwrap();
        if info["status"] == "ready" {
            return;
        }
        assert!(
            started.elapsed() < long,
            "head {head} not ready in {long:?}: {info}"
        );
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
}

/// FNV-1a over the bytes of a view's current positions (a Float32Array), as a page script.
const POSITIONS_DIGEST_JS: &str = "const digest = (a) => { \
     const b = new Uint8Array(a.buffer, a.byteOffset, a.byteLength); let h = 0x811c9dc5; \
     for (const x of b) { h ^= x; h = Math.imul(h, 0x01000193) >>> 0; } return h; };";

/// A page that is not facewire's, on its own origin, embedding the head with two lines.
async fn serve_a_foreign_page(facewire: &str, body: &str) -> (String, tokio::task::JoinHandle<()>) {
    let html = format!(
        "<!doctype html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>A speech therapy app</title></head>\
         <body><h1>Say \"oh\"</h1>\n\
         <script type=\"module\" src=\"{facewire}facewire-head.js\"></script>\n{body}\n</body></html>"
    );
    let app = axum::Router::new().route(
        "/",
        axum::routing::get(move || {
            let html = html.clone();
            async move { axum::response::Html(html) }
        }),
    );
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let address = listener.local_addr().unwrap();
    let task = tokio::spawn(async move {
        axum::serve(listener, app).await.unwrap();
    });
    (format!("http://{address}/"), task)
}

/// The `<facewire-head>` element in a page of another origin: the script and the element
/// are all it takes; it goes live, shows the frames of a stream of the test's own (its
/// `frame` event names each one's sequence number and what is said), its decoded
/// positions are the facewire page's, bit for bit, for the same frame, a stream that ends
/// raises `end` and an unknown head `error` with the close code.
/// `FACEWIRE_SCREENSHOTS=DIR` keeps a picture of it (`DIR/element.png.base64`).
async fn check_the_element_embeds(browser: &Browser, url: &str, long: Duration) {
    let (foreign, _server) = serve_a_foreign_page(
        url,
        "<facewire-head head=\"ict\" stream=\"embed\" mouth style=\"width: 640px\"></facewire-head>",
    )
    .await;
    assert_ne!(
        reqwest::Url::parse(&foreign).unwrap().origin(),
        reqwest::Url::parse(url).unwrap().origin()
    );
    wait_ready(url, "ict", long).await;
    let mut producer = connect_producer(url, "ict", "embed").await;
    produce_line(
        &mut producer,
        r#"{"seq":0,"t":0,"viseme":{"oculus":"aa"}}"#.to_string(),
    )
    .await;
    browser.open(&foreign).await;
    let element = "document.querySelector('facewire-head')";
    browser
        .wait_for(
            "the element live",
            &format!("return {element}.getAttribute('state') === 'live'"),
            long,
        )
        .await;
    browser
        .js(&format!(
            "window.seen = []; window.ended = null; window.failed = null; const e = {element}; \
             e.addEventListener('frame', (ev) => window.seen.push([ev.detail.seq, ev.detail.said])); \
             e.addEventListener('end', (ev) => {{ window.ended = ev.detail.message; }}); \
             e.addEventListener('error', (ev) => {{ window.failed = ev.detail; }});"
        ))
        .await;
    produce_line(
        &mut producer,
        r#"{"seq":1,"t":0.04,"viseme":{"oculus":"oh"}}"#.to_string(),
    )
    .await;
    let seen = browser
        .wait_for(
            "the element's frame event for seq 1",
            "return window.seen.some(([seq]) => seq === 1) && window.seen",
            long,
        )
        .await;
    assert!(
        seen.as_array().unwrap().iter().any(|s| s[0] == 1 && s[1] == "oh"),
        "the frame event names the frame and what it says: {seen}"
    );
    tokio::time::sleep(Duration::from_millis(500)).await;
    let shot = browser.screenshot("facewire-head").await;
    if let Some(dir) = std::env::var_os("FACEWIRE_SCREENSHOTS") {
        std::fs::write(std::path::Path::new(&dir).join("element.png.base64"), &shot).unwrap();
    }
    let embedded = browser
        .js(&format!(
            "{POSITIONS_DIGEST_JS} return digest({element}.headView.positions)"
        ))
        .await;

    // The facewire page on the same stream: the server sends it the newest frame, seq 1.
    browser.open(&format!("{url}?head=ict&stream=embed")).await;
    browser
        .wait_for(
            "the page showing seq 1",
            "return document.getElementById('syllable-0')?.textContent === 'oh'",
            long,
        )
        .await;
    let page = browser
        .js(&format!(
            "{POSITIONS_DIGEST_JS} return digest(window.facewireViews()[0].positions)"
        ))
        .await;
    assert_eq!(
        embedded, page,
        "the element and the page decode the same frame to the same positions"
    );
    let built = browser
        .js(
            "const heads = [...document.querySelectorAll('#views facewire-head')]; \
             return [heads.length, heads[0]?.headView === window.facewireViews()[0]]",
        )
        .await;
    assert_eq!(
        built,
        json!([1, true]),
        "the page's view is a <facewire-head> element"
    );

    // The stream ends: `end`. An unknown head: `error` with close code 4404.
    browser.open(&foreign).await;
    browser
        .wait_for(
            "the element live again",
            &format!("return {element}.getAttribute('state') === 'live'"),
            long,
        )
        .await;
    browser
        .js(&format!(
            "window.ended = null; window.failed = null; const e = {element}; \
             e.addEventListener('end', (ev) => {{ window.ended = ev.detail.message; }}); \
             e.addEventListener('error', (ev) => {{ window.failed = ev.detail; }});"
        ))
        .await;
    drop(producer);
    browser
        .wait_for("the element's end event", "return window.ended", long)
        .await;
    browser
        .js(&format!("{element}.setAttribute('head', 'nosuch')"))
        .await;
    let failed = browser
        .wait_for("the element's error event", "return window.failed", long)
        .await;
    assert_eq!(failed["code"], 4404, "{failed}");
    assert!(failed["message"].as_str().unwrap().contains("nosuch"), "{failed}");

    // With `audio`, the element speaks: a replay of the syllables, its Sound on button
    // pressed (a real click: browsers start sound only after one), its voice heard and
    // its frames drawn by the voice's clock (small, so that software WebGL draws every
    // frame in time: the element is measured, not SwiftShader).
    browser
        .js(&format!(
            "const e = {element}; e.style.width = '240px'; e.setAttribute('head', 'ict'); e.setAttribute('replay', 'syllables'); \
             e.setAttribute('audio', 'pcm'); return true"
        ))
        .await;
    let button = browser
        .wait_for(
            "the element's Sound on button",
            &format!(
                "const b = {element}.shadowRoot.querySelector('.sound-on'); \
                 if (b.hidden || {element}.state !== 'live') return null; \
                 const r = b.getBoundingClientRect(); return [r.left + r.width / 2, r.top + r.height / 2]"
            ),
            long,
        )
        .await;
    let (x, y) = (button[0].as_f64().unwrap(), button[1].as_f64().unwrap());
    browser
        .act(json!([{ "type": "pointer", "id": "mouse", "actions": [
            { "type": "pointerMove", "duration": 0, "origin": "viewport", "x": x as i64, "y": y as i64 },
            { "type": "pointerDown", "button": 0 }, { "type": "pointerUp", "button": 0 }
        ]}]))
        .await;
    browser
        .wait_for(
            "the element's voice heard",
            &format!(
                "const s = {element}.sound; return s !== null && s.playing && \
                 s.heardTime(performance.now()) !== null && {element}.shadowRoot.querySelector('.sound-on').hidden"
            ),
            long,
        )
        .await;
    // Its socket is read in a worker (started from a page of another origin), so the
    // page's draws hold up neither the voice nor its arrival times.
    let off_main = browser
        .js(&format!("return {element}.headView.socket.offMainThread"))
        .await;
    assert_eq!(off_main, json!(true), "the element's socket runs in a worker");
    // Past the playout delay's first adaptation, each frame shown: when it is drawn minus
    // when its `t` is heard, as the page measures it (positive: the face is late).
    tokio::time::sleep(Duration::from_secs(2)).await;
    browser
        .js(
            "window.heard = []; document.querySelector('facewire-head').addEventListener('frame', (ev) => { \
             const at = ev.target.sound.heardAtMsForTime(ev.detail.t); \
             if (at !== null) window.heard.push(performance.now() - at); })",
        )
        .await;
    tokio::time::sleep(Duration::from_secs(3)).await;
    let heard = browser.js("return window.heard").await;
    let between = browser
        .js(&format!(
            "const i = [...{element}.group.intervals].sort((a, b) => a - b); return i[i.length >> 1]"
        ))
        .await
        .as_f64()
        .unwrap();
    let mut ahead_ms: Vec<f64> = heard
        .as_array()
        .unwrap()
        .iter()
        .map(|d| d.as_f64().unwrap())
        .collect();
    assert!(
        ahead_ms.len() >= 10,
        "{} frames drawn by the voice in 3 s",
        ahead_ms.len()
    );
    ahead_ms.sort_by(f64::total_cmp);
    let median = ahead_ms[ahead_ms.len() / 2];
    let lag = browser
        .js(&format!(
            "const i = [...{element}.group.lags].sort((a, b) => a - b); return i[i.length >> 1]"
        ))
        .await
        .as_f64()
        .unwrap();
    println!(
        "the element's frames: face minus voice median {median:+.1} ms over {}, {between:.0} ms between chances to draw, lag {lag:.0} ms",
        ahead_ms.len()
    );
    // The group chooses the newest frame whose sound is heard by half a chance to draw
    // after the frame reaches the screen, `lag` after the chance (head-group.js
    // drawTarget); the `frame` event comes as the frame is shown, before it is drawn. So
    // a frame's event comes from half a chance plus the lag (plus up to a frame, 33 ms:
    // the newest due frame is taken) before its sound to about its sound: on a page that
    // draws every display frame, within the lip-reading bound of 40 ms; with software GL on
    // a loaded machine (chances 67-167 ms apart) up to 110 ms early. A page drawing frames
    // as they arrive, not by the voice, shows them the playout delay and the output's
    // latency late (over 90 ms).
    const FRAME_MS: f64 = 1000.0 / 30.0;
    let earliest = -(between / 2.0 + lag + FRAME_MS).max(40.0);
    assert!(
        (earliest..=40.0).contains(&median),
        "the element draws frames {median:+.1} ms from its voice (from {earliest:.0} to +40 allowed): {ahead_ms:?}"
    );
}

/// The seq of the frame view 1 shows now, or null before any.
const SHOWN_SEQ_JS: &str = "return document.getElementById('view-0')?.dataset.seq ?? null";

/// A replay's voice: the syllables replayed at a quarter of the pace with the sound on
/// (in a small window, which software WebGL draws fast enough to keep up: the page is
/// measured, not SwiftShader), the voice slowed (the sound runs at the replay's rate) and
/// each frame drawn within 15 ms (median) of when its sound is heard.
async fn check_the_replay_voice(browser: &Browser, url: &str, long: Duration) {
    browser
        .command("/window/rect", Some(json!({ "width": 800, "height": 600 })))
        .await;
    open_the_replay(browser, url, "makehuman", "", long).await;
    browser
        .js(
            "const s = document.getElementById('replay-speed'); s.value = '0.25'; \
             s.dispatchEvent(new Event('change'));",
        )
        .await;
    browser.click("#sound").await;
    browser
        .wait_for(
            "the replay's voice heard",
            "return window.facewireSound.heardTime(performance.now())",
            long,
        )
        .await;
    let rate = browser.js("return window.facewireSound.rate").await;
    assert_eq!(rate.as_f64(), Some(0.25), "the sound's rate");
    let logged = browser.js("return window.facewireSound.syncLog.length").await;
    tokio::time::sleep(Duration::from_secs(4)).await;
    let offsets = browser
        .js(&format!(
            "return window.facewireSound.syncLog.slice({logged}).filter(e => e.view === 0).map(e => e.offsetMs)"
        ))
        .await;
    let mut offsets: Vec<f64> = offsets
        .as_array()
        .unwrap()
        .iter()
        .map(|o| o.as_f64().unwrap())
        .collect();
    offsets.sort_by(f64::total_cmp);
    assert!(
        offsets.len() >= 15,
        "only {} frames drawn by their sound in 4 s",
        offsets.len()
    );
    let median = offsets[offsets.len() / 2];
    let p95 = offsets[(offsets.len() * 95 / 100).min(offsets.len() - 1)];
    let sound = browser.js(&text_of("sound-0")).await;
    println!(
        "replay voice at 0.25x: {} frames, face minus voice median {median:+.1} ms, p95 {p95:+.1} ms; the page: {sound}",
        offsets.len()
    );
    assert!(
        median.abs() <= 15.0,
        "face minus voice median {median:+.1} ms at 0.25x"
    );
    browser
        .command("/window/rect", Some(json!({ "width": 1280, "height": 1000 })))
        .await;
}

/// Opens the demo's recording of the syllables on `head` (`more`: further URL parameters)
/// and waits for its first frames.
async fn open_the_replay(browser: &Browser, url: &str, head: &str, more: &str, long: Duration) {
    wait_ready(url, head, long).await;
    browser
        .open(&format!("{url}?head={head}&replay=syllables{more}"))
        .await;
    browser
        .wait_for(
            "the replay's first frames",
            &format!(
                "return !document.getElementById('replay-bar').hidden && ({}) !== null",
                &SHOWN_SEQ_JS[7..]
            ),
            long,
        )
        .await;
}

/// Opens the demo's recording of the syllables on the ICT head in the mouth close-up
/// (`more`: further URL parameters), waits for its first frames and pauses it.
async fn open_the_paused_replay(browser: &Browser, url: &str, more: &str, long: Duration) {
    open_the_replay(browser, url, "ict", &format!("&mouth=1{more}"), long).await;
    browser.click("#replay-play").await;
    browser
        .wait_for(
            "the replay paused",
            "return document.getElementById('replay-play').textContent === 'Play'",
            long,
        )
        .await;
}

/// Seeks the paused replay to `frame` with the scrubber and waits until view 1 shows it.
async fn seek_the_replay(browser: &Browser, frame: u64, long: Duration) {
    browser
        .js(&format!(
            "const p = document.getElementById('replay-position'); p.value = '{frame}'; \
             p.dispatchEvent(new Event('input'))"
        ))
        .await;
    browser
        .wait_for(
            &format!("frame {frame} shown"),
            &format!("return document.getElementById('view-0').dataset.seq === '{frame}'"),
            long,
        )
        .await;
}

/// Replay of the demo's recording of the syllables (`?replay=syllables`): the transport
/// bar pauses it, its scrubber seeks and its buttons step, each landing on the frame asked
/// for exactly (the frame's `seq` is its index in the recording); a label looped at a
/// quarter of the pace shows only that label's frames, the first and the last among them,
/// about four times as far apart as recorded; and the URL keeps the replay.
async fn check_the_replay(browser: &Browser, url: &str, long: Duration) {
    open_the_paused_replay(browser, url, "", long).await;
    seek_the_replay(browser, 100, long).await;
    let shown = |frame: u64| format!("return document.getElementById('view-0').dataset.seq === '{frame}'");
    browser.click("#replay-forward").await;
    browser.wait_for("frame 101 shown", &shown(101), long).await;
    browser.click("#replay-back").await;
    browser.wait_for("frame 100 shown again", &shown(100), long).await;
    browser.click("#replay-back").await;
    browser.wait_for("frame 99 shown", &shown(99), long).await;
    // Paused: nothing else comes.
    tokio::time::sleep(Duration::from_millis(500)).await;
    assert_eq!(browser.js(SHOWN_SEQ_JS).await, "99");

    // "ta" looped at a quarter of the pace.
    let range = browser
        .js("const l = document.getElementById('replay-loop'); \
             const o = [...l.options].find((o) => o.text.startsWith('ta ')); \
             l.value = o.value; l.dispatchEvent(new Event('change')); \
             const s = document.getElementById('replay-speed'); s.value = '0.25'; \
             s.dispatchEvent(new Event('change')); return o.value")
        .await;
    let (first, last) = range
        .as_str()
        .and_then(|r| r.split_once('-'))
        .map(|(a, b)| (a.parse::<u64>().unwrap(), b.parse::<u64>().unwrap()))
        .unwrap_or_else(|| panic!("no loop option for ta: {range}"));
    // Every frame's seq and when the server sent it, as the page receives them (reading
    // them one by one over WebDriver would miss most; the page's own clock, busy drawing
    // in software, reads them in bursts).
    browser
        .js(
            "window.arrivals = null; import('/decode.js').then(({ readFrameHeader }) => { \
               const v = window.facewireViews()[0]; window.arrivals = []; \
               const received = v.frameArrived.bind(v); \
               v.frameArrived = (buffer, us) => { received(buffer, us); \
                 const h = readFrameHeader(buffer); window.arrivals.push([h.seq, h.serverSendUs / 1e6]); }; });",
        )
        .await;
    browser
        .wait_for("the arrivals recorded", "return window.arrivals !== null", long)
        .await;
    let lap = Duration::from_secs_f64((last - first + 1) as f64 / 30.0 * 4.0);
    tokio::time::sleep(lap * 2 + Duration::from_secs(1)).await;
    let arrivals: Vec<(u64, f64)> = browser
        .js("return window.arrivals")
        .await
        .as_array()
        .unwrap()
        .iter()
        .map(|a| (a[0].as_u64().unwrap(), a[1].as_f64().unwrap()))
        .collect();
    // Frames arriving before the loop took hold are left out: from the first in the range.
    let from = arrivals.iter().position(|&(s, _)| s == first).unwrap_or(0);
    let looped = &arrivals[from..];
    assert!(
        looped.iter().all(|&(s, _)| (first..=last).contains(&s)),
        "frames outside {first}-{last} while looping: {:?}",
        looped.iter().map(|&(s, _)| s).collect::<Vec<_>>()
    );
    for end in [first, last] {
        assert!(
            looped.iter().any(|&(s, _)| s == end),
            "the loop's frame {end} never came"
        );
    }
    // Every frame of the loop, in order: each the one after the last, or the first again.
    for w in looped.windows(2) {
        assert!(
            w[1].0 == w[0].0 + 1 || (w[0].0 == last && w[1].0 == first),
            "{} after {} in a loop over {first}-{last}",
            w[1].0,
            w[0].0
        );
    }
    let mut gaps: Vec<f64> = looped
        .windows(2)
        .filter(|w| w[1].0 == w[0].0 + 1)
        .map(|w| w[1].1 - w[0].1)
        .collect();
    gaps.sort_by(f64::total_cmp);
    let median = gaps[gaps.len() / 2];
    println!(
        "replay: ta (frames {first}-{last}) looped at 0.25x, frames {median:.3} s apart (recorded 1/30 s)"
    );
    assert!(
        (0.09..0.2).contains(&median),
        "{median} s between frames at 0.25x"
    );
    let address = browser.js("return location.search").await;
    assert!(
        address.as_str().unwrap().contains("replay=syllables"),
        "the URL keeps the replay: {address}"
    );
}
