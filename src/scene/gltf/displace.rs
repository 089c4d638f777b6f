//! True displacement: a node material whose Displacement method is "DISPLACEMENT" or "BOTH"
//! (`shader::instructions::TrueDisplacement`) moves its mesh before the BVH is built, as Cycles'
//! `GeometryManager::displace` does without adaptive subdivision: the displacement is evaluated
//! once per vertex (at the corner of the first triangle that uses it, with that corner's
//! normal and attributes), the vertex moved, and the normals recomputed.
//!
//! The exporter splits a Blender vertex at UV seams and sharp edges; its copies share the
//! position, so an instance's vertices are joined by position (bit for bit) and each group
//! moves once, by one offset: seams do not crack. Normals follow the mesh's normals domain
//! (`CAUSTIC_normals_domain`, Blender's `Mesh.normals_domain`, docs/contract.md):
//!
//! * POINT (all smooth): with "DISPLACEMENT", each vertex's normal becomes the normalised sum of
//!   the unit face normals of the displaced triangles around it; with "BOTH" the undisplaced
//!   normals stay, as Cycles keeps them for the bump to perturb.
//! * FACE (all flat): every triangle takes its displaced geometric normal.
//! * CORNER, or not given: a triangle whose three normals equal its geometric normal is taken
//!   as flat (its displaced geometric normal); the others' corner normals turn by the change of
//!   their vertex's averaged normal over the whole instance, as Cycles applies that delta to
//!   corner normals.

use super::Loader;
use crate::error::Result;
use crate::scene::{Material, Mesh};
use crate::shader::closure::Closures;
use crate::shader::geom::{ObjectData, geom_at};
use crate::shader::instructions::TrueDisplacement;
use crate::shader::program::with_registers;
use glam::{Mat3, Mat4, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::ops::Range;

/// The mesh's normals domain, from `CAUSTIC_normals_domain`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum NormalsDomain {
    /// Every face smooth, no sharp edge.
    Point,
    /// Every face flat.
    Face,
    /// Corner normals (sharp edges, mixed or custom normals), or not given.
    Corner,
}

impl NormalsDomain {
    /// The domain a mesh's extras value names (absent: Corner, the rule that reads the normals).
    pub(super) fn parse(v: Option<&serde_json::Value>) -> std::result::Result<Self, String> {
        match v {
            None => Ok(NormalsDomain::Corner),
            Some(v) => match v.as_str() {
                Some("POINT") => Ok(NormalsDomain::Point),
                Some("FACE") => Ok(NormalsDomain::Face),
                Some("CORNER") => Ok(NormalsDomain::Corner),
                _ => Err(format!("CAUSTIC_normals_domain {v} is not one of \"POINT\", \"FACE\", \"CORNER\"")),
            },
        }
    }
}

/// The positions before displacement while the instances load, up to the last vertex moved
/// (a vertex past the end was not moved).
#[derive(Clone, Debug, Default)]
pub(super) struct Undisplaced(Vec<Vec3>);

impl Undisplaced {
    /// Completes the list to every vertex of `mesh` and gives it to `Mesh::undisplaced` (left
    /// empty when nothing moved).
    pub(super) fn finish(self, mesh: &mut Mesh) {
        let mut u = self.0;
        if !u.is_empty() {
            u.extend_from_slice(&mesh.positions[u.len()..]);
            mesh.undisplaced = u;
        }
    }
}

/// Vertex `k`'s position before true displacement (deformation motion finds its source
/// vertices by them).
#[inline]
pub(super) fn undisplaced_at(mesh: &Mesh, k: usize) -> Vec3 {
    mesh.undisplaced.get(k).copied().unwrap_or(mesh.positions[k])
}

/// The unit normal of triangle `t` (zero when degenerate).
fn face_normal(p: &[Vec3], t: [u32; 3]) -> Vec3 {
    let [a, b, c] = t.map(|i| p[i as usize]);
    (b - a).cross(c - a).normalize_or_zero()
}

