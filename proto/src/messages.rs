//! JSON messages: what the server says to producers and viewers over WebSocket text
//! frames, and the HTTP resources. Every message has a `type` field.

use serde::{Deserialize, Serialize};

use crate::codes::{EndReason, ErrorCode};

/// First message on a viewer socket: everything needed to show the frames that follow.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    pub protocol: String,
    pub head: String,
    pub stream: String,
    /// Canonical algorithm spec.
    pub algorithm: String,
    pub vertices: u32,
    pub triangles: u32,
    /// Rest mesh, binary (`mesh.bin`: see PROTOCOL.md) and OBJ.
    pub rest_mesh: String,
    pub rest_obj: String,
    /// Where the rest mesh's lips are (`lips.bin`, `FWL1`: a weight per vertex), for
    /// drawing them in their own colour. Absent from servers before it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lip_tint: Option<String>,
    /// The head's texture, when it has one: where the rest mesh sits on it (`uv.bin`,
    /// `FWU1`) and the image (PNG or JPEG). Absent without one and from servers before it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texture: Option<TextureInfo>,
    /// Millimetres per head unit.
    pub mm_per_unit: f32,
    /// Quantization step of the deltas, head units per count.
    pub step: f32,
    /// The CANDIDE-3 lip vertices the per-lip-vertex roughness values belong to.
    pub lip_vertices: Vec<u32>,
    /// Whether frames carry per-vertex face roughness.
    pub face_roughness: bool,
    /// What the frames' per-vertex values (the block of flag bit 0) measure: `roughness`
    /// (face roughness) or `folds` (the largest turn of each vertex's triangles, degrees);
    /// absent when frames carry none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heat: Option<String>,
    /// The mouth at rest, head units: the midpoint of the inner-lip anchors (what a
    /// close-up looks at).
    pub mouth: [f32; 3],
    /// The head's parts (teeth, gums, tongue): drawn from their own meshes, placed by the
    /// frames' head and jaw motion.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub parts: Vec<PartInfo>,
    /// The frames' layout: `fwf2`, `fwf1` or `json`. Absent from servers before `FWF2`
    /// (their frames are `FWF1`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub format: Option<String>,
    /// The kinds of message that may follow the snapshot (`frame`, `end`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub messages: Vec<String>,
    /// The codec of the audio chunks (`FWA1`) this viewer gets (`pcm` or `opus`); absent
    /// when it asked for none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub audio: Option<String>,
    /// Every section kind the frames may carry (`fwf2` only), by number and name.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sections: Vec<SectionInfo>,
    /// The head's eyeballs, which `eye_motion` sections turn (by index here). Absent for a
    /// head without eyes and from servers before them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub eyes: Vec<EyeInfo>,
    /// A replay's recording (`.../recordings/{name}/view`); absent on a live stream.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub replay: Option<RecordingInfo>,
}

/// A section kind of a sectioned layout, as the snapshot lists it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SectionInfo {
    pub kind: u8,
    pub name: String,
}

impl SectionInfo {
    /// The list of a layout's `(kind, name)` table.
    pub fn list(table: &[(u8, &str)]) -> Vec<SectionInfo> {
        table
            .iter()
            .map(|&(kind, name)| SectionInfo {
                kind,
                name: name.to_string(),
            })
            .collect()
    }
}

/// A part of a head: its mesh (`mesh.bin` format) and how it moves.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PartInfo {
    pub name: String,
    /// `skull`, `jaw` or `tongue`.
    pub role: String,
    pub vertices: u32,
    pub triangles: u32,
    /// Its rest mesh, binary (`mesh.bin`), head units.
    pub mesh: String,
    /// The part as registered, when it held both rows of teeth and was split into
    /// `{name}_upper` (skull) and `{name}_lower` (jaw). Absent from servers before it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub split_from: Option<String>,
    /// Its closed pieces (teeth). A skull or jaw part with none is an open shell: the lips
    /// and the tongue are not kept out of it and contact is not measured (on f and v the
    /// lower lip is still brought to a skull part's surface). Absent (null) from servers
    /// before it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub closed_pieces: Option<u32>,
    /// For the part the tongue's shapes move: which of its vertices are the tongue itself
    /// rather than gums or the floor of the mouth (`tongue.bin`, FWL1, a weight per part
    /// vertex). Absent for other parts and from servers before it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tongue_proper: Option<String>,
}

