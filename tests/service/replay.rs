//! Recordings and their replay, through real sockets: a producer that asks for it is
//! recorded; the recording is listed with its labels, replayed frame by frame at the
//! viewer's pace (pause, seek, step, a loop at a quarter speed: every frame the one asked
//! for, by `seq`, the same frame deformed alike each time it is shown), refuses controls
//! it cannot follow without stopping, is deleted on request, and the limits hold.

use std::time::Instant;

use crate::common::service::{close_code, connect, memory_config, next_json, next_message, Server, Socket};

use facewire::server::config::Config;
use facewire_proto::messages::{RecordingInfo, ServerMessage};
use facewire_proto::viewer_frame::{decode, ViewerFrame};
use futures_util::SinkExt;
use tokio_tungstenite::tungstenite::Message;

/// Twelve frames, 30 a second: "pa" on 0-3, "ta" on 4-7, "ka" on 8-11, the jaw moving.
fn lesson_line(seq: u64) -> String {
    let label = ["pa", "ta", "ka"][seq as usize / 4];
    let jaw = 0.1 + 0.05 * seq as f64;
    format!(
        r#"{{"seq":{seq},"t":{},"label":"{label}","au":{{"jaw_drop":{jaw}}}}}"#,
        seq as f64 / 30.0
    )
}

