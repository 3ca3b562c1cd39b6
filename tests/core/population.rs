//! The automatic fit on the CI sample of the head population (`facewire population
//! --sample`: a third of the development members, a quarter of the held-out ones; ICT
//! identities, MakeHuman, the scan, face cuts, a low-poly face, other axes, turned,
//! mirrored and rescaled heads). docs/FITTING.md, "On a population", has the whole
//! population's table and the goals; this test holds the sample's figures as measured, so
//! that a change that makes them worse fails here.

use facewire::mask::Mask;
use facewire::population::{self, Maker};

/// The sample's figures as measured (27 members; see docs/FITTING.md): none refused and
/// none more than 5 mm (mean) from the reference since the learned reading reads the face
/// (5 and 2 with the rules alone), the median of the means 1.42 mm since the learned marks
/// combine many face-mesh points (2.64 with one point a mark; 2.27 with the rules alone,
/// over the 22 they did not refuse), 25 within 3 mm (20 with one point a mark). The goal of
/// none over 3 mm is not met yet.
const MAX_MEDIAN_MM: f32 = 1.5;
const MIN_WITHIN_3_MM: usize = 25;

/// The shipped heads in the sample and how far they may land from their landmark fits
/// (mm): MakeHuman's landmarks were picked by hand and mark its alar wings and eye corners
/// 4-6 mm from where the learned marks, trained mostly on ICT identities marked at the ICT
/// Face Model's own Multi-PIE indices, put them (3.43 mm measured; 2.24 before the marks
/// took many points).
const SHIPPED_HEADS_MM: [(&str, f32); 3] = [("makehuman", 3.6), ("scan", 2.0), ("ict generic", 1.0)];

/// The widest the sample's lips may be read apart at rest (mm).
const MAX_LIPS_APART_MM: f32 = 5.0;

#[test]
fn the_population_sample_is_fitted_as_measured() {
    let maker = Maker::new(&crate::common::repo_path("data")).unwrap();
    let mask = Mask::candide3();
    let sample = population::sample();
    assert!(sample.len() >= 20, "{} members", sample.len());
    let mut outcomes = Vec::new();
    for spec in &sample {
        let member = maker.make(spec).unwrap();
        let outcome = population::measure(&member, &mask);
        match &outcome.result {
            Ok(m) => eprintln!(
                "{}: {:.2} mm (max {:.1}), scale {:+.1} %, lips {:.2} mm apart",
                outcome.member,
                m.landmark_mean_mm,
                m.landmark_max_mm,
                100.0 * m.scale_error,
                m.lips_apart_mm
            ),
            // A refusal names the head it refuses.
            Err(e) => {
                eprintln!("{}: refused: {e}", outcome.member);
                assert!(e.starts_with(&outcome.member), "{e}");
            }
        }
        outcomes.push(outcome);
    }
    let refused = outcomes.iter().filter(|o| o.result.is_err()).count();
    let mut means: Vec<f32> = outcomes
        .iter()
        .filter_map(|o| o.result.as_ref().ok().map(|m| m.landmark_mean_mm))
        .collect();
    means.sort_by(f32::total_cmp);
    let over_5 = means.iter().filter(|&&m| m > 5.0).count();
    let within_3 = means.iter().filter(|&&m| m <= 3.0).count();
    let median = means[means.len() / 2];
    eprintln!(
        "{refused} refused of {}, {over_5} over 5 mm, {within_3} within 3 mm, median {median:.2} mm",
        outcomes.len()
    );
    // No member's mouth is open at rest: the ICT identities' lips stand up to 2.7 mm apart
    // (seed 63, a gap one sees through on the midline; the generic head's 0.5 mm), which
    // registration closes. A reading of tens of millimetres is the fit's error: seed 34's
    // read 43 mm against its nose before the lips' depth was the mask's.
    let apart: Vec<String> = outcomes
        .iter()
        .filter_map(|o| o.result.as_ref().ok().map(|m| (o, m)))
        .filter(|(_, m)| m.lips_apart_mm > MAX_LIPS_APART_MM)
        .map(|(o, m)| format!("{}: {:.1} mm", o.member, m.lips_apart_mm))
        .collect();
    assert!(apart.is_empty(), "lips read apart at rest: {apart:?}");
    assert_eq!(refused, 0, "refused");
    assert_eq!(over_5, 0, "over 5 mm");
    assert!(median <= MAX_MEDIAN_MM, "median {median} mm");
    assert!(within_3 >= MIN_WITHIN_3_MM, "{within_3} within 3 mm");
    for (name, within_mm) in SHIPPED_HEADS_MM {
        for o in outcomes.iter().filter(|o| o.member == name) {
            let m = o.result.as_ref().unwrap_or_else(|e| panic!("{e}"));
            assert!(
                m.landmark_mean_mm < within_mm,
                "{name}: {:.2} mm (worst mask vertex {}, {:.1} mm)",
                m.landmark_mean_mm,
                m.worst_vertex,
                m.landmark_max_mm
            );
        }
    }
}

