//! facewire: animate real 3D heads from CANDIDE-3 / MPEG-4 parameter streams.
//!
//! The geometry core (mask, head, fit) is plain synchronous Rust; the service and the CLI
//! are thin layers around it. Units are named everywhere: **mask units** (CANDIDE's model
//! frame), **head units** (whatever the head's OBJ uses) and **mm** (via the fit's
//! `mm_per_unit`).

pub mod animate;
pub mod atomic;
pub mod cancel;
#[cfg(feature = "cli")]
pub mod cli;
pub mod deform;
pub mod fit;
pub mod head;
pub mod input;
pub mod mask;
pub mod metrics;
pub mod population;
pub mod quote;
pub mod render;
#[cfg(feature = "reports")]
pub mod report;
#[cfg(feature = "server")]
pub mod server;
pub mod speech;
pub mod stream;
pub mod targets;
pub mod text_table;
pub mod voice;
