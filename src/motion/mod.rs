//! Motion blur: the shutter, the time of a camera sample, and the scene's moving
//! triangles (`CAUSTIC_motion`, docs/contract.md).
//!
//! Times are in frames relative to the rendered frame (0 is the frame the glTF file was
//! exported at). A scene that moves gives its step times (ascending) and, for each moving
//! triangle, its corners at every step; between steps the corners are interpolated
//! linearly (the loader bakes transform motion at enough steps that the chord of a
//! rotation stays close to its arc, see `gltf/motion.rs`). Moving triangles live in their
//! own BVH ([`accel::MotionAccel`]) beside the static one; a static scene has none and
//! draws no time.
//!
//! Every ray of a camera sample shares the sample's time (as in Cycles, where bounce and
//! shadow rays copy the camera ray's time, and a BDPT light subpath takes the camera
//! sample's). So the time is a property of the sample the worker thread is computing:
//! [`TimeScope`] sets it for the duration of one camera sample and the intersection and
//! shading of moving triangles read it ([`ray_time`]). This keeps every integrator's walk
//! unchanged; the thread-local is written once per sample and read only for scenes that
//! move.

pub mod accel;
pub mod camera;
pub mod shutter;
pub mod transform;
pub mod vector;

use glam::Vec3;
use std::cell::Cell;

pub use camera::CameraMotion;
pub use shutter::Shutter;

thread_local! {
    /// The time of the camera sample this thread is computing (frames; 0 outside one).
    static RAY_TIME: Cell<f32> = const { Cell::new(0.0) };
}

/// The time of the camera sample the calling thread is computing (0 outside a [`TimeScope`]).
#[inline]
pub fn ray_time() -> f32 {
    RAY_TIME.with(Cell::get)
}

/// Sets the calling thread's ray time for one camera sample; the previous time comes
/// back when the scope ends (also on unwinding).
pub struct TimeScope {
    previous: f32,
}

impl TimeScope {
    /// Enters time `t` (frames), or leaves the time as it is for `None` (no motion blur).
    #[inline]
    pub fn enter(t: Option<f32>) -> Option<Self> {
        let t = t?;
        Some(TimeScope { previous: RAY_TIME.with(|c| c.replace(t)) })
    }
}

impl Drop for TimeScope {
    fn drop(&mut self) {
        RAY_TIME.with(|c| c.set(self.previous));
    }
}

/// Where time `t` falls among ascending step times: (segment i, fraction f), so that a
/// value at `t` is `v[i] + f (v[i + 1] − v[i])`. Times outside the steps clamp.
#[inline]
pub fn segment(times: &[f32], t: f32) -> (usize, f32) {
    let n = times.len();
    if n < 2 || !(t > times[0]) {
        return (0, 0.0);
    }
    if t >= times[n - 1] {
        return (n.saturating_sub(2), 1.0);
    }
    // Few steps (usually 2-9): a linear scan beats a binary search.
    let mut i = 0;
    while i + 2 < n && t >= times[i + 1] {
        i += 1;
    }
    (i, (t - times[i]) / (times[i + 1] - times[i]))
}

/// The scene's motion: the shutter, the step times and every moving triangle's corners
/// (and vertex normals) at each step.
#[derive(Clone, Debug, Default)]
pub struct SceneMotion {
    /// Step times in frames, ascending, at least two.
    pub times: Vec<f32>,
    /// The shutter when the render blurs motion; None when the steps serve the Vector
    /// pass only (Blender renders such a frame sharp, at time 0).
    pub shutter: Option<Shutter>,
    /// Per scene triangle, its index among the moving triangles (`STATIC`: it does not move).
    pub slot: Vec<u32>,
    /// Scene triangle index of each moving triangle.
    pub triangles: Vec<u32>,
    /// Corners of moving triangle k at step s: `corners[k * steps + s]`.
    pub corners: Vec<[Vec3; 3]>,
    /// Vertex normals, laid out as `corners`.
    pub normals: Vec<[Vec3; 3]>,
    /// Names of the moving objects (for `caustic info` and warnings).
    pub objects: Vec<String>,
}

/// `SceneMotion::slot` of a triangle that does not move.
pub const STATIC: u32 = u32::MAX;

impl SceneMotion {
    /// Number of steps.
    #[inline]
    pub fn steps(&self) -> usize {
        self.times.len()
    }

    /// True when camera samples draw a time (motion blur on and something moves).
    #[inline]
    pub fn blurs(&self) -> bool {
        self.shutter.is_some()
    }

    /// Index among the moving triangles of scene triangle `tri`, if it moves.
    #[inline]
    pub fn moving(&self, tri: u32) -> Option<usize> {
        match self.slot.get(tri as usize) {
            Some(&k) if k != STATIC => Some(k as usize),
            _ => None,
        }
    }

    /// Corners and vertex normals of moving triangle `k` at time `t`.
    #[inline]
    pub fn triangle_at(&self, k: usize, t: f32) -> ([Vec3; 3], [Vec3; 3]) {
        let (i, f) = segment(&self.times, t);
        let base = k * self.steps() + i;
        let lerp3 = |a: &[Vec3; 3], b: &[Vec3; 3]| [0, 1, 2].map(|j| a[j].lerp(b[j], f));
        if f == 0.0 {
            return (self.corners[base], self.normals[base]);
        }
        (lerp3(&self.corners[base], &self.corners[base + 1]), lerp3(&self.normals[base], &self.normals[base + 1]))
    }

    /// The triangles the static BVH holds when the render blurs (those that do not move),
    /// as (corners, scene triangle index); every triangle otherwise.
    pub fn static_triangles(&self, all: &[[Vec3; 3]]) -> (Vec<[Vec3; 3]>, Vec<u32>) {
        let keep = |t: usize| !self.blurs() || self.slot.get(t).is_none_or(|&k| k == STATIC);
        let ids: Vec<u32> = (0..all.len()).filter(|&t| keep(t)).map(|t| t as u32).collect();
        (ids.iter().map(|&t| all[t as usize]).collect(), ids)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_clamp_and_interpolate() {
        let times = [-1.0, 0.0, 1.0];
        assert_eq!(segment(&times, -2.0), (0, 0.0));
        assert_eq!(segment(&times, -0.5), (0, 0.5));
        assert_eq!(segment(&times, 0.0), (1, 0.0));
        assert_eq!(segment(&times, 0.25), (1, 0.25));
        assert_eq!(segment(&times, 1.0), (1, 1.0));
        assert_eq!(segment(&times, 5.0), (1, 1.0));
        assert_eq!(segment(&[0.0, 0.5], 0.25), (0, 0.5));
    }

    #[test]
    fn time_scope_restores() {
        assert_eq!(ray_time(), 0.0);
        {
            let _a = TimeScope::enter(Some(0.25));
            assert_eq!(ray_time(), 0.25);
            {
                let _b = TimeScope::enter(None);
                assert_eq!(ray_time(), 0.25);
            }
        }
        assert_eq!(ray_time(), 0.0);
    }
}
