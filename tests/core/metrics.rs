//! Quality metrics against hand-computed meshes, an independent reference implementation
//! and the shipped heads, fits and ARKit targets.

use crate::allocations_during;
use crate::common::data;

use std::collections::BTreeSet;

use facewire::fit::{anchor_mask, Anchors, FitFile, FittedMask};
use facewire::head::{Head, SurfaceDistance, SurfaceIndex};
use facewire::mask::{Mask, INNER_LIP_MID_LOWER, INNER_LIP_MID_UPPER, LIP_VERTICES};
use facewire::metrics::*;
use facewire::targets::ExpressionTarget;
use glam::{DMat3, DVec3, Vec3};

struct Fitted {
    head: Head,
    fitted: FittedMask,
    anchors: Anchors,
    mm: f32,
}

fn load_fitted(name: &str) -> Fitted {
    let head = Head::load(&data(&format!("heads/{name}.obj"))).unwrap();
    let mask = Mask::candide3();
    let fit = FitFile::load(&data(&format!("heads/{name}.fit.toml")))
        .unwrap()
        .resolve("fit", &mask)
        .unwrap();
    let fitted = FittedMask::new(mask, fit);
    let mm = fitted.fit.mm_per_unit;
    let anchors = anchor_mask(&head, &fitted.neutral, mm);
    Fitted {
        head,
        fitted,
        anchors,
        mm,
    }
}

/// A regular grid of `n x n` unit squares in the plane z = 0, two triangles per square.
fn grid(n: u32) -> Head {
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            positions.push(Vec3::new(i as f32, j as f32, 0.0));
        }
    }
    let mut triangles = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
            triangles.push([a, b, d]);
            triangles.push([a, d, c]);
        }
    }
    Head::new("grid", positions, triangles)
}

#[test]
fn a_flat_grid_is_smooth_and_a_bump_roughens_it_with_its_height() {
    let flat = grid(8);
    let mut r = Roughness::whole_mesh(&flat).unwrap();
    r.evaluate(&flat.positions).unwrap();
    assert!(r
        .vertex_mean()
        .iter()
        .chain(r.vertex_variance())
        .all(|&x| x == 0.0));
    assert!(r.triangle_roughness().iter().all(|&x| x == 0.0));
    let mut heat = vec![1.0f32; flat.positions.len()];
    r.face_vertex_roughness(&flat.positions, &mut heat).unwrap();
    assert!(heat.iter().all(|&x| x == 0.0));

    let centre = 4 * 9 + 4;
    let mut bumped = |height: f32| {
        let mut p = flat.positions.clone();
        p[centre].z = height;
        r.evaluate(&p).unwrap();
        r.triangle_roughness().to_vec()
    };
    let (small, big) = (bumped(0.05), bumped(0.3));
    // Only triangles containing the centre tilt, so a vertex's fan changes only when the
    // vertex is the centre or one of its neighbours.
    let near: Vec<u32> = std::iter::once(centre as u32)
        .chain(flat.topology.neighbors_of(centre as u32).map(|(v, _)| v))
        .collect();
    for (k, &t) in r.region_triangles().iter().enumerate() {
        if flat.triangles[t as usize].iter().any(|v| near.contains(v)) {
            assert!(
                small[k] > 0.0 && big[k] > small[k],
                "triangle {t}: {} vs {}",
                small[k],
                big[k]
            );
        } else {
            assert_eq!(big[k], 0.0, "triangle {t}");
        }
    }
    let peak = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    assert!(peak(&big) > 10.0 * peak(&small));
}

