//! A population of heads to measure the automatic fit on heads it was never tuned on: ICT
//! Face Model identities made on demand (two spreads), the MakeHuman head, the scan and the
//! generic ICT head, and variants of them as users' files come (face cuts, a low-poly face,
//! other axes, turned, mirrored, other units). Each member carries its reference: the
//! landmark fit of the head it was made from, carried into its frame. Part of it is held
//! out of development and reported apart. `facewire population` prints the table.

pub mod identity_model;
mod measure;
pub mod variant;

use std::path::{Path, PathBuf};

use glam::{Mat3, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::animate::PartInput;
use crate::fit::{fit_from_landmarks, Fit, FittedMask, Landmarks};
use crate::head::{Head, PartRole};
use crate::mask::Mask;
pub use identity_model::{IdentityModel, IdentityModelError, IdentityPart};
pub use measure::{measure, Measures, Outcome};
pub use variant::{Placement, Unit, Variant};

/// Where a member's head comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Source {
    /// An identity of the ICT Face Model: weights N(0, sigma^2) from `seed`.
    IctIdentity { seed: u64, sigma: f32 },
    /// The ICT Face Model's generic head (`data/heads/ict_head.obj`).
    IctGeneric,
    /// The MakeHuman head (`data/heads/makehuman_head.obj`).
    MakeHuman,
    /// The scanned head (`data/heads/lee_perry_smith_head.obj`).
    Scan,
}

impl Source {
    /// The family it belongs to, for per-source summaries: `ict`, `makehuman`, `scan`.
    pub fn family(&self) -> &'static str {
        match self {
            Source::IctIdentity { .. } | Source::IctGeneric => "ict",
            Source::MakeHuman => "makehuman",
            Source::Scan => "scan",
        }
    }

    pub fn label(&self) -> String {
        match self {
            Source::IctIdentity { seed, sigma } => format!("ict seed {seed} (sigma {sigma})"),
            Source::IctGeneric => "ict generic".into(),
            Source::MakeHuman => "makehuman".into(),
            Source::Scan => "scan".into(),
        }
    }

    /// The folder of expression targets (ground truth) of its heads, relative to
    /// `data/heads/`; `None` for the scan, which has none.
    pub fn targets_dir(&self) -> Option<&'static str> {
        match self {
            Source::IctIdentity { .. } | Source::IctGeneric => Some("ict_targets/skin"),
            Source::MakeHuman => Some("makehuman_arkit"),
            Source::Scan => None,
        }
    }

    fn shipped(&self) -> Option<(&'static str, &'static str)> {
        match self {
            Source::IctIdentity { .. } | Source::IctGeneric => None,
            Source::MakeHuman => Some(("makehuman_head.obj", "makehuman_head.landmarks.toml")),
            Source::Scan => Some(("lee_perry_smith_head.obj", "lee_perry_smith_head.landmarks.toml")),
        }
    }
}

/// One member: a source head and the changes made to it, in order (face cuts and
/// decimation first, as they read the source's frame).
#[derive(Debug, Clone, PartialEq)]
pub struct MemberSpec {
    pub source: Source,
    pub variants: Vec<Variant>,
    /// Kept out of development: reported apart, never looked at head by head while the
    /// method is changed.
    pub held_out: bool,
}

impl MemberSpec {
    fn new(source: Source, variants: Vec<Variant>, held_out: bool) -> MemberSpec {
        MemberSpec {
            source,
            variants,
            held_out,
        }
    }

    pub fn name(&self) -> String {
        let mut name = self.source.label();
        for variant in &self.variants {
            name.push_str(", ");
            name.push_str(&variant.label());
        }
        name
    }
}

