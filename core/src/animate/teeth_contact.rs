//! Contact as a constraint: after the deform, lip vertices that went into a tooth (pressed
//! by a frame against the incisors) and tongue vertices shaped into one are
//! put back just outside it, and their neighbours follow with a smooth falloff so that no
//! crease marks the spot. The measures in `metrics::contact` report what is left.
//!
//! The teeth are the closed pieces of the skull and jaw parts ([`crate::head::solid`]);
//! skull pieces stay at rest, jaw pieces move with the frame's jaw motion, all in the
//! head's frame before its own motion. A lip vertex already inside a tooth at rest (a
//! model's lips may rest in its teeth) may go as deep as it rests, no deeper: moving it out
//! would change the head at rest, and leaving it free folds the lip where its pushed
//! neighbours meet it. A tongue vertex inside a tooth at rest (gums round a tooth's neck)
//! is left to the tongue's shaping.
//!
//! Per frame, for each watched vertex inside a tooth: its push `d` is from where it is
//! to the tooth's nearest surface point, plus [`CONTACT_MARGIN_MM`] along the same line.
//! Every vertex `u` within [`FALLOFF_MM`] over the surface of a pushed vertex `v` moves by
//! `w(|uv|) d_v` with `w(s) = (1 - (s / FALLOFF_MM)²)²`; where several pushes reach `u`,
//! the largest of them. A push may leave a vertex in the next tooth (between two teeth),
//! so the search runs again, at most [`PASSES`] times; a vertex the last round left in a
//! tooth then goes out alone, with no falloff. Each job remembers where each
//! vertex was last found clear of the teeth and by how much; until it has moved that far
//! from there it cannot be inside one and is not tested, so a frame tests the few
//! vertices near the teeth that moved. The bound holds for any next frame (a seek, a
//! replay): the answers are those of testing every vertex. Nothing is allocated per frame.

use glam::{Affine3A, Vec3};

use crate::head::{closed_pieces, surface_of, Head, Part, PartRole, Solid, SurfaceDistance, SurfaceIndex};

/// Pushed vertices end this far outside the tooth, mm.
pub const CONTACT_MARGIN_MM: f32 = 0.2;
/// Reach of a push into the vertex's neighbours over the surface, mm.
pub const FALLOFF_MM: f32 = 3.0;
/// At most this many rounds of pushes per frame: a push may leave a neighbour, or a vertex
/// between two teeth, in the next tooth.
pub const PASSES: usize = 4;
/// Lip vertices this close to the teeth's box at rest are watched, mm.
pub const WATCH_MM: f32 = 15.0;

/// Vertices of one mesh that are watched, each with the neighbours its push reaches.
#[derive(Debug, Clone)]
struct Watched {
    vertices: Vec<u32>,
    /// Each vertex's index in `vertices`, [`NOT_WATCHED`] for one not watched.
    index_of: Vec<u32>,
    /// Each watched vertex's clearance at rest.
    at_rest: Vec<Clearance>,
    /// How deep each may be in a tooth (head units): 0, or for a lip vertex that rests
    /// in a tooth, its depth at rest.
    allowed: Vec<f32>,
    /// For `vertices[k]`: `reach[start[k]..start[k + 1]]`, (vertex, weight), itself first.
    start: Vec<u32>,
    reach: Vec<(u32, f32)>,
}

impl Watched {
    /// Every vertex of `mesh` that `watch` keeps (giving how deep in a tooth it may be),
    /// with its reach over the surface and its clearance from the `teeth` (skull's,
    /// jaw's) at rest.
    fn new(
        mesh: &Head,
        falloff: f32,
        teeth: [&Option<SurfaceIndex>; 2],
        mut watch: impl FnMut(u32, Vec3) -> Option<f32>,
    ) -> Watched {
        let mut distances = SurfaceDistance::new(mesh.positions.len());
        let mut watched = Watched {
            vertices: Vec::new(),
            index_of: vec![NOT_WATCHED; mesh.positions.len()],
            at_rest: Vec::new(),
            allowed: Vec::new(),
            start: vec![0],
            reach: Vec::new(),
        };
        for (v, &p) in mesh.positions.iter().enumerate() {
            let Some(allowed) = watch(v as u32, p) else {
                continue;
            };
            watched.allowed.push(allowed);
            watched.index_of[v] = watched.vertices.len() as u32;
            watched.vertices.push(v as u32);
            // A vertex in a tooth at rest has no clearance: it is probed every frame.
            watched.at_rest.push(Clearance {
                at: [p; 2],
                by: teeth.map(|surface| match allowed > 0.0 {
                    true => 0.0,
                    false => surface
                        .as_ref()
                        .and_then(|s| s.closest_point(p))
                        .map_or(f32::INFINITY, |hit| hit.distance),
                }),
            });
            let reached = distances
                .run(&mesh.topology, &[(v as u32, 0.0)], falloff)
                .to_vec();
            for u in reached {
                let s = distances.distance(u) / falloff;
                watched.reach.push((u, (1.0 - s * s).powi(2)));
            }
            watched.start.push(watched.reach.len() as u32);
        }
        watched
    }

