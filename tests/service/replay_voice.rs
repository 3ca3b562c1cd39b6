//! A recording's voice, through real sockets: a producer's PCM voice is kept with its
//! frames, listed, replayed with `audio=` on the frames' own timeline (sample for sample
//! at 1x; at a quarter of the pace four times as long at the same pitch, each chunk sent
//! with the frame it goes with), in Opus too, kept across a restart; a recording without
//! a voice replays silent, its snapshot saying so.

use std::time::{Duration, Instant};

use crate::common::service::{connect, next_json, next_message, Server, Socket, OPUS_LOOKAHEAD_S};

use facewire::server::config::Config;
use facewire_proto::audio_chunk::{AudioBody, AudioChunk};
use facewire_proto::messages::{RecordingInfo, ServerMessage};
use facewire_proto::viewer_frame::{decode, ViewerFrame};
use futures_util::SinkExt;
use tokio_tungstenite::tungstenite::Message;

/// The voice: a 220 Hz tone at 16 kHz, 1 s.
const RATE: f64 = 16_000.0;
const TONE_HZ: f64 = 220.0;

fn tone_sample(i: usize) -> i16 {
    (8_000.0 * (i as f64 * TONE_HZ * std::f64::consts::TAU / RATE).sin()) as i16
}

/// Produces 30 frames (1 s at 30 fps) and 50 chunks of 20 ms of the tone on stream `v`
/// of head `mh`, recorded as `voiced`.
async fn produce_voiced(server: &Server) {
    let mut producer = connect(&server.ws("/v1/heads/mh/streams/v/produce?record=voiced")).await;
    let mut chunk = 0usize;
    for seq in 0..30u64 {
        let t = seq as f64 / 30.0;
        let line = format!(
            r#"{{"seq":{seq},"t":{t},"au":{{"jaw_drop":{}}}}}"#,
            0.02 * seq as f64
        );
        producer.send(Message::Text(line.into())).await.unwrap();
        assert!(matches!(
            next_json(&mut producer).await,
            ServerMessage::Ack { .. }
        ));
        while chunk < 50 && chunk as f64 * 0.02 <= t + 1.0 / 30.0 {
            let audio = AudioChunk {
                t_s: chunk as f64 * 0.02,
                server_receive_us: 0,
                body: AudioBody::Pcm {
                    sample_rate: 16_000,
                    samples: (chunk * 320..(chunk + 1) * 320).map(tone_sample).collect(),
                },
                ignored: Vec::new(),
            };
            producer
                .send(Message::Binary(audio.encode().into()))
                .await
                .unwrap();
            chunk += 1;
        }
    }
    producer
        .send(Message::Text(r#"{"type":"end"}"#.into()))
        .await
        .unwrap();
    loop {
        if let ServerMessage::End { .. } = next_json(&mut producer).await {
            break;
        }
    }
}

enum Replayed {
    Frame(Box<ViewerFrame>, Instant),
    Audio(AudioChunk, Instant),
    Json(ServerMessage),
}

async fn receive(socket: &mut Socket) -> Replayed {
    match next_message(socket).await {
        Some(Message::Binary(bytes)) if bytes.starts_with(b"FWA1") => {
            Replayed::Audio(AudioChunk::decode(&bytes).unwrap(), Instant::now())
        }
        Some(Message::Binary(bytes)) => Replayed::Frame(Box::new(decode(&bytes).unwrap()), Instant::now()),
        Some(Message::Text(text)) => Replayed::Json(serde_json::from_str(text.as_str()).unwrap()),
        other => panic!("expected a frame, audio or JSON, got {other:?}"),
    }
}

fn pcm(chunk: &AudioChunk) -> &[i16] {
    match &chunk.body {
        AudioBody::Pcm {
            sample_rate: 16_000,
            samples,
        } => samples,
        other => panic!("expected 16 kHz PCM, got {other:?}"),
    }
}

/// The frequency of a tone from its rising zero crossings, Hz.
fn frequency(samples: &[i16]) -> f64 {
    let crossings: Vec<usize> = (1..samples.len())
        .filter(|&i| samples[i - 1] < 0 && samples[i] >= 0)
        .collect();
    (crossings.len() - 1) as f64 * RATE / (crossings[crossings.len() - 1] - crossings[0]) as f64
}

async fn voiced_recording(server: &Server) -> RecordingInfo {
    let listed: Vec<RecordingInfo> = reqwest::get(server.http("/v1/heads/mh/recordings"))
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    listed
        .into_iter()
        .find(|r| r.name == "voiced")
        .expect("the voiced recording listed")
}

/// Opens the replay of `voiced` with `audio`; returns the socket and its snapshot's codec.
async fn open(server: &Server, audio: &str) -> (Socket, Option<String>) {
    let path = format!("/v1/heads/mh/recordings/voiced/view?format=fwf2&audio={audio}");
    let mut replay = connect(&server.ws(&path)).await;
    match next_json(&mut replay).await {
        ServerMessage::Snapshot(snapshot) => {
            assert!(
                snapshot.messages.iter().any(|m| m == "audio"),
                "{:?}",
                snapshot.messages
            );
            (replay, snapshot.audio)
        }
        other => panic!("expected the snapshot, got {other:?}"),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_recording_s_voice_replays_with_its_frames_slowed_at_its_pitch() {
    let dir = tempfile::tempdir().unwrap();
    let config = Config {
        data_dir: Some(dir.path().to_path_buf()),
        ..Config::default()
    };
    let server = Server::start(config.clone()).await;
    server.register("mh", "makehuman_head", "").await;
    produce_voiced(&server).await;
    let listed = voiced_recording(&server).await;
    assert_eq!(listed.frames, 30);
    assert_eq!(listed.voice_s, Some(1.0), "{listed:?}");

    // At 1x: the voice as it was sent, sample for sample, each chunk at its own t.
    let (mut replay, codec) = open(&server, "pcm").await;
    assert_eq!(codec.as_deref(), Some("pcm"));
    let mut chunks = Vec::new();
    while chunks.len() < 10 {
        if let Replayed::Audio(chunk, _) = receive(&mut replay).await {
            chunks.push(chunk);
        }
    }
    for (k, chunk) in chunks.iter().enumerate() {
        assert!(
            (chunk.t_s - 0.02 * k as f64).abs() < 1e-9,
            "chunk {k} at {}",
            chunk.t_s
        );
        let sent: Vec<i16> = (k * 320..(k + 1) * 320).map(tone_sample).collect();
        assert_eq!(pcm(chunk), sent.as_slice(), "chunk {k}");
    }

    // Paused, back to frame 0, then at a quarter of the pace: each 20 ms chunk covers 5 ms
    // of the recording, at the tone's pitch, and goes out with the frame it goes with.
    replay
        .send(Message::Text(r#"{"type":"pause"}"#.into()))
        .await
        .unwrap();
    replay
        .send(Message::Text(r#"{"type":"seek","frame":0}"#.into()))
        .await
        .unwrap();
    replay
        .send(Message::Text(r#"{"type":"play","speed":0.25}"#.into()))
        .await
        .unwrap();
    let (mut slow, mut frames) = (Vec::new(), Vec::new());
    let mut answers = 0;
    while slow.len() < 60 || frames.len() < 4 {
        match receive(&mut replay).await {
            Replayed::Json(ServerMessage::Replay { speed, .. }) => {
                answers += 1;
                if answers == 3 {
                    assert_eq!(speed, 0.25);
                    // What came before the play's answer was of the earlier run.
                    slow.clear();
                    frames.clear();
                }
            }
            Replayed::Audio(chunk, at) if answers == 3 => slow.push((chunk, at)),
            Replayed::Frame(frame, at) if answers == 3 => frames.push((frame.header.seq, at)),
            Replayed::Json(other) => panic!("unexpected {other:?}"),
            _ => {}
        }
    }
    for (k, (chunk, _)) in slow.iter().enumerate() {
        assert!(
            (chunk.t_s - 0.005 * k as f64).abs() < 1e-9,
            "chunk {k} at {}",
            chunk.t_s
        );
        assert_eq!(pcm(chunk).len(), 320);
    }
    let heard: Vec<i16> = slow[2..58].iter().flat_map(|(c, _)| pcm(c).to_vec()).collect();
    let hz = frequency(&heard);
    println!("replay voice at 0.25x: {hz:.1} Hz (sent {TONE_HZ} Hz)");
    assert!((hz - TONE_HZ).abs() < 3.0, "{hz} Hz");
    // Frame 3 (t = 0.1 s) goes out with the chunk of t = 0.1 s, 0.4 s into the run.
    let &(_, frame_at) = frames
        .iter()
        .find(|(seq, _)| *seq == 3)
        .expect("frame 3 replayed");
    let (_, chunk_at) = slow[20];
    let apart = if frame_at > chunk_at {
        frame_at - chunk_at
    } else {
        chunk_at - frame_at
    };
    println!("frame 3 and its chunk sent {} ms apart", apart.as_millis());
    assert!(apart < Duration::from_millis(40), "{apart:?}");
    drop(replay);

    // In Opus: 40 ms packets, as the live streams' encoder makes them, on the same timeline.
    let (mut opus, codec) = open(&server, "opus").await;
    assert_eq!(codec.as_deref(), Some("opus"));
    let mut packets = Vec::new();
    while packets.len() < 5 {
        if let Replayed::Audio(chunk, _) = receive(&mut opus).await {
            packets.push(chunk);
        }
    }
    for (k, chunk) in packets.iter().enumerate() {
        // At its first decoded sample: the encoder's look-ahead before its first given.
        let first_decoded = 0.04 * k as f64 - OPUS_LOOKAHEAD_S;
        assert!((chunk.t_s - first_decoded).abs() < 1e-9, "{}", chunk.t_s);
        let AudioBody::Opus { packet } = &chunk.body else {
            panic!("expected Opus, got {:?}", chunk.body)
        };
        assert_eq!(
            facewire_proto::audio_chunk::opus_packet_samples(packet, 0).ok(),
            Some(1920)
        );
    }
    drop(opus);

    // A recording without a voice replays silent with audio=: its snapshot names no
    // audio, as a live stream's whose producer sends none.
    let mut silent_producer = connect(&server.ws("/v1/heads/mh/streams/q/produce?record=silent")).await;
    silent_producer
        .send(Message::Text(r#"{"seq":0,"t":0}"#.into()))
        .await
        .unwrap();
    assert!(matches!(
        next_json(&mut silent_producer).await,
        ServerMessage::Ack { .. }
    ));
    drop(silent_producer);
    let snapshot = loop {
        let mut socket = connect(&server.ws("/v1/heads/mh/recordings/silent/view?audio=pcm")).await;
        match next_json(&mut socket).await {
            ServerMessage::Snapshot(snapshot) => break snapshot,
            // Listed once its producer is gone: not yet.
            ServerMessage::Error { .. } => tokio::time::sleep(Duration::from_millis(50)).await,
            other => panic!("expected the snapshot, got {other:?}"),
        }
    };
    assert_eq!(snapshot.audio, None);
    assert!(
        !snapshot.messages.iter().any(|m| m == "audio"),
        "{:?}",
        snapshot.messages
    );
    server.stop().await;

    // Kept across a restart: listed the same, heard the same.
    let server = Server::start(config).await;
    server.wait_ready("mh", "").await;
    assert_eq!(voiced_recording(&server).await, listed);
    assert!(dir.path().join("heads/mh/recordings/voiced.wav").is_file());
    let (mut replay, _) = open(&server, "pcm").await;
    loop {
        if let Replayed::Audio(chunk, _) = receive(&mut replay).await {
            let sent: Vec<i16> = (0..320).map(tone_sample).collect();
            assert_eq!(pcm(&chunk), sent.as_slice());
            break;
        }
    }
    server.stop().await;
}
