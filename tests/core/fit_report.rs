//! The fit report on the shipped heads and fits: every region measured, the warnings each
//! head deserves and no others; an open mouth at rest and a face-only mesh reported as such.

use facewire::fit::{fit_from_landmarks, report, FitFile, FitReport, FitWarning, FittedMask, Landmarks};
use facewire::head::Head;
use facewire::mask::{FaceRegion, Mask};

fn shipped_report(name: &str) -> FitReport {
    let mask = Mask::candide3();
    let head = Head::load(&crate::common::data(&format!("heads/{name}.obj"))).unwrap();
    let fit = FitFile::load(&crate::common::data(&format!("heads/{name}.fit.toml")))
        .unwrap()
        .resolve("fit", &mask)
        .unwrap();
    report(&head, &FittedMask::new(mask, fit))
}

fn kinds(report: &FitReport) -> Vec<&'static str> {
    report
        .warnings
        .iter()
        .map(|w| match w.warning {
            FitWarning::FarFromSurface { .. } => "far",
            FitWarning::NoHeadUnder { .. } => "past edge",
            FitWarning::LipsApartAtRest { .. } => "lips apart",
            FitWarning::FromFit { .. } => "from the fit",
        })
        .collect()
}

#[test]
fn the_shipped_fits_report_every_region_and_closed_lips() {
    let mask = Mask::candide3();
    let used = mask.used_vertices().iter().filter(|&&u| u).count();
    for (name, mean_mm, warnings) in [
        // The surface means are docs/FITTING.md's table.
        ("makehuman_head", 3.24, vec!["far"]),
        ("lee_perry_smith_head", 2.99, vec!["far"]),
        ("ict_head", 1.50, vec![]),
    ] {
        let r = shipped_report(name);
        assert!(
            (r.surface.mean_mm - mean_mm).abs() < 0.01,
            "{name}: {}",
            r.surface.mean_mm
        );
        let regions: Vec<FaceRegion> = r.regions.iter().map(|g| g.region).collect();
        assert_eq!(regions, FaceRegion::ALL, "{name}");
        let counted: usize = r.regions.iter().map(|g| g.distances.count).sum();
        assert_eq!(counted, used, "{name}");
        // Each region's mean lies within the overall range, and the worst is the overall worst.
        let worst = r.regions.iter().map(|g| g.distances.max_mm).fold(0.0, f32::max);
        assert_eq!(worst, r.surface.max_mm, "{name}");
        assert!(r.inner_lip_gap_mm < 2.0, "{name}: {}", r.inner_lip_gap_mm);
        assert_eq!(kinds(&r), warnings, "{name}: {:?}", r.warnings);
    }
    // The scan's hairline: the forehead top (vertex 0) is the furthest, 18.6 mm.
    let scan = shipped_report("lee_perry_smith_head");
    match &scan.warnings[0].warning {
        FitWarning::FarFromSurface {
            worst_mask_vertex,
            worst_mm,
            ..
        } => assert_eq!((*worst_mask_vertex, (worst_mm * 10.0).round()), (0, 186.0)),
        other => panic!("{other:?}"),
    }
}

#[test]
fn an_open_mouth_at_rest_is_reported() {
    let mask = Mask::candide3();
    // The MakeHuman head with its jaw open, fitted from the neutral head's landmarks.
    let head = Head::load(&crate::common::data("heads/makehuman_head_jawopen.obj")).unwrap();
    let landmarks = Landmarks::load(&crate::common::data("heads/makehuman_head.landmarks.toml")).unwrap();
    let fit = fit_from_landmarks(&head, &landmarks, "landmarks", &mask)
        .unwrap()
        .fit;
    let r = report(&head, &FittedMask::new(mask, fit));
    assert!(r.inner_lip_gap_mm > 20.0, "{}", r.inner_lip_gap_mm);
    let warning = r
        .warnings
        .iter()
        .find(|w| matches!(w.warning, FitWarning::LipsApartAtRest { .. }))
        .expect("lips apart");
    assert!(
        warning.message.contains("registering the head closes them"),
        "{}",
        warning.message
    );
}

#[test]
fn a_face_only_mesh_reports_the_mask_past_its_edge() {
    let mask = Mask::candide3();
    let head = Head::load(&crate::common::data("heads/ict_head.obj")).unwrap();
    let fit = FitFile::load(&crate::common::data("heads/ict_head.fit.toml"))
        .unwrap()
        .resolve("fit", &mask)
        .unwrap();
    let fitted = FittedMask::new(mask, fit);
    // 80 mm around the nose tip: the forehead's top and the temples are cut off.
    let face = crate::common::cut_face(&head, fitted.neutral[5], 80.0, 60.0, fitted.fit.mm_per_unit);
    let r = report(&face, &fitted);
    let past: Vec<(FaceRegion, usize)> = r
        .warnings
        .iter()
        .filter_map(|w| match &w.warning {
            FitWarning::NoHeadUnder {
                region,
                mask_vertices,
            } => Some((*region, mask_vertices.len())),
            _ => None,
        })
        .collect();
    assert!(
        past.iter()
            .any(|&(region, n)| region == FaceRegion::ForeheadAndCheeks && n > 0),
        "{past:?}"
    );
    assert!(
        past.iter().all(|&(region, _)| region != FaceRegion::Nose),
        "{past:?}"
    );
    // Vertices past the edge are not also called far off the surface.
    assert!(!kinds(&r).contains(&"far"), "{:?}", r.warnings);
}
