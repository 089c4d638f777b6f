//! Cycles' shadow terminator geometry offset (Object > Shading > Shadow Terminator >
//! Geometry Offset, `shadow_ray_offset` in `kernel/light/sample.h`): a shadow ray from a
//! smooth-shaded triangle lit near its terminator starts on a curved surface through the
//! triangle's corners and normals (Hanika's "Hacking the Shadow Terminator", a parabolic
//! patch bounded by each corner's tangent plane), not on the flat triangle, so that the
//! neighbouring flat triangles of a coarse smooth mesh do not shadow it. A flat-shaded
//! triangle (its corners' normals all its own) gets no offset: the patch is the triangle.

//!
//! Its Shading Offset (`shift_cos_in`) pushes the terminator towards the light instead: the
//! BSDF's cosine with the light is remapped to cos(k θ), k > 1, so light from beyond
//! θ = π / (2k) adds nothing (Cycles' `bsdf_eval` and `bsdf_sample`, from appleseed).

use crate::scene::mesh::Mesh;
use glam::{Vec2, Vec3};

/// The offset from the flat triangle `tri` at barycentrics `bary` (the weights of its second
/// and third corners) to the smooth patch through its corners, along the interpolated normal;
/// `ng` is the side the offset is measured from (the geometric normal, flipped for a shadow
/// ray that leaves through the back).
pub fn smooth_surface_offset(mesh: &Mesh, tri: u32, bary: Vec2, ng: Vec3) -> Vec3 {
    let Some(&[i0, i1, i2]) = mesh.triangles.get(tri as usize) else {
        return Vec3::ZERO;
    };
    let (Some(&v0), Some(&v1), Some(&v2)) =
        (mesh.positions.get(i0 as usize), mesh.positions.get(i1 as usize), mesh.positions.get(i2 as usize))
    else {
        return Vec3::ZERO;
    };
    let (Some(&n0), Some(&n1), Some(&n2)) =
        (mesh.normals.get(i0 as usize), mesh.normals.get(i1 as usize), mesh.normals.get(i2 as usize))
    else {
        return Vec3::ZERO;
    };
    // One normal at every corner (a flat face, or custom normals set alike, as on foliage
    // cards): no patch. Cycles builds its patch from the mesh's vertex normals, not the custom
    // ones, and those of a planar face are the face's own, so its patch is the face itself
    // (glTF-Blender-IO's 10_custom_normals_with_modifier.blend: a plane of one custom normal
    // lying 87 degrees off its own, 1.0057 of Cycles with 24 of 192 blocks lit through it).
    if n0 == n1 && n1 == n2 {
        return Vec3::ZERO;
    }
    let (u, v, w) = (1.0 - bary.x - bary.y, bary.x, bary.y);
    let p = v0 * u + v1 * v + v2 * w;
    // Not normalised, as Cycles: the patch's height is along the blended normal.
    let n = n0 * u + n1 * v + n2 * w;
    // The parabola through the corners with the corners' normals as its slopes.
    let a = (n2 - n0).dot(v0 - v2);
    let b = (n2 - n1).dot(v1 - v2);
    let c = (n1 - n0).dot(v1 - v0);
    let mut h = a * u * (u - 1.0) + (a + b + c) * u * v + b * v * (v - 1.0);
    // Bounded by the corners' tangent planes (the local linear envelope), on the side the
    // shading normal points to: below the flat triangle the same bound with the normals
    // negated (exact: a negated vector negates its dot products bit for bit).
    let side = if n.dot(ng) > 0.0 { 1.0 } else { -1.0 };
    let reach = |vi: Vec3, ni: Vec3, va: Vec3, vb: Vec3| {
        let ni = ni * side;
        let e = (va - vi).dot(ni).max((vb - vi).dot(ni)).max(0.0);
        ((vi - p).dot(ni) + e).max(0.0)
    };
    let h0 = reach(v0, n0, v1, v2);
    let h1 = reach(v1, n1, v0, v2);
    let h2 = reach(v2, n2, v0, v1);
    h = side * h0.min(h1).min(h2).max(side * h * 0.5);
    n * h
}

