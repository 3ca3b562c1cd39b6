//! What a load run will do, checked before it starts: its counts, duration and targets
//! held to their bounds (loopback only unless asked), and the frames every producer sends.

use std::net::ToSocketAddrs;

use super::{Args, MAX_NODES, MAX_SECONDS, MAX_STREAMS, MAX_VIEWERS};
use crate::mask::Mask;
use crate::stream::{syllables, JsonlWriter};

/// Refuses counts, durations and targets out of bounds, naming the flag.
pub(super) fn check(args: &Args) -> Result<(), String> {
    if !(1..=MAX_STREAMS).contains(&args.streams) {
        return Err(format!("--streams {}: must be 1 to {MAX_STREAMS}", args.streams));
    }
    if !(1..=MAX_VIEWERS).contains(&args.viewers) {
        return Err(format!("--viewers {}: must be 1 to {MAX_VIEWERS}", args.viewers));
    }
    if !(args.seconds > 0.0 && args.seconds <= MAX_SECONDS) {
        return Err(format!(
            "--seconds {}: must be above 0 and at most {MAX_SECONDS}",
            args.seconds
        ));
    }
    if !(args.fps > 0.0 && args.fps <= crate::stream::MAX_FPS) {
        return Err(format!(
            "--fps {}: must be above 0 and at most {}",
            args.fps,
            crate::stream::MAX_FPS
        ));
    }
    if args.derive && args.audio.is_none() {
        return Err("--derive: the face is derived from the voice, so give --audio too".to_string());
    }
    if args.view_urls.len() > MAX_NODES {
        return Err(format!(
            "--view-url given {} times: at most {MAX_NODES}",
            args.view_urls.len()
        ));
    }
    check_url("--url", &args.url, args.allow_remote)?;
    for url in &args.view_urls {
        check_url("--view-url", url, args.allow_remote)?;
    }
    Ok(())
}

/// Refuses a URL that is not `http://HOST:PORT`, or not on loopback without `allow_remote`.
fn check_url(flag: &str, url: &str, allow_remote: bool) -> Result<(), String> {
    let Some(authority) = url.strip_prefix("http://") else {
        return Err(format!("{flag} {url:?}: expected http://HOST:PORT"));
    };
    let host_port = authority.trim_end_matches('/');
    let addrs: Vec<_> = host_port
        .to_socket_addrs()
        .map_err(|e| format!("{flag} {url:?}: {e}"))?
        .collect();
    if !allow_remote && (addrs.is_empty() || addrs.iter().any(|a| !a.ip().is_loopback())) {
        return Err(format!(
            "{flag} {url:?}: not a loopback address; a load run opens thousands of sockets, so give --allow-remote to aim it at another machine"
        ));
    }
    Ok(())
}

/// The syllable stream at `fps` as JSONL objects.
pub(super) fn syllable_frames(
    fps: f64,
) -> Result<Vec<serde_json::Value>, Box<dyn std::error::Error + Send + Sync>> {
    let mask = Mask::candide3();
    let mut frames = Vec::new();
    for frame in syllables::generate(fps)? {
        let mut writer = JsonlWriter::new(Vec::new(), &mask);
        writer.write_frame(&frame)?;
        frames.push(serde_json::from_slice(&writer.into_inner()?)?);
    }
    Ok(frames)
}
