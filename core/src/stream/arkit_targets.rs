//! Which of a head's own morph targets stand for ARKit blendshapes, so an avatar that
//! ships them is driven by them ([`super::ArkitBasis::derive`]) rather than by the
//! shipped basis. Exporters name the same blendshape differently: ARKit's own names
//! (`mouthSmileLeft`, Ready Player Me, Live Link rigs), sides as `_L`/`_R` or `.L`/`.R`
//! (the ICT Face Model, Blender), a namespace before a `.`, `:` or `|` (`blendShape1.jawOpen`
//! from Maya and Apple's exports), words split by underscores (`mouth_smile_left`). And
//! some models split what ARKit keeps whole (`browInnerUp_L` and `browInnerUp_R`): both
//! halves together make the blendshape.

use glam::Vec3;

use super::blendshapes::ARKIT_BLENDSHAPES;
use crate::targets::ExpressionTarget;

/// What a morph target's name says it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ArkitTargetName {
    /// An ARKit blendshape (its index into [`ARKIT_BLENDSHAPES`]).
    Whole(u8),
    /// One side of a blendshape ARKit keeps whole (`browInnerUp_L`).
    Half { shape: u8, side: Side },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    Left,
    Right,
}

impl Side {
    fn word(self) -> &'static str {
        match self {
            Side::Left => "left",
            Side::Right => "right",
        }
    }
}

/// What a morph target named `name` stands for, if anything ARKit has.
pub fn arkit_target_name(name: &str) -> Option<ArkitTargetName> {
    let lower = name.trim().to_ascii_lowercase();
    let (stem, side) = split_side(&lower);
    let stem = stem
        .rsplit(['.', ':', '|'])
        .next()
        .unwrap_or(stem)
        .replace(['_', '-', ' '], "");
    let index = |word: &str| {
        ARKIT_BLENDSHAPES
            .iter()
            .position(|n| n.eq_ignore_ascii_case(word))
            .and_then(|i| u8::try_from(i).ok())
    };
    match side {
        None => index(&stem).map(ArkitTargetName::Whole),
        Some(side) => index(&format!("{stem}{}", side.word()))
            .map(ArkitTargetName::Whole)
            .or_else(|| index(&stem).map(|shape| ArkitTargetName::Half { shape, side })),
    }
}

/// `name` (lower case) without a one-letter side suffix (`_l`, `.r`), and the side.
fn split_side(name: &str) -> (&str, Option<Side>) {
    let Some(stem) = name.get(..name.len().saturating_sub(2)) else {
        return (name, None);
    };
    match name.get(stem.len()..) {
        Some("_l" | ".l") => (stem, Some(Side::Left)),
        Some("_r" | ".r") => (stem, Some(Side::Right)),
        _ => (name, None),
    }
}

