//! Emitters whose node graph reads the Light Path node. The path tracer evaluates such an
//! emitter with the state of the path that finds it (`scene::light_path`: a camera ray, a
//! bounce's kind and depth, next-event estimation from a shading point); a path that starts
//! on the light has no such state. BDPT and VCM therefore take these emitters by the
//! camera-side strategies alone (`integrator::bdpt::path_emitters`); photons, which must
//! start on them, read them as light sampling without a path does
//! (`LightPath::LIGHT_EMISSION`: no flag, Ray Depth 1, the other depths 0, Ray Length 0),
//! which is exact only for the outputs that read the same for a photon as for every ray
//! that finds the emitter after the camera's: Is Camera Ray and Is Shadow Ray (both 0).

use crate::light::Light;
use crate::scene::Scene;
use crate::scene::light_path::PathOutput;

/// Per light: an emissive triangle whose material's emission may read the Light Path node,
/// or a light whose node tree varies over it.
pub fn reading_light_path(scene: &Scene) -> Vec<bool> {
    (0..scene.lights.len()).map(|i| reads_light_path(scene, i)).collect()
}

/// True for light `index` when it is an emissive triangle whose material's emission may
/// read the Light Path node, or a light whose node tree varies over it
/// (`light::light_graph`): its emission depends on the receiver (the direction, Light
/// Falloff's distance), which a light subpath leaving it does not know yet.
#[inline]
pub fn reads_light_path(scene: &Scene, index: usize) -> bool {
    if scene.light_graphs.get(index).is_some_and(Option::is_some) {
        return true;
    }
    match &scene.lights[index] {
        Light::Triangle { tri } => scene.materials[scene.mesh.tri_material[*tri as usize] as usize]
            .nodes
            .as_ref()
            .is_some_and(|p| p.emission_reads_light_path()),
        _ => false,
    }
}

/// The Light Path outputs a photon reads as the rays that find the emitter do.
fn exact_for_photons(o: PathOutput) -> bool {
    matches!(o, PathOutput::IsCamera | PathOutput::IsShadow)
}

/// For the photon integrators (`integrator`: their name in the message): a warning naming
/// each emitting material that reads an output of the Light Path node that its photons
/// cannot read as the path tracer's rays do, and what is approximated; `None` when there
/// is none.
pub fn photon_warning(scene: &Scene, integrator: &str) -> Option<String> {
    let reads = reading_light_path(scene);
    let mut seen = vec![false; scene.materials.len()];
    let mut named = Vec::new();
    for (l, _) in scene.lights.iter().zip(&reads).filter(|(_, r)| **r) {
        let Light::Triangle { tri } = l else { continue };
        let m = scene.mesh.tri_material[*tri as usize] as usize;
        if std::mem::replace(&mut seen[m], true) {
            continue;
        }
        let Some(prog) = scene.materials[m].nodes.as_ref() else { continue };
        let mut outputs: Vec<&str> = Vec::new();
        for o in prog.light_path_outputs().filter(|o| !exact_for_photons(*o)) {
            let name = PathOutput::ALL.iter().find(|(_, x)| *x == o).map_or("?", |(n, _)| *n);
            if !outputs.contains(&name) {
                outputs.push(name);
            }
        }
        if !outputs.is_empty() {
            named.push(format!("'{}' ({})", scene.materials[m].name, outputs.join(", ")));
        }
    }
    let lights: Vec<String> = scene
        .light_graphs
        .iter()
        .flatten()
        .filter(|g| g.reads_ray_length())
        .map(|g| format!("'{}'", g.name()))
        .collect();
    let lights = (!lights.is_empty()).then(|| {
        format!(
            "the node tree of light(s) {} reads the ray's length (Light Falloff): {integrator}'s photons leave \
             the light before their first segment's length is known and read a Ray Length of 1, so the light \
             they carry from it is approximated; its direct light (next-event estimation) and its emission seen \
             by camera paths are as the path tracer's",
            lights.join(", ")
        )
    });
    let materials = (!named.is_empty()).then(|| {
        format!(
            "emission of material(s) {} reads the Light Path node: {integrator}'s photons leave the emitter \
             without a camera path and read it as light sampling without a path does (no ray flag, Ray Depth 1, \
             the other depths and Ray Length 0), so the light they carry from it is approximated; its emission \
             seen by camera paths and its direct light (next-event estimation) are as the path tracer's",
            named.join(", ")
        )
    });
    match (materials, lights) {
        (Some(m), Some(l)) => Some(format!("{m}; {l}")),
        (m, l) => m.or(l),
    }
}

/// The integrators that shade surfaces from the light side, for
/// [`scattering_warning`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightSide {
    /// BDPT and VCM: light subpaths, whose vertices light tracing shows to the camera. Paths
    /// through such triangles are made by the camera side alone (`bdpt::visibility`); the
    /// warning names the materials of strands, which that rule does not cover.
    Subpaths,
    /// Jensen's photon mapping and SPPM: photons, read at camera vertices.
    Photons,
}

impl LightSide {
    /// The outputs a light-side vertex reads as the path tracer's ray there does: Is Shadow
    /// Ray (0 on both; connections' shadow rays set it), and for photons Is Camera Ray
    /// too (a photon's vertices lie beyond the camera's first hit, which the camera path
    /// shades itself; light tracing shows a light subpath's vertex as that first hit).
    fn exact(self, o: PathOutput) -> bool {
        o == PathOutput::IsShadow || (self == LightSide::Photons && o == PathOutput::IsCamera)
    }
}

/// A warning naming each node material whose scattering (BSDFs, transparency,
/// displacement) reads a Light Path output that `side`'s vertices cannot read as the path
/// tracer's rays do (`integrator`: its name in the message); `None` when there is none.
pub fn scattering_warning(scene: &Scene, integrator: &str, side: LightSide) -> Option<String> {
    // BDPT and VCM leave the paths through such triangles to the camera side
    // (`integrator::bdpt::visibility`); only strands and points, which that test does not
    // see, remain.
    let on_strands = |m: usize| {
        scene.curves.strands.iter().any(|s| s.material as usize == m)
            || scene.points.objects.iter().any(|o| o.material as usize == m)
    };
    let named: Vec<String> = scene
        .materials
        .iter()
        .enumerate()
        .filter(|(i, _)| side == LightSide::Photons || on_strands(*i))
        .filter_map(|(_, m)| {
            let prog = m.nodes.as_ref()?;
            let outputs: Vec<&str> = prog
                .scattering_light_path
                .iter()
                .filter(|o| !side.exact(**o))
                .filter_map(|o| PathOutput::ALL.iter().find(|(_, x)| x == o).map(|(n, _)| *n))
                .collect();
            (!outputs.is_empty()).then(|| format!("'{}' ({})", m.name, outputs.join(", ")))
        })
        .collect();
    if named.is_empty() {
        return None;
    }
    let what = match side {
        LightSide::Subpaths => {
            "shades a light subpath's vertices on their strands (hair, curves) and points with the light subpath's own \
             state (its last bounce's kind and depth, no camera path), so light reaching the camera through \
             those strands and points by light tracing, connections or merging is approximated (their triangles' paths \
             are left to the camera side, exact)"
        }
        LightSide::Photons => {
            "scatters photons on them with the photon's own state (its last bounce's kind and depth, no camera \
             path), so the light the photons carry through them is approximated"
        }
    };
    Some(format!(
        "the BSDF or transparency of material(s) {} reads the Light Path node: {integrator} {what}; camera paths \
         shade them as the path tracer does",
        named.join(", ")
    ))
}