/// `rho` on a 4 x 4 height field, against values from an independent implementation
/// (Python, normals from the same triangles, fans ordered by angle around each vertex
/// instead of through shared spokes, two-pass variance).
#[test]
fn a_height_field_matches_the_reference_implementation() {
    const HEIGHTS: [[f32; 4]; 4] = [
        [0.0, 0.125, 0.0, 0.25],
        [0.125, 0.375, -0.125, 0.0],
        [0.0, 0.25, 0.5, 0.125],
        [0.25, 0.0, 0.125, 0.375],
    ];
    const G: [f64; 16] = [
        0.01449275362318836,
        0.1364718197918538,
        0.021931489943704585,
        0.0,
        0.014492753623188415,
        0.10755684050976262,
        0.06659468744885284,
        0.021931489943704585,
        0.11454480150184099,
        0.00864721129727756,
        0.13338268442204407,
        0.11193619657509402,
        0.0,
        0.11454480150184099,
        0.00610731625137656,
        0.3246753246753247,
    ];
    const V: [f64; 16] = [
        0.0,
        0.0005233607993818896,
        7.008268798782078e-05,
        0.0,
        0.00021003990758244092,
        0.01990545838397365,
        0.0036755679232684108,
        7.008268798782078e-05,
        0.01159442693299396,
        7.790655191243979e-05,
        0.02700097458512102,
        0.004544377309410519,
        0.0,
        0.01159442693299396,
        3.729931179432688e-05,
        0.0,
    ];
    const RHO: [f64; 18] = [
        0.10829760611815939,
        0.10658509365439858,
        0.07442807829501522,
        0.10193851847616528,
        0.021931489943704585,
        0.06495405028172598,
        0.10620724738353965,
        0.11208190641919366,
        0.118366293864912,
        0.12223443849203493,
        0.09107214521549789,
        0.12364572258668279,
        0.11419021341306149,
        0.11454480150184099,
        0.1328492392976192,
        0.11349483179786461,
        0.13029313471392612,
        0.13320710799067736,
    ];
    let mut head = grid(3);
    for (v, p) in head.positions.iter_mut().enumerate() {
        p.z = HEIGHTS[v / 4][v % 4];
    }
    let mut r = Roughness::whole_mesh(&head).unwrap();
    r.evaluate(&head.positions).unwrap();
    let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
    let got = (r.vertex_mean(), r.vertex_variance(), r.triangle_roughness());
    for v in 0..16 {
        assert!(close(got.0[v], G[v]), "G({v}) = {} vs {}", got.0[v], G[v]);
        assert!(close(got.1[v], V[v]), "V({v}) = {} vs {}", got.1[v], V[v]);
    }
    assert_eq!(got.2.len(), RHO.len());
    for (t, (&rho, &expected)) in got.2.iter().zip(&RHO).enumerate() {
        assert!(close(rho, expected), "rho({t}) = {rho} vs {expected}");
    }
}

/// Rotates about a tilted axis and translates, in f64, rounding once to f32.
fn rigid_motion(positions: &[Vec3]) -> Vec<Vec3> {
    let rotation = DMat3::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
    let shift = DVec3::new(0.3, -0.8, 0.5);
    positions
        .iter()
        .map(|p| (rotation * p.as_dvec3() + shift).as_vec3())
        .collect()
}

#[test]
fn a_rigid_motion_leaves_every_roughness_value_unchanged() {
    let Fitted {
        head, anchors, mm, ..
    } = load_fitted("lee_perry_smith_head");
    let moved = rigid_motion(&head.positions);
    let region = LipRegion::new(&head, &anchors, mm).unwrap();
    let mut lips = LipRoughness::new(&head, &region).unwrap();
    let before = lips.rows(&head.positions, 0, 0.0).unwrap();
    let rho_before = lips.roughness().triangle_roughness().to_vec();
    let after = lips.rows(&moved, 0, 0.0).unwrap();
    // The moved positions are rounded to f32: up to 3e-7 head units on this 5-unit scan,
    // against triangle altitudes down to 7e-4 units (0.04 mm) at the mouth corners, which
    // tilts a normal by up to ~1e-4 rad at worst. Observed: 5.5e-6 on a value of 0.63.
    let same = |x: f64, y: f64| (x - y).abs() <= 1e-5 + 1e-4 * x.abs();
    for (b, a) in before.iter().zip(&after) {
        assert_eq!(b.mask_vertex, a.mask_vertex);
        for (x, y) in [(b.min, a.min), (b.max, a.max), (b.mean, a.mean)] {
            assert!(same(x, y), "lip vertex {}: {x} vs {y}", b.mask_vertex);
        }
    }
    for (t, (&x, &y)) in rho_before
        .iter()
        .zip(lips.roughness().triangle_roughness())
        .enumerate()
    {
        assert!(same(x, y), "lip triangle {t}: {x} vs {y}");
    }
    assert!(
        before[LIP_ROWS - 1].mean > 1e-3,
        "the scan's lips are not flat: {:?}",
        before[LIP_ROWS - 1]
    );

    let mut whole = Roughness::whole_mesh(&head).unwrap();
    let mut heat_before = vec![0.0f32; head.positions.len()];
    let mut heat_after = heat_before.clone();
    whole
        .face_vertex_roughness(&head.positions, &mut heat_before)
        .unwrap();
    whole.face_vertex_roughness(&moved, &mut heat_after).unwrap();
    for (v, (x, y)) in heat_before.iter().zip(&heat_after).enumerate() {
        assert!(same(f64::from(*x), f64::from(*y)), "vertex {v}: {x} vs {y}");
    }
    assert!(heat_before.iter().filter(|&&x| x > 0.0).count() > head.positions.len() / 2);
}

