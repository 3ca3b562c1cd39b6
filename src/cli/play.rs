//! `facewire play`: push a parameter stream file, and with `--audio` its voice, to a
//! producer WebSocket in real time (frames faster with `--speed`), reporting how many
//! frames were acknowledged and why any frame or audio chunk was refused.

use std::time::Duration;

use futures_util::{SinkExt, StreamExt};
use tokio_tungstenite::tungstenite::Message;

use super::serve::runtime;
use super::{CliResult, FilePath};
use crate::mask::Mask;
use crate::server::config::Limits;
use crate::stream::{open_stream, JsonlWriter};
use crate::voice::read_wav;
use facewire_proto::messages::ServerMessage;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Stream file (.jsonl, .fap, .fau).
    stream: FilePath,
    /// Producer URL, e.g. ws://127.0.0.1:8480/v1/heads/scan/streams/main/produce
    #[arg(long)]
    url: String,
    /// Playback speed: 2 plays twice as fast.
    #[arg(long, default_value_t = 1.0)]
    speed: f64,
    /// Producer token, if the server wants one.
    #[arg(long)]
    token: Option<String>,
    /// A WAV file (16, 24 or 48 kHz; mixed to mono) sent with the stream in 20 ms PCM
    /// chunks, its first sample at the stream's first frame's `t`.
    #[arg(long)]
    audio: Option<FilePath>,
}

pub(super) fn with_token(url: &str, token: Option<&str>) -> String {
    match token {
        Some(t) => format!("{url}{}token={t}", if url.contains('?') { '&' } else { '?' }),
        None => url.to_string(),
    }
}

pub fn run(args: Args) -> CliResult {
    if !(args.speed.is_finite() && args.speed > 0.0) {
        return Err(format!("--speed {}: must be a positive number", args.speed).into());
    }
    if args.audio.is_some() && args.speed != 1.0 {
        return Err("--audio plays in real time: leave --speed at 1".into());
    }
    let mask = Mask::candide3();
    // (t, message) in the order they are sent; a frame goes before a chunk at its `t`.
    let mut messages = Vec::new();
    for frame in open_stream(&args.stream, &mask)? {
        let frame = frame?;
        let mut writer = JsonlWriter::new(Vec::new(), &mask);
        writer.write_frame(&frame)?;
        let line = String::from_utf8(writer.into_inner()?)?;
        messages.push((frame.time_s, Message::Text(line.trim_end().to_string().into())));
    }
    let frames = messages.len();
    let first = messages.first().map_or(0.0, |m| m.0);
    if let Some(path) = &args.audio {
        let file = std::fs::File::open(path).map_err(|e| format!("cannot open {}: {e}", path.display()))?;
        let voice = read_wav(std::io::BufReader::new(file), &path.display().to_string())?;
        for chunk in voice.audio_chunks(first) {
            messages.push((chunk.t_s, Message::Binary(chunk.encode().into())));
        }
        messages.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    let url = with_token(&args.url, args.token.as_deref());
    runtime(&Limits::default())?.block_on(async move {
        // Without Nagle: an audio chunk the server does not answer would otherwise hold the
        // next message back until its ACK, delayed up to 40 ms by the server's kernel.
        let (socket, _) = tokio_tungstenite::connect_async_with_config(url.as_str(), None, true)
            .await
            .map_err(|e| format!("cannot connect to {}: {e}", args.url))?;
        let (mut tx, mut rx) = socket.split();
        let reader = tokio::spawn(async move {
            let (mut acks, mut errors) = (0usize, Vec::new());
            while let Some(Ok(message)) = rx.next().await {
                let Message::Text(text) = message else { continue };
                match serde_json::from_str::<ServerMessage>(text.as_str()) {
                    Ok(ServerMessage::Ack { .. }) => acks += 1,
                    Ok(ServerMessage::Error { code, message, .. }) => {
                        errors.push(format!("{code}: {message}"))
                    }
                    _ => {}
                }
            }
            (acks, errors)
        });
        let start = tokio::time::Instant::now();
        let mut sent_frames = 0;
        for (i, (time_s, message)) in messages.into_iter().enumerate() {
            let at = start + Duration::from_secs_f64(((time_s - first) / args.speed).max(0.0));
            tokio::time::sleep_until(at).await;
            let is_frame = matches!(message, Message::Text(_));
            tx.send(message)
                .await
                .map_err(|e| format!("sending message {i} (t = {time_s} s): {e}"))?;
            if is_frame {
                sent_frames += 1;
                if sent_frames % 30 == 0 {
                    eprint!("\r{sent_frames} / {frames} frames");
                }
            }
        }
        tx.send(Message::Text(r#"{"type":"end"}"#.into())).await?;
        tokio::time::sleep(Duration::from_millis(200)).await;
        tx.send(Message::Close(None)).await.ok();
        let (acks, errors) = reader.await?;
        eprintln!();
        println!(
            "sent {frames} frames, {acks} acknowledged, {} refused",
            errors.len()
        );
        for e in errors.iter().take(10) {
            println!("  {e}");
        }
        Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
    })
}
