//! Emission a ray meets without hitting scene geometry: area and sphere lights it crosses,
//! and suns it points at on escape, each weighted by MIS against light sampling and filtered
//! by the light's linking and ray visibility.

use super::{SceneContext, power_heuristic};
use crate::light::light_graph::graph_factor;
use crate::light::{
    area_to_solid_angle, intersect_sphere_light, sphere_light_pdf, sphere_mask, spot_inside_pdf, spot_sphere_faces,
};
use crate::math::Rgb;
use crate::sampling::warp::uniform_cone_pdf;
use crate::scene::light_path::LightPath;
use glam::Vec3;

impl<'a> SceneContext<'a> {
    /// Emission of lights that are not scene geometry (area and sphere lights) crossed by
    /// a ray before `tmax`, each weighted by MIS against light sampling from `prev_p`
    /// with the normal `prev_n` that light selection was given there (`prev_pdf` = 0: no
    /// MIS); lights hidden from the camera are skipped for camera rays, and for other rays
    /// lights not linked to `receiver`, the triangle the ray left, or hidden from the
    /// kind of the path's last bounce (`path`, [`light_seen_by`](Self::light_seen_by)).
    /// Returns the radiance and whether anything was crossed.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn crossed_emission(
        &self,
        org: Vec3,
        dir: Vec3,
        tmax: f32,
        prev_p: Vec3,
        prev_n: Vec3,
        prev_pdf: f32,
        camera_ray: bool,
        receiver: u32,
        path: &LightPath,
    ) -> (Rgb, bool) {
        self.crossed_emission_each(org, dir, tmax, prev_p, prev_n, prev_pdf, camera_ray, receiver, path, |_, _| {})
    }

    /// [`crossed_emission`](Self::crossed_emission), also handing each crossed light's
    /// index and its weighted radiance to `each` (the light groups file them).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn crossed_emission_each(
        &self,
        org: Vec3,
        dir: Vec3,
        tmax: f32,
        prev_p: Vec3,
        prev_n: Vec3,
        prev_pdf: f32,
        camera_ray: bool,
        receiver: u32,
        path: &LightPath,
        mut each: impl FnMut(usize, Rgb),
    ) -> (Rgb, bool) {
        let mut sum = Rgb::ZERO;
        let mut any = false;
        if self.catcher_only && camera_ray {
            // The catcher pass starts on the camera segment that the split path already
            // walked: what it crossed there is counted once, before the split.
            return (sum, any);
        }
        for (a, index) in &self.area_lights {
            let seen = if camera_ray { a.camera_visible } else { self.bounce_finds(*index, receiver, path) };
            if !seen || (prev_pdf > 0.0 && self.shadow_linked(*index)) {
                continue;
            }
            if let Some(t) = a.intersect(org, dir, tmax)
                && (-dir).dot(a.normal) > 0.0
            {
                let w = if prev_pdf == 0.0 {
                    1.0
                } else {
                    power_heuristic(prev_pdf, self.light_pdf(*index, prev_p, prev_n, org + dir * t, a.normal))
                };
                let f = graph_factor(self.scene, *index, org + dir * t, a.normal, prev_p, *path);
                let c = a.radiance * f * (w * a.spread_attenuation((-dir).dot(a.normal)));
                sum += c;
                each(*index, c);
                any = true;
            }
        }
        for &(center, radius, radiance, soft, camera_visible, spot, index) in &self.spheres {
            let seen = if camera_ray { camera_visible } else { self.bounce_finds(index, receiver, path) };
            if !seen || (prev_pdf > 0.0 && self.shadow_linked(index)) {
                continue;
            }
            // A spot's cone masks the ray's direction (receivers inside the sphere unmasked).
            let radiance = radiance * sphere_mask(&spot, center, radius, prev_p, -dir);
            if radiance == Rgb::ZERO {
                continue;
            }
            if soft {
                // The disk faces the ray's origin (the previous vertex).
                let n = (prev_p - center).normalize_or(Vec3::Y);
                let denom = n.dot(dir);
                if denom >= 0.0 {
                    continue;
                }
                let t = n.dot(center - org) / denom;
                let q = org + dir * t;
                if !(t > 0.0 && t < tmax) || (q - center).length_squared() > radius * radius {
                    continue;
                }
                let w = if prev_pdf == 0.0 {
                    1.0
                } else {
                    let dist = (q - prev_p).length();
                    let light_pdf = self.lights.pmf(prev_p, prev_n, index)
                        * area_to_solid_angle(1.0 / (std::f32::consts::PI * radius * radius), dist, -denom);
                    power_heuristic(prev_pdf, light_pdf)
                };
                let radiance = radiance * graph_factor(self.scene, index, q, Vec3::ZERO, prev_p, *path);
                sum += radiance * w;
                each(index, radiance * w);
                any = true;
            } else if spot.is_some() && !spot_sphere_faces(org, dir, center) {
                // Cycles' spot sphere is one-sided: from inside, rays leaving the centre's side
                // find nothing (their MIS share is lost, as in Cycles).
                continue;
            } else if let Some(t) = intersect_sphere_light(org, dir, center, radius, tmax) {
                // From inside the ball the ray finds the far side, as Cycles' does.
                let w = if prev_pdf == 0.0 {
                    1.0
                } else {
                    let dist = (center - prev_p).length();
                    let pdf = if spot.is_some() && dist <= radius {
                        // A spot's next-event estimation inside: Cycles' cosine hemisphere.
                        spot_inside_pdf(prev_n, dir)
                    } else {
                        sphere_light_pdf(dist, radius)
                    };
                    power_heuristic(prev_pdf, self.lights.pmf(prev_p, prev_n, index) * pdf)
                };
                let q = org + dir * t;
                let radiance = radiance * graph_factor(self.scene, index, q, (q - center) / radius, prev_p, *path);
                sum += radiance * w;
                each(index, radiance * w);
                any = true;
            }
        }
        (sum, any)
    }

    /// Radiance of sun disks seen along an escaping ray, MIS-weighted as `crossed_emission`
    /// (`receiver`: the triangle a non-camera ray left, for light linking; `path`: its last
    /// bounce, for the sun's ray visibility).
    #[inline]
    pub fn sun_emission(&self, dir: Vec3, prev_pdf: f32, camera_ray: bool, receiver: u32, path: &LightPath) -> Rgb {
        self.sun_emission_each(dir, prev_pdf, camera_ray, receiver, path, |_, _| {})
    }

    /// [`sun_emission`](Self::sun_emission), also handing each sun's index and weighted
    /// radiance to `each`.
    #[inline]
    pub fn sun_emission_each(
        &self,
        dir: Vec3,
        prev_pdf: f32,
        camera_ray: bool,
        receiver: u32,
        path: &LightPath,
        mut each: impl FnMut(usize, Rgb),
    ) -> Rgb {
        let mut sum = Rgb::ZERO;
        if self.catcher_only && camera_ray {
            return sum;
        }
        for &(to_sun, cos_half, radiance, index) in &self.suns {
            if dir.dot(to_sun) >= cos_half
                && (camera_ray || self.bounce_finds(index, receiver, path))
                && !(prev_pdf > 0.0 && self.shadow_linked(index))
            {
                let w = if prev_pdf == 0.0 {
                    1.0
                } else {
                    power_heuristic(prev_pdf, self.lights.infinite_pmf(index) * uniform_cone_pdf(cos_half))
                };
                let radiance = radiance * graph_factor(self.scene, index, to_sun, Vec3::ZERO, Vec3::ZERO, *path);
                sum += radiance * w;
                each(index, radiance * w);
            }
        }
        sum
    }
}
