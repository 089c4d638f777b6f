//! Shading normals that keep specular reflection above the surface, as Cycles keeps them
//! (its "bump map correction", on by default for every shader).
//!
//! A normal map or interpolated vertex normals can tilt the shading normal so far that the
//! mirror image of the viewer about it points below the geometric surface. The integrators
//! must reject such a reflection (it would leave through the surface), which paints black
//! rings on normal-mapped mirrors. Cycles instead turns the normal towards the geometric
//! normal, within the plane of both, just enough that the mirror reflection leaves at a
//! small angle above the surface; [`valid_reflection_normal`] does the same.
//!
//! Cycles bends the normal of its glossy, metal and glass closures and keeps the diffuse one
//! on the unbent normal; Caustic's glTF BSDF gives its diffuse base the unbent normal as a
//! frame of its own (`PbrBsdf::diffuse_frame`), and a node graph's mixture gives every
//! closure its own frame (`shader::shade`).

use glam::Vec3;

/// The shading normal `n` turned towards the geometric normal `ng` until the reflection of
/// the viewer direction `wo` about it leaves the surface at the height
/// t = min(0.9 (wo·ng), 0.01) (a reflection is allowed to be as shallow as the view, never
/// shallower, and never needs to be steeper than 0.01); `n` itself when its reflection is
/// already that high. `ng` is the unit geometric normal on the viewer's side (wo·ng ≥ 0),
/// `wo` and `n` are unit vectors.
pub fn valid_reflection_normal(ng: Vec3, wo: Vec3, n: Vec3) -> Vec3 {
    let wz = wo.dot(ng).max(0.0);
    let threshold = (0.9 * wz).min(0.01);
    let reflected = 2.0 * n.dot(wo) * n - wo;
    if reflected.dot(ng) >= threshold {
        return n;
    }
    // Work in the plane of ng (z) and the part of n across it (x): the bent normal is
    // n' = x sqrt(1 - z²) + ng z. Its reflection's height is 2 (n'·wo) z - wz = t, with
    // n'·wo = wx sqrt(1 - z²) + wz z. Isolating the square root and squaring gives a
    // quadratic in z²: 4a z⁴ - 2b z² + c = 0 with a = wx² + wz², b = 2(a + wz t),
    // c = (t + wz)². Squaring admits the root of 2 wx z sqrt(1 - z²) = -(t + wz(1 - 2z²))
    // as well; the sign of wx tells which of the two roots solves the unsquared equation
    // (both sides must share wx's sign).
    let x = (n - n.dot(ng) * ng).try_normalize().unwrap_or(n);
    let wx = wo.dot(x);
    let a = wx * wx + wz * wz;
    if !(a > 0.0) {
        return ng;
    }
    let b = 2.0 * (a + wz * threshold);
    let c = (threshold + wz) * (threshold + wz);
    let disc = (b * b - 4.0 * a * c).max(0.0).sqrt();
    let z2 = if wx < 0.0 { 0.25 * (b + disc) / a } else { 0.25 * (b - disc) / a };
    let z2 = z2.clamp(0.0, 1.0);
    (x * (1.0 - z2).sqrt() + ng * z2.sqrt()).try_normalize().unwrap_or(ng)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Height of the mirror reflection of `wo` about `n` above the plane of `ng`.
    fn height(ng: Vec3, wo: Vec3, n: Vec3) -> f32 {
        (2.0 * n.dot(wo) * n - wo).dot(ng)
    }

    #[test]
    fn a_normal_whose_reflection_is_above_the_surface_is_kept() {
        let ng = Vec3::Z;
        let n = Vec3::new(0.3, 0.1, 1.0).normalize();
        let wo = Vec3::new(-0.2, 0.0, 1.0).normalize();
        assert!(height(ng, wo, n) > 0.01);
        assert_eq!(valid_reflection_normal(ng, wo, n), n);
    }

    #[test]
    fn a_bent_normal_reflects_exactly_to_the_threshold_in_the_plane_of_both_normals() {
        let ng = Vec3::Z;
        // Views on both sides of the tilt (wx of either sign), steep to grazing, and normals
        // tilted 50° to 89° (their reflections are below the surface for these views), also
        // normals that face away from the viewer.
        let mut bent = 0;
        for &(vx, vy, vz) in
            &[(0.0, 0.0, 1.0), (0.5, 0.2, 0.8), (-0.6, 0.3, 0.7), (0.9, -0.1, 0.05), (-0.95, 0.0, 0.02)]
        {
            let wo = Vec3::new(vx, vy, vz).normalize();
            for tilt_deg in [50.0f32, 65.0, 80.0, 89.0] {
                for azimuth_deg in [0.0f32, 90.0, 180.0, 250.0] {
                    let (t, a) = (tilt_deg.to_radians(), azimuth_deg.to_radians());
                    let n = Vec3::new(t.sin() * a.cos(), t.sin() * a.sin(), t.cos());
                    if height(ng, wo, n) >= (0.9 * wo.z).min(0.01) {
                        continue;
                    }
                    bent += 1;
                    let b = valid_reflection_normal(ng, wo, n);
                    let want = (0.9 * wo.z).min(0.01);
                    // f32 rounding through the quartic's roots: the height is a difference of
                    // terms of size ≤ 2, each carrying a few ulps (1e-7), and the root's square
                    // root amplifies errors near z² = 0 or 1; 2e-4 bounds them with room and is
                    // 50 times below the threshold itself.
                    assert!((height(ng, wo, b) - want).abs() < 2e-4, "wo {wo} n {n}: height {}", height(ng, wo, b));
                    assert!((b.length() - 1.0).abs() < 1e-5);
                    // In the plane of ng and n, turned towards ng, and facing the viewer.
                    assert!(b.dot(ng.cross(n)).abs() < 1e-4, "left the plane: {b}");
                    assert!(b.dot(ng) > n.dot(ng));
                    assert!(b.dot(wo) > 0.0);
                }
            }
        }
        assert!(bent > 20, "the cases must exercise the bend ({bent})");
    }
}