impl Loader<'_> {
    /// Displaces the instance whose vertices are `verts` and triangles `tris` (placed by
    /// `world`), where their material asks for it (module doc); `undisplaced` keeps the
    /// positions it moves from.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn displace_instance(
        &mut self,
        mesh: &mut Mesh,
        verts: Range<usize>,
        tris: Range<usize>,
        objects: &[ObjectData],
        world: &Mat4,
        materials: &[Material],
        domain: NormalsDomain,
        undisplaced: &mut Undisplaced,
        instance: &str,
    ) -> Result<()> {
        let td = |m: u32| -> Option<&TrueDisplacement> {
            materials.get(m as usize)?.nodes.as_ref()?.true_displacement.as_deref()
        };
        if !tris.clone().any(|t| td(mesh.tri_material[t]).is_some()) {
            return Ok(());
        }
        let v0 = verts.start;
        // Each vertex's group: the instance's vertices at one position.
        let mut groups: HashMap<[u32; 3], u32> = HashMap::new();
        let group: Vec<u32> = mesh.positions[verts.clone()]
            .iter()
            .map(|p| {
                let n = groups.len() as u32;
                *groups.entry(p.to_array().map(f32::to_bits)).or_insert(n)
            })
            .collect();
        let ng = groups.len();
        // Each displaced group's first corner (triangle, corner), as Cycles visits them.
        let mut first: Vec<Option<(u32, u8)>> = vec![None; ng];
        for t in tris.clone() {
            if td(mesh.tri_material[t]).is_none() {
                continue;
            }
            for (j, &v) in mesh.triangles[t].iter().enumerate() {
                let g = group[v as usize - v0] as usize;
                if first[g].is_none() {
                    first[g] = Some((t as u32, j as u8));
                }
            }
        }
        let jobs: Vec<(u32, u8)> = first.iter().flatten().copied().collect();
        let m3 = Mat3::from_mat4(*world);
        let textures = &self.textures;
        let eval = |&(t, j): &(u32, u8)| -> Vec3 {
            let d = td(mesh.tri_material[t as usize]).expect("a displaced triangle");
            let (b1, b2) = match j {
                0 => (0.0, 0.0),
                1 => (1.0, 0.0),
                _ => (0.0, 1.0),
            };
            let g = geom_at(mesh, objects, textures, t, b1, b2);
            let amount = with_registers(|r| {
                let mut closures = Closures::default();
                d.program.run(&g, r, &mut closures);
                r[d.height as usize]
            });
            if d.object_space {
                // Cycles: the object-space normal times the amount, carried by the object's
                // transform (so the object's scale scales it).
                m3 * ((m3.transpose() * g.n).normalize_or_zero() * amount)
            } else {
                g.n * amount
            }
        };
        let offsets: Vec<Vec3> = jobs.par_iter().map(eval).collect();
        // Non-finite offsets: Cycles' `ensure_finite` leaves those vertices in place.
        let mut bad: HashMap<String, usize> = HashMap::new();
        let mut offset = vec![Vec3::ZERO; ng];
        let mut k = 0;
        for (g, f) in first.iter().enumerate() {
            let Some((t, _)) = f else { continue };
            let d = offsets[k];
            k += 1;
            if d.is_finite() {
                offset[g] = d;
            } else {
                let name = &materials[mesh.tri_material[*t as usize] as usize].name;
                *bad.entry(name.clone()).or_default() += 1;
            }
        }
        let mut bad: Vec<_> = bad.into_iter().collect();
        bad.sort();
        for (name, n) in bad {
            self.warn(format!(
                "material '{name}': its displacement is NaN or infinite at {n} vertices of object '{instance}'; \
                 those vertices are not moved (as Cycles)"
            ));
        }
        // Before anything moves: flat triangles and the averaged normals (CORNER).
        let flat: Vec<bool> = tris
            .clone()
            .map(|t| match domain {
                NormalsDomain::Face => true,
                NormalsDomain::Point => false,
                NormalsDomain::Corner => {
                    let tri = mesh.triangles[t];
                    let n = tri.map(|i| mesh.normals[i as usize]);
                    let f = face_normal(&mesh.positions, tri);
                    n.iter().all(|&n| n == Vec3::ZERO) || n.iter().all(|&n| n.dot(f) > 1.0 - 1e-5)
                }
            })
            .collect();
        let averaged = |mesh: &Mesh, keep: &dyn Fn(usize) -> bool| -> Vec<Vec3> {
            let mut sum = vec![Vec3::ZERO; ng];
            for t in tris.clone().filter(|&t| keep(t)) {
                let f = face_normal(&mesh.positions, mesh.triangles[t]);
                for &v in &mesh.triangles[t] {
                    sum[group[v as usize - v0] as usize] += f;
                }
            }
            sum.iter().map(|s| s.normalize_or_zero()).collect()
        };
        let pre = (domain == NormalsDomain::Corner).then(|| averaged(mesh, &|_| true));
        if undisplaced.0.len() < verts.end {
            let from = undisplaced.0.len();
            // The copy (`Mesh::undisplaced`) grows to every vertex loaded so far.
            let bytes = ((verts.end - from) * std::mem::size_of::<Vec3>()) as u64;
            self.budget.charge(format!("the undisplaced positions of object '{instance}'"), bytes)?;
            undisplaced.0.extend_from_slice(&mesh.positions[from..verts.end]);
        }
        for k in verts.clone() {
            let p = mesh.positions[k] + offset[group[k - v0] as usize];
            if p.abs().max_element() > super::MAX_COORDINATE {
                return Err(self.err(format!(
                    "object '{instance}': a vertex displaced to {p} lies beyond ±{:e} scene units (not supported)",
                    super::MAX_COORDINATE
                )));
            }
            mesh.positions[k] = p;
        }
        let tri_slice = tris.clone();
        match domain {
            NormalsDomain::Face => {
                for k in verts.clone() {
                    mesh.normals[k] = Vec3::ZERO;
                }
            }
            NormalsDomain::Point => {
                // Only "DISPLACEMENT" recomputes: "BOTH" keeps the normals its bump perturbs.
                let recompute: Vec<bool> =
                    tri_slice.clone().map(|t| td(mesh.tri_material[t]).is_some_and(|d| !d.bump)).collect();
                let post = averaged(mesh, &|t| recompute[t - tris.start]);
                for t in tri_slice.filter(|&t| recompute[t - tris.start]) {
                    for v in mesh.triangles[t] {
                        let v = v as usize;
                        let n = post[group[v - v0] as usize];
                        if n != Vec3::ZERO {
                            mesh.normals[v] = n;
                        }
                    }
                }
            }
            NormalsDomain::Corner => {
                let pre = pre.expect("computed for CORNER");
                let post = averaged(mesh, &|_| true);
                let mut done = vec![false; verts.len()];
                for (t, &flat) in tri_slice.clone().zip(&flat) {
                    if flat {
                        continue;
                    }
                    for v in mesh.triangles[t] {
                        let v = v as usize;
                        if std::mem::replace(&mut done[v - v0], true) {
                            continue;
                        }
                        let g = group[v - v0] as usize;
                        let n = mesh.normals[v];
                        mesh.normals[v] = (n + post[g] - pre[g]).normalize_or(n);
                    }
                }
                // A zero normal marks the geometric normal: the displaced facet's.
                for (t, &flat) in tri_slice.zip(&flat) {
                    if flat {
                        for v in mesh.triangles[t] {
                            mesh.normals[v as usize] = Vec3::ZERO;
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::Scene;
    use base64::Engine;
    use glam::Vec3;
    use serde_json::{Value, json};

    /// Two halves of the plane z = 0, x in [-1, 0] and [0, 1], each a primitive of Q × Q quads
    /// with its own vertices (the column x = 0 twice, as an exporter splits a UV seam): U runs
    /// over [0, 0.5] on the left half and [0.75, 1.25] on the right. The material displaces by
    /// the UV's U (Height U, Midlevel 0, Scale 1) by `method`; the mesh's extras give `domain`.
    fn seamed(method: &str, domain: Option<&str>) -> Scene {
        seamed_result(method, domain).unwrap()
    }

    /// [`seamed`], or the loader's error.
    fn seamed_result(method: &str, domain: Option<&str>) -> crate::error::Result<Scene> {
        const Q: usize = 2;
        let n = Q + 1;
        let mut bytes: Vec<u8> = Vec::new();
        let mut views = Vec::new();
        let mut accessors = Vec::new();
        let mut prims = Vec::new();
        let mut push = |data: Vec<u8>, acc: Value| {
            views.push(json!({"buffer": 0, "byteOffset": bytes.len(), "byteLength": data.len()}));
            bytes.extend(data);
            let mut acc = acc;
            acc["bufferView"] = json!(views.len() - 1);
            accessors.push(acc);
            accessors.len() - 1
        };
        let f = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
        for (x0, u0) in [(-1.0f32, 0.0f32), (0.0, 0.75)] {
            let (mut p, mut nrm, mut uv) = (Vec::new(), Vec::new(), Vec::new());
            for j in 0..n {
                for i in 0..n {
                    let (s, t) = (i as f32 / Q as f32, j as f32 / Q as f32);
                    p.extend([x0 + s, -1.0 + 2.0 * t, 0.0]);
                    nrm.extend([0.0, 0.0, 1.0]);
                    uv.extend([u0 + 0.5 * s, 1.0 - t]);
                }
            }
            let mut idx: Vec<u32> = Vec::new();
            for j in 0..Q {
                for i in 0..Q {
                    let a = (j * n + i) as u32;
                    idx.extend([a, a + 1, a + 1 + n as u32, a, a + 1 + n as u32, a + n as u32]);
                }
            }
            let pa = push(
                f(&p),
                json!({"componentType": 5126, "count": n * n, "type": "VEC3", "min": [x0, -1, 0], "max": [x0 + 1.0, 1, 0]}),
            );
            let na = push(f(&nrm), json!({"componentType": 5126, "count": n * n, "type": "VEC3"}));
            let ua = push(f(&uv), json!({"componentType": 5126, "count": n * n, "type": "VEC2"}));
            let ia = push(
                idx.iter().flat_map(|x| x.to_le_bytes()).collect(),
                json!({"componentType": 5125, "count": idx.len(), "type": "SCALAR"}),
            );
            prims.push(json!({"attributes": {"POSITION": pa, "NORMAL": na, "TEXCOORD_0": ua}, "indices": ia,
                              "material": 0}));
        }
        let nodes = json!([
            {"name": "TexCoord", "type": "ShaderNodeTexCoord"},
            {"name": "Separate", "type": "ShaderNodeSeparateXYZ", "inputs": {"Vector": {"link": [0, "UV"]}}},
            {"name": "Displacement", "type": "ShaderNodeDisplacement", "props": {"space": "OBJECT"},
             "inputs": {"Height": {"link": [1, "X"]}, "Midlevel": {"value": 0.0}, "Scale": {"value": 1.0}}},
            {"name": "Diffuse", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": {"value": [1, 1, 1, 1]}}}
        ]);
        let mut mesh = json!({"primitives": prims});
        if let Some(d) = domain {
            mesh["extras"] = json!({"CAUSTIC_normals_domain": d});
        }
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&bytes)
        );
        let doc = json!({
            "asset": {"version": "2.0"},
            "extensionsUsed": ["CAUSTIC_materials_nodes"],
            "buffers": [{"uri": uri, "byteLength": bytes.len()}],
            "bufferViews": views,
            "accessors": accessors,
            "materials": [{"name": "seamed", "extensions": {"CAUSTIC_materials_nodes": {"version": 1,
                "nodes": nodes, "displacement_method": method,
                "output": {"surface": [3, "BSDF"], "displacement": [2, "Displacement"]}}}}],
            "meshes": [mesh],
            "nodes": [{"mesh": 0, "name": "Plane"}],
            "scenes": [{"nodes": [0]}]
        });
        let budget = crate::memory::MemoryBudget::unlimited();
        crate::scene::gltf::load_bytes(&serde_json::to_vec(&doc).unwrap(), std::path::Path::new("."), "s.gltf", &budget)
    }

    /// Each vertex rises by its U (Blender's U is glTF's), and the seam's two copies rise
    /// once, by the left copy's U (its triangles come first, as Cycles visits them): no crack.
    #[test]
    fn vertices_move_by_their_height_and_seams_move_once() {
        let s = seamed("DISPLACEMENT", Some("POINT"));
        let m = &s.mesh;
        assert_eq!(m.positions.len(), 18);
        for (k, p) in m.positions.iter().enumerate() {
            // Left half: U = (x + 1) / 2; right half: U = 0.75 + x / 2, but x = 0 is the seam.
            let u = if k < 9 || p.x == 0.0 { (p.x + 1.0) / 2.0 } else { 0.75 + p.x / 2.0 };
            assert!((p.z - u).abs() < 1e-6, "vertex {k} at {p}: z {} vs U {u}", p.z);
        }
        // Generated reads the undisplaced point (Cycles' orco): Blender's Y is glTF's -z, 0 here.
        assert!(m.undisplaced.iter().all(|p| p.z == 0.0));
        for t in 0..m.triangles.len() as u32 {
            let g = crate::shader::geom::geom_at(m, &s.objects, &[], t, 0.3, 0.2);
            assert!(g.p.z > 0.0 && g.generated().y.abs() < 1e-6, "triangle {t}: {} at {}", g.generated(), g.p);
        }
    }

    /// Normals after displacement by the domain: POINT with "DISPLACEMENT" averages the
    /// displaced facets (tilted against the slope, the same on both copies of the seam), POINT
    /// with "BOTH" keeps the undisplaced normals for the bump, FACE and a plane without a domain
    /// (whose normals equal its facets', so taken as flat) take the displaced facets (zero).
    #[test]
    fn normals_follow_the_domain_and_method() {
        let s = seamed("DISPLACEMENT", Some("POINT"));
        for (k, n) in s.mesh.normals.iter().enumerate() {
            assert!((n.length() - 1.0).abs() < 1e-5 && n.x < -0.1 && n.y.abs() < 1e-5, "vertex {k}: {n}");
        }
        let seam = |p: Vec3| p.x == 0.0;
        let left: Vec<_> = (0..9).filter(|&k| seam(s.mesh.positions[k])).map(|k| s.mesh.normals[k]).collect();
        let right: Vec<_> = (9..18).filter(|&k| seam(s.mesh.positions[k])).map(|k| s.mesh.normals[k]).collect();
        assert_eq!(left, right, "the seam's copies share their normal");
        let both = seamed("BOTH", Some("POINT"));
        assert!(both.mesh.normals.iter().all(|&n| n == Vec3::Z), "{:?}", both.mesh.normals);
        assert!(both.materials[0].nodes.as_ref().unwrap().displacement_normal.is_some(), "BOTH bumps");
        let only = seamed("DISPLACEMENT", Some("POINT"));
        assert!(only.materials[0].nodes.as_ref().unwrap().displacement_normal.is_none(), "DISPLACEMENT does not");
        for domain in [Some("FACE"), None] {
            let s = seamed("DISPLACEMENT", domain);
            assert!(s.mesh.normals.iter().all(|&n| n == Vec3::ZERO), "{domain:?}: {:?}", s.mesh.normals);
        }
    }

    /// A normals domain that is not Blender's is refused, naming the mesh.
    #[test]
    fn an_unknown_normals_domain_is_an_error() {
        let Err(e) = seamed_result("DISPLACEMENT", Some("EDGE")) else { panic!("an unknown domain loaded") };
        let e = e.to_string();
        assert!(e.contains("mesh 0") && e.contains("CAUSTIC_normals_domain \"EDGE\""), "{e}");
    }
}