/// The animation goals the CI sample of whole heads holds (`facewire population --animate
/// --sample`, landmark fits, the default algorithm): no lip vertex enters the teeth
/// beyond what the head has at rest, the tongue at most this deep in them (mm).
const MAX_TONGUE_DEPTH_MM: f32 = 0.5;
/// Lip folds are not solved on every head yet (docs/METRICS.md, "On a population"): the
/// sample's sum over its heads as measured on the syllable stream timed by its voice, so
/// that a change that adds folds fails. Seeds 11, 21 and 1001 fold 54, 103 and 74 lip
/// triangle-frames with V smoothed over the lips (130, 488 and 281 before it; seed 1006,
/// 103 before, folds nowhere now). The goal is 0.
const MAX_SAMPLE_LIP_FOLDS: u64 = 231;

/// Animates `spec`'s whole head from its landmark fit through the syllable stream with
/// the default algorithm (`facewire population --animate`'s row), with whether it has
/// parts.
fn animate_whole_head(
    maker: &Maker,
    spec: &population::MemberSpec,
) -> (String, bool, facewire::report::AnimationMeasures) {
    let data = crate::common::repo_path("data");
    let algorithm = facewire::report::parse_algorithms(facewire::deform::spec::DEFAULT_ALGORITHM)
        .unwrap()
        .remove(0);
    let member = maker.make(spec).unwrap();
    let targets = spec.source.targets_dir().map_or(Vec::new(), |dir| {
        facewire::targets::ExpressionTarget::load_dir(
            &data.join("heads").join(dir),
            member.head.positions.len(),
        )
        .unwrap()
    });
    let outcome = facewire::report::animate(
        &member,
        facewire::report::FitSource::Landmarks,
        &Mask::candide3(),
        &data.join("streams/syllables.jsonl"),
        &algorithm,
        &targets,
    );
    let m = outcome
        .result
        .unwrap_or_else(|e| panic!("{}: {e}", outcome.member));
    eprintln!("{}: {m:?}", outcome.member);
    (outcome.member, !member.parts.is_empty(), m)
}

/// The whole heads whose names start with each of `names`, one each.
fn whole_heads_named(names: &[&str]) -> Vec<population::MemberSpec> {
    let heads: Vec<_> = population::whole_heads()
        .into_iter()
        .filter(|m| names.iter().any(|n| m.name().starts_with(n)))
        .collect();
    assert_eq!(heads.len(), names.len(), "{names:?}");
    heads
}

