//! A small software renderer for pictures of heads and fitted masks: orthographic view,
//! z-buffer, Lambert shading, depth-tested wireframe overlay, PNG output. It exists so a
//! fit can be checked by eye (`facewire render`) and so the docs' pictures are
//! reproducible without a GPU or a browser.

use std::io::Write;

use glam::{Mat3, Vec3};

use crate::fit::FittedMask;
use crate::head::Head;

/// Where the camera looks from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum View {
    /// Looking at the face (down -z).
    Front,
    /// From the face's right side.
    Side,
    /// Halfway between front and the face's right side.
    ThreeQuarter,
}

impl View {
    /// Rotation taking head coordinates (+y up, +z out of the face) to camera coordinates
    /// (+x right on screen, +y up, +z towards the viewer).
    fn rotation(self) -> Mat3 {
        match self {
            View::Front => Mat3::IDENTITY,
            View::Side => Mat3::from_rotation_y(std::f32::consts::FRAC_PI_2),
            View::ThreeQuarter => Mat3::from_rotation_y(std::f32::consts::FRAC_PI_4),
        }
    }
}

/// Colours of an overlay: where it is in front of the surface and, optionally, where it
/// is behind it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ink {
    pub visible: [u8; 3],
    pub hidden: Option<[u8; 3]>,
}

impl Ink {
    /// Shown only where visible.
    pub fn opaque(visible: [u8; 3]) -> Ink {
        Ink {
            visible,
            hidden: None,
        }
    }

    /// Shown everywhere, blended with the surface where hidden.
    pub fn see_through(visible: [u8; 3]) -> Ink {
        Ink {
            visible,
            hidden: Some(visible),
        }
    }
}

/// Most pixels the triangles of one picture may visit (each triangle's clipped bounding
/// box), per pixel of the picture: a head seen whole visits each pixel a few times (front
/// and back, lips and teeth); a mesh whose triangles each cover the picture would take
/// minutes. At 800 x 800 this is 41 million visits, a fraction of a second.
pub const MAX_VISITS_PER_PIXEL: u64 = 64;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "drawing its {triangles} triangles would visit {visits} pixels, {per_pixel:.0} per pixel of \
     the {width} x {height} picture (at most {MAX_VISITS_PER_PIXEL})"
)]
pub struct DrawCostError {
    pub triangles: usize,
    pub visits: u64,
    pub per_pixel: f64,
    pub width: usize,
    pub height: usize,
}

/// An RGB image with a depth buffer.
pub struct Canvas {
    pub width: usize,
    pub height: usize,
    rgb: Vec<[u8; 3]>,
    depth: Vec<f32>,
    rotation: Mat3,
    /// Pixels per unit and the camera-space point at the image centre.
    zoom: f32,
    center: Vec3,
}