#[test]
fn each_lip_patch_is_the_triangles_within_5_mm_along_the_surface() {
    for name in ["makehuman_head", "lee_perry_smith_head", "ict_head"] {
        let Fitted {
            head, anchors, mm, ..
        } = load_fitted(name);
        let region = LipRegion::new(&head, &anchors, mm).unwrap();
        let mut search = SurfaceDistance::new(head.positions.len());
        let mut union = BTreeSet::new();
        for (mask_vertex, triangles) in region.per_lip_vertex() {
            // independently: the fans of every vertex the bounded search settles
            let reached = search.run(&head.topology, &[(anchors.vertex[mask_vertex], 0.0)], 5.0 / mm);
            let mut expected = BTreeSet::new();
            for &v in reached {
                for fan in head.topology.fans_of(v) {
                    expected.extend(head.topology.fan(fan).iter().copied());
                }
            }
            assert_eq!(
                triangles.iter().copied().collect::<BTreeSet<_>>(),
                expected,
                "{name} {mask_vertex}"
            );
            union.extend(triangles.iter().copied());
        }
        assert_eq!(region.union(), union.into_iter().collect::<Vec<_>>().as_slice());
        // the lips touch, but their patches do not: they are far apart along the surface
        let patch = |j: usize| -> BTreeSet<u32> {
            let (_, t) = region.per_lip_vertex().find(|&(m, _)| m == j).unwrap();
            t.iter().copied().collect()
        };
        assert!(
            patch(INNER_LIP_MID_UPPER).is_disjoint(&patch(INNER_LIP_MID_LOWER)),
            "{name}"
        );
        // a larger radius only adds triangles
        let wider = LipRegion::with_radius(&head, &anchors, mm, 8.0).unwrap();
        assert!(wider.union().len() > region.union().len());
        assert!(region
            .union()
            .iter()
            .all(|t| wider.union().binary_search(t).is_ok()));
    }
}