#[test]
fn the_whole_heads_animate_within_the_contact_goals() {
    let maker = Maker::new(&crate::common::repo_path("data")).unwrap();
    let sample = population::whole_heads_sample();
    assert!(sample.len() >= 8, "{} heads", sample.len());
    let mut lip_folds = 0;
    for spec in &sample {
        let (member, has_parts, m) = animate_whole_head(&maker, spec);
        lip_folds += m.lip_folds;
        if !has_parts {
            assert_eq!(m.lips_in_teeth, None, "{member}");
            continue;
        }
        assert_eq!(m.split_parts, ["teeth"], "{member}");
        assert_eq!(m.lips_in_teeth, Some(0), "{member}");
        // Both eyeballs found on every identity, and no lid left in one through 20 s of
        // blinks and glances (the lids enter them without the constraint).
        assert_eq!(m.eyes, 2, "{member}");
        assert_eq!(m.lids_in_eyes, Some(0), "{member}");
        assert!(m.lids_in_eyes_unconstrained.is_some(), "{member}");
        let depth = m.tongue_depth_mm.unwrap();
        assert!(
            depth <= MAX_TONGUE_DEPTH_MM,
            "{member}: tongue {depth} mm in the teeth"
        );
        let gap = m.fv_gap_mm.unwrap();
        assert!(gap <= MAX_FV_GAP_MM, "{member}: f/v gap {gap} mm");
        let truth = m.ground_truth_rms_mm.unwrap();
        assert!(truth < 0.7, "{member}: ground truth {truth} mm");
    }
    eprintln!("{lip_folds} lip folds over the sample");
    assert!(lip_folds <= MAX_SAMPLE_LIP_FOLDS, "{lip_folds} lip folds");
}

/// The goal: on every f and v the lower lip comes within this of the upper teeth (mm).
const MAX_FV_GAP_MM: f64 = 1.5;

/// The identities whose lower lip stopped farthest short of the upper teeth on f before
/// the labiodental contact (landmark fits: seed 27 by 2.90 mm, held-out seed 1007 by
/// 2.62 mm) meet them now.
#[test]
fn the_lower_lip_meets_the_upper_teeth_on_f_where_it_stopped_short() {
    let maker = Maker::new(&crate::common::repo_path("data")).unwrap();
    let heads = whole_heads_named(&["ict seed 27 ", "ict seed 1007 "]);
    for spec in &heads {
        let (member, _, m) = animate_whole_head(&maker, spec);
        // At the contact's 0.2 mm margin (measured 0.200 and 0.201: the frame nearest the
        // teeth asks for a little less than the full labiodental shape), far inside the goal.
        let gap = m.fv_gap_mm.unwrap();
        assert!(gap <= 0.21, "{member}: f/v gap {gap} mm");
        assert_eq!(
            m.lips_in_teeth,
            Some(0),
            "{member}: the pull leaves no lip in the teeth"
        );
    }
}

/// The identities whose mouth corners folded most under the unsmoothed field (landmark
/// fits: seed 6 on 1,378 lip triangle-frames, sharpest 153 degrees; held-out seed 1004 on
/// 424, where needle triangles turned too) fold nowhere with the field smoothed over the
/// lips and the needles bound to their long edges (docs/ALGORITHMS.md, "Biharmonic").
#[test]
fn the_mouth_corners_that_folded_most_fold_no_more() {
    let maker = Maker::new(&crate::common::repo_path("data")).unwrap();
    let heads = whole_heads_named(&["ict seed 6 ", "ict seed 1004 "]);
    for spec in &heads {
        let (member, _, m) = animate_whole_head(&maker, spec);
        assert_eq!(m.lip_folds, 0, "{member}: sharpest {} degrees", m.fold_deg);
        // The smoothing costs the ground truth about 0.01 mm (measured 0.514 and 0.519).
        let truth = m.ground_truth_rms_mm.unwrap();
        assert!(truth < 0.53, "{member}: ground truth {truth} mm");
    }
}