/// Where a viewer fetches a head's texture.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TextureInfo {
    /// `uv.bin` (`FWU1`): the texture coordinates of the rest mesh's triangles.
    pub uv: String,
    /// The image, PNG or JPEG (its content type says which).
    pub image: String,
}

/// An eyeball of a head: a rigid mesh that turns about its centre with the gaze and moves
/// with the head (head units, the head's frame at rest).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EyeInfo {
    pub name: String,
    /// `left` or `right`: the face's own.
    pub side: String,
    pub vertices: u32,
    pub triangles: u32,
    /// Its rest mesh, binary (`mesh.bin`), head units.
    pub mesh: String,
    /// What it turns about.
    pub centre: [f32; 3],
    /// Where it looks at rest (unit length): the face's forward.
    pub forward: [f32; 3],
    /// Its sphere's radius, head units.
    pub radius: f32,
    /// The iris's and the pupil's radius about `forward`, head units (12 mm and 4 mm
    /// across on an adult): for drawing.
    pub iris_radius: f32,
    pub pupil_radius: f32,
    /// The eyes part as registered, when it held both eyeballs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub split_from: Option<String>,
}

/// Messages the server sends as JSON text.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ServerMessage {
    Snapshot(Box<Snapshot>),
    /// A producer frame was accepted.
    Ack {
        seq: u64,
        received_us: u64,
        /// Section kinds of an `FWP2` frame the server does not know and skipped.
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        ignored: Vec<u8>,
    },
    /// Something was refused; `seq` and `field` say which frame and field when known.
    Error {
        code: ErrorCode,
        message: String,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        seq: Option<u64>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        field: Option<String>,
    },
    /// A frame the server derived from an audio-only producer's voice (`derive=visemes`),
    /// sent to that producer when it asked (`derived=1`): what a parameter producer would
    /// have sent, for comparing with one's own.
    Derived {
        seq: u64,
        /// On the stream's clock, s.
        t: f64,
        viseme: DerivedViseme,
        /// The probability the tracker gave the viseme shown, 0 to 1.
        confidence: f32,
    },
    /// Where a replay stands (`.../recordings/{name}/view`): after every control the
    /// viewer sends, and when the replay stops at its last frame.
    Replay {
        /// The frame shown, an index into the recording (the frames' `seq`).
        frame: u64,
        playing: bool,
        /// Playback speed, 1 the recording's own pace.
        speed: f64,
        /// The frames played over and over, first and last, inclusive; absent when none.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        r#loop: Option<[u64; 2]>,
    },
    /// The stream ended (producer finished or gone, head deleted, server shutting down).
    /// A producer that sent `end` gets it back before its socket closes.
    End {
        reason: EndReason,
        message: String,
    },
}

/// The viseme of a derived frame, named as a JSONL frame's `viseme` names one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DerivedViseme {
    /// The Oculus/Meta name (`sil`, `PP`, `FF`, ... `ou`).
    pub oculus: String,
}

/// What a replay's viewer may send (JSON text): each answered with a `replay` message.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum ReplayControl {
    /// Plays on from the frame shown, at `speed` (the recording's pace times this; the
    /// last speed, 1 at first, when absent).
    Play {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        speed: Option<f64>,
    },
    Pause,
    /// Shows frame `frame` (an index into the recording), playing or paused as before.
    Seek {
        frame: u64,
    },
    /// Pauses and shows the frame `frames` after the one shown (before, when negative).
    Step {
        frames: i64,
    },
    /// Plays frames `first` to `last` over and over (from `first` if the frame shown is
    /// outside them); without them, the loop is cleared.
    Loop {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        first: Option<u64>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        last: Option<u64>,
    },
}

/// A recording as `GET /v1/heads/{id}/recordings` lists it and a replay's snapshot names it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RecordingInfo {
    pub name: String,
    /// The stream it was recorded from.
    pub stream: String,
    pub frames: u64,
    /// From the first frame's `t` to the last's, the producer's seconds.
    pub duration_s: f64,
    /// Whether the producer sent more frames than a recording holds (the rest were not kept).
    pub cut: bool,
    /// Each run of frames with the same label, in order.
    pub labels: Vec<RecordingLabel>,
    /// How long its voice is, seconds, when the stream carried one (a replay then plays
    /// it). Absent without a voice and from servers before it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub voice_s: Option<f64>,
}

/// A run of a recording's frames that carry the same label.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RecordingLabel {
    pub label: String,
    /// First and last frame of the run (indices into the recording), inclusive.
    pub first: u64,
    pub last: u64,
}