#[test]
fn the_summary_row_is_the_union_and_every_row_matches_the_whole_mesh() {
    let Fitted {
        head, anchors, mm, ..
    } = load_fitted("lee_perry_smith_head");
    // a smooth ripple, so the lips are deformed and not just the scan's own shape
    let deformed: Vec<Vec3> = head
        .positions
        .iter()
        .map(|p| *p + Vec3::new(0.0, 0.0, 0.02 * (7.0 * p.x).sin() * (5.0 * p.y).cos()))
        .collect();
    let region = LipRegion::new(&head, &anchors, mm).unwrap();
    let mut lips = LipRoughness::new(&head, &region).unwrap();
    let rows = lips.rows(&deformed, 42, 1.4).unwrap();
    let mut whole = Roughness::whole_mesh(&head).unwrap();
    whole.evaluate(&deformed).unwrap();
    let rho = whole.triangle_roughness();
    let stats = |triangles: &mut dyn Iterator<Item = u32>| {
        let values: Vec<f64> = triangles.map(|t| rho[t as usize]).collect();
        let min = values.iter().copied().fold(f64::INFINITY, f64::min);
        let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        (min, max, values.iter().sum::<f64>() / values.len() as f64)
    };
    let close = |a: (f64, f64, f64), r: &LipRoughnessRow| {
        (a.0 - r.min).abs() < 1e-12 && (a.1 - r.max).abs() < 1e-12 && (a.2 - r.mean).abs() < 1e-12
    };
    let mut union = BTreeSet::new();
    for ((mask_vertex, triangles), row) in region.per_lip_vertex().zip(&rows) {
        assert_eq!(row.mask_vertex, mask_vertex as i32);
        assert_eq!((row.frame, row.time_s), (42, 1.4));
        assert!(close(stats(&mut triangles.iter().copied()), row), "{row:?}");
        assert!(row.min <= row.mean && row.mean <= row.max && row.min >= 0.0);
        union.extend(triangles.iter().copied());
    }
    let summary = rows[LIP_ROWS - 1];
    assert!(summary.is_summary() && summary.mask_vertex == SUMMARY_MASK_VERTEX);
    assert!(close(stats(&mut union.iter().copied()), &summary), "{summary:?}");
    assert_eq!(
        summary.min,
        rows[..LIP_ROWS - 1]
            .iter()
            .map(|r| r.min)
            .fold(f64::INFINITY, f64::min)
    );
    assert_eq!(
        summary.max,
        rows[..LIP_ROWS - 1].iter().map(|r| r.max).fold(0.0, f64::max)
    );
    assert_eq!(LIP_ROWS, LIP_VERTICES.len() + 1);
    // the region evaluator computes far fewer normals than the whole head has triangles
    assert!(lips.roughness().normal_count() < head.triangles.len() / 10);
}

#[test]
fn the_symmetric_head_gets_mirror_equal_rows() {
    // MakeHuman's head is left-right symmetric and so are its fit and anchors: each lip
    // vertex's row equals its mirror partner's (CANDIDE pairs left and right lip vertices).
    let Fitted {
        head, anchors, mm, ..
    } = load_fitted("makehuman_head");
    let region = LipRegion::new(&head, &anchors, mm).unwrap();
    let mut lips = LipRoughness::new(&head, &region).unwrap();
    let rows = lips.rows(&head.positions, 0, 0.0).unwrap();
    let of = |j: i32| rows.iter().find(|r| r.mask_vertex == j).unwrap();
    for (left, right) in [
        (31, 64),
        (33, 66),
        (79, 80),
        (81, 82),
        (83, 84),
        (85, 86),
        (88, 89),
    ] {
        let (a, b) = (of(left), of(right));
        for (x, y) in [(a.min, b.min), (a.max, b.max), (a.mean, b.mean)] {
            assert!((x - y).abs() < 1e-9, "{left}/{right}: {x} vs {y}");
        }
    }
    // and the patches of the middle vertices differ from their neighbours'
    assert!((of(7).mean - of(33).mean).abs() > 1e-3);
}

fn row(frame: u64, mask_vertex: i32, mean: f64) -> LipRoughnessRow {
    LipRoughnessRow {
        frame,
        time_s: frame as f64 / 30.0,
        mask_vertex,
        min: mean / 2.0,
        max: mean * 2.0,
        mean,
    }
}

