//! Blender's AOV Output node as Cycles runs it (`svm_node_aov_color`, `svm_node_aov_value`):
//! at a camera-ray hit the node's Color input (alpha 1) or Value input is added to the
//! AOV's pass, whichever the view layer's AOV of that name is. The compiler puts what only
//! AOV Output nodes read after the surface's operations (`Program::surface_end`), so that
//! ordinary shading never computes it; `write` runs both parts at the hits that
//! `integrator::shader_aovs` walks.

use super::closure::Closures;
use super::geom::Geom;
use super::geom::SceneRays;
use super::instructions::Program;
use super::program::with_registers;
use super::shade::traced_geom_of;
use crate::scene::Scene;
use crate::scene::hit::SurfaceHit;
use crate::scene::shader_aovs::{AovKind, AovSums, AovTarget};
use glam::Vec3;

impl Program {
    /// Runs the operations only AOV Output nodes read, after `run` filled `regs` at `g`.
    pub fn run_aovs(&self, g: &Geom, regs: &mut [f32]) {
        // The tail holds data nodes only: no closure is made there.
        let mut sink = Closures::default();
        self.steps(&self.ops[self.surface_end.min(self.ops.len())..], g, regs, &mut sink);
    }
}

/// Adds the AOV values of material program `prog` at hit `s` seen from `wo` to `sums`, for
/// its AOV Output nodes `targets` (`crate::scene::shader_aovs`); `rays`: the scene's rays
/// for its AO and Bevel nodes.
pub fn write(
    scene: &Scene,
    prog: &Program,
    targets: &[AovTarget],
    s: &SurfaceHit,
    wo: Vec3,
    sums: &mut AovSums,
    rays: Option<&dyn SceneRays>,
) {
    let g = traced_geom_of(scene, prog, s, wo, rays);
    with_registers(|regs| {
        let mut closures = Closures::default();
        prog.run(&g, regs, &mut closures);
        prog.run_aovs(&g, regs);
        add_targets(prog, targets, regs, sums);
    });
}

/// Adds what program `prog`'s AOV Output nodes `targets` read from `regs` (after `run` and
/// `run_aovs`) to `sums`: a colour with alpha 1, or a value.
pub fn add_targets(prog: &Program, targets: &[AovTarget], regs: &[f32], sums: &mut AovSums) {
    for t in targets {
        let node = &prog.aovs[t.output as usize];
        let at = t.offset as usize;
        match t.kind {
            AovKind::Color => {
                let c = node.color as usize;
                for k in 0..3 {
                    sums.0[at + k] += regs[c + k];
                }
                sums.0[at + 3] += 1.0;
            }
            AovKind::Value => sums.0[at] += regs[node.value as usize],
        }
    }
}