/// Where a shadow ray toward direction `wi` leaves shading point `p` (shading normal `ns`,
/// geometric `ng`) of triangle `tri` whose object's Geometry Offset is `cutoff`: moved onto
/// the smooth patch by the share of it Cycles takes (all of it where the light grazes the
/// shading normal, fading to none where both normals face it by more than `cutoff`); and
/// whether the ray may then meet its own triangle. Cycles' shadow ray skips its own triangle
/// unless the origin was moved and the light is behind the triangle's plane (on the side away
/// from the shading normal): then it is meant to hit it, so that light from beyond the
/// geometric horizon reaches only where the lifted origin clears the triangle.
#[allow(clippy::too_many_arguments)]
pub fn shadow_ray_origin(
    mesh: &Mesh,
    tri: u32,
    bary: Vec2,
    p: Vec3,
    ns: Vec3,
    ng: Vec3,
    wi: Vec3,
    cutoff: f32,
) -> (Vec3, bool) {
    if !(cutoff > 0.0) {
        return (p, false);
    }
    let nl = ns.dot(wi);
    let side = if nl < 0.0 { -ng } else { ng };
    let nl = nl.abs();
    let ngl = side.dot(wi);
    let amount =
        if nl < cutoff { (2.0 - (ngl + nl) / cutoff).clamp(0.0, 1.0) } else { (1.0 - ngl / cutoff).clamp(0.0, 1.0) };
    if amount > 0.0 { (p + smooth_surface_offset(mesh, tri, bary, side) * amount, ngl <= 0.0) } else { (p, false) }
}

/// Whether the segment from `org` along `wi` meets triangle `tri` of `mesh` (from just behind
/// `org`: an origin on the flat triangle itself, a patch of no height, meets it too).
pub fn meets_own_triangle(mesh: &Mesh, tri: u32, org: Vec3, wi: Vec3) -> bool {
    let Some(&[i0, i1, i2]) = mesh.triangles.get(tri as usize) else {
        return false;
    };
    let (Some(&v0), Some(&v1), Some(&v2)) =
        (mesh.positions.get(i0 as usize), mesh.positions.get(i1 as usize), mesh.positions.get(i2 as usize))
    else {
        return false;
    };
    // The origin's own rounding: the triangle through it may be found a hair behind it.
    let eps = 1e-5 * (1.0 + org.abs().max_element());
    crate::accel::RayTransform::new(org, wi)
        .intersect(&[v0.into(), v1.into(), v2.into()], -eps, f32::INFINITY)
        .is_some()
}

