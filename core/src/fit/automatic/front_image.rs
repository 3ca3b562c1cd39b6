//! The head seen from straight in front of a fit: a range image along the fitted
//! mask's z axis, read in **mask units** (x to the face's left, y up, z out of the face), so
//! that features can be looked for where CANDIDE puts them.

use glam::{DVec3, Vec2};

use super::depth_map::{DepthMap, View};
use crate::fit::umeyama::Similarity;
use crate::head::Head;

pub struct FrontImage {
    similarity: Similarity,
    view: View,
    map: DepthMap,
    /// The translation's component along the view, head units.
    forward_offset: f64,
}

impl FrontImage {
    /// `winding` as for [`DepthMap::render`]; `cells` along the image's longer side.
    pub fn render(head: &Head, similarity: &Similarity, winding: f32, cells: usize) -> FrontImage {
        let view = View::of_rotation(similarity.rotation.as_mat3());
        FrontImage {
            similarity: *similarity,
            view,
            map: DepthMap::render(&head.positions, &head.triangles, view, cells, winding),
            forward_offset: similarity.translation.dot(view.forward.as_dvec3()),
        }
    }

    /// How far forward the surface comes at mask point (x, y), as a mask z.
    pub fn z_at(&self, x: f64, y: f64) -> Option<f64> {
        let on_plane = self.similarity.apply(DVec3::new(x, y, 0.0)).as_vec3();
        let (across, _): (Vec2, f32) = self.view.project(on_plane);
        self.map
            .depth_at(across)
            .map(|d| (f64::from(d) - self.forward_offset) / self.similarity.scale)
    }

    /// The most forward surface within `reach` of mask point (x, y) (a square, sampled
    /// 9 by 9), as a mask z; `None` when none is seen there.
    pub fn frontmost_near(&self, x: f64, y: f64, reach: f64) -> Option<f64> {
        (-4..=4)
            .flat_map(|i| (-4..=4).map(move |j| (i, j)))
            .filter_map(|(i, j)| self.z_at(x + reach * f64::from(i) / 4.0, y + reach * f64::from(j) / 4.0))
            .reduce(f64::max)
    }

    /// A mask-frame point in head units.
    pub fn head_point(&self, mask_point: DVec3) -> DVec3 {
        self.similarity.apply(mask_point)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use glam::DMat3;

    use super::*;

    /// `head` seen straight along +z, its own frame taken for the mask's (one head unit
    /// per mask unit), `cells` along the image's longer side.
    pub(crate) fn seen_from_the_front(head: &Head, cells: usize) -> FrontImage {
        let identity = Similarity {
            rotation: DMat3::IDENTITY,
            scale: 1.0,
            translation: DVec3::ZERO,
        };
        FrontImage::render(head, &identity, 1.0, cells)
    }
}