/// Control messages a producer may send as JSON text besides frames.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ProducerMessage {
    /// The producer is done; viewers get `end`.
    End,
}

/// A registered head as `GET /v1/heads` and `GET /v1/heads/{id}` describe it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeadInfo {
    pub id: String,
    pub vertices: u32,
    pub triangles: u32,
    pub mm_per_unit: f32,
    /// `registering`, `ready` or `failed`.
    pub status: String,
    /// Registration progress, 0..1.
    pub progress: f32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Live streams: those with a producer, a viewer or a frame in the last
    /// `stream_linger_s`.
    pub streams: Vec<String>,
    /// Algorithms bound so far (canonical specs).
    pub algorithms: Vec<String>,
    /// Its parts, once registered.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub parts: Vec<PartInfo>,
    /// Its eyeballs, once registered.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub eyes: Vec<EyeInfo>,
    /// How well the fit lays the mask on the head, once registered.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit: Option<FitSummary>,
    /// In the answer to a registration from a glTF file: which of its meshes became what.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<HeadSource>,
    /// The ARKit blendshapes the head's own morph targets define (ARKit's names, in its
    /// order): ARKit weights for these move the mask as the head's targets do, the others
    /// as the shipped basis. Absent when it has none, and from servers before it.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub arkit_blendshapes: Vec<String>,
}

/// Which meshes of a registered file became the head's skin and parts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeadSource {
    /// `glb`.
    pub format: String,
    /// The mesh taken for the skin (its node's name, else its mesh's).
    pub skin: String,
    pub parts: Vec<PartSource>,
    /// Meshes not used (hair, lashes, clothes, ...).
    pub left_out: Vec<String>,
    /// What became of the skin's base colour image: kept as the head's texture, or left
    /// out and why. Absent when it has none, and from servers before it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texture: Option<String>,
    /// The skin's morph targets taken as ARKit blendshapes, each with the targets it was
    /// made from. Absent when none, and from servers before it.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub arkit_targets: Vec<ArkitTargetSource>,
    /// The skin's morph targets not taken, each with why.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub targets_left_out: Vec<TargetLeftOut>,
}

/// An ARKit blendshape the head's own morph targets make.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ArkitTargetSource {
    /// ARKit's name (`mouthSmileLeft`).
    pub blendshape: String,
    /// The file's target names it was made from: one, or two halves summed
    /// (`browInnerUp_L`, `browInnerUp_R`).
    pub from: Vec<String>,
}

/// A morph target of the file not used, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TargetLeftOut {
    pub name: String,
    pub why: String,
}

/// A part and the file's mesh it was made from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PartSource {
    pub name: String,
    pub mesh: String,
}

/// How well a head's fit lays the CANDIDE mask on it: the distance from each fitted mask
/// vertex (those a triangle uses) to the head's surface, mm, and what to look at
/// (`GET /v1/heads/{id}/fit` has the whole report).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitSummary {
    pub surface_mean_mm: f32,
    pub surface_max_mm: f32,
    /// The mask vertex furthest from the surface.
    pub worst_mask_vertex: u32,
    /// The fit report's warnings, as sentences.
    #[serde(default)]
    pub warnings: Vec<String>,
}

impl ServerMessage {
    /// An `end` message with the reason's sentence.
    pub fn end(reason: EndReason) -> ServerMessage {
        ServerMessage::End {
            reason,
            message: reason.message().to_string(),
        }
    }
}

/// The body of every HTTP error response.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorBody {
    pub error: ErrorCode,
    pub message: String,
    /// For `internal` errors: the id the server's log has the cause under.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub request_id: Option<String>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_are_tagged() {
        let ack = ServerMessage::Ack {
            seq: 3,
            received_us: 10,
            ignored: vec![],
        };
        assert_eq!(
            serde_json::to_string(&ack).unwrap(),
            r#"{"type":"ack","seq":3,"received_us":10}"#
        );
        let end: ProducerMessage = serde_json::from_str(r#"{"type":"end"}"#).unwrap();
        assert_eq!(end, ProducerMessage::End);
        let error = ServerMessage::Error {
            code: ErrorCode::BadFrame,
            message: "line 1".into(),
            seq: Some(4),
            field: None,
        };
        let text = serde_json::to_string(&error).unwrap();
        assert_eq!(
            text,
            r#"{"type":"error","code":"bad_frame","message":"line 1","seq":4}"#
        );
        assert_eq!(serde_json::from_str::<ServerMessage>(&text).unwrap(), error);
    }
}
