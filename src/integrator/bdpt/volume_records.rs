//! What BDPT's subpaths record for VCM's volume merging (`vcm::volume_merge`): the segments a
//! light subpath crosses in media after delta bounces alone, and the camera subpath's first
//! medium vertex. Kept here, beside the scratch that holds them, so that VCM depends on BDPT
//! and not the reverse.

use crate::integrator::bdpt::passes::First;
use crate::math::Rgb;
use crate::medium::{MediumStack, Phase};
use glam::Vec3;

/// A segment a light subpath crossed in a medium after delta bounces alone.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LightSegment {
    /// Start of the segment.
    pub org: Vec3,
    /// Unit direction of travel.
    pub dir: Vec3,
    /// Length (infinite for a subpath leaving the scene).
    pub t_end: f32,
    /// The media the segment is in.
    pub media: MediumStack,
    /// The light subpath's throughput at the segment's start.
    pub beta: Rgb,
    /// Delta bounces before the segment (k ≥ 1).
    pub bounces: u32,
    /// The light the subpath started at.
    pub light: u32,
}

/// The camera subpath's first medium vertex, where the path tracer takes over.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MediumVertex {
    /// Position.
    pub p: Vec3,
    /// Unit direction the camera subpath arrived along.
    pub dir: Vec3,
    /// The phase function there.
    pub phase: Phase,
    /// The camera subpath's throughput (σ_s · Tr / p of the free flight included).
    pub beta: Rgb,
    /// Scattering events before it (surfaces of the camera subpath).
    pub events_before: u32,
    /// The class of the camera subpath's first scattering event, for the light passes.
    pub first: First,
}
