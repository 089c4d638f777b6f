//! Merging a second loaded scene — the viewport's added objects and changed meshes, exported
//! alone — into the running one without reloading it (`objects` request, docs/protocol.md).
//! Everything the second scene holds per vertex, triangle, material, texture, instance and
//! emitter is appended with its indices shifted past the running scene's; nothing already
//! there moves, so every index a renderer, an edit or the client holds stays valid (light
//! indices too, as the visibility edit keeps them). An object of the second scene named as
//! one already loaded replaces it: the old instance is retired (the server hides it for good:
//! its triangles collapse in the BVH as a hidden object's do, its emitters turn black in
//! their slots) and the name finds the new one from then on. The BVH side is the server's
//! (`Accel::relocate` puts the new triangles in its side BVH).

use crate::light::Light;
use crate::scene::Scene;
use crate::scene::light_groups::NONE;
use crate::scene::visibility::{HiddenObject, RayMask};

/// What a merge appended and what it replaced, as indices into `Scene::instances`.
#[derive(Debug, Default)]
pub struct Merged {
    /// The new instances (the second scene's, in its order).
    pub added: Vec<usize>,
    /// The instances the new ones replace (same name), to be hidden for good.
    pub retired: Vec<usize>,
}

/// Checks that `add` can be merged into `scene` (else the client sends `load`), before the
/// server stops the render for it.
pub fn check(scene: &Scene, add: &Scene) -> Result<(), String> {
    match refusal(scene, add) {
        Some(why) => Err(format!("the objects cannot be merged into the running scene: {why}; send load")),
        None => Ok(()),
    }
}

/// Why a second scene cannot be merged in place, or None.
fn refusal(scene: &Scene, add: &Scene) -> Option<String> {
    if !add.curves.is_empty() {
        return Some("it holds hair or curves".into());
    }
    if !add.points.is_empty() {
        return Some("it holds point clouds".into());
    }
    if add.motion.is_some() {
        return Some("it holds motion blur steps".into());
    }
    if !add.grids.is_empty() {
        return Some("it holds volume objects".into());
    }
    // Receiver and blocker collections name objects by node index in their own file.
    if !scene.light_linking.rules.is_empty() || !add.light_linking.rules.is_empty() {
        return Some("the scene uses light linking, whose collections are numbered by node".into());
    }
    if let Some(r) = add.report.lights.iter().find(|r| r.kind != "emissive" && r.kind != "world") {
        return Some(format!("it holds the {} light '{}' (lights are added by load)", r.kind, r.name));
    }
    None
}

/// A per-triangle (or per-light) table that is empty when every entry would be `fill`:
/// extends `mine` (of `len` entries when non-empty) by `theirs` (of `their_len`), filling
/// whichever side is empty, and leaves both empty when both are.
fn append_table<T: Clone>(mine: &mut Vec<T>, len: usize, theirs: &[T], their_len: usize, fill: T) {
    if mine.is_empty() && theirs.is_empty() {
        return;
    }
    mine.resize(len, fill.clone());
    if theirs.is_empty() {
        mine.resize(len + their_len, fill);
    } else {
        mine.extend_from_slice(theirs);
    }
}

/// The entries `kept` of a per-light table, empty when the table is (every light the default).
fn pick<T: Copy>(table: &[T], kept: &[usize], fill: T) -> Vec<T> {
    if table.is_empty() {
        return Vec::new();
    }
    kept.iter().map(|&i| table.get(i).copied().unwrap_or(fill)).collect()
}