    fn is_empty(&self) -> bool {
        self.vertices.is_empty()
    }
}

/// [`Watched::index_of`] a vertex that is not watched.
const NOT_WATCHED: u32 = u32::MAX;

/// Where a watched vertex was last found clear of the teeth, in the skull's frame and in
/// the jaw's (head units), and by how much: until it has moved that far from there it
/// cannot be inside a tooth, and is not tested.
#[derive(Debug, Clone, Copy)]
struct Clearance {
    at: [Vec3; 2],
    by: [f32; 2],
}

/// What a probe of the teeth found at a point.
enum Probe<'s> {
    Inside(&'s Solid),
    /// Outside every tooth, at least this far from them (head units).
    Clear(f32),
}

/// The teeth of one head and the vertices that must stay out of them: built once per
/// head, shared by its jobs (each keeps a [`ContactScratch`]).
#[derive(Debug, Clone)]
pub struct TeethContact {
    skull: Vec<Solid>,
    jaw: Vec<Solid>,
    skin: Watched,
    /// The tongue part's rest positions and its watched vertices.
    tongue: Option<(Vec<Vec3>, Watched)>,
    /// [`CONTACT_MARGIN_MM`] in head units.
    margin: f32,
}

/// Per-job buffers of [`TeethContact::apply`].
#[derive(Debug, Clone)]
pub struct ContactScratch {
    /// The skin's and the tongue's watched vertices' clearances, as the last frames left
    /// them (a bound that holds whatever frame comes next).
    skin: Vec<Clearance>,
    tongue: Vec<Clearance>,
    rounds: Rounds,
}

/// The buffers of one round of pushes.
#[derive(Debug, Clone)]
struct Rounds {
    /// (watched index, push), this round.
    pushes: Vec<(u32, Vec3)>,
    /// The watched vertices the last round moved: the next round tests only those.
    recheck: Vec<u32>,
    /// The offset of each vertex of the mesh being settled, and which are non-zero.
    offsets: Vec<Vec3>,
    touched: Vec<u32>,
}

/// A mesh the constraint moves: where its vertices are (head frame, before the head's
/// motion) and how a push in that frame moves one.
trait Moving {
    fn position(&self, v: u32) -> Vec3;
    fn push(&mut self, v: u32, by: Vec3);
}

/// The deformed skin: positions as they are.
struct Skin<'a>(&'a mut [Vec3]);

impl Moving for Skin<'_> {
    fn position(&self, v: u32) -> Vec3 {
        self.0[v as usize]
    }

    fn push(&mut self, v: u32, by: Vec3) {
        self.0[v as usize] += by;
    }
}

/// The tongue: at `jaw(rest + delta)`; a push goes back into the deltas' frame.
struct Tongue<'a> {
    rest: &'a [Vec3],
    deltas: &'a mut [Vec3],
    jaw: Affine3A,
    jaw_inverse: Affine3A,
}

impl Moving for Tongue<'_> {
    fn position(&self, v: u32) -> Vec3 {
        self.jaw
            .transform_point3(self.rest[v as usize] + self.deltas[v as usize])
    }

    fn push(&mut self, v: u32, by: Vec3) {
        self.deltas[v as usize] += self.jaw_inverse.transform_vector3(by);
    }
}

/// What one frame's constraint did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContactApplied {
    /// Skin and tongue vertices found inside a tooth and pushed out.
    pub skin_pushed: u32,
    pub tongue_pushed: u32,
}

