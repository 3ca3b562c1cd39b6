//! MPEG-4's high-level expression (FAP 2) as input: two of the standard's six expressions
//! (joy, sadness, anger, fear, disgust, surprise), each with an intensity, move the mask
//! through a table of CANDIDE-3 animation-unit shapes, the way FAP 1's visemes do
//! ([`super::visemes`]). docs/STREAMS.md, "Expressions", has the table.

use super::frame::ExpressionFap;

/// The animation units the expressions use, by index in CANDIDE-3.1.6: upper_lip_raiser
/// (0), jaw_drop (1), lip_stretcher (2), brow_lowerer (3), lip_corner_depressor (4),
/// outer_brow_raiser (5), eyes_closed (6), lid_tightener (7), nose_wrinkler (8),
/// lip_presser (9), upper_lid_raiser (10), and the mouth corners' raise, FAPs 12 and 13
/// (units 20 and 21, mask units).
pub const EXPRESSION_UNITS: [u16; 13] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 20, 21];

/// One MPEG-4 expression at full intensity: its number (`expression_select`), name, and
/// the weight of each of [`EXPRESSION_UNITS`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Expression {
    pub number: u8,
    pub name: &'static str,
    pub shape: [f32; 13],
}

/// The expressions, indexed by `expression_select` (0 is neutral), after the standard's
/// descriptions (ISO/IEC 14496-2, table C.3) in CANDIDE's units.
#[rustfmt::skip]
pub const EXPRESSIONS: [Expression; 7] = [
    //                                                 uplip jaw  stretch brow_lo corner_dn brow_out eyes_cl lid_ti nose  press  lid_up c12   c13
    Expression { number: 0, name: "neutral",  shape: [0.0,  0.0,  0.0,  0.0,  0.0,  0.0,  0.0,  0.0,  0.0,  0.0,  0.0,  0.0,   0.0] },
    // The mouth's corners pulled back and up, the cheeks lifting the lower lids.
    Expression { number: 1, name: "joy",      shape: [0.10, 0.05, 0.45, 0.0,  0.0,  0.0,  0.0,  0.25, 0.0,  0.0,  0.0,  0.025, 0.025] },
    // The inner brows drawn up and together, lids drooping, corners down.
    Expression { number: 2, name: "sadness",  shape: [0.0,  0.0,  0.0,  0.30, 0.18, -0.3, 0.15, 0.0,  0.0,  0.0,  0.0,  0.0,   0.0] },
    // Brows down and together, lids tight and eyes staring, lips pressed.
    Expression { number: 3, name: "anger",    shape: [0.0,  0.0,  0.0,  0.60, 0.05, 0.0,  0.0,  0.40, 0.0,  0.45, 0.30, 0.0,   0.0] },
    // Brows raised, eyes wide, mouth open with the lips stretched back.
    Expression { number: 4, name: "fear",     shape: [0.0,  0.15, 0.35, 0.0,  0.05, 0.60, 0.0,  0.0,  0.0,  0.0,  0.60, 0.0,   0.0] },
    // The upper lip raised, the nose wrinkled, brows lowered.
    Expression { number: 5, name: "disgust",  shape: [0.30, 0.0,  0.0,  0.35, 0.10, 0.0,  0.0,  0.20, 0.70, 0.0,  0.0,  0.0,   0.0] },
    // Brows high, eyes wide, the jaw dropped.
    Expression { number: 6, name: "surprise", shape: [0.0,  0.35, 0.0,  0.0,  0.0,  0.90, 0.0,  0.0,  0.0,  0.0,  0.70, 0.0,   0.0] },
];

/// Adds FAP 2's expressions to the animation-unit weights `out` (one slot per unit):
/// `intensity1 / 63` of expression `select1` plus `intensity2 / 63` of `select2`, the
/// intensities clamped to 0..=63. A frame that defines an expression (`definition` 1)
/// adds nothing, nor does a select outside 0..=6. `init_face` is not used: facewire's
/// neutral face is the registered head. Allocates nothing.
pub fn add_expression(expression: &ExpressionFap, out: &mut [f32]) {
    if expression.definition != 0 {
        return;
    }
    for (select, intensity) in [
        (expression.select1, expression.intensity1),
        (expression.select2, expression.intensity2),
    ] {
        let Some(shape) = usize::try_from(select).ok().and_then(|i| EXPRESSIONS.get(i)) else {
            continue;
        };
        let share = intensity.clamp(0, 63) as f32 / 63.0;
        for (&unit, weight) in EXPRESSION_UNITS.iter().zip(shape.shape) {
            if let Some(slot) = out.get_mut(usize::from(unit)) {
                *slot += share * weight;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mask::Mask;

    fn expression(select1: i32, intensity1: i32, select2: i32, intensity2: i32) -> ExpressionFap {
        ExpressionFap {
            select1,
            intensity1,
            select2,
            intensity2,
            init_face: 0,
            definition: 0,
        }
    }

    #[test]
    fn the_units_are_candides() {
        let mask = Mask::candide3();
        let keys: Vec<&str> = EXPRESSION_UNITS
            .iter()
            .map(|&u| mask.animation_units[usize::from(u)].key.as_str())
            .collect();
        assert_eq!(
            keys,
            [
                "upper_lip_raiser",
                "jaw_drop",
                "lip_stretcher",
                "brow_lowerer",
                "lip_corner_depressor",
                "outer_brow_raiser",
                "eyes_closed",
                "lid_tightener",
                "nose_wrinkler",
                "lip_presser",
                "upper_lid_raiser",
                "fap12_raise_l_cornerlip",
                "fap13_raise_r_cornerlip",
            ]
        );
        for (i, e) in EXPRESSIONS.iter().enumerate() {
            assert_eq!(usize::from(e.number), i);
        }
    }

    #[test]
    fn two_expressions_add_by_their_intensities() {
        let mut out = [0.0; 65];
        // Full joy and a third of surprise.
        add_expression(&expression(1, 63, 6, 21), &mut out);
        assert_eq!(out[2], 0.45);
        assert!((out[1] - (0.05 + 0.35 / 3.0)).abs() < 1e-6, "{}", out[1]);
        assert!((out[5] - 0.9 / 3.0).abs() < 1e-6, "{}", out[5]);
        assert_eq!(out[20], 0.025);
        // Neutral, out of range, or a definition: nothing.
        for fap in [
            expression(0, 63, 0, 63),
            expression(7, 63, -1, 63),
            ExpressionFap {
                definition: 1,
                ..expression(1, 63, 2, 63)
            },
        ] {
            let mut out = [0.0; 65];
            add_expression(&fap, &mut out);
            assert!(out.iter().all(|&w| w == 0.0), "{fap:?}");
        }
        // Intensities beyond 63 count as 63.
        let mut out = [0.0; 65];
        add_expression(&expression(3, 200, 0, 0), &mut out);
        assert_eq!(out[3], 0.6);
    }
}