/// Appends `add` to `scene` (see the module doc). On refusal nothing is changed.
pub fn merge(scene: &mut Scene, mut add: Scene) -> Result<Merged, String> {
    check(scene, &add)?;
    let v0 = scene.mesh.positions.len() as u32;
    let t0 = scene.mesh.triangles.len() as u32;
    let m0 = scene.materials.len() as u32;
    let x0 = scene.textures.len() as u32;
    let o0 = scene.objects.len() as u32;
    let (nt, nl) = (add.mesh.triangles.len(), add.lights.len());
    let mut merged = Merged::default();
    // Every instance of a name the second scene brings is replaced (older copies of an object
    // replaced before are already hidden for good: retiring them again changes nothing).
    for name in add.instances.iter().map(|s| &s.name) {
        for (i, s) in scene.instances.iter().enumerate() {
            if &s.name == name && !merged.retired.contains(&i) {
                merged.retired.push(i);
            }
        }
    }

    // Geometry: vertices as they are, triangles shifted to the appended vertices.
    let (m, a) = (&mut scene.mesh, &mut add.mesh);
    // Undisplaced positions (Generated coordinates) for both or neither.
    if !m.undisplaced.is_empty() || !a.undisplaced.is_empty() {
        if m.undisplaced.is_empty() {
            m.undisplaced = m.positions.clone();
        }
        if a.undisplaced.is_empty() {
            a.undisplaced = a.positions.clone();
        }
        m.undisplaced.append(&mut a.undisplaced);
    }
    m.positions.append(&mut a.positions);
    m.normals.append(&mut a.normals);
    m.tangents.append(&mut a.tangents);
    m.uv0.append(&mut a.uv0);
    m.uv1.append(&mut a.uv1);
    m.colors.append(&mut a.colors);
    m.append_attributes(a, v0 as usize);
    m.triangles.extend(a.triangles.iter().map(|t| t.map(|v| v + v0)));
    m.tri_material.extend(a.tri_material.iter().map(|x| x + m0));
    // A triangle without instance data reads NO_OBJECT (`Scene::object_of`): index past the list.
    let objects: Vec<u32> = a.tri_object.iter().map(|o| o + o0).collect();
    append_table(&mut m.tri_object, t0 as usize, &objects, nt, u32::MAX);

    // Materials read textures and shader programs read images by index into `textures`.
    for mat in &mut add.materials {
        for t in mat.textures_mut() {
            t.texture += x0;
        }
        if let Some(p) = &mut mat.nodes {
            for op in &mut std::sync::Arc::make_mut(p).ops {
                if let crate::shader::instructions::Op::Image(img) = op
                    && let Some(t) = &mut img.texture
                {
                    *t += x0;
                }
            }
        }
    }
    scene.materials.append(&mut add.materials);
    scene.textures.append(&mut add.textures);
    scene.report.materials.append(&mut add.report.materials);
    scene.objects.append(&mut add.objects);

    // Emitters: the second scene's emissive triangles, after every light there is (its world,
    // the running scene's to keep, is left out).
    let nl0 = scene.lights.len();
    let kept: Vec<usize> = (0..nl).filter(|&i| !matches!(add.lights[i], Light::World)).collect();
    for &i in &kept {
        let Light::Triangle { tri } = add.lights[i] else {
            unreachable!("refusal() lets only emissive triangles and the world through")
        };
        scene.lights.push(Light::Triangle { tri: tri + t0 });
        scene.light_power.push(add.light_power[i]);
        scene.light_casts_shadow.push(add.light_casts_shadow.get(i).copied().unwrap_or(true));
    }
    let catcher = pick(&add.light_lights_catcher, &kept, true);
    let rays = pick(&add.light_rays, &kept, RayMask::ALL);
    append_table(&mut scene.light_lights_catcher, nl0, &catcher, kept.len(), true);
    append_table(&mut scene.light_rays, nl0, &rays, kept.len(), RayMask::ALL);
    // Emissive triangles have no Max Bounces (Cycles).
    append_table(&mut scene.light_max_bounces, nl0, &[], kept.len(), crate::scene::light_bounces::NO_LIMIT);
    scene.report.lights.extend(add.report.lights.into_iter().filter(|r| r.kind == "emissive"));

    // Light groups by name: the second file's group numbers are its own.
    let g = &mut scene.light_groups;
    let to_mine = |x: u8| {
        add.light_groups
            .names
            .get(x as usize)
            .and_then(|n| g.names.iter().position(|m| m == n))
            .map_or(NONE, |i| i as u8)
    };
    let of_tri: Vec<u8> = add.light_groups.of_tri.iter().map(|&x| to_mine(x)).collect();
    let of_light: Vec<u8> = pick(&add.light_groups.of_light, &kept, NONE).into_iter().map(to_mine).collect();
    append_table(&mut g.of_tri, t0 as usize, &of_tri, nt, NONE);
    append_table(&mut g.of_light, nl0, &of_light, kept.len(), NONE);

    // Ray visibility, holdouts and catchers per triangle.
    let (v, av) = (&mut scene.ray_visibility, &add.ray_visibility);
    append_table(&mut v.per_triangle, t0 as usize, &av.per_triangle, nt, RayMask::ALL);
    append_table(&mut v.holdout, t0 as usize, &av.holdout, nt, false);
    append_table(&mut v.catcher, t0 as usize, &av.catcher, nt, false);
    append_table(&mut v.terminator, t0 as usize, &av.terminator, nt, 0.0);
    append_table(&mut v.shading_frequency, t0 as usize, &av.shading_frequency, nt, 1.0);
    v.hidden_objects.extend(av.hidden_objects.iter().map(|h| HiddenObject {
        name: h.name.clone(),
        triangles: h.triangles.start + t0 as usize..h.triangles.end + t0 as usize,
        mask: h.mask,
    }));
    v.holdout_objects.extend(av.holdout_objects.iter().cloned());
    v.catcher_objects.extend(av.catcher_objects.iter().cloned());

    scene.pass_ids.append(&add.pass_ids, t0, m0);
    let first = scene.instances.len();
    for mut s in add.instances {
        s.vertices = s.vertices.start + v0..s.vertices.end + v0;
        s.triangles = s.triangles.start + t0..s.triangles.end + t0;
        s.object = s.object.map(|o| o + o0);
        scene.instances.push(s);
    }
    merged.added = (first..scene.instances.len()).collect();
    scene.report.triangles += nt;
    scene.report.instances += merged.added.len();
    for w in add.warnings {
        if !scene.warnings.contains(&w) {
            scene.warnings.push(w);
        }
    }
    // The running scene's identity now covers the second file's too.
    scene.source_hash = scene.source_hash.rotate_left(1) ^ add.source_hash;
    Ok(merged)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_stay_empty_or_cover_every_entry() {
        let mut mine: Vec<u8> = Vec::new();
        append_table(&mut mine, 3, &[], 2, 0);
        assert!(mine.is_empty(), "both sides default: nothing stored");
        append_table(&mut mine, 3, &[7, 8], 2, 0);
        assert_eq!(mine, [0, 0, 0, 7, 8]);
        append_table(&mut mine, 5, &[], 1, 9);
        assert_eq!(mine, [0, 0, 0, 7, 8, 9]);
    }
}
