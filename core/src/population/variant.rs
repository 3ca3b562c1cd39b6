//! How a population head differs from the head it was made from, as users' files differ:
//! a face cut out of a whole head, a low-poly face, another orientation (axes swapped,
//! turned, mirrored) or other units. Each variant says where its head's points go, so the
//! reference fit's points go there too.

use glam::{Mat3, Vec3};

use crate::head::Head;

/// A change of frame `p -> linear * p`: a rotation, possibly a mirror, times a scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    pub linear: Mat3,
}

impl Placement {
    pub const IDENTITY: Placement = Placement {
        linear: Mat3::IDENTITY,
    };

    pub fn apply(&self, p: Vec3) -> Vec3 {
        self.linear * p
    }

    /// The length factor (head units of the placed head per head unit of the source).
    pub fn scale(&self) -> f32 {
        self.linear.determinant().abs().cbrt()
    }

    /// The frame is mirrored: the face's left is now where a right would be.
    pub fn mirrors(&self) -> bool {
        self.linear.determinant() < 0.0
    }
}

/// Units a file may be written in, besides the model's centimetres.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    Millimetres,
    Metres,
    Inches,
}

impl Unit {
    pub fn mm(self) -> f32 {
        match self {
            Unit::Millimetres => 1.0,
            Unit::Metres => 1000.0,
            Unit::Inches => 25.4,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Unit::Millimetres => "mm",
            Unit::Metres => "m",
            Unit::Inches => "in",
        }
    }
}

/// One change made to a source head.
#[derive(Debug, Clone, PartialEq)]
pub enum Variant {
    /// Only the face: within `radius_mm` of the nose tip and `depth_mm` behind it (ears and
    /// the back of the head gone), as face trackers and face scans give.
    FaceCut { radius_mm: f32, depth_mm: f32 },
    /// Decimated to about this many vertices (meshoptimizer's edge collapse).
    LowPoly { vertices: usize },
    /// Written with +z up and -y forward (Blender, 3ds Max).
    ZUp,
    /// Written looking along -z (OpenGL cameras, some scanners).
    MinusZForward,
    /// One axis negated, as scanners and exporters with another handedness write.
    Mirrored { axis: usize },
    /// Turned by `degrees` about `axis` (head frame, before any other change of frame).
    Turned { axis: Vec3, degrees: f32 },
    /// Written in another unit.
    InUnits(Unit),
}

impl Variant {
    /// The change of frame this variant makes, given the source's mm per unit.
    pub fn placement(&self, source_mm_per_unit: f32) -> Placement {
        let linear = match self {
            Variant::FaceCut { .. } | Variant::LowPoly { .. } => Mat3::IDENTITY,
            // +y up, +z forward -> +z up, -y forward.
            Variant::ZUp => Mat3::from_rotation_x(std::f32::consts::FRAC_PI_2),
            Variant::MinusZForward => Mat3::from_rotation_y(std::f32::consts::PI),
            Variant::Mirrored { axis } => {
                let mut diagonal = Vec3::ONE;
                diagonal[*axis] = -1.0;
                Mat3::from_diagonal(diagonal)
            }
            Variant::Turned { axis, degrees } => {
                Mat3::from_axis_angle(axis.normalize(), degrees.to_radians())
            }
            Variant::InUnits(unit) => Mat3::from_diagonal(Vec3::splat(source_mm_per_unit / unit.mm())),
        };
        Placement { linear }
    }

    /// A short label for tables: `face cut`, `low-poly 500`, `turned 28 about (0, 0, 1)`, ...
    pub fn label(&self) -> String {
        match self {
            Variant::FaceCut { .. } => "face cut".into(),
            Variant::LowPoly { vertices } => format!("low-poly {vertices}"),
            Variant::ZUp => "Z up".into(),
            Variant::MinusZForward => "-Z forward".into(),
            Variant::Mirrored { axis } => format!("mirrored {}", ["x", "y", "z"][*axis]),
            Variant::Turned { axis, degrees } => {
                let a = axis.normalize();
                format!("turned {degrees:.0} about ({:.2}, {:.2}, {:.2})", a.x, a.y, a.z)
            }
            Variant::InUnits(unit) => format!("in {}", unit.name()),
        }
    }