#[test]
fn the_table_has_a_header_and_one_exact_line_per_row() {
    let mut tsv = RoughnessTsvWriter::new(Vec::new()).unwrap();
    tsv.write_rows(&[
        LipRoughnessRow {
            frame: 3,
            time_s: 0.1,
            mask_vertex: 87,
            min: 0.0,
            max: 0.5,
            mean: 1.25e-7,
        },
        row(3, -1, 0.25),
    ])
    .unwrap();
    let text = String::from_utf8(tsv.finish().unwrap()).unwrap();
    assert_eq!(
        text,
        "frame\ttime_s\tmask_vertex\tmin\tmax\tmean\n3\t0.1\t87\t0\t0.5\t0.000000125\n3\t0.1\t-1\t0.125\t0.5\t0.25\n"
    );
    // values read back exactly
    let last: Vec<f64> = text
        .lines()
        .nth(2)
        .unwrap()
        .split('\t')
        .map(|f| f.parse().unwrap())
        .collect();
    assert_eq!(last, vec![3.0, 0.1, -1.0, 0.125, 0.5, 0.25]);

    struct Full;
    impl std::io::Write for Full {
        fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
            Err(std::io::Error::other("disk full"))
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    assert!(matches!(RoughnessTsvWriter::new(Full), Err(TsvError::Header(_))));
}

#[test]
fn syllables_average_summary_means_and_algorithms_average_syllables() {
    let mut scores = SyllableScores::new();
    assert_eq!(scores.algorithm_score(), None);
    // per-vertex rows carry large values that must not count
    scores.add("pa", &[row(0, 7, 100.0), row(0, -1, 1.0)]);
    scores.add("pa", &[row(1, -1, 2.0)]);
    scores.add("pi", &[row(2, 8, 100.0), row(2, -1, 4.0)]);
    scores.add("pa", &[row(3, -1, 3.0)]);
    scores.add("rest", &[row(4, 31, 100.0)]);
    let listed: Vec<(String, u64, f64)> = scores
        .scores()
        .map(|s| (s.label.to_string(), s.frames, s.mean))
        .collect();
    assert_eq!(listed, vec![("pa".into(), 3, 2.0), ("pi".into(), 1, 4.0)]);
    let algorithm = scores.algorithm_score().unwrap();
    assert_eq!(algorithm.syllables, 2);
    assert_eq!(algorithm.mean, 3.0);
    assert_eq!(algorithm.variance, 1.0);
    let e1 = algorithm_score([0.1, 0.2, 0.3, 0.6]).unwrap();
    assert!(
        (e1.mean - 0.3).abs() < 1e-15 && (e1.variance - 0.035).abs() < 1e-15,
        "{e1:?}"
    );
}

#[test]
fn targets_load_and_jaw_open_rebuilds_the_shipped_open_mouth_head() {
    let rest = Head::load(&data("heads/makehuman_head.obj")).unwrap();
    let open = Head::load(&data("heads/makehuman_head_jawopen.obj")).unwrap();
    let n = rest.positions.len();
    let targets = ExpressionTarget::load_dir(&data("heads/makehuman_arkit"), n).unwrap();
    assert_eq!(targets.len(), 51);
    assert!(targets.windows(2).all(|w| w[0].name < w[1].name));
    assert!(targets
        .iter()
        .all(|t| !t.listed.is_empty() && t.displacements.len() == n));
    let jaw = targets.iter().find(|t| t.name == "jawOpen").unwrap();
    let mut posed = vec![Vec3::ZERO; n];
    jaw.apply_into(&rest.positions, 1.0, &mut posed).unwrap();
    let worst = posed
        .iter()
        .zip(&open.positions)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0, f32::max);
    assert!(worst < 1e-5, "{worst} head units");
    let moved = jaw.displacements.iter().map(|d| d.length()).fold(0.0, f32::max);
    assert!(moved > 0.1, "the jaw opens over 10 mm: {moved} dm");

    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("broken.target");
    std::fs::write(&bad, "# header\n12 0 0.5\n").unwrap();
    let err = ExpressionTarget::load_dir(dir.path(), n).unwrap_err();
    let message = err.to_string();
    assert!(
        message.contains("broken.target: line 2: expected 4 fields"),
        "{message}"
    );
    assert!(ExpressionTarget::load(&dir.path().join("missing.target"), n).is_err());
}

