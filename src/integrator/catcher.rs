//! Shadow catcher (Blender's Object > Visibility > Shadow Catcher), as Cycles defines it
//! (`kernel/integrator/shadow_catcher.h`, `intersect_closest.h`, `film/light_passes.h`):
//! a camera path whose first surface (through pass-throughs only) is a catcher splits
//! there in two. The path itself goes on as if nothing were special and gives Combined;
//! a second path, the catcher pass, starts on the same camera segment in a scene where
//! only catcher objects exist (for every ray, shadow rays too) and only the lights that
//! light catchers shine, and gives the Shadow Catcher sums. Paths that never split also
//! go to the matte sums; a split adds its throughput's mean to the matte's transparency
//! and counts one catcher sample. The film turns these sums into Cycles' passes
//! (`crate::shadow_catcher`).
//!
//! The path tracer splits, and so do BDPT and VCM (`bdpt::catcher`): their camera subpath
//! splits where its first segment ends on a catcher and the catcher pass is the path
//! tracer's walk from that state; their light-tracing splats go to the matte unless the
//! vertex the camera sees is on a catcher. Jensen's and SPPM's camera paths split too
//! (their catcher pass is the path tracer's walk from the split; SPPM's matte,
//! `photon::sppm_catcher`). Only the viewport (`caustic serve`) renders catchers as
//! ordinary objects (docs/contract.md says so).

use super::SceneContext;
use super::walk::PathState;
use crate::math::Rgb;
use crate::passes::{Aov, slot};
use crate::sampling::PixelSampler;
use crate::scene::Scene;
use crate::scene::visibility::RayMask;
use std::borrow::Cow;

/// Where a camera path split at a shadow catcher, and what it saw of the world.
#[derive(Clone, Copy, Debug)]
pub struct Split {
    /// The path may split (its context has a catcher pass and it is a camera path).
    pub allowed: bool,
    /// The state that walked the camera segment ending on the catcher, and the radiance
    /// gathered before it (the matte's share of the sample).
    pub at: Option<(PathState, Rgb)>,
    /// The world seen directly by the camera ray (throughput included), for Cycles'
    /// background pass under an opaque film.
    pub background: Rgb,
    /// The sample stream where the split camera segment began: the catcher pass replays
    /// it, as Cycles' split copies the path's random state, so that with nothing on the
    /// catcher both paths draw the same lights and bounces and the catcher stays clear.
    pub stream: Option<PixelSampler>,
}

impl Default for Split {
    /// A path that never splits.
    fn default() -> Self {
        Split::new(false)
    }
}

impl Split {
    /// A path that splits when `allowed` and finds a catcher.
    pub fn new(allowed: bool) -> Self {
        Split { allowed, at: None, background: Rgb::ZERO, stream: None }
    }
}

/// Files one camera sample into the catcher sums: `radiance` is the sample's Combined,
/// `pass` the catcher pass's radiance (when it split), `behind` the world along the camera
/// ray behind the catcher (throughput included).
pub fn record(aov: &mut Aov, split: &Split, radiance: Rgb, pass: Rgb, behind: Rgb) {
    match split.at {
        Some((pre, matte)) => {
            aov.add3(slot::CATCHER_MATTE, matte);
            aov.add3(slot::CATCHER_PASS, pass);
            aov.0[slot::CATCHER_SPLIT] += (pre.beta.x + pre.beta.y + pre.beta.z) / 3.0;
            aov.0[slot::CATCHER_COUNT] += 1.0;
            aov.add3(slot::CATCHER_BACKGROUND, behind);
        }
        None => {
            aov.add3(slot::CATCHER_MATTE, radiance);
            aov.add3(slot::CATCHER_BACKGROUND, split.background);
        }
    }
}

impl<'a> SceneContext<'a> {
    /// Adds the shadow catcher's pass context `pass` (built by [`pass_context`]): camera
    /// paths of the path tracer split at catchers.
    pub fn with_shadow_catcher(mut self, pass: SceneContext<'a>) -> Self {
        self.catcher = Some(Box::new(pass));
        self
    }
}

/// The context of the catcher pass, made from a fresh context of the same scene: every
/// object that is no catcher is seen by no ray (shadow rays included), and lights light the
/// pass when their object is a catcher (emissive meshes) or their flag says so (lights,
/// `Scene::light_lights_catcher`; Blender sets it on lights by default). `visibility`: the
/// objects' own ray visibility is honoured too.
pub fn pass_context<'a>(mut ctx: SceneContext<'a>, visibility: bool) -> SceneContext<'a> {
    let scene: &Scene = ctx.scene;
    let vis = &scene.ray_visibility;
    let n = scene.mesh.triangles.len();
    let table: Vec<RayMask> = (0..n)
        .map(|t| match vis.is_catcher(t as u32) {
            true if visibility => vis.per_triangle.get(t).copied().unwrap_or(RayMask::ALL),
            true => RayMask::ALL,
            false => RayMask(0),
        })
        .collect();
    for (t, m) in table.iter().enumerate() {
        ctx.masked[t] |= *m != RayMask::ALL;
        ctx.transparent[t] |= !m.meets(RayMask::SHADOW);
    }
    ctx.visibility = Cow::Owned(table);
    ctx.lights_catcher = scene
        .lights
        .iter()
        .enumerate()
        .map(|(i, l)| match l {
            crate::light::Light::Triangle { tri } => vis.is_catcher(*tri),
            _ => scene.light_lights_catcher.get(i).copied().unwrap_or(true),
        })
        .collect();
    ctx.catcher_only = true;
    ctx
}
