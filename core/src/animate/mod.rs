//! A registered head animated frame by frame: the job the service runs once per frame for
//! every (stream, algorithm) that has viewers, and that `facewire deform`, the tests and
//! the benchmarks run offline. Parameter frame in; moved mask, deformed head, lip
//! roughness, the head's own rigid motion, the jaw's, the eyes', the tongue's shape and an
//! encoded viewer frame out. Plain synchronous Rust: no runtime, no allocation per frame.

mod eyeball;
mod eyelid_contact;
mod frame_meters;
mod gaze;
mod head;
mod head_motion;
mod jaw;
mod job;
mod json_frame;
mod labiodental;
mod lip_tint;
mod part_role;
mod part_split;
mod rigid;
mod teeth_contact;
mod tongue;

pub use eyeball::{fit_sphere, Eyeball, EyeballError, RadialProfile, Side, PROFILE_BINS};
pub use eyelid_contact::{EyelidContact, LidsInEyes, INSIDE_TOLERANCE_MM, LID_WATCH_MM};
pub use frame_meters::{FrameMeasures, FrameMeters, MeterError};
pub use gaze::{Gaze, GAZE_LIMIT_RAD};
pub use head::{AnimatedHead, AnimatedHeadError, PartInput, PartSplit, STEP_MM};
pub use head_motion::{head_motion, NECK_PIVOT_MASK};
pub use jaw::{jaw_motion, CHIN_VERTICES, JAW_PIVOT_MASK};
pub use job::{FrameJob, FrameJobError, FrameTimes, Heat};
pub use labiodental::{LabiodentalApplied, LabiodentalContact, LabiodentalScratch};
pub use lip_tint::{lip_tint, SOFT_EDGE_MM};
pub use part_role::infer_role;
pub use rigid::RigidMotion;
pub use teeth_contact::{
    ContactApplied, ContactScratch, TeethContact, CONTACT_MARGIN_MM, FALLOFF_MM, WATCH_MM,
};
pub use tongue::{
    TongueLandmarks, TongueShaper, BODY_BEHIND_TIP, BODY_REACH, FREE_MM, HELD_MM, TIP_REACH,
    TONGUE_OUT_COUNTS,
};
