//! The world: light arriving from infinitely far away, a constant colour or an
//! equirectangular image (Blender's Environment Texture) times a strength, rotated about
//! the up axis (a Mapping node's Z rotation). Images are importance sampled with a 2D
//! piecewise-constant distribution of luminance × sin θ, so NEE picks bright texels and
//! MIS with BSDF sampling covers the rest.
//!
//! A world node graph (`world_graph.rs`) gives the radiance itself; its baked table then
//! serves as `image`, for sampling only (the graph's value × `color`, which is 1).
//!
//! Directions are glTF world directions (Y up). The image mapping is Blender's: with
//! Blender's axes b = (x, -z, y) of the glTF direction, u = 0.5 - atan2(b.y, b.x) / 2π and
//! v = 0.5 + asin(b.z) / π, with v = 1 at the image's top row.

use super::{AreaLight, area_to_solid_angle};
use crate::math::{Rgb, luminance};
use crate::sampling::Distribution1D;
use crate::sampling::warp::{UNIFORM_SPHERE_PDF, uniform_sphere};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// An equirectangular radiance image with its sampling distribution.
#[derive(Clone, Debug)]
pub struct EnvImage {
    /// Width in texels.
    pub width: usize,
    /// Height in texels.
    pub height: usize,
    /// Linear RGB radiance, top row first.
    pub texels: Vec<Rgb>,
    /// Distribution over rows (top row first).
    marginal: Distribution1D,
    /// Distribution over texels within each row.
    rows: Vec<Distribution1D>,
}

impl EnvImage {
    /// Builds the image and its distribution; None if the image is empty or not finite.
    pub fn new(width: usize, height: usize, texels: Vec<Rgb>) -> Option<Self> {
        if width == 0 || height == 0 || texels.len() != width * height || texels.iter().any(|t| !t.is_finite()) {
            return None;
        }
        let mut rows = Vec::with_capacity(height);
        let mut row_weights = Vec::with_capacity(height);
        // The lookup is bilinear, so a bright texel lights half of each neighbour: weigh
        // every texel by the brightest of its 3×3 neighbourhood, or samples landing beside
        // a small sun see its radiance with a sky texel's tiny pdf (fireflies; found by the
        // benchmark's HDRI scene, 50× Cycles' error).
        let lum: Vec<f32> = texels.iter().map(|t| luminance(t.max(Rgb::ZERO))).collect();
        let near_max = |x: usize, y: usize| -> f32 {
            let mut m = 0.0f32;
            for dy in [-1i64, 0, 1] {
                let yy = (y as i64 + dy).clamp(0, height as i64 - 1) as usize;
                for dx in [-1i64, 0, 1] {
                    let xx = (x as i64 + dx).rem_euclid(width as i64) as usize;
                    m = m.max(lum[yy * width + xx]);
                }
            }
            m
        };
        for y in 0..height {
            // sin θ of the row centre: rows near the poles cover less solid angle.
            let theta = PI * (y as f32 + 0.5) / height as f32;
            let s = theta.sin();
            let w: Vec<f32> = (0..width).map(|x| near_max(x, y) * s).collect();
            row_weights.push(w.iter().map(|&v| v as f64).sum::<f64>() as f32);
            rows.push(Distribution1D::new(&w));
        }
        Some(EnvImage { width, height, texels, marginal: Distribution1D::new(&row_weights), rows })
    }

    /// Bilinear radiance at (u, v) (v = 1 at the top), wrapping in u.
    #[inline]
    fn lookup(&self, uv: Vec2) -> Rgb {
        let x = uv.x * self.width as f32 - 0.5;
        let y = (1.0 - uv.y) * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let at = |xi: i64, yi: i64| {
            let xi = xi.rem_euclid(self.width as i64) as usize;
            let yi = yi.clamp(0, self.height as i64 - 1) as usize;
            self.texels[yi * self.width + xi]
        };
        let (x0, y0) = (x0 as i64, y0 as i64);
        let a = at(x0, y0).lerp(at(x0 + 1, y0), fx);
        let b = at(x0, y0 + 1).lerp(at(x0 + 1, y0 + 1), fx);
        a.lerp(b, fy)
    }
}

/// The world light.
#[derive(Clone, Debug)]
pub struct Environment {
    /// Constant radiance (when there is no image) or the image's multiplier.
    pub color: Rgb,
    /// Optional image.
    pub image: Option<EnvImage>,
    /// Rotation of the mapping about the up axis, radians.
    pub rotation: f32,
    /// A world node graph: the radiance of every direction (`image` is then its baked
    /// table, which only steers sampling).
    pub graph: Option<super::world_graph::WorldGraph>,
    /// Blender's light portals (area lights marked Portal): windows through which light
    /// sampling also aims at the world from points on their inner side. They emit nothing
    /// and change only the noise, never the mean.
    pub portals: Vec<AreaLight>,
}