/// Produces the lesson on stream `s` of head `mh` with `record` and ends it.
async fn produce_lesson(server: &Server, record: &str, frames: u64) {
    let mut producer = connect(&server.ws(&format!("/v1/heads/mh/streams/s/produce?record={record}"))).await;
    for seq in 0..frames {
        producer
            .send(Message::Text(lesson_line(seq).into()))
            .await
            .unwrap();
        assert!(matches!(
            next_json(&mut producer).await,
            ServerMessage::Ack { .. }
        ));
    }
    producer
        .send(Message::Text(r#"{"type":"end"}"#.into()))
        .await
        .unwrap();
    assert!(matches!(
        next_json(&mut producer).await,
        ServerMessage::End { .. }
    ));
}

async fn recordings(server: &Server) -> Vec<RecordingInfo> {
    reqwest::get(server.http("/v1/heads/mh/recordings"))
        .await
        .unwrap()
        .json()
        .await
        .unwrap()
}

enum Received {
    Frame(Box<ViewerFrame>, Instant),
    Json(ServerMessage),
}

async fn receive(socket: &mut Socket) -> Received {
    match next_message(socket).await {
        Some(Message::Binary(bytes)) => Received::Frame(Box::new(decode(&bytes).unwrap()), Instant::now()),
        Some(Message::Text(text)) => Received::Json(serde_json::from_str(text.as_str()).unwrap()),
        other => panic!("expected a frame or JSON, got {other:?}"),
    }
}

/// Sends a control and returns what comes until its `replay` (or `error`) answer: the
/// frames before it and the answer.
async fn control(replay: &mut Socket, control: &str) -> (Vec<ViewerFrame>, ServerMessage) {
    replay
        .send(Message::Text(control.to_string().into()))
        .await
        .unwrap();
    let mut frames = Vec::new();
    loop {
        match receive(replay).await {
            Received::Frame(frame, _) => frames.push(*frame),
            Received::Json(m @ (ServerMessage::Replay { .. } | ServerMessage::Error { .. })) => {
                return (frames, m)
            }
            Received::Json(other) => panic!("unexpected {other:?}"),
        }
    }
}

/// The next frame, skipping `replay` messages.
async fn next_replayed(replay: &mut Socket) -> (ViewerFrame, Instant) {
    loop {
        match receive(replay).await {
            Received::Frame(frame, at) => return (*frame, at),
            Received::Json(ServerMessage::Replay { .. }) => {}
            Received::Json(other) => panic!("unexpected {other:?}"),
        }
    }
}

fn field_of(message: &ServerMessage) -> Option<&str> {
    match message {
        ServerMessage::Error { field, .. } => field.as_deref(),
        other => panic!("expected an error, got {other:?}"),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_recorded_stream_replays_frame_by_frame_at_the_viewers_pace() {
    let server = Server::start(memory_config()).await;
    server.register("mh", "makehuman_head", "").await;
    produce_lesson(&server, "lesson", 12).await;

    let listed = recordings(&server).await;
    assert_eq!(listed.len(), 1, "{listed:?}");
    let lesson = &listed[0];
    assert_eq!(
        (lesson.name.as_str(), lesson.stream.as_str(), lesson.frames),
        ("lesson", "s", 12)
    );
    assert!(
        (lesson.duration_s - 11.0 / 30.0).abs() < 1e-9,
        "{}",
        lesson.duration_s
    );
    assert!(!lesson.cut);
    let runs: Vec<(&str, u64, u64)> = lesson
        .labels
        .iter()
        .map(|l| (l.label.as_str(), l.first, l.last))
        .collect();
    assert_eq!(runs, [("pa", 0, 3), ("ta", 4, 7), ("ka", 8, 11)]);

    let mut replay = connect(&server.ws("/v1/heads/mh/recordings/lesson/view?format=fwf2")).await;
    let ServerMessage::Snapshot(snapshot) = next_json(&mut replay).await else {
        panic!("expected a snapshot")
    };
    assert_eq!(snapshot.replay.as_ref(), Some(lesson));
    assert_eq!(snapshot.messages, ["frame", "replay", "end"]);
    assert_eq!(snapshot.stream, "s");
    let (first, _) = next_replayed(&mut replay).await;
    assert_eq!(first.header.seq, 0);
    assert_eq!(first.label.as_deref(), Some("pa"));

    // Paused, sought, stepped: each frame the one asked for.
    let (_, paused) = control(&mut replay, r#"{"type":"pause"}"#).await;
    let ServerMessage::Replay { playing: false, .. } = paused else {
        panic!("{paused:?}")
    };
    let (shown, answer) = control(&mut replay, r#"{"type":"seek","frame":5}"#).await;
    assert!(
        matches!(
            answer,
            ServerMessage::Replay {
                frame: 5,
                playing: false,
                ..
            }
        ),
        "{answer:?}"
    );
    let five = match shown.last() {
        Some(frame) => frame.clone(),
        None => next_replayed(&mut replay).await.0,
    };
    assert_eq!(five.header.seq, 5);
    assert_eq!(five.label.as_deref(), Some("ta"));
    let (_, answer) = control(&mut replay, r#"{"type":"step","frames":1}"#).await;
    assert!(
        matches!(answer, ServerMessage::Replay { frame: 6, .. }),
        "{answer:?}"
    );
    assert_eq!(next_replayed(&mut replay).await.0.header.seq, 6);
    let (_, answer) = control(&mut replay, r#"{"type":"step","frames":-2}"#).await;
    assert!(
        matches!(answer, ServerMessage::Replay { frame: 4, .. }),
        "{answer:?}"
    );
    let four = next_replayed(&mut replay).await.0;
    assert_eq!(four.header.seq, 4);

    // Controls it cannot follow: an error naming the field, and the replay goes on.
    let (_, refused) = control(&mut replay, r#"{"type":"seek","frame":12}"#).await;
    assert_eq!(field_of(&refused), Some("frame"));
    let (_, refused) = control(&mut replay, r#"{"type":"play","speed":5}"#).await;
    assert_eq!(field_of(&refused), Some("speed"));
    let (_, refused) = control(&mut replay, r#"{"type":"loop","first":7,"last":4}"#).await;
    assert_eq!(field_of(&refused), Some("last"));
    let (_, refused) = control(&mut replay, r#"{"type":"rewind"}"#).await;
    assert!(matches!(refused, ServerMessage::Error { .. }), "{refused:?}");

    // "ta" looped at a quarter of the pace: 4, 5, 6, 7, 4, 5, ... 133 ms apart, and the
    // frame shown twice deformed alike.
    let (_, answer) = control(&mut replay, r#"{"type":"loop","first":4,"last":7}"#).await;
    assert!(
        matches!(
            answer,
            ServerMessage::Replay {
                r#loop: Some([4, 7]),
                ..
            }
        ),
        "{answer:?}"
    );
    let (_, answer) = control(&mut replay, r#"{"type":"play","speed":0.25}"#).await;
    assert!(
        matches!(answer, ServerMessage::Replay { playing: true, .. }),
        "{answer:?}"
    );
    let mut played = Vec::new();
    for _ in 0..6 {
        played.push(next_replayed(&mut replay).await);
    }
    let seqs: Vec<u64> = played.iter().map(|(f, _)| f.header.seq).collect();
    assert_eq!(seqs, [5, 6, 7, 4, 5, 6]);
    let mut gaps: Vec<f64> = played
        .windows(2)
        .map(|w| (w[1].1 - w[0].1).as_secs_f64())
        .collect();
    gaps.sort_by(f64::total_cmp);
    let median = gaps[gaps.len() / 2];
    assert!(
        (0.10..0.17).contains(&median),
        "frames {median:.3} s apart at 0.25x (1/30 s recorded)"
    );
    let again = &played[3].0;
    assert_eq!(
        (again.moved.clone(), again.jaw, again.lip.clone()),
        (four.moved.clone(), four.jaw, four.lip.clone())
    );

    // Deleted: gone from the list, and a new replay is refused; the one playing goes on.
    let status = reqwest::Client::new()
        .delete(server.http("/v1/heads/mh/recordings/lesson"))
        .send()
        .await
        .unwrap()
        .status();
    assert_eq!(status, 204);
    assert!(recordings(&server).await.is_empty());
    assert!(next_replayed(&mut replay).await.0.header.seq <= 7);
    let mut gone = connect(&server.ws("/v1/heads/mh/recordings/lesson/view")).await;
    assert!(matches!(next_json(&mut gone).await, ServerMessage::Error { .. }));
    assert_eq!(close_code(&mut gone).await, 4404);
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn recordings_keep_to_their_limits() {
    let mut config: Config = memory_config();
    config.limits.max_recordings_per_head = 1;
    config.limits.max_recording_frames = 3;
    let server = Server::start(config).await;
    server.register("mh", "makehuman_head", "").await;
    produce_lesson(&server, "1", 5).await;
    let listed = recordings(&server).await;
    assert_eq!(listed.len(), 1);
    assert_eq!(
        (listed[0].name.as_str(), listed[0].frames, listed[0].cut),
        ("s-1", 3, true)
    );
    // The head holds the most: a producer asking for another is refused before it starts.
    let refused =
        tokio_tungstenite::connect_async(server.ws("/v1/heads/mh/streams/s/produce?record=1")).await;
    let Err(tokio_tungstenite::tungstenite::Error::Http(response)) = refused else {
        panic!("expected a refusal, got {refused:?}")
    };
    assert_eq!(response.status(), 429);
    // A name that is not an id is refused too.
    let status = reqwest::Client::new()
        .post(server.http("/v1/heads/mh/streams/s/batch?record=Not%20an%20id"))
        .body(lesson_line(0))
        .send()
        .await
        .unwrap()
        .status();
    assert_eq!(status, 429, "the limit is checked first");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn all_recordings_together_keep_to_their_memory() {
    // Room for two of the lesson's frames (each a frame, a 2-byte label, one unit weight).
    let frame = std::mem::size_of::<facewire::stream::Frame>();
    let mut config: Config = memory_config();
    config.limits.max_recording_bytes = 2 * frame + 64;
    let server = Server::start(config).await;
    server.register("mh", "makehuman_head", "").await;
    produce_lesson(&server, "first", 5).await;
    let listed = recordings(&server).await;
    assert_eq!((listed[0].frames, listed[0].cut), (2, true), "{listed:?}");
    // Deleted, its memory is free again for the next.
    let status = reqwest::Client::new()
        .delete(server.http("/v1/heads/mh/recordings/first"))
        .send()
        .await
        .unwrap()
        .status();
    assert_eq!(status, 204);
    produce_lesson(&server, "second", 2).await;
    let listed = recordings(&server).await;
    assert_eq!(
        (listed[0].name.as_str(), listed[0].frames, listed[0].cut),
        ("second", 2, false)
    );
    server.stop().await;
}

/// Every replayed frame of recording `name` of head `mh`, in order, with the server's
/// clock readings left out: the replay played through at full speed.
async fn replay_all(server: &Server, name: &str, frames: u64) -> Vec<ViewerFrame> {
    let mut replay = connect(&server.ws(&format!("/v1/heads/mh/recordings/{name}/view?format=fwf2"))).await;
    assert!(matches!(next_json(&mut replay).await, ServerMessage::Snapshot(_)));
    let mut shown = Vec::new();
    while (shown.len() as u64) < frames {
        let (mut frame, _) = next_replayed(&mut replay).await;
        frame.header.server_receive_us = 0;
        frame.header.server_send_us = 0;
        shown.push(frame);
    }
    shown
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn recordings_survive_a_restart_and_deleted_ones_stay_deleted() {
    let dir = tempfile::tempdir().unwrap();
    let config = Config {
        data_dir: Some(dir.path().to_path_buf()),
        ..Config::default()
    };
    let server = Server::start(config.clone()).await;
    server.register("mh", "makehuman_head", "").await;
    produce_lesson(&server, "lesson", 12).await;
    produce_lesson(&server, "scratch", 12).await;
    let before = recordings(&server).await;
    let lesson_before = replay_all(&server, "lesson", 12).await;
    let deleted = reqwest::Client::new()
        .delete(server.http("/v1/heads/mh/recordings/scratch"))
        .send()
        .await
        .unwrap();
    assert_eq!(deleted.status(), 204);
    server.stop().await;

    let server = Server::start(config).await;
    server.wait_ready("mh", "").await;
    let after = recordings(&server).await;
    assert_eq!(
        after,
        before
            .iter()
            .filter(|r| r.name == "lesson")
            .cloned()
            .collect::<Vec<_>>(),
        "the recordings listed after the restart"
    );
    // The same frames, deformed the same: positions, labels and times.
    assert_eq!(replay_all(&server, "lesson", 12).await, lesson_before);
    // A name taken on disk is taken: a new recording of it is refused.
    let again =
        tokio_tungstenite::connect_async(server.ws("/v1/heads/mh/streams/s/produce?record=lesson")).await;
    let Err(tokio_tungstenite::tungstenite::Error::Http(response)) = again else {
        panic!("expected a refusal, got {again:?}")
    };
    assert_eq!(response.status(), 400);
    // The files are a facewire JSONL stream any reader takes, beside what they do not say.
    let shelf = dir.path().join("heads/mh/recordings");
    let text = std::fs::read_to_string(shelf.join("lesson.jsonl")).unwrap();
    assert_eq!(text.lines().count(), 12);
    assert!(
        text.starts_with(r#"{"seq":0,"t":0.0,"label":"pa","au":{"jaw_drop":0.1}}"#),
        "{text}"
    );
    assert!(!shelf.join("scratch.jsonl").exists() && !shelf.join("scratch.json").exists());
}
