//! Sphere lights that enclose surfaces. Cycles lights a point inside a sphere light's ball
//! from every direction (`light/point.h`: the sphere's far side is seen from inside; a spot's
//! sphere unmasked by its cone, found by ray hits only moving toward its centre's side,
//! `light/spot.h`), which the path tracer follows (`sample.rs`, `integrator::emission`). The integrators that start
//! paths on the lights emit from the sphere outward only, and BDPT's and VCM's camera-side
//! strategies weigh such paths against those light subpaths: for them this light is named.

use crate::light::Light;
use crate::scene::Scene;
use glam::Vec3;

/// Squared distance from `p` to the triangle `a b c` (the clearance bound's exact f64 test).
fn distance2_to_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> f32 {
    crate::accel::point_triangle_squared(p.as_dvec3(), &[a.into(), b.into(), c.into()]) as f32
}

/// Indices of the sphere lights (Soft Falloff off) whose ball holds part of a mesh surface.
pub fn enclosing_spheres(scene: &Scene) -> Vec<usize> {
    let m = &scene.mesh;
    scene
        .lights
        .iter()
        .enumerate()
        .filter_map(|(i, l)| match l {
            Light::Sphere { center, radius, soft: false, .. } => {
                let r2 = radius * radius;
                m.triangles
                    .iter()
                    .any(|t| {
                        let [a, b, c] = t.map(|v| m.positions[v as usize]);
                        distance2_to_triangle(*center, a, b, c) < r2
                    })
                    .then_some(i)
            }
            _ => None,
        })
        .collect()
}

/// The warning for `integrator` (BDPT, VCM, Jensen's photon mapping, SPPM) when a sphere
/// light encloses surfaces, naming the lights; None otherwise.
pub fn warning(scene: &Scene, integrator: &str) -> Option<String> {
    let lights = enclosing_spheres(scene);
    let name = |i: usize| scene.report.lights.get(i).map_or_else(|| format!("light {i}"), |r| format!("'{}'", r.name));
    (!lights.is_empty()).then(|| {
        format!(
            "sphere light(s) {} (Soft Falloff off) enclose surfaces, which Cycles lights from inside the sphere: \
             {integrator} emits from the sphere outward only, so the light inside differs from the path tracer's \
             (and Cycles'); render with the path tracer",
            lights.into_iter().map(name).collect::<Vec<_>>().join(", ")
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closest point of a triangle in each of its seven regions, against brute force
    /// over a fine barycentric grid.
    #[test]
    fn distance_to_triangle_matches_brute_force() {
        let (a, b, c) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.5, 1.5, 0.3));
        let n = 400;
        for p in [
            Vec3::new(-1.0, -1.0, 0.5),
            Vec3::new(3.0, -0.5, -0.2),
            Vec3::new(0.4, 3.0, 1.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
            Vec3::new(2.0, 1.5, 0.4),
            Vec3::new(0.8, 0.5, 1.0),
        ] {
            let mut best = f32::INFINITY;
            for i in 0..=n {
                for j in 0..=(n - i) {
                    let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
                    best = best.min((p - (a + (b - a) * u + (c - a) * v)).length_squared());
                }
            }
            let got = distance2_to_triangle(p, a, b, c);
            // The grid's spacing (≤ 2/400 per axis) bounds brute force's excess distance.
            assert!(got <= best + 1e-6 && best.sqrt() - got.sqrt() < 0.02, "{p}: {got} vs {best}");
        }
    }
}
