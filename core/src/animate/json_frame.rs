//! The naive viewer frame that FWF1 is measured against: every vertex's position as JSON
//! numbers, what a server without quantized deltas would send. Served to viewers that ask
//! for `format=json` and used by `facewire load --format json` as the baseline for bytes
//! and CPU (docs/PERFORMANCE.md); FWF1 is what the page and the clients use.

use glam::Vec3;
use serde::Serialize;

#[derive(Serialize)]
struct JsonFrame<'a> {
    #[serde(rename = "type")]
    kind: &'static str,
    seq: u64,
    t: f64,
    /// The deformed head, head units, in the head's vertex order, before the head's own
    /// motion: `[[x, y, z], ...]`.
    positions: &'a [Vec3],
}

/// Replaces `out` with the frame `{"type":"frame","seq":..,"t":..,"positions":[[x,y,z],..]}`;
/// `out` keeps its capacity, so a reused buffer allocates nothing after the first frame.
pub fn write_json_frame(seq: u64, time_s: f64, positions: &[Vec3], out: &mut Vec<u8>) {
    out.clear();
    let frame = JsonFrame {
        kind: "frame",
        seq,
        t: time_s,
        positions,
    };
    serde_json::to_writer(&mut *out, &frame).expect("a frame of finite numbers serializes");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_is_every_position_as_json() {
        let mut out = Vec::new();
        write_json_frame(7, 0.25, &[Vec3::new(1.0, -0.5, 0.125), Vec3::ZERO], &mut out);
        assert_eq!(
            std::str::from_utf8(&out).unwrap(),
            r#"{"type":"frame","seq":7,"t":0.25,"positions":[[1.0,-0.5,0.125],[0.0,0.0,0.0]]}"#
        );
        let capacity = out.capacity();
        write_json_frame(8, 0.5, &[Vec3::ONE], &mut out);
        assert_eq!(out.capacity(), capacity);
        assert!(out.starts_with(br#"{"type":"frame","seq":8,"#));
    }
}