impl Canvas {
    /// A canvas framing `bounds_points` (any points of the scene) seen from `view`.
    pub fn framing(points: &[Vec3], view: View, width: usize, height: usize) -> Canvas {
        let rotation = view.rotation();
        let (lo, hi) = points.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &p| {
                let q = rotation * p;
                (lo.min(q), hi.max(q))
            },
        );
        let size = (hi - lo).max(Vec3::splat(1e-6));
        let zoom = 0.92 * (width as f32 / size.x).min(height as f32 / size.y);
        Canvas {
            width,
            height,
            rgb: vec![[250, 250, 252]; width * height],
            depth: vec![f32::NEG_INFINITY; width * height],
            rotation,
            zoom,
            center: 0.5 * (lo + hi),
        }
    }

    /// Screen position (pixels, y down) and depth (larger is nearer) of a scene point.
    fn project(&self, p: Vec3) -> Vec3 {
        let q = self.rotation * p - self.center;
        Vec3::new(
            self.width as f32 * 0.5 + q.x * self.zoom,
            self.height as f32 * 0.5 - q.y * self.zoom,
            q.z * self.zoom,
        )
    }

    /// Pixels the triangles' bounding boxes, clipped to the picture, hold together.
    fn fill_visits(&self, positions: &[Vec3], triangles: &[[u32; 3]]) -> u64 {
        triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| self.project(positions[v as usize]));
                let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
                let span = |lo: f32, hi: f32, size: usize| {
                    let (lo, hi) = (lo.floor().max(0.0), hi.ceil().min(size as f32 - 1.0));
                    if hi >= lo {
                        (hi - lo) as u64 + 1
                    } else {
                        0
                    }
                };
                span(lo.x, hi.x, self.width) * span(lo.y, hi.y, self.height)
            })
            .sum()
    }

    /// Fills shaded triangles. `color` gives the base colour of each triangle. Refuses,
    /// drawing nothing, when the triangles would visit more than [`MAX_VISITS_PER_PIXEL`]
    /// pixels per pixel of the picture.
    pub fn draw_mesh(
        &mut self,
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        color: impl Fn(usize) -> [f32; 3],
    ) -> Result<(), DrawCostError> {
        let visits = self.fill_visits(positions, triangles);
        let pixels = (self.width * self.height).max(1) as u64;
        if visits > MAX_VISITS_PER_PIXEL * pixels {
            return Err(DrawCostError {
                triangles: triangles.len(),
                visits,
                per_pixel: visits as f64 / pixels as f64,
                width: self.width,
                height: self.height,
            });
        }
        let light = Vec3::new(-0.35, 0.45, 1.0).normalize();
        for (i, t) in triangles.iter().enumerate() {
            let [a, b, c] = t.map(|v| positions[v as usize]);
            let normal = self.rotation * (b - a).cross(c - a);
            if normal.length_squared() == 0.0 {
                continue;
            }
            // Two-sided lighting: scans are not always consistently wound.
            let shade = 0.25 + 0.75 * normal.normalize().dot(light).abs();
            let base = color(i);
            let rgb = base.map(|c| (c * shade * 255.0).clamp(0.0, 255.0) as u8);
            self.fill_triangle(self.project(a), self.project(b), self.project(c), rgb);
        }
        Ok(())
    }

    fn fill_triangle(&mut self, a: Vec3, b: Vec3, c: Vec3, rgb: [u8; 3]) {
        let min_x = a.x.min(b.x).min(c.x).floor().max(0.0) as usize;
        let max_x = (a.x.max(b.x).max(c.x).ceil() as usize).min(self.width.saturating_sub(1));
        let min_y = a.y.min(b.y).min(c.y).floor().max(0.0) as usize;
        let max_y = (a.y.max(b.y).max(c.y).ceil() as usize).min(self.height.saturating_sub(1));
        let area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
        if area.abs() < 1e-12 {
            return;
        }
        for y in min_y..=max_y {
            for x in min_x..=max_x {
                let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                let w0 = ((b.x - px) * (c.y - py) - (b.y - py) * (c.x - px)) / area;
                let w1 = ((c.x - px) * (a.y - py) - (c.y - py) * (a.x - px)) / area;
                let w2 = 1.0 - w0 - w1;
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let z = w0 * a.z + w1 * b.z + w2 * c.z;
                let k = y * self.width + x;
                if z > self.depth[k] {
                    self.depth[k] = z;
                    self.rgb[k] = rgb;
                }
            }
        }
    }

    /// Draws a line in `ink`; where the mesh is more than `slack` (scene units) in front
    /// of it, it is drawn in `ink.hidden` or not at all.
    pub fn draw_line(&mut self, p: Vec3, q: Vec3, ink: Ink, slack: f32) {
        let (a, b) = (self.project(p), self.project(q));
        let steps = ((b - a).truncate().length().ceil() as usize).max(1);
        for s in 0..=steps {
            let t = s as f32 / steps as f32;
            let m = a.lerp(b, t);
            self.plot(m, ink, slack * self.zoom);
        }
    }

    /// Draws a filled dot of radius `radius` pixels, depth-tested like lines.
    pub fn draw_dot(&mut self, p: Vec3, radius: f32, ink: Ink, slack: f32) {
        let c = self.project(p);
        let r = radius.ceil() as i64;
        for dy in -r..=r {
            for dx in -r..=r {
                if ((dx * dx + dy * dy) as f32) <= radius * radius {
                    self.plot(c + Vec3::new(dx as f32, dy as f32, 0.0), ink, slack * self.zoom);
                }
            }
        }
    }

    fn plot(&mut self, m: Vec3, ink: Ink, slack_px: f32) {
        if m.x < 0.0 || m.y < 0.0 {
            return;
        }
        let (x, y) = (m.x as usize, m.y as usize);
        if x >= self.width || y >= self.height {
            return;
        }
        let k = y * self.width + x;
        if m.z + slack_px >= self.depth[k] {
            self.rgb[k] = ink.visible;
        } else if let Some(hidden) = ink.hidden {
            // behind the surface: blend, so the surface still shows through
            let under = self.rgb[k];
            self.rgb[k] = std::array::from_fn(|c| ((u16::from(under[c]) + u16::from(hidden[c])) / 2) as u8);
        }
    }

    /// Writes the image as an 8-bit RGB PNG.
    pub fn write_png(&self, out: impl Write) -> Result<(), png::EncodingError> {
        let mut encoder = png::Encoder::new(out, self.width as u32, self.height as u32);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header()?;
        let bytes: Vec<u8> = self.rgb.iter().flatten().copied().collect();
        writer.write_image_data(&bytes)?;
        writer.finish()
    }
}