#[test]
fn face_vertices_cover_the_mask_and_the_targets_motion_but_not_the_back_of_the_head() {
    for name in ["makehuman_head", "lee_perry_smith_head", "ict_head"] {
        let Fitted {
            head,
            fitted,
            anchors,
            mm,
        } = load_fitted(name);
        let face = FaceVertices::new(&head, &fitted.mask, &anchors, mm).unwrap();
        assert_eq!(face.radius_mm(), FACE_RADIUS_MM);
        let inside: BTreeSet<u32> = face.vertices().iter().copied().collect();
        // every vertex within 3 mm of the fitted mask's surface is in: no holes between anchors
        let mask_surface = SurfaceIndex::new(&fitted.neutral, &fitted.mask.triangles);
        for (v, p) in head.positions.iter().enumerate() {
            if mask_surface.closest_point(*p).unwrap().distance * mm < 3.0 {
                assert!(
                    inside.contains(&(v as u32)),
                    "{name}: vertex {v} on the mask is left out"
                );
            }
        }
        let back = (0..head.positions.len())
            .min_by(|&a, &b| head.positions[a].z.total_cmp(&head.positions[b].z))
            .unwrap();
        assert!(!inside.contains(&(back as u32)), "{name}");
        assert!(face.vertices().len() < head.positions.len() * 2 / 3, "{name}");

        if name == "makehuman_head" {
            // the ARKit targets move the face: at least 95 % of their squared displacement is in
            let targets =
                ExpressionTarget::load_dir(&data("heads/makehuman_arkit"), head.positions.len()).unwrap();
            let (mut all, mut kept) = (0.0f64, 0.0f64);
            for t in &targets {
                for (v, d) in t.displacements.iter().enumerate() {
                    let e = f64::from(d.length_squared());
                    all += e;
                    if inside.contains(&(v as u32)) {
                        kept += e;
                    }
                }
            }
            assert!(kept / all > 0.95, "{}", kept / all);
        }
    }
}

#[test]
fn ground_truth_scores_the_target_itself_zero_and_no_motion_the_targets_own_size() {
    let Fitted {
        head,
        fitted,
        anchors,
        mm,
    } = load_fitted("makehuman_head");
    let n = head.positions.len();
    let face = FaceVertices::new(&head, &fitted.mask, &anchors, mm).unwrap();
    let jaw = ExpressionTarget::load(&data("heads/makehuman_arkit/jawOpen.target"), n).unwrap();
    let mut target = vec![Vec3::ZERO; n];
    jaw.apply_into(&head.positions, 1.0, &mut target).unwrap();

    let oracle = ground_truth_error(&target, &target, &face, mm).unwrap();
    assert_eq!((oracle.rms_mm, oracle.max_mm), (0.0, 0.0));
    assert_eq!(oracle.vertices, face.vertices().len());

    let still = ground_truth_error(&head.positions, &target, &face, mm).unwrap();
    let squares: f64 = face
        .vertices()
        .iter()
        .map(|&v| f64::from(jaw.displacements[v as usize].length_squared()) * f64::from(mm * mm))
        .sum();
    let own_rms = (squares / face.vertices().len() as f64).sqrt();
    let own_max = face
        .vertices()
        .iter()
        .map(|&v| jaw.displacements[v as usize].length() * mm)
        .fold(0.0, f32::max);
    assert!(
        (still.rms_mm - own_rms).abs() < 1e-4,
        "{} vs {own_rms}",
        still.rms_mm
    );
    assert!((still.max_mm - f64::from(own_max)).abs() < 1e-3);
    assert!(still.rms_mm > 1.0 && still.max_mm > 10.0, "{still:?}");

    // half the expression is half the error, anywhere on the face
    let mut half = vec![Vec3::ZERO; n];
    jaw.apply_into(&head.positions, 0.5, &mut half).unwrap();
    let halfway = ground_truth_error(&half, &target, &face, mm).unwrap();
    assert!((halfway.rms_mm - still.rms_mm / 2.0).abs() < 1e-3, "{halfway:?}");

    assert!(matches!(
        ground_truth_error(&half[1..], &target, &face, mm),
        Err(FidelityError::Length { .. })
    ));
    assert!(matches!(
        ground_truth_error(&half, &target, &face, 0.0),
        Err(FidelityError::Scale(_))
    ));
}

