//! facewire's geometry and speech core: the CANDIDE-3 mask and its fit to a head, the
//! interpolation algorithms that deform the dense head, the mesh-quality metrics, the
//! parameter streams and their posing, and the speech-to-viseme model.
//!
//! Plain synchronous Rust with no async runtime and no web framework, usable as a library
//! on its own; the `facewire` crate (service, CLI, reports) is a thin layer around it and
//! re-exports every module here. Units are named everywhere: **mask units** (CANDIDE's
//! model frame), **head units** (whatever the head's OBJ uses) and **mm** (via the fit's
//! `mm_per_unit`).

pub mod animate;
pub mod atomic;
pub mod cancel;
pub mod deform;
pub mod fit;
pub mod head;
pub mod input;
pub mod mask;
pub mod metrics;
pub mod population;
pub mod quote;
pub mod render;
pub mod speech;
pub mod stream;
pub mod targets;
pub mod text_table;
pub mod voice;
