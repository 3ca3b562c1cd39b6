use facewire::deform::Registration;
use facewire::fit::FittedMask;
use facewire::mask::{Mask, LIP_VERTICES};
use facewire::population::{self, Maker};

#[test]
#[ignore]
fn corner_anchor_compression() {
    let maker = Maker::new(&crate::common::repo_path("data")).unwrap();
    let mask = Mask::candide3();
    let names = [
        "ict generic",
        "ict seed 4 ",
        "ict seed 6 ",
        "ict seed 27 ",
        "ict seed 21 ",
        "ict seed 8 ",
        "ict seed 31 ",
    ];
    for spec in population::whole_heads()
        .into_iter()
        .filter(|m| names.iter().any(|n| m.name().starts_with(n)))
    {
        let member = maker.make(&spec).unwrap();
        let fit = member.landmark_fit.clone().unwrap();
        let reg = Registration::try_new(member.head.clone(), FittedMask::new(mask.clone(), fit)).unwrap();
        let mm = reg.mm_per_unit();
        let mut edges = std::collections::BTreeSet::new();
        for t in &mask.triangles {
            for k in 0..3 {
                let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
                if LIP_VERTICES.contains(&a) || LIP_VERTICES.contains(&b) {
                    edges.insert((a.min(b), a.max(b)));
                }
            }
        }
        let mut rows: Vec<(f32, usize, usize, f32, f32)> = edges
            .iter()
            .map(|&(a, b)| {
                let dm = reg.mask_rest()[a].distance(reg.mask_rest()[b]) * mm;
                let ha = reg.head.positions[reg.anchors.vertex[a] as usize];
                let hb = reg.head.positions[reg.anchors.vertex[b] as usize];
                let dh = ha.distance(hb) * mm;
                (dh / dm, a, b, dm, dh)
            })
            .collect();
        rows.sort_by(|x, y| x.0.total_cmp(&y.0));
        eprintln!("== {}", spec.name());
        for r in rows.iter().take(6) {
            eprintln!(
                "  {}-{}: mask {:.2} mm, anchors {:.2} mm, ratio {:.2}",
                r.1, r.2, r.3, r.4, r.0
            );
        }
    }
}