#[test]
fn control_error_is_zero_when_the_head_follows_the_mask_at_the_anchors() {
    let Fitted {
        head,
        fitted,
        anchors,
        mm,
    } = load_fitted("makehuman_head");
    let n = head.positions.len();
    let jaw = ExpressionTarget::load(&data("heads/makehuman_arkit/jawOpen.target"), n).unwrap();
    let mut controls = vec![Vec3::ZERO; anchors.vertex.len()];
    jaw.controls_into(&anchors, 1.0, &mut controls).unwrap();
    let moving = controls
        .iter()
        .filter(|d| f64::from(d.length() * mm) > MOVING_CONTROL_MM)
        .count();
    assert!(moving > 10, "jawOpen moves many anchors: {moving}");

    // the head moved by exactly delta at the anchors (the target itself)
    let mut target = vec![Vec3::ZERO; n];
    jaw.apply_into(&head.positions, 1.0, &mut target).unwrap();
    let exact = control_error(&target, &head.positions, &anchors, &controls, mm).unwrap();
    assert_eq!(exact.moving, moving);
    // only the f32 rounding of rest + delta remains
    assert!(exact.max_mm < 1e-4, "{exact:?}");

    // a head that does not move misses every control by its whole displacement
    let still = control_error(&head.positions, &head.positions, &anchors, &controls, mm).unwrap();
    let sizes: Vec<f64> = controls
        .iter()
        .map(|d| f64::from(d.length()) * f64::from(mm))
        .filter(|&s| s > MOVING_CONTROL_MM)
        .collect();
    let mean = sizes.iter().sum::<f64>() / sizes.len() as f64;
    assert!((still.mean_mm - mean).abs() < 1e-4, "{} vs {mean}", still.mean_mm);
    assert!((still.max_mm - sizes.iter().copied().fold(0.0, f64::max)).abs() < 1e-4);

    // and the mask's own motion: with the jaw dropped, nothing moving on the head
    let jaw_drop = fitted.mask.animation_unit("jaw_drop").unwrap();
    let mut weights = vec![0.0; fitted.mask.animation_units.len()];
    weights[jaw_drop] = 0.5;
    let mut deltas = vec![Vec3::ZERO; fitted.neutral.len()];
    fitted.controls_into(&weights, &mut deltas);
    let mut followed = head.positions.clone();
    let mut seen: Vec<Option<Vec3>> = vec![None; n];
    let mut consistent = true;
    for (&v, &d) in anchors.vertex.iter().zip(&deltas) {
        // two mask vertices sharing one anchor must ask for the same motion to be met
        match seen[v as usize] {
            Some(previous) if previous != d => consistent = false,
            _ => seen[v as usize] = Some(d),
        }
        followed[v as usize] = head.positions[v as usize] + d;
    }
    let e = control_error(&followed, &head.positions, &anchors, &deltas, mm).unwrap();
    assert!(
        consistent,
        "mask vertices sharing an anchor ask it to move differently"
    );
    assert!(e.max_mm < 1e-4, "{e:?}");
    assert!(e.moving > 0);
    assert!(matches!(
        control_error(&followed, &head.positions, &anchors, &deltas[1..], mm),
        Err(FidelityError::Length { .. })
    ));
}

#[test]
fn mouth_opening_compares_the_inner_lip_anchors_with_the_mask() {
    let Fitted {
        head,
        fitted,
        anchors,
        mm,
    } = load_fitted("makehuman_head");
    let open = Head::load(&data("heads/makehuman_head_jawopen.obj")).unwrap();
    let mut posed = vec![Vec3::ZERO; fitted.neutral.len()];
    // neutral: the mask's inner lips coincide, the head's are apart: no ratio
    fitted.pose_into(&[], &mut posed);
    let neutral = mouth_opening(&head.positions, &anchors, &posed, mm).unwrap();
    assert!(neutral.mask_mm < 1e-3 && neutral.ratio.is_none(), "{neutral:?}");
    let (up, low) = (
        anchors.vertex[INNER_LIP_MID_UPPER] as usize,
        anchors.vertex[INNER_LIP_MID_LOWER] as usize,
    );
    let rest_gap = f64::from(head.positions[up].distance(head.positions[low]) * mm);
    assert!((neutral.head_mm - rest_gap).abs() < 1e-4);
    assert!(neutral.head_mm < 3.0, "{neutral:?}");

    // jaw dropped on the mask; the head either stays shut or is the artist's open jaw
    let jaw_drop = fitted.mask.animation_unit("jaw_drop").unwrap();
    let mut weights = vec![0.0; fitted.mask.animation_units.len()];
    weights[jaw_drop] = 0.5;
    fitted.pose_into(&weights, &mut posed);
    let shut = mouth_opening(&head.positions, &anchors, &posed, mm).unwrap();
    let opened = mouth_opening(&open.positions, &anchors, &posed, mm).unwrap();
    assert!(shut.mask_mm > 5.0, "{shut:?}");
    assert_eq!(shut.mask_mm, opened.mask_mm);
    assert!((shut.ratio.unwrap() - shut.head_mm / shut.mask_mm).abs() < 1e-12);
    assert!(
        shut.ratio.unwrap() < 0.5 && opened.head_mm > shut.head_mm + 5.0,
        "{shut:?} {opened:?}"
    );
    assert!(matches!(
        mouth_opening(&head.positions, &anchors, &posed[..40], mm),
        Err(FidelityError::Length { .. })
    ));
}

