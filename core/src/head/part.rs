//! Meshes that belong to a head without being its skin (teeth, gums, a tongue), each with
//! a role that says how it moves: with the skull (upper teeth and gums: the head's own
//! motion only), with the jaw (lower teeth and gums: the jaw's motion, then the head's), or
//! as the tongue (with the jaw, and shaped on top of that), or as eyes (each eyeball turned
//! about its own centre by the frame's gaze, then carried by the head's motion). They are
//! drawn, never deformed by the skin's algorithm.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::Head;

/// Parts one head may carry.
pub const MAX_PARTS: usize = 8;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PartRole {
    /// Moves with the skull: the head's motion only (upper teeth, upper gums).
    Skull,
    /// Moves with the jaw (lower teeth, lower gums).
    Jaw,
    /// Moves with the jaw and is shaped by the tongue's parameters.
    Tongue,
    /// Eyeballs: each turns about its own centre with the frame's gaze (FAPs 23-26, ARKit
    /// `eyeLook*`), then moves with the head.
    Eyes,
}

impl PartRole {
    pub const ALL: [PartRole; 4] = [PartRole::Skull, PartRole::Jaw, PartRole::Tongue, PartRole::Eyes];

    pub fn name(self) -> &'static str {
        match self {
            PartRole::Skull => "skull",
            PartRole::Jaw => "jaw",
            PartRole::Tongue => "tongue",
            PartRole::Eyes => "eyes",
        }
    }

    /// Whether the jaw carries it.
    pub fn moves_with_jaw(self) -> bool {
        matches!(self, PartRole::Jaw | PartRole::Tongue)
    }
}

impl fmt::Display for PartRole {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("part role {found}: expected skull, jaw, tongue or eyes")]
pub struct PartRoleError {
    pub found: String,
}

impl FromStr for PartRole {
    type Err = PartRoleError;

    fn from_str(s: &str) -> Result<PartRole, PartRoleError> {
        PartRole::ALL
            .into_iter()
            .find(|role| role.name() == s)
            .ok_or_else(|| PartRoleError {
                found: crate::quote::quote(s),
            })
    }
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PartListError {
    #[error("{count} parts; a head carries at most {MAX_PARTS}")]
    TooMany { count: usize },
    #[error("part {name:?} is given twice")]
    Duplicate { name: String },
}

/// Checks the names of a head's parts: at most [`MAX_PARTS`], none given twice.
pub fn check_part_names<'a>(names: impl ExactSizeIterator<Item = &'a str>) -> Result<(), PartListError> {
    if names.len() > MAX_PARTS {
        return Err(PartListError::TooMany { count: names.len() });
    }
    let mut seen: Vec<&str> = Vec::with_capacity(MAX_PARTS);
    for name in names {
        if seen.contains(&name) {
            return Err(PartListError::Duplicate {
                name: name.to_string(),
            });
        }
        seen.push(name);
    }
    Ok(())
}

/// A part mesh (head units, the head's frame) and its role.
#[derive(Debug, Clone)]
pub struct Part {
    /// Its name, unique on the head (`teeth_lower`).
    pub name: String,
    pub role: PartRole,
    pub mesh: Head,
    /// The part as given, when it held both rows of teeth and this is one of them.
    pub split_from: Option<String>,
    /// Its closed pieces (teeth): 0 for an open shell, which contact cannot use.
    pub closed_pieces: usize,
}

impl Part {
    pub fn new(name: String, role: PartRole, mesh: Head, split_from: Option<String>) -> Part {
        Part {
            closed_pieces: super::closed_piece_count(&mesh),
            name,
            role,
            mesh,
            split_from,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roles_read_and_print_by_name() {
        for role in PartRole::ALL {
            assert_eq!(role.name().parse::<PartRole>(), Ok(role));
        }
        assert!("teeth"
            .parse::<PartRole>()
            .unwrap_err()
            .to_string()
            .contains("skull, jaw, tongue or eyes"));
        assert!(!PartRole::Skull.moves_with_jaw() && !PartRole::Eyes.moves_with_jaw());
        assert!(PartRole::Jaw.moves_with_jaw() && PartRole::Tongue.moves_with_jaw());
    }

    #[test]
    fn part_lists_are_bounded_and_named_once() {
        assert_eq!(check_part_names(["a", "b"].into_iter()), Ok(()));
        assert_eq!(
            check_part_names(["a", "b", "a"].into_iter()),
            Err(PartListError::Duplicate { name: "a".into() })
        );
        assert_eq!(
            check_part_names(["p"; 9].into_iter()),
            Err(PartListError::TooMany { count: 9 })
        );
    }
}