/// A member made: its head and its reference, in the head's own frame and units.
#[derive(Debug, Clone)]
pub struct Member {
    pub spec: MemberSpec,
    pub head: Head,
    /// The landmark fit's mask vertices that its landmarks hold (mask vertex, head units).
    pub reference: Vec<(u32, Vec3)>,
    /// The head's true millimetres per unit (the scan's from its landmark fit's 63 mm
    /// pupils: no physical scale is known for it).
    pub mm_per_unit: f32,
    /// The head's frame is a mirror image of the source's: the mask's left lies where the
    /// reference's right does.
    pub mirrored: bool,
    /// The landmark fit itself, for a member with no variants (its head is the source's).
    pub landmark_fit: Option<Fit>,
    /// Its teeth, gums and tongue as users have them, for an ICT member with no variants
    /// (the shipped heads' parts are not part of the population): see [`ict_parts`].
    pub parts: Vec<PartInput>,
}

#[derive(Debug, thiserror::Error)]
pub enum PopulationError {
    #[error(transparent)]
    Model(#[from] IdentityModelError),
    #[error("{path}: {message}")]
    Shipped { path: PathBuf, message: String },
}

/// Makes members from the project's data folder (`data/`), loading the identity model once.
pub struct Maker {
    data_dir: PathBuf,
    model: IdentityModel,
    ict_landmarks: Landmarks,
    mask: Mask,
}

/// Spread of the two ICT populations: the model's own sampler's (1) and a wider one.
pub const SIGMAS: [f32; 2] = [1.0, 1.5];

impl Maker {
    pub fn new(data_dir: &Path) -> Result<Maker, PopulationError> {
        let model = IdentityModel::load(&IdentityModel::shipped_dir(data_dir))?;
        let ict_landmarks = load_landmarks(data_dir, "ict_head.landmarks.toml")?;
        Ok(Maker {
            data_dir: data_dir.to_path_buf(),
            model,
            ict_landmarks,
            mask: Mask::candide3(),
        })
    }

    pub fn model(&self) -> &IdentityModel {
        &self.model
    }

