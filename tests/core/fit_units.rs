//! A fit does not depend on the unit a head is written in: the same head in millimetres,
//! metres or inches gets the same mask, scaled. The solver's ridge on the shape units is
//! weighed in mask units (docs/FITTING.md), so the landmark fit is exact to rounding; the
//! automatic fit also guesses the unit and searches on grids sized from the head, so it is
//! held to a bound.

use facewire::fit::{fit_automatically, fit_from_landmarks, Fit, FittedMask, Landmarks};
use facewire::head::Head;
use facewire::mask::Mask;

use super::automatic_fit::HEADS;

/// Unit changes a user's file may come in: to millimetres and metres from centimetres, and
/// to inches; also 1000 and 1/1000 beyond them.
const FACTORS: [f32; 5] = [10.0, 0.01, 1.0 / 2.54, 1000.0, 0.001];

fn scaled(head: &Head, factor: f32) -> Head {
    Head::new(
        &head.name,
        head.positions.iter().map(|&p| p * factor).collect(),
        head.triangles.clone(),
    )
}

/// Mean and largest distance (mm at `mm_per_unit`) between `fit`'s mask and the mask of
/// `scaled_fit` brought back by `1 / factor`.
fn apart_mm(fit: &Fit, scaled_fit: &Fit, factor: f32, mm_per_unit: f32) -> (f32, f32) {
    let mask = Mask::candide3();
    let here = FittedMask::new(mask.clone(), fit.clone()).neutral;
    let there = FittedMask::new(mask.clone(), scaled_fit.clone()).neutral;
    let used = mask.used_vertices();
    let distances: Vec<f32> = used
        .iter()
        .map(|&v| here[v as usize].distance(there[v as usize] / factor) * mm_per_unit)
        .collect();
    let mean = distances.iter().sum::<f32>() / distances.len() as f32;
    (mean, distances.iter().copied().fold(0.0, f32::max))
}

/// The landmark fit of every shipped head, in every unit, is the same mask to 10 µm (f32
/// rounding: measured at most 2.7 µm, MakeHuman at a thousandth of its unit).
/// Before the ridge was weighed in mask units the joint refinement weighed it in head
/// units: MakeHuman's mask in metres lay up to 11 mm from its mask in its own unit.
#[test]
fn a_landmark_fit_is_the_same_in_any_unit() {
    let mask = Mask::candide3();
    let mut failures = Vec::new();
    for (obj, landmarks) in HEADS {
        let head = Head::load(&crate::common::data(obj)).unwrap();
        let landmarks = Landmarks::load(&crate::common::data(landmarks)).unwrap();
        let fit = fit_from_landmarks(&head, &landmarks, "landmarks", &mask)
            .unwrap()
            .fit;
        for factor in FACTORS {
            let found = fit_from_landmarks(&scaled(&head, factor), &landmarks, "landmarks", &mask)
                .unwrap()
                .fit;
            let (mean, worst) = apart_mm(&fit, &found, factor, fit.mm_per_unit);
            if worst > 1e-2 {
                failures.push(format!(
                    "{obj} x{factor}: {mean:.4} mm on average, {worst:.4} at most"
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// The automatic fit of the ICT head in millimetres, metres and inches lies within
/// `UNIT_MEAN_MM` of its fit in centimetres, and the other shipped heads in metres (or a
/// thousandth of their unit) within the same of their own. Before the ridge was weighed
/// in mask units the ICT head in metres was fitted 1.86 mm from its surface against
/// 0.61 mm in centimetres.
#[test]
fn an_automatic_fit_is_the_same_in_any_unit() {
    let mask = Mask::candide3();
    let mut failures = Vec::new();
    for (obj, factors) in [
        (HEADS[2].0, &[10.0, 0.01, 1.0 / 2.54][..]),
        (HEADS[0].0, &[0.001][..]),
        (HEADS[1].0, &[0.001][..]),
        (HEADS[3].0, &[0.01][..]),
        (HEADS[4].0, &[10.0][..]),
    ] {
        let head = Head::load(&crate::common::data(obj)).unwrap();
        let fit = fit_automatically(&head, &mask, None).unwrap().fit;
        for &factor in factors {
            let found = fit_automatically(&scaled(&head, factor), &mask, None)
                .unwrap_or_else(|e| panic!("{obj} x{factor}: {e}"))
                .fit;
            let (mean, worst) = apart_mm(&fit, &found, factor, fit.mm_per_unit);
            eprintln!("{obj} x{factor}: the mask {mean:.2} mm (at most {worst:.2}) from its own unit's");
            if mean > UNIT_MEAN_MM {
                failures.push(format!(
                    "{obj} x{factor}: {mean:.3} mm on average, {worst:.3} at most"
                ));
            }
            let ratio = found.mm_per_unit * factor / fit.mm_per_unit;
            if !(0.99..1.01).contains(&ratio) {
                failures.push(format!(
                    "{obj} x{factor}: the unit guessed {ratio} times as large"
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// How far (mm, mean over the mask) a head's automatic fit in another unit may lie from
/// its fit in its own: measured 0.23 mm at most (ICT in metres and in inches). The fit is
/// not exactly invariant: its pictures' cells are sized from the head and fall elsewhere
/// on it, and a 0.1 % rescale alone moves a fit's worst vertex by up to 0.9 mm.
const UNIT_MEAN_MM: f32 = 0.5;