/// A head's morph targets sorted into those that make ARKit blendshapes and those that do
/// not.
#[derive(Debug, Clone, PartialEq)]
pub struct ArkitTargets {
    /// One target per blendshape, named by ARKit's name, in ARKit's order.
    pub chosen: Vec<ExpressionTarget>,
    /// For each chosen target, the file's names it was made from (one, or two halves).
    pub made_from: Vec<Vec<String>>,
    /// The names of targets left out, each with why.
    pub left_out: Vec<(String, &'static str)>,
}

impl ArkitTargets {
    /// Sorts `targets` (a head's, head units): a target whose name is an ARKit
    /// blendshape's is that blendshape; two halves (`_L`, `_R`) of a blendshape ARKit
    /// keeps whole are summed into it. The first of two targets for the same blendshape is
    /// kept; a whole target is kept over halves; a lone half is left out.
    pub fn sort(targets: Vec<ExpressionTarget>) -> ArkitTargets {
        let mut whole: [Option<(ExpressionTarget, String)>; 52] = std::array::from_fn(|_| None);
        let mut halves: [[Option<ExpressionTarget>; 2]; 52] = std::array::from_fn(|_| [None, None]);
        let mut left_out = Vec::new();
        for target in targets {
            match arkit_target_name(&target.name) {
                None => left_out.push((target.name, "not named like an ARKit blendshape")),
                Some(ArkitTargetName::Whole(shape)) => {
                    let slot = &mut whole[usize::from(shape)];
                    if slot.is_some() {
                        left_out.push((target.name, "a second target for the same ARKit blendshape"));
                    } else {
                        let name = target.name.clone();
                        *slot = Some((target, name));
                    }
                }
                Some(ArkitTargetName::Half { shape, side }) => {
                    let slot = &mut halves[usize::from(shape)][side as usize];
                    if slot.is_some() {
                        left_out.push((target.name, "a second target for the same side"));
                    } else {
                        *slot = Some(target);
                    }
                }
            }
        }
        let mut sorted = ArkitTargets {
            chosen: Vec::new(),
            made_from: Vec::new(),
            left_out,
        };
        for (shape, (whole, [left, right])) in whole.into_iter().zip(halves).enumerate() {
            let arkit_name = ARKIT_BLENDSHAPES[shape];
            match (whole, left, right) {
                (Some((target, name)), left, right) => {
                    for half in [left, right].into_iter().flatten() {
                        sorted
                            .left_out
                            .push((half.name, "its ARKit blendshape has a whole target"));
                    }
                    sorted.chosen.push(renamed(target, arkit_name));
                    sorted.made_from.push(vec![name]);
                }
                (None, Some(left), Some(right)) => {
                    sorted.made_from.push(vec![left.name.clone(), right.name.clone()]);
                    sorted.chosen.push(summed(arkit_name, &left, &right));
                }
                (None, Some(half), None) | (None, None, Some(half)) => {
                    sorted
                        .left_out
                        .push((half.name, "one half of an ARKit blendshape without the other"));
                }
                (None, None, None) => {}
            }
        }
        sorted
    }
}

fn renamed(target: ExpressionTarget, name: &str) -> ExpressionTarget {
    ExpressionTarget {
        name: name.to_string(),
        ..target
    }
}

/// `a + b`, vertex by vertex (two halves of one head's targets: the same vertex count).
fn summed(name: &str, a: &ExpressionTarget, b: &ExpressionTarget) -> ExpressionTarget {
    let count = a.displacements.len().max(b.displacements.len());
    let at = |t: &ExpressionTarget, v: usize| t.displacements.get(v).copied().unwrap_or(Vec3::ZERO);
    ExpressionTarget::from_displacements(name, (0..count).map(|v| at(a, v) + at(b, v)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stream::arkit_index;

    fn whole(name: &str) -> Option<ArkitTargetName> {
        arkit_index(name).map(ArkitTargetName::Whole)
    }

    #[test]
    fn exporters_names_are_read_as_arkit_blendshapes() {
        assert_eq!(arkit_target_name("jawOpen"), whole("jawOpen"));
        assert_eq!(arkit_target_name("JAWOPEN"), whole("jawOpen"));
        assert_eq!(arkit_target_name("mouthSmile_L"), whole("mouthSmileLeft"));
        assert_eq!(arkit_target_name("mouthSmile.R"), whole("mouthSmileRight"));
        assert_eq!(
            arkit_target_name("blendShape1.mouthSmile_L"),
            whole("mouthSmileLeft")
        );
        assert_eq!(
            arkit_target_name("head_geo:eyeBlinkRight"),
            whole("eyeBlinkRight")
        );
        assert_eq!(arkit_target_name("mouth_smile_left"), whole("mouthSmileLeft"));
        assert_eq!(
            arkit_target_name("browInnerUp_L"),
            Some(ArkitTargetName::Half {
                shape: arkit_index("browInnerUp").unwrap(),
                side: Side::Left
            })
        );
        assert_eq!(
            arkit_target_name("cheekPuff_R"),
            Some(ArkitTargetName::Half {
                shape: arkit_index("cheekPuff").unwrap(),
                side: Side::Right
            })
        );
        for not_arkit in ["smile", "", "_L", "jawOpenWide", "viseme_aa", "jawOpen_X"] {
            assert_eq!(arkit_target_name(not_arkit), None, "{not_arkit:?}");
        }
    }

    fn target(name: &str, moves: &[(usize, f32)]) -> ExpressionTarget {
        let mut d = vec![Vec3::ZERO; 4];
        for &(v, x) in moves {
            d[v] = Vec3::new(x, 0.0, 0.0);
        }
        ExpressionTarget::from_displacements(name, d)
    }

    #[test]
    fn halves_are_summed_and_the_rest_is_said() {
        let sorted = ArkitTargets::sort(vec![
            target("browInnerUp_R", &[(1, 2.0), (2, 1.0)]),
            target("smile", &[(0, 1.0)]),
            target("jawOpen", &[(3, 1.0)]),
            target("cheekPuff_L", &[(0, 1.0)]),
            target("browInnerUp_L", &[(0, 3.0), (2, 0.5)]),
            target("JawOpen", &[(3, 9.0)]),
        ]);
        let names: Vec<&str> = sorted.chosen.iter().map(|t| t.name.as_str()).collect();
        // ARKit's order: jawOpen (17) before browInnerUp (43).
        assert_eq!(names, ["jawOpen", "browInnerUp"]);
        assert_eq!(sorted.chosen[0].displacements[3].x, 1.0);
        let brow: Vec<f32> = sorted.chosen[1].displacements.iter().map(|d| d.x).collect();
        assert_eq!(brow, [3.0, 2.0, 1.5, 0.0]);
        assert_eq!(sorted.chosen[1].listed, [0, 1, 2]);
        assert_eq!(
            sorted.made_from,
            [
                vec!["jawOpen".to_string()],
                vec!["browInnerUp_L".into(), "browInnerUp_R".into()]
            ]
        );
        let left_out: Vec<&str> = sorted.left_out.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(left_out, ["smile", "JawOpen", "cheekPuff_L"]);
    }
}