/// Share of world light samples aimed through portals where a portal faces the point
/// (Cycles' portal and map methods weigh one each).
const PORTAL_SHARE: f32 = 0.5;

impl Environment {
    /// The world of a node graph: its radiance baked into a table for sampling (`bake_width`
    /// wide), or a constant colour when the graph reads nothing of the direction. None
    /// when the table is not finite.
    pub fn from_graph(graph: super::world_graph::WorldGraph) -> Option<Environment> {
        if let Some(c) = graph.program().constant_emission {
            let color = if c.is_finite() { c.max(Vec3::ZERO) } else { return None };
            return Some(Environment { color, image: None, rotation: 0.0, graph: None, portals: Vec::new() });
        }
        let unrotated = Environment { color: Rgb::ONE, image: None, rotation: 0.0, graph: None, portals: Vec::new() };
        let width = graph.bake_width();
        let texels = graph.bake(width, |uv| unrotated.uv_to_dir(uv));
        let image = EnvImage::new(width, width / 2, texels)?;
        Some(Environment {
            color: Rgb::ONE,
            image: Some(image),
            rotation: 0.0,
            graph: Some(graph),
            portals: Vec::new(),
        })
    }

    /// Image coordinates of a glTF direction.
    #[inline]
    fn dir_to_uv(&self, d: Vec3) -> Vec2 {
        // Blender axes, then the Mapping node's rotation about Blender's Z (it rotates the
        // lookup vector: out = R · in).
        let (bx, by, bz) = (d.x, -d.z, d.y);
        let (s, c) = self.rotation.sin_cos();
        let (rx, ry) = (c * bx - s * by, s * bx + c * by);
        let u = 0.5 - ry.atan2(rx) / (2.0 * PI);
        let v = 0.5 + bz.clamp(-1.0, 1.0).asin() / PI;
        Vec2::new(u.rem_euclid(1.0), v)
    }

    /// glTF direction of image coordinates (inverse of `dir_to_uv`).
    #[inline]
    fn uv_to_dir(&self, uv: Vec2) -> Vec3 {
        let phi = (0.5 - uv.x) * 2.0 * PI;
        let lat = (uv.y - 0.5) * PI;
        let (rx, ry, bz) = (lat.cos() * phi.cos(), lat.cos() * phi.sin(), lat.sin());
        let (s, c) = self.rotation.sin_cos();
        let (bx, by) = (c * rx + s * ry, -s * rx + c * ry);
        Vec3::new(bx, bz, -by)
    }

    /// Radiance arriving from direction `d` (pointing away from the scene).
    #[inline]
    pub fn radiance(&self, d: Vec3) -> Rgb {
        if let Some(g) = &self.graph {
            return g.radiance(d) * self.color;
        }
        match &self.image {
            None => self.color,
            Some(img) => img.lookup(self.dir_to_uv(d)) * self.color,
        }
    }

    /// Radiance arriving from `d` along a ray of path state `path`: as [`radiance`](Self::radiance)
    /// unless the world's graph reads the Light Path node, which then reads that state.
    #[inline]
    pub fn radiance_for(&self, d: Vec3, path: &crate::scene::light_path::LightPath) -> Rgb {
        match &self.graph {
            Some(g) if g.reads_light_path() => g.radiance_for(d, *path) * self.color,
            _ => self.radiance(d),
        }
    }