impl TeethContact {
    /// The constraint for the vertices of the `lips` triangles of `skin` (head units,
    /// `mm_per_unit` mm each) and for the tongue among `parts`; `None` when no part has a
    /// closed piece (no teeth to keep out of).
    pub fn new(skin: &Head, lips: &[u32], parts: &[Part], mm_per_unit: f32) -> Option<TeethContact> {
        let (mut skull, mut jaw) = (Vec::new(), Vec::new());
        for part in parts {
            match part.role {
                PartRole::Skull => skull.extend(closed_pieces(&part.mesh).0),
                PartRole::Jaw => jaw.extend(closed_pieces(&part.mesh).0),
                PartRole::Tongue | PartRole::Eyes => {}
            }
        }
        if skull.is_empty() && jaw.is_empty() {
            return None;
        }
        let (mut min, mut max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for solid in skull.iter().chain(&jaw) {
            min = min.min(solid.min);
            max = max.max(solid.max);
        }
        let reach = Vec3::splat(WATCH_MM / mm_per_unit);
        let (near_min, near_max) = (min - reach, max + reach);
        let depth_at_rest = |p: Vec3| {
            skull
                .iter()
                .chain(&jaw)
                .find(|solid| solid.contains(p))
                .map(|solid| solid.distance(p))
        };
        let falloff = FALLOFF_MM / mm_per_unit;
        let surface = |solids: &[Solid]| {
            let triangles: Vec<[Vec3; 3]> = solids.iter().flat_map(|s| s.triangles.iter().copied()).collect();
            surface_of(&triangles)
        };
        let teeth = [&surface(&skull), &surface(&jaw)];
        let mut on_lips = vec![false; skin.positions.len()];
        for &t in lips {
            for v in skin.triangles[t as usize] {
                on_lips[v as usize] = true;
            }
        }
        let skin = Watched::new(skin, falloff, teeth, |v, p| {
            (on_lips[v as usize] && p.cmpge(near_min).all() && p.cmple(near_max).all())
                .then(|| depth_at_rest(p).map_or(0.0, |depth| depth.max(f32::MIN_POSITIVE)))
        });
        let tongue = parts
            .iter()
            .find(|p| p.role == PartRole::Tongue)
            .map(|part| {
                let watched = Watched::new(&part.mesh, falloff, teeth, |_, p| {
                    depth_at_rest(p).is_none().then_some(0.0)
                });
                (part.mesh.positions.clone(), watched)
            })
            .filter(|(_, w)| !w.is_empty());
        Some(TeethContact {
            skull,
            jaw,
            skin,
            tongue,
            margin: CONTACT_MARGIN_MM / mm_per_unit,
        })
    }

    /// Buffers for one job on a head of `skin_vertices` vertices whose tongue has
    /// `tongue_vertices`.
    pub fn scratch(&self, skin_vertices: usize, tongue_vertices: usize) -> ContactScratch {
        let watched = self
            .skin
            .vertices
            .len()
            .max(self.tongue.as_ref().map_or(0, |(_, w)| w.vertices.len()));
        let vertices = skin_vertices.max(tongue_vertices);
        ContactScratch {
            skin: self.skin.at_rest.clone(),
            tongue: self
                .tongue
                .as_ref()
                .map_or(Vec::new(), |(_, w)| w.at_rest.clone()),
            rounds: Rounds {
                pushes: Vec::with_capacity(watched),
                recheck: Vec::with_capacity(watched),
                offsets: vec![Vec3::ZERO; vertices],
                touched: Vec::with_capacity(vertices),
            },
        }
    }

    /// Puts the skin (deformed, head units, before the head's motion) and the tongue (its
    /// rest plus `tongue_deltas`, before `jaw`; `None` for a head without a tongue) back
    /// out of the teeth, `jaw` moving the jaw's teeth (and the tongue).
    pub fn apply(
        &self,
        skin: &mut [Vec3],
        jaw: Affine3A,
        tongue_deltas: Option<&mut [Vec3]>,
        scratch: &mut ContactScratch,
    ) -> ContactApplied {
        let jaw_inverse = jaw.inverse();
        let ContactScratch {
            skin: skin_clearance,
            tongue: tongue_clearance,
            rounds,
        } = scratch;
        let skin_pushed = self.settle(
            &self.skin,
            skin_clearance,
            &mut Skin(skin),
            &jaw,
            &jaw_inverse,
            rounds,
        );
        let tongue_pushed = match (&self.tongue, tongue_deltas) {
            (Some((rest, watched)), Some(deltas)) => {
                let mut tongue = Tongue {
                    rest,
                    deltas,
                    jaw,
                    jaw_inverse,
                };
                self.settle(watched, tongue_clearance, &mut tongue, &jaw, &jaw_inverse, rounds)
            }
            _ => 0,
        };
        ContactApplied {
            skin_pushed,
            tongue_pushed,
        }
    }

    /// Rounds of pushes on one mesh's `watched` vertices until none is inside a tooth or
    /// [`PASSES`] rounds have run: the first round tests every watched vertex, the next
    /// ones those the last round moved. Returns how many the first round pushed.
    fn settle(
        &self,
        watched: &Watched,
        clearances: &mut [Clearance],
        mesh: &mut impl Moving,
        jaw: &Affine3A,
        jaw_inverse: &Affine3A,
        rounds: &mut Rounds,
    ) -> u32 {
        let mut first = 0;
        let mut settled = false;
        for pass in 0..PASSES {
            rounds.pushes.clear();
            let mut probe = |k: u32| {
                let p = mesh.position(watched.vertices[k as usize]);
                let allowed = watched.allowed[k as usize];
                if let Some(push) =
                    self.probe_vertex(&mut clearances[k as usize], p, allowed, jaw, jaw_inverse)
                {
                    rounds.pushes.push((k, push));
                }
            };
            match pass {
                0 => (0..watched.vertices.len() as u32).for_each(&mut probe),
                _ => rounds.recheck.iter().copied().for_each(&mut probe),
            }
            if pass == 0 {
                first = rounds.pushes.len() as u32;
            }
            if rounds.pushes.is_empty() {
                settled = true;
                break;
            }
            spread(watched, rounds);
            rounds.recheck.clear();
            for &u in &rounds.touched {
                mesh.push(u, rounds.offsets[u as usize]);
                rounds.offsets[u as usize] = Vec3::ZERO;
                if watched.index_of[u as usize] != NOT_WATCHED {
                    rounds.recheck.push(watched.index_of[u as usize]);
                }
            }
        }
        if !settled {
            // The last round's pushes may have left a neighbour in a tooth, a fraction of
            // a millimetre deep: each such vertex goes out on its own, with no falloff.
            for &k in &rounds.recheck {
                let v = watched.vertices[k as usize];
                let allowed = watched.allowed[k as usize];
                let p = mesh.position(v);
                if let Some(push) =
                    self.probe_vertex(&mut clearances[k as usize], p, allowed, jaw, jaw_inverse)
                {
                    mesh.push(v, push);
                }
            }
        }
        first
    }

    /// A watched vertex at `p`: its push (head frame) if it is deeper in a tooth than
    /// `allowed`, else `None` with its clearance updated where it was probed clear.
    fn probe_vertex(
        &self,
        clearance: &mut Clearance,
        p: Vec3,
        allowed: f32,
        jaw: &Affine3A,
        jaw_inverse: &Affine3A,
    ) -> Option<Vec3> {
        let in_jaw = jaw_inverse.transform_point3(p);
        for (frame, (solids, q)) in [(&self.skull, p), (&self.jaw, in_jaw)].into_iter().enumerate() {
            if q.distance_squared(clearance.at[frame]) < clearance.by[frame] * clearance.by[frame] {
                continue;
            }
            match probe(solids, q) {
                Probe::Inside(solid) => {
                    let push = self.push(solid, q, allowed)?;
                    return Some(if frame == 0 {
                        push
                    } else {
                        jaw.transform_vector3(push)
                    });
                }
                Probe::Clear(by) => {
                    clearance.at[frame] = q;
                    clearance.by[frame] = by;
                }
            }
        }
        None
    }

    /// From `p` inside `solid` to [`CONTACT_MARGIN_MM`] outside its nearest surface point,
    /// or for a vertex `allowed` some depth (it rests inside), back to that depth; `None`
    /// when it is not deeper than that.
    fn push(&self, solid: &Solid, p: Vec3, allowed: f32) -> Option<Vec3> {
        let to_surface = solid.closest_point(p) - p;
        let depth = to_surface.length();
        if depth <= allowed {
            return None;
        }
        let by = match allowed > 0.0 {
            true => depth - allowed,
            false => depth + self.margin,
        };
        Some(to_surface * (by / depth))
    }
}

/// Whether `q` is inside one of `solids`, or how far it is at least from them all: the
/// distance to the nearest box of a solid; none when `q` is in a box but not in its solid
/// (an exact distance costs more than probing again next frame).
fn probe(solids: &[Solid], q: Vec3) -> Probe<'_> {
    let mut clear = f32::INFINITY;
    for solid in solids {
        let outside_box = (solid.min - q)
            .max(q - solid.max)
            .max(Vec3::ZERO)
            .length_squared();
        if outside_box > 0.0 {
            clear = clear.min(outside_box);
        } else if solid.contains(q) {
            return Probe::Inside(solid);
        } else {
            clear = 0.0;
        }
    }
    Probe::Clear(clear.sqrt())
}

