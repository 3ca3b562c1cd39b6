//! The automatic fit on the CI sample of the head population (`facewire population
//! --sample`: a third of the development members, a quarter of the held-out ones; ICT
//! identities, MakeHuman, the scan, face cuts, a low-poly face, other axes, turned,
//! mirrored and rescaled heads). docs/FITTING.md, "On a population", has the whole
//! population's table and the goals; this test holds the sample's figures as measured, so
//! that a change that makes them worse fails here.

mod common;

use facewire::mask::Mask;
use facewire::population::{self, Maker};

/// The sample's figures as measured when the population arrived (27 members; see
/// docs/FITTING.md): 5 refused, 2 fits more than 5 mm (mean) from the reference, the
/// median of the means 2.27 mm. The goals (no refusal, none over 3 mm) are not met yet.
const MAX_REFUSED: usize = 5;
const MAX_OVER_5_MM: usize = 2;
const MAX_MEDIAN_MM: f32 = 2.4;

#[test]
fn the_population_sample_is_fitted_as_measured() {
    let maker = Maker::new(&common::repo_path("data")).unwrap();
    let mask = Mask::candide3();
    let sample = population::sample();
    assert!(sample.len() >= 20, "{} members", sample.len());
    let mut outcomes = Vec::new();
    for spec in &sample {
        let member = maker.make(spec).unwrap();
        let outcome = population::measure(&member, &mask);
        match &outcome.result {
            Ok(m) => eprintln!(
                "{}: {:.2} mm (max {:.1}), scale {:+.1} %",
                outcome.member,
                m.landmark_mean_mm,
                m.landmark_max_mm,
                100.0 * m.scale_error
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
    let median = means[means.len() / 2];
    eprintln!(
        "{refused} refused of {}, {over_5} over 5 mm, median {median:.2} mm",
        outcomes.len()
    );
    assert!(refused <= MAX_REFUSED, "{refused} refused");
    assert!(over_5 <= MAX_OVER_5_MM, "{over_5} over 5 mm");
    assert!(median <= MAX_MEDIAN_MM, "median {median} mm");
    // The heads the method was first built on stay within the 3 mm goal.
    for o in outcomes
        .iter()
        .filter(|o| ["makehuman", "scan", "ict generic"].contains(&o.member.as_str()))
    {
        let m = o.result.as_ref().unwrap_or_else(|e| panic!("{e}"));
        assert!(m.landmark_mean_mm < 3.0, "{}: {m:?}", o.member);
    }
}