    /// The head this variant makes of `head` (`nose_tip` in head units, the source's frame
    /// before this variant; `mm_per_unit` of `head`).
    pub fn apply(&self, head: &Head, nose_tip: Vec3, mm_per_unit: f32) -> Head {
        match self {
            Variant::FaceCut { radius_mm, depth_mm } => {
                cut_face(head, nose_tip, *radius_mm, *depth_mm, mm_per_unit)
            }
            Variant::LowPoly { vertices } => decimated(head, *vertices),
            _ => {
                let placement = self.placement(mm_per_unit);
                Head::new(
                    &head.name,
                    head.positions.iter().map(|&p| placement.apply(p)).collect(),
                    head.triangles.clone(),
                )
            }
        }
    }
}

/// The part of `head` within `radius_mm` of `centre` and at most `depth_mm` behind it
/// (along -z: the head faces +z), renumbered, triangles kept whole.
pub fn cut_face(head: &Head, centre: Vec3, radius_mm: f32, depth_mm: f32, mm_per_unit: f32) -> Head {
    let keep: Vec<bool> = head
        .positions
        .iter()
        .map(|p| p.distance(centre) * mm_per_unit < radius_mm && (centre.z - p.z) * mm_per_unit < depth_mm)
        .collect();
    let triangles: Vec<[u32; 3]> = head
        .triangles
        .iter()
        .filter(|t| t.iter().all(|&v| keep[v as usize]))
        .copied()
        .collect();
    Head::compacted(&head.name, &head.positions, &triangles)
}

/// `head` with about `vertices` vertices left by meshoptimizer's quadric edge collapse (no
/// error bound: the count decides), unreferenced vertices dropped.
pub fn decimated(head: &Head, vertices: usize) -> Head {
    let bytes: Vec<u8> = head
        .positions
        .iter()
        .flat_map(|p| p.to_array())
        .flat_map(f32::to_le_bytes)
        .collect();
    let adapter = meshopt::VertexDataAdapter::new(&bytes, 12, 0).expect("12-byte positions");
    let indices: Vec<u32> = head.triangles.iter().flatten().copied().collect();
    // A closed triangulated surface has about twice as many triangles as vertices.
    let target = 3 * 2 * vertices.min(head.positions.len());
    let kept = meshopt::simplify(
        &indices,
        &adapter,
        target,
        f32::MAX,
        meshopt::SimplifyOptions::None,
        None,
    );
    let triangles: Vec<[u32; 3]> = kept.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    Head::compacted(&head.name, &head.positions, &triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placements_turn_mirror_and_scale_as_named() {
        let p = Vec3::new(1.0, 2.0, 3.0);
        // Z up: the old up (+y) is now +z, the old forward (+z) now -y.
        let z_up = Variant::ZUp.placement(10.0);
        assert!(z_up.apply(Vec3::Y).distance(Vec3::Z) < 1e-6);
        assert!(z_up.apply(Vec3::Z).distance(-Vec3::Y) < 1e-6);
        assert!(!z_up.mirrors());
        let mirrored = Variant::Mirrored { axis: 0 }.placement(10.0);
        assert_eq!(mirrored.apply(p), Vec3::new(-1.0, 2.0, 3.0));
        assert!(mirrored.mirrors());
        // Centimetres written as metres: a hundredth.
        let metres = Variant::InUnits(Unit::Metres).placement(10.0);
        assert!((metres.scale() - 0.01).abs() < 1e-7);
        assert!(metres.apply(p).distance(p * 0.01) < 1e-7);
    }

    #[test]
    fn a_decimated_grid_keeps_about_the_asked_vertices_and_its_outline() {
        let grid = crate::head::flat_grid(40);
        let low = decimated(&grid, 100);
        assert!(
            (60..=140).contains(&low.positions.len()),
            "{}",
            low.positions.len()
        );
        let (a, b) = (grid.bounds(), low.bounds());
        assert!(
            a.min.distance(b.min) < 1e-4 && a.max.distance(b.max) < 1e-4,
            "{b:?}"
        );
        assert!(low.problems.is_empty(), "{:?}", low.problems);
    }

    #[test]
    fn a_face_cut_keeps_what_lies_near_the_centre_and_in_front() {
        let grid = crate::head::flat_grid(10);
        // Unit squares read as 1 mm; 3 mm around (5, 5).
        let cut = cut_face(&grid, Vec3::new(5.0, 5.0, 0.0), 3.0, 1.0, 1.0);
        assert!(cut
            .positions
            .iter()
            .all(|p| p.distance(Vec3::new(5.0, 5.0, 0.0)) < 3.0));
        assert!(!cut.triangles.is_empty());
    }
}