/// Spreads `rounds.pushes` over each pushed vertex's reach into `rounds.offsets` (the
/// largest push reaching a vertex wins, but a pushed vertex takes its own push: it ends
/// outside its tooth whatever its neighbours do), listing the vertices touched.
fn spread(watched: &Watched, rounds: &mut Rounds) {
    rounds.touched.clear();
    for &(k, push) in &rounds.pushes {
        let (from, to) = (watched.start[k as usize], watched.start[k as usize + 1]);
        for &(u, w) in &watched.reach[from as usize..to as usize] {
            let offset = &mut rounds.offsets[u as usize];
            let candidate = push * w;
            if candidate.length_squared() > offset.length_squared() {
                if *offset == Vec3::ZERO {
                    rounds.touched.push(u);
                }
                *offset = candidate;
            }
        }
    }
    for &(k, push) in &rounds.pushes {
        let v = watched.vertices[k as usize];
        let offset = &mut rounds.offsets[v as usize];
        if *offset == Vec3::ZERO && push != Vec3::ZERO {
            rounds.touched.push(v);
        }
        *offset = push;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::head::{box_mesh, flat_grid};

    /// A closed box between `min` and `max` as a part with `role`.
    fn tooth(min: Vec3, max: Vec3, role: PartRole) -> Part {
        Part::new("tooth".into(), role, box_mesh(min, max), None)
    }

    /// Every triangle of `head`, as the lip region.
    fn all(head: &Head) -> Vec<u32> {
        (0..head.triangles.len() as u32).collect()
    }

    /// Grid vertex at (x, y) of `flat_grid(20)`.
    fn at(x: u32, y: u32) -> usize {
        (y * 21 + x) as usize
    }

    #[test]
    fn a_vertex_pressed_into_a_tooth_ends_just_outside_and_its_neighbours_follow() {
        // 1 head unit = 1 mm: the margin is 0.2 units, the falloff 3.
        let skin = flat_grid(20);
        let parts = [tooth(
            Vec3::new(9.0, 9.0, -3.0),
            Vec3::new(11.0, 11.0, -0.6),
            PartRole::Skull,
        )];
        let contact = TeethContact::new(&skin, &all(&skin), &parts, 1.0).expect("a closed tooth");
        let mut scratch = contact.scratch(skin.positions.len(), 0);
        let mut now = skin.positions.clone();
        now[at(10, 10)].z = -1.0;
        let applied = contact.apply(&mut now, Affine3A::IDENTITY, None, &mut scratch);
        assert_eq!(
            applied,
            ContactApplied {
                skin_pushed: 1,
                tongue_pushed: 0
            }
        );
        // Up through the nearest face (the top, 0.4 away), to 0.2 above it.
        assert!(
            (now[at(10, 10)] - Vec3::new(10.0, 10.0, -0.4)).length() < 1e-5,
            "{}",
            now[at(10, 10)]
        );
        // A neighbour 1 mm over the surface rises by w(1/3) = (1 - 1/9)^2 of the push (0.6).
        let w = (1.0f32 - 1.0 / 9.0).powi(2);
        assert!((now[at(11, 10)].z - 0.6 * w).abs() < 1e-5, "{}", now[at(11, 10)]);
        // Beyond the falloff nothing moves; no buffer grows.
        assert_eq!(now[at(14, 10)], skin.positions[at(14, 10)]);
        assert_eq!(now[at(10, 5)], skin.positions[at(10, 5)]);
        // The next frame starts clean: at rest, nothing is pushed.
        let mut rest = skin.positions.clone();
        assert_eq!(
            contact
                .apply(&mut rest, Affine3A::IDENTITY, None, &mut scratch)
                .skin_pushed,
            0
        );
        assert_eq!(rest, skin.positions);
    }

    #[test]
    fn the_jaw_carries_its_teeth_and_a_vertex_inside_at_rest_is_left_alone() {
        let skin = flat_grid(20);
        let parts = [
            // Above the skin at rest; the jaw brings it down through it.
            tooth(
                Vec3::new(9.0, 9.0, 1.0),
                Vec3::new(11.0, 11.0, 3.0),
                PartRole::Jaw,
            ),
            // Holds grid vertex (3, 3) at rest.
            tooth(
                Vec3::new(2.5, 2.5, -1.0),
                Vec3::new(3.5, 3.5, 1.0),
                PartRole::Skull,
            ),
        ];
        let contact = TeethContact::new(&skin, &all(&skin), &parts, 1.0).unwrap();
        let mut scratch = contact.scratch(skin.positions.len(), 0);
        let jaw = Affine3A::from_translation(Vec3::new(0.0, 0.0, -3.5));
        let mut now = skin.positions.clone();
        now[at(10, 10)].z = -1.0;
        now[at(3, 3)].z = 0.5;
        contact.apply(&mut now, jaw, None, &mut scratch);
        // The moved tooth spans z -2.5..-0.5: out through its top, to -0.3.
        assert!((now[at(10, 10)].z + 0.3).abs() < 1e-5, "{}", now[at(10, 10)]);
        assert_eq!(now[at(3, 3)].z, 0.5);
    }

    #[test]
    fn a_tongue_is_pushed_in_its_own_frame() {
        let skin = flat_grid(4);
        let mut tongue = flat_grid(20);
        tongue.name = "tongue".into();
        let parts = [
            tooth(
                Vec3::new(9.0, 9.0, 0.6),
                Vec3::new(11.0, 11.0, 3.0),
                PartRole::Skull,
            ),
            Part::new("tongue".into(), PartRole::Tongue, tongue.clone(), None),
        ];
        let contact = TeethContact::new(&skin, &all(&skin), &parts, 1.0).unwrap();
        let mut scratch = contact.scratch(skin.positions.len(), tongue.positions.len());
        let mut deltas = vec![Vec3::ZERO; tongue.positions.len()];
        // The tongue's vertex raised 1 into the tooth, the jaw lowering it 0.5 back: 0.5 in.
        deltas[at(10, 10)].z = 1.5;
        let jaw = Affine3A::from_translation(Vec3::new(0.0, 0.0, -0.5));
        let mut skin_now = skin.positions.clone();
        let applied = contact.apply(&mut skin_now, jaw, Some(&mut deltas), &mut scratch);
        assert_eq!(applied.tongue_pushed, 1);
        // In the head's frame it ends at 0.6 - 0.2 = 0.4: a delta of 0.9.
        assert!(
            (deltas[at(10, 10)].z - 0.9).abs() < 1e-5,
            "{}",
            deltas[at(10, 10)]
        );
    }

    #[test]
    fn remembered_clearances_give_the_answers_of_testing_every_vertex() {
        // A row of teeth under the skin and a bump of skin that sinks into them and rises
        // again, frame after frame, with the jaw moving: a job that remembers where each
        // vertex was last clear must push exactly as one that tests every vertex afresh.
        let skin = flat_grid(20);
        let parts = [
            tooth(
                Vec3::new(4.0, 4.0, -3.0),
                Vec3::new(8.0, 8.0, -0.3),
                PartRole::Skull,
            ),
            tooth(
                Vec3::new(11.0, 4.0, -3.0),
                Vec3::new(15.0, 8.0, -0.3),
                PartRole::Jaw,
            ),
        ];
        let contact = TeethContact::new(&skin, &all(&skin), &parts, 1.0).unwrap();
        let mut kept = contact.scratch(skin.positions.len(), 0);
        let mut pushed_frames = 0;
        for f in 0..40 {
            let t = f as f32 / 39.0 * std::f32::consts::TAU;
            let depth = 2.0 * t.sin().max(0.0) + 0.3 * (3.0 * t).cos();
            let mut now = skin.positions.clone();
            for (v, p) in now.iter_mut().enumerate() {
                let (x, y) = ((v % 21) as f32, (v / 21) as f32);
                let r2 = (x - 10.0).powi(2) / 30.0 + (y - 6.0).powi(2) / 6.0;
                p.z -= depth * (-r2).exp();
            }
            let jaw = Affine3A::from_translation(Vec3::new(0.0, 0.0, 0.4 * t.cos()));
            let mut afresh = now.clone();
            let a = contact.apply(&mut now, jaw, None, &mut kept);
            let b = contact.apply(
                &mut afresh,
                jaw,
                None,
                &mut contact.scratch(skin.positions.len(), 0),
            );
            assert_eq!(a, b, "frame {f}");
            assert_eq!(now, afresh, "frame {f}");
            pushed_frames += usize::from(a.skin_pushed > 0);
        }
        // Both kinds of frame were seen.
        assert!(
            (5..35).contains(&pushed_frames),
            "{pushed_frames} of 40 frames pushed"
        );
    }
}
