//! The `--part [ROLE:]PATH` argument of `facewire deform` and `facewire compare`: a part
//! mesh (teeth, gums, tongue) in the head's units and frame, named after its file, with
//! its role given or left to be inferred.

use std::path::Path;

use crate::animate::{AnimatedHead, PartInput};
use crate::head::{Head, PartRole};

/// `[ROLE:]PATH` into a part to register.
pub fn load_part(text: &str) -> Result<PartInput, String> {
    let (role, path) = text
        .split_once(':')
        .and_then(|(role, path)| Some((Some(role.parse::<PartRole>().ok()?), path)))
        .unwrap_or((None, text));
    let path = Path::new(path);
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .ok_or_else(|| format!("--part {text:?}: no file name"))?;
    let mesh = Head::load(path).map_err(|e| format!("--part {text:?}: {e}"))?;
    Ok(PartInput { name, role, mesh })
}

/// Every `--part` of a command, loaded.
pub fn load_parts(texts: &[String]) -> Result<Vec<PartInput>, String> {
    texts.iter().map(|t| load_part(t)).collect()
}

/// Says on stderr how each part of `head` moves, which were split from one mesh holding
/// both rows of teeth, which teeth are open shells that contact cannot use, and the eyes.
pub fn describe_parts(head: &AnimatedHead) {
    let mm = head.registration.mm_per_unit();
    for eye in &head.eyes {
        let split = eye.split_from.as_ref().map_or(String::new(), |from| {
            format!(" (split from {from}: both eyeballs in one mesh)")
        });
        eprintln!(
            "part {}: {} vertices, the {} eye, turns about its centre (a sphere of {:.1} mm){split}",
            eye.name,
            eye.mesh.positions.len(),
            eye.side.name(),
            eye.radius * mm
        );
    }
    for part in &head.parts {
        let split = part.split_from.as_ref().map_or(String::new(), |from| {
            format!(" (split from {from}: both rows of teeth in one mesh)")
        });
        eprintln!(
            "part {}: {} vertices, moves with the {}{split}",
            part.name,
            part.mesh.positions.len(),
            part.role
        );
        if part.role != PartRole::Tongue && part.closed_pieces == 0 {
            eprintln!(
                "warning: part {} has no closed piece (an open shell): the lips and the tongue are not kept out of it, and contact is not measured against it (on f and v the lower lip is still brought to a skull part's surface)",
                part.name
            );
        }
    }
}