/// The identities whose landmark fits anchored part of the mask's lower lip on the upper
/// lip (seed 32: 1,230 lip triangle-frames past 60 degrees, sharpest 143; seed 4: 493,
/// 179) fold nowhere with each lip's anchors kept to their own lip (docs/FITTING.md,
/// "Anchors, and the lips"), and come nearer the ICT targets (measured 0.600 and 0.554 mm,
/// 0.616 and 0.588 before).
#[test]
fn lips_anchored_on_their_own_lip_fold_nowhere() {
    let maker = Maker::new(&crate::common::repo_path("data")).unwrap();
    for (spec, max_truth) in whole_heads_named(&["ict seed 4 ", "ict seed 32 "])
        .iter()
        .zip([0.56, 0.61])
    {
        let (member, _, m) = animate_whole_head(&maker, spec);
        assert_eq!(m.lip_folds, 0, "{member}: sharpest {} degrees", m.fold_deg);
        let truth = m.ground_truth_rms_mm.unwrap();
        assert!(truth < max_truth, "{member}: ground truth {truth} mm");
    }
}

/// The identities whose tongue went deepest into the teeth (landmark fits: seed 2 0.51 mm,
/// seed 39 0.54 mm, the neighbours of the contact's last round of pushes) stay within the
/// goal, 0.5 mm.
#[test]
fn the_tongue_that_went_deepest_stays_within_half_a_millimetre_of_the_teeth() {
    let maker = Maker::new(&crate::common::repo_path("data")).unwrap();
    for spec in &whole_heads_named(&["ict seed 2 ", "ict seed 39 "]) {
        let (member, _, m) = animate_whole_head(&maker, spec);
        let depth = m.tongue_depth_mm.unwrap();
        assert!(depth <= 0.5, "{member}: tongue {depth} mm in the teeth");
    }
}

#[test]
fn teeth_given_whole_are_split_where_the_model_numbers_its_rows() {
    let data = crate::common::repo_path("data");
    let maker = Maker::new(&data).unwrap();
    let mask = Mask::candide3();
    for spec in population::whole_heads_sample()
        .into_iter()
        .filter(|s| s.source.family() == "ict")
    {
        let member = maker.make(&spec).unwrap();
        let fit = member.landmark_fit.clone().unwrap();
        let registration = facewire::deform::Registration::new(
            member.head.clone(),
            facewire::fit::FittedMask::new(mask.clone(), fit),
        );
        let teeth = member.parts.iter().find(|p| p.name == "teeth").unwrap();
        let head = facewire::animate::AnimatedHead::with_parts(registration, member.parts.clone()).unwrap();
        assert_eq!(head.splits.len(), 1, "{}", spec.name());
        let split = &head.splits[0];
        // The model ships 16 teeth in each row, upper first (vertices 0..2208).
        assert_eq!(
            (split.upper_pieces, split.lower_pieces),
            (16, 16),
            "{}",
            spec.name()
        );
        let sorted = |points: &mut dyn Iterator<Item = glam::Vec3>| {
            let mut v: Vec<[u32; 3]> = points.map(|p| p.to_array().map(f32::to_bits)).collect();
            v.sort_unstable();
            v
        };
        let part = |name: &str| head.parts.iter().find(|p| p.name == name).unwrap();
        let upper = part("teeth_upper");
        let lower = part("teeth_lower");
        assert_eq!(upper.role, facewire::head::PartRole::Skull);
        assert_eq!(lower.role, facewire::head::PartRole::Jaw);
        assert_eq!(
            sorted(&mut upper.mesh.positions.iter().copied()),
            sorted(&mut teeth.mesh.positions[..2208].iter().copied()),
            "{}",
            spec.name()
        );
        assert_eq!(
            sorted(&mut lower.mesh.positions.iter().copied()),
            sorted(&mut teeth.mesh.positions[2208..].iter().copied()),
            "{}",
            spec.name()
        );
        assert_eq!(
            upper.mesh.triangles.len() + lower.mesh.triangles.len(),
            teeth.mesh.triangles.len()
        );
    }
}