/// Draws `fitted`'s neutral mask (its edges, its vertices, the lips in red) over what the
/// canvas holds. `slack` (head units) lets lines on the surface through the depth test.
pub fn draw_fitted_mask(canvas: &mut Canvas, fitted: &FittedMask, points: &[Vec3], slack: f32) {
    let used = fitted.mask.used_vertices();
    for t in &fitted.mask.triangles {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            canvas.draw_line(points[a], points[b], Ink::see_through([20, 90, 200]), slack);
        }
    }
    for (j, &p) in points.iter().enumerate().filter(|(j, _)| used[*j]) {
        let lip = crate::mask::LIP_VERTICES.contains(&j);
        canvas.draw_dot(
            p,
            2.5,
            Ink::see_through(if lip { [200, 30, 30] } else { [20, 60, 160] }),
            slack,
        );
    }
}

/// A PNG of `fitted` on `head`, `size` pixels square, framed on the mask and seen from
/// `view` of the face: the fit's own front, whichever way the head's axes point.
pub fn fitted_mask_png(
    head: &Head,
    fitted: &FittedMask,
    view: View,
    size: usize,
) -> Result<Vec<u8>, DrawCostError> {
    let to_face = fitted.fit.pose.rotation().transpose();
    let positions: Vec<Vec3> = head.positions.iter().map(|&p| to_face * p).collect();
    let mask: Vec<Vec3> = fitted.neutral.iter().map(|&p| to_face * p).collect();
    let mut canvas = Canvas::framing(&mask, view, size, size);
    canvas.draw_mesh(&positions, &head.triangles, |_| [0.86, 0.76, 0.68])?;
    draw_fitted_mask(&mut canvas, fitted, &mask, 0.004 * head.bounds().size().length());
    let mut png = Vec::new();
    canvas
        .write_png(&mut png)
        .expect("encoding a picture into memory cannot fail");
    Ok(png)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearer_triangle_wins_and_lines_hide_behind_it() {
        let p = vec![
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(1.0, -1.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        ];
        let mut canvas = Canvas::framing(&p, View::Front, 64, 64);
        canvas
            .draw_mesh(&p, &[[0, 1, 2], [3, 4, 5]], |i| {
                if i == 0 {
                    [1.0, 0.0, 0.0]
                } else {
                    [0.0, 0.0, 1.0]
                }
            })
            .unwrap();
        let centre = canvas.rgb[32 * 64 + 32];
        assert!(centre[2] > 0 && centre[0] == 0, "{centre:?}");
        // a line on the far plane is hidden, one on the near plane shows
        canvas.draw_line(
            Vec3::new(-0.2, 0.0, 0.0),
            Vec3::new(0.2, 0.0, 0.0),
            Ink::opaque([0, 255, 0]),
            0.01,
        );
        assert_ne!(canvas.rgb[canvas.width * 32 + 32], [0, 255, 0]);
        canvas.draw_line(
            Vec3::new(-0.2, 0.0, 1.0),
            Vec3::new(0.2, 0.0, 1.0),
            Ink::opaque([0, 255, 0]),
            0.01,
        );
        let row = &canvas.rgb[canvas.width * 32..canvas.width * 33];
        assert!(row.contains(&[0, 255, 0]));
        let mut png = Vec::new();
        canvas.write_png(&mut png).unwrap();
        assert_eq!(&png[1..4], b"PNG");
    }

    #[test]
    fn triangles_that_each_cover_the_picture_are_refused_before_drawing() {
        let p = vec![
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        // Framed on its middle: each triangle's box holds the whole 40 x 40 picture.
        let middle = [Vec3::splat(-0.1), Vec3::splat(0.1)];
        let mut canvas = Canvas::framing(&middle, View::Front, 40, 40);
        assert_eq!(canvas.draw_mesh(&p, &vec![[0, 1, 2]; 64], |_| [1.0; 3]), Ok(()));
        let error = canvas
            .draw_mesh(&p, &vec![[0, 1, 2]; 65], |_| [1.0; 3])
            .unwrap_err();
        assert_eq!((error.triangles, error.visits), (65, 65 * 40 * 40));
    }
}