    /// Samples a direction toward the world: (direction, radiance, solid-angle pdf).
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Rgb, f32)> {
        match &self.image {
            None => {
                let d = uniform_sphere(u);
                Some((d, self.color, UNIFORM_SPHERE_PDF))
            }
            Some(img) => {
                let (row, _, uy) = img.marginal.sample(u.y);
                let (col, _, ux) = img.rows[row].sample(u.x);
                // Continuous position within the texel; v = 1 is the top row.
                let uv = Vec2::new((col as f32 + ux) / img.width as f32, 1.0 - (row as f32 + uy) / img.height as f32);
                let d = self.uv_to_dir(uv);
                // The density from the direction itself, exactly as `pdf` computes it (a
                // sample on a texel edge may round into the neighbour: measure zero).
                let pdf = self.pdf(d);
                (pdf > 0.0 && pdf.is_finite()).then(|| (d, self.radiance(d), pdf))
            }
        }
    }

    /// Solid-angle density of direction `d` lying in texel (row, col): the texel's
    /// probability spread over its (u, v) area, divided by the Jacobian 2π² cos(latitude).
    #[inline]
    fn pdf_uv_texel(&self, img: &EnvImage, row: usize, col: usize, d: Vec3) -> f32 {
        let p = img.marginal.pmf(row) * img.rows[row].pmf(col) * (img.width * img.height) as f32;
        // cos(latitude) is the length of the direction's horizontal part (up is glTF Y).
        // The density grows as 1/cos(latitude) toward the poles (integrably); directions
        // within 1e-6 rad of a pole (a set of measure ~1e-12) are given 0.
        let cos_lat = (d.x * d.x + d.z * d.z).sqrt();
        if cos_lat < 1e-6 { 0.0 } else { p / (2.0 * PI * PI * cos_lat) }
    }

    /// A portal lies on `p`'s side when `p` is in front of it, where its light would go
    /// (Cycles' side test, with its 1e-4 margin).
    #[inline]
    fn portal_faces(portal: &AreaLight, p: Vec3) -> bool {
        portal.normal.dot(p - portal.center) > 1e-4
    }

    /// Solid-angle density of the portal method from `p` choosing `d` (a portal chosen
    /// uniformly among those facing `p`, a point uniformly on it), and how many face `p`.
    #[inline]
    fn portal_pdf(&self, p: Vec3, d: Vec3) -> (f32, usize) {
        let (mut sum, mut facing) = (0.0f32, 0usize);
        for portal in &self.portals {
            if !Self::portal_faces(portal, p) {
                continue;
            }
            facing += 1;
            if let Some(t) = portal.intersect(p, d, f32::INFINITY) {
                sum += area_to_solid_angle(1.0 / portal.area, t, portal.normal.dot(d).abs());
            }
        }
        if facing == 0 { (0.0, 0) } else { (sum / facing as f32, facing) }
    }

    /// Samples a direction toward the world from the point `p`: as [`sample`](Self::sample),
    /// or with portals facing `p` half the time through one of them (Cycles' portal
    /// method), with the density of the mixture.
    #[inline]
    pub fn sample_from(&self, p: Vec3, u: Vec2) -> Option<(Vec3, Rgb, f32)> {
        if self.portals.is_empty() {
            return self.sample(u);
        }
        let facing = self.portals.iter().filter(|q| Self::portal_faces(q, p)).count();
        if facing == 0 {
            return self.sample(u);
        }
        let d = if u.x < PORTAL_SHARE {
            // Rescaled: u.x picks the method, then the portal; u.y and the rest the point.
            let ux = u.x / PORTAL_SHARE * facing as f32;
            let k = (ux as usize).min(facing - 1);
            let portal = self.portals.iter().filter(|q| Self::portal_faces(q, p)).nth(k)?;
            let q = portal.sample_point(Vec2::new(ux - k as f32, u.y));
            (q - p).try_normalize()?
        } else {
            let ux = (u.x - PORTAL_SHARE) / (1.0 - PORTAL_SHARE);
            self.sample(Vec2::new(ux.min(1.0 - f32::EPSILON), u.y))?.0
        };
        let pdf = self.pdf_from(p, d);
        (pdf > 0.0 && pdf.is_finite()).then(|| (d, self.radiance(d), pdf))
    }

    /// Solid-angle density with which [`sample_from`](Self::sample_from) at `p` chooses `d`.
    #[inline]
    pub fn pdf_from(&self, p: Vec3, d: Vec3) -> f32 {
        if self.portals.is_empty() {
            return self.pdf(d);
        }
        match self.portal_pdf(p, d) {
            (_, 0) => self.pdf(d),
            (portal, _) => PORTAL_SHARE * portal + (1.0 - PORTAL_SHARE) * self.pdf(d),
        }
    }

    /// Solid-angle density of `sample` choosing direction `d`.
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        match &self.image {
            None => UNIFORM_SPHERE_PDF,
            Some(img) => {
                let uv = self.dir_to_uv(d);
                let col = ((uv.x * img.width as f32) as usize).min(img.width - 1);
                let row = (((1.0 - uv.y) * img.height as f32) as usize).min(img.height - 1);
                self.pdf_uv_texel(img, row, col, d)
            }
        }
    }

    /// Mean radiance luminance over the sphere (for the light's power).
    pub fn mean_luminance(&self) -> f32 {
        match &self.image {
            None => luminance(self.color),
            Some(img) => {
                let mut sum = 0.0f64;
                let mut wsum = 0.0f64;
                for y in 0..img.height {
                    let w = (PI * (y as f32 + 0.5) / img.height as f32).sin() as f64;
                    for x in 0..img.width {
                        sum += luminance(img.texels[y * img.width + x] * self.color) as f64 * w;
                        wsum += w;
                    }
                }
                (sum / wsum.max(1e-12)) as f32
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{ChiSquareTest, assert_chi2};

    fn test_image() -> EnvImage {
        let (w, h) = (32, 16);
        let texels = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                // A bright "sun" texel and a smooth gradient.
                let sun = if (x, y) == (20, 5) { 200.0 } else { 0.0 };
                Rgb::splat(0.2 + x as f32 / w as f32 + sun) * Rgb::new(1.0, 0.8, 0.6)
            })
            .collect();
        EnvImage::new(w, h, texels).unwrap()
    }

    #[test]
    fn chi2_environment_image() {
        for rotation in [0.0f32, 1.3] {
            let env =
                Environment { color: Rgb::ONE, image: Some(test_image()), rotation, graph: None, portals: Vec::new() };
            let t = ChiSquareTest::new(&format!("environment map rot={rotation}"));
            assert_chi2(t.run_with_pdf(|u| env.sample(u).map(|(d, _, p)| (d, p)), |d| env.pdf(d)));
        }
    }

    /// Portals as a scene has them: two facing the origin, one behind the first (a ray
    /// through the first passes the second too, so the densities sum), one facing away
    /// (never chosen, and a point behind every portal samples the map alone).
    fn portals() -> Vec<AreaLight> {
        use crate::light::AreaShape;
        let quad = |shape, c: [f32; 3], ax: [f32; 3], ay: [f32; 3], emit: [f32; 3]| {
            AreaLight::new(shape, Vec3::from(c), Vec3::from(ax), Vec3::from(ay), Vec3::from(emit), Rgb::ZERO).unwrap()
        };
        vec![
            quad(AreaShape::Rectangle, [0.0, 0.0, -2.0], [0.8, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, 0.0, 1.0]),
            quad(AreaShape::Ellipse, [1.5, 0.5, 0.0], [0.0, 0.6, 0.0], [0.0, 0.0, 0.4], [-1.0, 0.0, 0.0]),
            quad(AreaShape::Rectangle, [0.2, 0.1, -3.0], [1.5, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
            quad(AreaShape::Rectangle, [0.0, -2.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]),
        ]
    }

    /// World sampling through portals (the portal method mixed with the map's or the
    /// uniform sphere's) draws directions with the density `pdf_from` gives, from a point
    /// facing three portals and from one behind them all.
    #[test]
    fn chi2_environment_through_portals() {
        for (label, image) in [("image", Some(test_image())), ("constant", None)] {
            let env = Environment { color: Rgb::ONE, image, rotation: 0.3, graph: None, portals: portals() };
            for p in [Vec3::ZERO, Vec3::new(0.1, -0.2, -5.0)] {
                let t = ChiSquareTest::new(&format!("portals, {label} world, from {p}"));
                assert_chi2(t.run_with_pdf(|u| env.sample_from(p, u).map(|(d, _, q)| (d, q)), |d| env.pdf_from(p, d)));
            }
        }
        // The origin faces the first three: half the density goes through them.
        let env = Environment { color: Rgb::ONE, image: None, rotation: 0.0, graph: None, portals: portals() };
        let through_both = env.pdf_from(Vec3::ZERO, -Vec3::Z);
        let (one, two) = (1.0 / (4.0 * 0.8 * 0.5) * 4.0, 1.0 / (4.0 * 1.5 * 1.0) * 9.0);
        let want = 0.5 * (one + two) / 3.0 + 0.5 * UNIFORM_SPHERE_PDF;
        assert!((through_both - want).abs() < 1e-4 * want, "{through_both} vs {want}");
    }

    #[test]
    fn uv_direction_round_trip_and_blender_axes() {
        let env = Environment { color: Rgb::ONE, image: None, rotation: 0.7, graph: None, portals: Vec::new() };
        for &(u, v) in &[(0.1f32, 0.2f32), (0.5, 0.5), (0.9, 0.8), (0.3, 0.95)] {
            let d = env.uv_to_dir(Vec2::new(u, v));
            let back = env.dir_to_uv(d);
            assert!((back - Vec2::new(u, v)).length() < 1e-4, "{u},{v} -> {back}");
        }
        // Unrotated: Blender's -X (glTF -X) is the image centre u = 0.5... per the formula
        // u = 0.5 - atan2(y, x)/2π: +X is u = 0.5, +Y (glTF -Z) is u = 0.25; up is v = 1.
        let env = Environment { color: Rgb::ONE, image: None, rotation: 0.0, graph: None, portals: Vec::new() };
        assert!((env.dir_to_uv(Vec3::X) - Vec2::new(0.5, 0.5)).length() < 1e-5);
        assert!((env.dir_to_uv(-Vec3::Z) - Vec2::new(0.25, 0.5)).length() < 1e-5);
        assert!((env.dir_to_uv(Vec3::Y).y - 1.0).abs() < 1e-5);
    }
}
