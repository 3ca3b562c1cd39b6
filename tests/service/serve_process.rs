//! `facewire serve` as a process: SIGTERM ends it within its shutdown deadline even while a
//! big head is registering and a request is half sent.

use std::io::{BufRead, BufReader, Write};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::data;
use facewire::head::{obj, subdivide, Head};

#[test]
fn sigterm_ends_the_server_during_a_registration_and_a_half_sent_request() {
    let dir = tempfile::tempdir().unwrap();
    // The scan subdivided twice: 141k vertices, seconds of registration work.
    let head = Head::load(&data("heads/lee_perry_smith_head.obj")).unwrap();
    let (mut positions, mut triangles) = (head.positions.clone(), head.triangles.clone());
    for _ in 0..2 {
        (positions, triangles) = subdivide::midpoint(&positions, &triangles);
    }
    let mut big = Vec::new();
    obj::write(&mut big, &[], &positions, &triangles).unwrap();
    let mut server = Command::new(env!("CARGO_BIN_EXE_facewire"))
        .args(["serve", "--addr", "127.0.0.1:0", "--data-dir"])
        .arg(dir.path())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(server.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let addr = line
        .trim()
        .trim_start_matches("facewire listening on http://")
        .trim_end_matches('/')
        .to_string();
    let body = serde_json::json!({
        "id": "big",
        "obj": String::from_utf8(big).unwrap(),
        "fit": std::fs::read_to_string(data("heads/lee_perry_smith_head.fit.toml")).unwrap(),
    });
    let response = reqwest::blocking::Client::new()
        .post(format!("http://{addr}/v1/heads"))
        .json(&body)
        .send()
        .unwrap();
    assert_eq!(response.status(), 202);
    let mut half = std::net::TcpStream::connect(&addr).unwrap();
    half.write_all(b"POST /v1/heads HTTP/1.1\r\nHost: x\r\nContent-Length: 100\r\n\r\n{")
        .unwrap();
    let info: serde_json::Value = reqwest::blocking::get(format!("http://{addr}/v1/heads/big"))
        .unwrap()
        .json()
        .unwrap();
    assert_eq!(info["status"], "registering", "{info}");

    let started = Instant::now();
    // SAFETY: kill sends a signal to the child this test started.
    assert_eq!(unsafe { libc::kill(server.id() as i32, libc::SIGTERM) }, 0);
    let status = loop {
        if let Some(status) = server.try_wait().unwrap() {
            break status;
        }
        if started.elapsed() > Duration::from_secs(15) {
            server.kill().unwrap();
            panic!("facewire serve still running 15 s after SIGTERM");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    assert!(status.success(), "{status:?}");
    assert!(
        started.elapsed() < Duration::from_secs(7),
        "{:?}",
        started.elapsed()
    );
    drop(half);
}
