//! The 52 ARKit blendshape names, in the order every format that carries ARKit weights by
//! index uses (frames' `arkit` lists, FWP1, the retarget basis).

/// The 52 ARKit blendshapes in Apple's documented order (`ARFaceAnchor.BlendShapeLocation`:
/// left eye, right eye, jaw, mouth, brows, cheeks, nose, tongue), which is also the order
/// of Unreal's `EARFaceBlendShape` and Live Link Face. A frame's `arkit` entries index it.
pub const ARKIT_BLENDSHAPES: [&str; 52] = [
    "eyeBlinkLeft",
    "eyeLookDownLeft",
    "eyeLookInLeft",
    "eyeLookOutLeft",
    "eyeLookUpLeft",
    "eyeSquintLeft",
    "eyeWideLeft",
    "eyeBlinkRight",
    "eyeLookDownRight",
    "eyeLookInRight",
    "eyeLookOutRight",
    "eyeLookUpRight",
    "eyeSquintRight",
    "eyeWideRight",
    "jawForward",
    "jawLeft",
    "jawRight",
    "jawOpen",
    "mouthClose",
    "mouthFunnel",
    "mouthPucker",
    "mouthLeft",
    "mouthRight",
    "mouthSmileLeft",
    "mouthSmileRight",
    "mouthFrownLeft",
    "mouthFrownRight",
    "mouthDimpleLeft",
    "mouthDimpleRight",
    "mouthStretchLeft",
    "mouthStretchRight",
    "mouthRollLower",
    "mouthRollUpper",
    "mouthShrugLower",
    "mouthShrugUpper",
    "mouthPressLeft",
    "mouthPressRight",
    "mouthLowerDownLeft",
    "mouthLowerDownRight",
    "mouthUpperUpLeft",
    "mouthUpperUpRight",
    "browDownLeft",
    "browDownRight",
    "browInnerUp",
    "browOuterUpLeft",
    "browOuterUpRight",
    "cheekPuff",
    "cheekSquintLeft",
    "cheekSquintRight",
    "noseSneerLeft",
    "noseSneerRight",
    "tongueOut",
];

/// Index of an ARKit blendshape by name, case-insensitively (`jawOpen` -> 17).
pub fn arkit_index(name: &str) -> Option<u8> {
    ARKIT_BLENDSHAPES
        .iter()
        .position(|n| n.eq_ignore_ascii_case(name))
        .and_then(|i| u8::try_from(i).ok())
}

/// An ARKit `eyeLook*` weight of 1 turns the eye this far, radians (30 degrees). Apple
/// documents the weights (0 to 1) but no angle; 30 degrees is about where people turn
/// the head rather than the eyes alone, so a full weight is a wide, natural look.
pub const ARKIT_LOOK_RAD: f32 = std::f32::consts::PI / 6.0;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arkit_table_is_apples_order() {
        assert_eq!(ARKIT_BLENDSHAPES.len(), 52);
        assert_eq!(arkit_index("jawOpen"), Some(17));
        assert_eq!(arkit_index("JAWOPEN"), Some(17));
        assert_eq!(arkit_index("browDownLeft"), Some(41));
        assert_eq!(arkit_index("tongueOut"), Some(51));
        assert_eq!(arkit_index("smile"), None);
        let mut sorted = ARKIT_BLENDSHAPES.to_vec();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), 52);
    }
}
