//! facewire: animate real 3D heads from CANDIDE-3 / MPEG-4 parameter streams.
//!
//! The geometry core (mask, head, fit, deform, metrics, stream, speech) is the crate
//! `facewire-core` (`core/`), plain synchronous Rust, re-exported here module by module so
//! that `facewire::deform` and `crate::deform` name the same thing everywhere; the
//! service, the CLI and the reports are thin layers around it. Units are named
//! everywhere: **mask units** (CANDIDE's model frame), **head units** (whatever the head's
//! OBJ uses) and **mm** (via the fit's `mm_per_unit`).

pub use facewire_core::{
    animate, atomic, cancel, deform, fit, head, input, mask, metrics, population, quote, render, speech,
    stream, targets, text_table, voice,
};

#[cfg(feature = "cli")]
pub mod cli;
#[cfg(feature = "reports")]
pub mod report;
#[cfg(feature = "server")]
pub mod server;
