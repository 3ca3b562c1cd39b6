//! `facewire play`: push a parameter stream file to a producer WebSocket in real time (or
//! faster with `--speed`), reporting how many frames were acknowledged and why any were
//! refused.

use std::time::Duration;

use futures_util::{SinkExt, StreamExt};
use tokio_tungstenite::tungstenite::Message;

use super::serve::runtime;
use super::{CliResult, FilePath};
use crate::mask::Mask;
use crate::stream::{open_stream, JsonlWriter};
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
    let mask = Mask::candide3();
    let mut lines = Vec::new();
    for frame in open_stream(&args.stream, &mask)? {
        let frame = frame?;
        let mut writer = JsonlWriter::new(Vec::new(), &mask);
        writer.write_frame(&frame)?;
        let line = String::from_utf8(writer.into_inner()?)?;
        lines.push((frame.seq, frame.time_s, line.trim_end().to_string()));
    }
    let url = with_token(&args.url, args.token.as_deref());
    runtime()?.block_on(async move {
        let (socket, _) = tokio_tungstenite::connect_async(url.as_str())
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
        let first = lines.first().map_or(0.0, |l| l.1);
        for (i, (_, time_s, line)) in lines.iter().enumerate() {
            let at = start + Duration::from_secs_f64(((time_s - first) / args.speed).max(0.0));
            tokio::time::sleep_until(at).await;
            tx.send(Message::Text(line.clone().into()))
                .await
                .map_err(|e| format!("sending frame {i}: {e}"))?;
            if (i + 1) % 30 == 0 {
                eprint!("\r{} / {} frames", i + 1, lines.len());
            }
        }
        tx.send(Message::Text(r#"{"type":"end"}"#.into())).await?;
        tokio::time::sleep(Duration::from_millis(200)).await;
        tx.send(Message::Close(None)).await.ok();
        let (acks, errors) = reader.await?;
        eprintln!();
        println!(
            "sent {} frames, {acks} acknowledged, {} refused",
            lines.len(),
            errors.len()
        );
        for e in errors.iter().take(10) {
            println!("  {e}");
        }
        Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
    })
}
