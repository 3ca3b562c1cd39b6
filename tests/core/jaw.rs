//! The jaw: a rigid motion per frame derived from the mask's motion, which carries the
//! parts that move with it. Ground truth: the ICT Face Model's jaw targets move its lower
//! teeth rigidly (`jawOpen` 25 degrees); driving the ICT head with each target at the
//! anchors, as the ground-truth comparison does, must put the lower teeth within 1 mm RMS
//! of the target's teeth.

use crate::common::{data, register};

use facewire::animate::jaw_motion;
use facewire::head::Head;
use facewire::targets::ExpressionTarget;
use glam::Vec3;

#[test]
fn the_jaw_targets_put_the_lower_teeth_within_a_millimetre() {
    let reg = register("ict_head");
    let teeth = Head::load(&data("heads/ict_head_teeth_lower.obj")).unwrap();
    let mm = reg.mm_per_unit();
    let mut controls = vec![Vec3::ZERO; reg.mask_rest().len()];
    for name in ["jawOpen", "jawLeft", "jawRight", "jawForward"] {
        let skin = ExpressionTarget::load(
            &data(&format!("heads/ict_targets/skin/{name}.target")),
            reg.vertex_count(),
        )
        .unwrap();
        let truth = ExpressionTarget::load(
            &data(&format!("heads/ict_targets/teeth_lower/{name}.target")),
            teeth.positions.len(),
        )
        .unwrap();
        skin.controls_into(&reg.anchors, 1.0, &mut controls).unwrap();
        let mask_now: Vec<Vec3> = reg
            .mask_rest()
            .iter()
            .zip(&controls)
            .map(|(r, d)| *r + *d)
            .collect();
        let jaw = jaw_motion(reg.mask_rest(), &mask_now, &reg.fitted.fit.pose);
        let mut expected = vec![Vec3::ZERO; teeth.positions.len()];
        truth.apply_into(&teeth.positions, 1.0, &mut expected).unwrap();
        let (mut squared, mut moved) = (0.0f64, 0.0f64);
        for (p, e) in teeth.positions.iter().zip(&expected) {
            squared += f64::from(jaw.apply(*p).distance_squared(*e));
            moved += f64::from(p.distance_squared(*e));
        }
        let n = teeth.positions.len() as f64;
        let rms = (squared / n).sqrt() * f64::from(mm);
        let still = (moved / n).sqrt() * f64::from(mm);
        eprintln!(
            "{name}: lower teeth {rms:.2} mm RMS from the target's (they move {still:.2} mm RMS); jaw turns {:.1} deg",
            jaw.rotation.angle_between(glam::Quat::IDENTITY).to_degrees()
        );
        assert!(rms < 1.0, "{name}: {rms} mm RMS");
    }
}