/// The factor Cycles' Shading Offset applies to a BSDF value for light at cosine `cos_in` to
/// the shading normal (on its side), with frequency multiplier `k` (> 1): max(cos(k θ), 0) /
/// cos θ, which replaces the cosine term by cos(k θ); 1 for `k` ≤ 1, 0 at or below the horizon.
#[inline]
pub fn shift_cos_in(cos_in: f32, k: f32) -> f32 {
    if k <= 1.0 {
        return 1.0;
    }
    if cos_in <= 0.0 {
        return 0.0;
    }
    let cos_in = cos_in.min(1.0);
    (cos_in.acos() * k).cos().max(0.0) / cos_in
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One triangle of a coarse sphere of radius 1 (corners on the sphere, normals radial).
    fn sphere_facet() -> Mesh {
        let corners = [Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 0.0, 1.0)];
        Mesh {
            positions: corners.to_vec(),
            normals: corners.to_vec(),
            triangles: vec![[0, 1, 2]],
            tri_material: vec![0],
            ..Default::default()
        }
    }

    /// The centre of an octant facet lies 1 - 1/√3 = 0.42 inside the unit sphere; the patch
    /// lifts it outwards, toward the sphere and not beyond it.
    #[test]
    fn a_coarse_sphere_facet_is_lifted_toward_the_sphere() {
        let mesh = sphere_facet();
        let ng = Vec3::ONE.normalize();
        let bary = Vec2::splat(1.0 / 3.0);
        let p = Vec3::splat(1.0 / 3.0);
        let lifted = p + smooth_surface_offset(&mesh, 0, bary, ng);
        assert!(lifted.length() > p.length() + 0.05, "lifted {} from {}", lifted.length(), p.length());
        assert!(lifted.length() <= 1.0 + 1e-5, "not beyond the sphere: {}", lifted.length());
        // At a corner the patch is the corner itself.
        assert!(smooth_surface_offset(&mesh, 0, Vec2::new(1.0, 0.0), ng).length() < 1e-6);
    }

    /// A flat-shaded triangle (every corner's normal its own) is its own patch: no offset;
    /// and a light well above both normals moves no origin.
    #[test]
    fn flat_triangles_and_high_lights_keep_their_origin() {
        let mut mesh = sphere_facet();
        let ng = Vec3::ONE.normalize();
        mesh.normals = vec![ng; 3];
        assert!(smooth_surface_offset(&mesh, 0, Vec2::splat(0.3), ng).length() < 1e-6);
        let smooth = sphere_facet();
        let p = Vec3::splat(1.0 / 3.0);
        let (o, _) = shadow_ray_origin(&smooth, 0, Vec2::splat(1.0 / 3.0), p, ng, ng, ng, 0.1);
        assert_eq!(o, p, "a light along the normal");
        let grazing = (ng.cross(Vec3::Z).normalize() + ng * 0.02).normalize();
        let (o, own) = shadow_ray_origin(&smooth, 0, Vec2::splat(1.0 / 3.0), p, ng, ng, grazing, 0.1);
        assert!(o.length() > p.length() + 0.05, "a grazing light: the whole offset");
        assert!(!own, "a light above the triangle's plane skips the triangle");
        assert_eq!(
            shadow_ray_origin(&smooth, 0, Vec2::splat(1.0 / 3.0), p, ng, ng, grazing, 0.0),
            (p, false),
            "offset 0"
        );
    }

    /// Corners that share one normal tilted off the face (custom normals set alike) lift
    /// nothing, and a light behind the face then meets the face itself.
    #[test]
    fn one_tilted_normal_at_every_corner_is_a_flat_patch() {
        let mut mesh = sphere_facet();
        let tilted = Vec3::new(0.9, -0.2, 0.4).normalize();
        mesh.normals = vec![tilted; 3];
        let ng = Vec3::ONE.normalize();
        assert_eq!(smooth_surface_offset(&mesh, 0, Vec2::splat(0.3), ng), Vec3::ZERO);
        let p = Vec3::splat(1.0 / 3.0);
        let behind = (-ng + tilted * 1.5).normalize();
        assert!(tilted.dot(behind) > 0.0 && ng.dot(behind) < 0.0, "above the shading normal, behind the face");
        let (o, own) = shadow_ray_origin(&mesh, 0, Vec2::splat(1.0 / 3.0), p, tilted, ng, behind, 0.1);
        assert_eq!(o, p);
        assert!(own && meets_own_triangle(&mesh, 0, o, behind), "the face blocks it");
    }

    #[test]
    fn shading_offset_remaps_the_cosine_to_cos_k_theta() {
        // Offset 0.5: k = 1 / (1 - 0.25) = 4/3; the terminator moves from 90° to 67.5°.
        let k = 1.0 / (1.0 - 0.5 * 0.5);
        for deg in [0.0f32, 20.0, 45.0, 60.0, 67.0, 68.0, 80.0, 89.9] {
            let theta = deg.to_radians();
            let got = shift_cos_in(theta.cos(), k) * theta.cos();
            let want = (k * theta).cos().max(0.0);
            assert!((got - want).abs() < 1e-5, "{deg}°: {got} vs {want}");
        }
        assert_eq!(shift_cos_in(0.3, 1.0), 1.0, "no offset: unchanged");
        assert_eq!(shift_cos_in(0.0, k), 0.0, "at the horizon: nothing (not 0 / 0)");
        assert_eq!(shift_cos_in(-0.2, k), 0.0);
    }
}