#[test]
fn regions_refuse_bad_inputs_with_the_vertex_at_fault() {
    let Fitted {
        head,
        fitted,
        anchors,
        mm,
    } = load_fitted("makehuman_head");
    assert_eq!(
        LipRegion::new(&head, &anchors, -1.0).unwrap_err(),
        RegionError::Scale(-1.0)
    );
    assert!(matches!(
        LipRegion::with_radius(&head, &anchors, mm, f32::NAN),
        Err(RegionError::Radius(_))
    ));
    let short = Anchors {
        vertex: anchors.vertex[..50].to_vec(),
        distance: anchors.distance[..50].to_vec(),
    };
    assert_eq!(
        LipRegion::new(&head, &short, mm).unwrap_err(),
        RegionError::MissingAnchor {
            mask_vertex: 64,
            count: 50
        }
    );
    let mut wrong = anchors.clone();
    wrong.vertex[8] = 1_000_000;
    let err = FaceVertices::new(&head, &fitted.mask, &wrong, mm).unwrap_err();
    assert_eq!(
        err.to_string(),
        format!(
            "mask vertex 8 is anchored to head vertex 1000000, but the head has {} vertices",
            head.positions.len()
        )
    );
}

#[test]
fn per_frame_calls_allocate_nothing() {
    let Fitted {
        head,
        fitted,
        anchors,
        mm,
    } = load_fitted("makehuman_head");
    let n = head.positions.len();
    let region = LipRegion::new(&head, &anchors, mm).unwrap();
    let mut lips = LipRoughness::new(&head, &region).unwrap();
    let mut whole = Roughness::whole_mesh(&head).unwrap();
    let face = FaceVertices::new(&head, &fitted.mask, &anchors, mm).unwrap();
    let jaw = ExpressionTarget::load(&data("heads/makehuman_arkit/jawOpen.target"), n).unwrap();
    let mut frame = vec![Vec3::ZERO; n];
    let mut target = vec![Vec3::ZERO; n];
    let mut heat = vec![0.0f32; n];
    let mut controls = vec![Vec3::ZERO; anchors.vertex.len()];
    let mut posed = vec![Vec3::ZERO; anchors.vertex.len()];
    let mut tsv = RoughnessTsvWriter::new(std::io::sink()).unwrap();

    let allocated = allocations_during(|| {
        for step in 0..3u64 {
            let weight = step as f32 / 2.0;
            jaw.apply_into(&head.positions, weight, &mut frame).unwrap();
            jaw.apply_into(&head.positions, 1.0, &mut target).unwrap();
            jaw.controls_into(&anchors, weight, &mut controls).unwrap();
            fitted.pose_into(&[], &mut posed);
            let rows = lips.rows(&frame, step, step as f64 / 30.0).unwrap();
            tsv.write_rows(&rows).unwrap();
            whole.evaluate(&frame).unwrap();
            whole.face_vertex_roughness(&frame, &mut heat).unwrap();
            control_error(&frame, &head.positions, &anchors, &controls, mm).unwrap();
            mouth_opening(&frame, &anchors, &posed, mm).unwrap();
            ground_truth_error(&frame, &target, &face, mm).unwrap();
        }
    });
    assert_eq!(allocated, 0);
    // the counter does count: a growing vector is seen
    let mut grown = Vec::new();
    assert!(allocations_during(|| grown = (0..100u64).collect()) > 0);
    assert_eq!(grown.len(), 100);
}