    /// The member's head and reference.
    pub fn make(&self, spec: &MemberSpec) -> Result<Member, PopulationError> {
        let weights = match spec.source {
            Source::IctIdentity { seed, sigma } => Some(self.model.weights(seed, sigma)),
            Source::IctGeneric => Some(Vec::new()),
            Source::MakeHuman | Source::Scan => None,
        };
        let parts = match &weights {
            Some(weights) if spec.variants.is_empty() => ict_parts(&self.model, weights),
            _ => Vec::new(),
        };
        let (head, landmarks) = match spec.source {
            Source::IctIdentity { seed, .. } => (
                self.model.part(
                    IdentityPart::Skin,
                    weights.as_deref().unwrap_or_default(),
                    &format!("ict_seed{seed}.obj"),
                ),
                self.ict_landmarks.clone(),
            ),
            Source::IctGeneric => (
                self.model.part(IdentityPart::Skin, &[], "ict_head.obj"),
                self.ict_landmarks.clone(),
            ),
            Source::MakeHuman | Source::Scan => {
                let (obj, landmarks) = spec.source.shipped().expect("a shipped head");
                let path = self.data_dir.join("heads").join(obj);
                let head = Head::load(&path).map_err(|e| PopulationError::Shipped {
                    path: path.clone(),
                    message: e.to_string(),
                })?;
                (head, load_landmarks(&self.data_dir, landmarks)?)
            }
        };
        let fit = fit_from_landmarks(&head, &landmarks, "landmarks", &self.mask).map_err(|e| {
            PopulationError::Shipped {
                path: self.data_dir.join("heads"),
                message: format!("{}: reference fit: {e}", spec.source.label()),
            }
        })?;
        let fitted = FittedMask::new(self.mask.clone(), fit.fit.clone());
        let mut reference: Vec<(u32, Vec3)> = landmarks
            .landmarks
            .iter()
            .map(|l| (l.mask_vertex, fitted.neutral[l.mask_vertex as usize]))
            .collect();
        let nose_tip = landmarks
            .landmarks
            .iter()
            .find(|l| l.mask_vertex == 5)
            .map_or(fitted.neutral[5], |l| head.positions[l.head_vertex as usize]);
        let mut mm_per_unit = fitted.fit.mm_per_unit;
        let mut head = head;
        let mut linear = Mat3::IDENTITY;
        for variant in &spec.variants {
            let placement = variant.placement(mm_per_unit);
            head = variant.apply(&head, linear * nose_tip, mm_per_unit);
            for (_, p) in &mut reference {
                *p = placement.apply(*p);
            }
            linear = placement.linear * linear;
            mm_per_unit /= placement.scale();
        }
        head.name = spec.name();
        Ok(Member {
            spec: spec.clone(),
            head,
            reference,
            mm_per_unit,
            mirrored: linear.determinant() < 0.0,
            landmark_fit: spec.variants.is_empty().then_some(fit.fit),
            parts,
        })
    }
}

/// Vertices of the model's gums-and-tongue mesh that are the upper gums (0..568); the rest
/// are the lower gums, the floor of the mouth and the tongue, one connected surface.
pub const UPPER_GUMS: u32 = 568;

/// An ICT identity's parts as a user would pass them: the teeth as the model ships them,
/// both rows in one mesh with no role (facewire splits it); the gums and tongue cut where
/// the shipped ICT head's are (`data/heads/LICENSES.md`): `gums_upper` (skull) and
/// `gums_lower_tongue` (tongue); and both eyeballs in one mesh, role `eyes` (facewire splits
/// them by side).
pub fn ict_parts(model: &IdentityModel, weights: &[f32]) -> Vec<PartInput> {
    let gums_tongue = model.part(IdentityPart::GumsTongue, weights, "gums_tongue");
    let side = |upper: bool, name: &str| {
        let triangles: Vec<[u32; 3]> = gums_tongue
            .triangles
            .iter()
            .filter(|t| t.iter().all(|&v| (v < UPPER_GUMS) == upper))
            .copied()
            .collect();
        Head::compacted(name, &gums_tongue.positions, &triangles)
    };
    vec![
        PartInput {
            name: "teeth".into(),
            role: None,
            mesh: model.part(IdentityPart::Teeth, weights, "teeth"),
        },
        PartInput {
            name: "gums_upper".into(),
            role: Some(PartRole::Skull),
            mesh: side(true, "gums_upper"),
        },
        PartInput {
            name: "gums_lower_tongue".into(),
            role: Some(PartRole::Tongue),
            mesh: side(false, "gums_lower_tongue"),
        },
        PartInput {
            name: "eyes".into(),
            role: Some(PartRole::Eyes),
            mesh: model.part(IdentityPart::Eyes, weights, "eyes"),
        },
    ]
}

fn load_landmarks(data_dir: &Path, name: &str) -> Result<Landmarks, PopulationError> {
    let path = data_dir.join("heads").join(name);
    Landmarks::load(&path).map_err(|e| PopulationError::Shipped {
        path,
        message: e.to_string(),
    })
}

/// The population: at least 60 heads from three sources. Development members first, then
/// the held-out ones (other seeds, other turns).
pub fn members() -> Vec<MemberSpec> {
    let ict = |seed: u64, sigma: f32| Source::IctIdentity { seed, sigma };
    let face_cut = Variant::FaceCut {
        radius_mm: 110.0,
        depth_mm: 60.0,
    };
    let mut members = Vec::new();
    // 40 identities as they come, 30 of the model's own spread and 10 wider.
    for seed in 1..=30 {
        members.push(MemberSpec::new(ict(seed, SIGMAS[0]), vec![], false));
    }
    for seed in 31..=40 {
        members.push(MemberSpec::new(ict(seed, SIGMAS[1]), vec![], false));
    }
    for source in [Source::IctGeneric, Source::MakeHuman, Source::Scan] {
        members.push(MemberSpec::new(source, vec![], false));
        members.push(MemberSpec::new(source, vec![face_cut.clone()], false));
    }
    let variants = [
        vec![face_cut.clone()],
        vec![face_cut.clone(), Variant::LowPoly { vertices: 500 }],
        vec![Variant::ZUp],
        vec![Variant::MinusZForward],
        vec![Variant::Mirrored { axis: 0 }],
        vec![Variant::Mirrored { axis: 2 }],
        vec![Variant::InUnits(Unit::Millimetres)],
        vec![Variant::InUnits(Unit::Metres)],
        vec![Variant::InUnits(Unit::Inches)],
        vec![Variant::Turned {
            axis: Vec3::X,
            degrees: 15.0,
        }],
        vec![Variant::Turned {
            axis: Vec3::X,
            degrees: -20.0,
        }],
        vec![Variant::Turned {
            axis: Vec3::Z,
            degrees: 28.0,
        }],
    ];
    for (k, variant) in variants.into_iter().enumerate() {
        members.push(MemberSpec::new(ict(41 + k as u64, SIGMAS[k % 2]), variant, false));
    }
    members.push(MemberSpec::new(
        Source::MakeHuman,
        vec![face_cut.clone(), Variant::LowPoly { vertices: 500 }],
        false,
    ));
    members.push(MemberSpec::new(Source::Scan, vec![Variant::ZUp], false));
    let mut turns = ChaCha8Rng::seed_from_u64(0x7e57);
    for k in 0..4 {
        members.push(MemberSpec::new(
            ict(60 + k, SIGMAS[0]),
            vec![random_turn(&mut turns)],
            false,
        ));
    }
    // Held out: other seeds and other turns, never tuned on.
    for seed in 1001..=1010 {
        members.push(MemberSpec::new(
            ict(seed, SIGMAS[(seed % 2) as usize]),
            vec![],
            true,
        ));
    }
    let mut held_turns = ChaCha8Rng::seed_from_u64(0x4e1d);
    for seed in 1011..=1014 {
        members.push(MemberSpec::new(
            ict(seed, SIGMAS[0]),
            vec![random_turn(&mut held_turns)],
            true,
        ));
    }
    members.push(MemberSpec::new(
        ict(1015, SIGMAS[1]),
        vec![face_cut.clone()],
        true,
    ));
    members.push(MemberSpec::new(
        ict(1016, SIGMAS[0]),
        vec![face_cut, Variant::LowPoly { vertices: 500 }],
        true,
    ));
    members.push(MemberSpec::new(
        ict(1017, SIGMAS[0]),
        vec![Variant::ZUp, Variant::InUnits(Unit::Millimetres)],
        true,
    ));
    members.push(MemberSpec::new(
        Source::MakeHuman,
        vec![random_turn(&mut held_turns)],
        true,
    ));
    members
}

/// The members whose heads are their sources' own (no cut, no other frame): those the
/// animation is measured on (`facewire population --animate`), with their parts and
/// their landmark fits.
pub fn whole_heads() -> Vec<MemberSpec> {
    members().into_iter().filter(|m| m.variants.is_empty()).collect()
}

/// The whole heads CI animates: every tenth development ICT head, MakeHuman and the scan,
/// and every fifth held-out head.
pub fn whole_heads_sample() -> Vec<MemberSpec> {
    let (dev, held): (Vec<_>, Vec<_>) = whole_heads().into_iter().partition(|m| !m.held_out);
    let (ict, others): (Vec<_>, Vec<_>) = dev.into_iter().partition(|m| m.source.family() == "ict");
    ict.into_iter()
        .step_by(10)
        .chain(others)
        .chain(held.into_iter().step_by(5))
        .collect()
}

/// Every third development member and every fourth held-out one: the sample CI runs.
pub fn sample() -> Vec<MemberSpec> {
    let all = members();
    let (dev, held): (Vec<_>, Vec<_>) = all.into_iter().partition(|m| !m.held_out);
    dev.into_iter()
        .step_by(3)
        .chain(held.into_iter().step_by(4))
        .collect()
}

/// A turn about an axis drawn evenly over the sphere, by an angle drawn evenly in 0-180
/// degrees.
fn random_turn(rng: &mut ChaCha8Rng) -> Variant {
    let z: f32 = rng.random_range(-1.0..1.0);
    let phi: f32 = rng.random_range(0.0..std::f32::consts::TAU);
    let r = (1.0 - z * z).sqrt();
    Variant::Turned {
        axis: Vec3::new(r * phi.cos(), r * phi.sin(), z),
        degrees: rng.random_range(0.0..180.0),
    }
}
