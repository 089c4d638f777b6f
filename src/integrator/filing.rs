//! Where a path continued on behalf of another integrator (the photon integrators' media
//! and subsurface parts, `PathIntegrator::continue_path_filed`) files its contributions
//! besides the radiance it returns: the light passes by the camera path's tally so far
//! and the light groups by emitter, into the camera sample the caller fills.

use super::light_passes::Tally;
use crate::film::CameraSample;

/// The caller's light-pass and light-group bookkeeping handed to a continued path.
pub struct Filing<'a> {
    /// The camera path's light-pass tally at the point of continuation (None: no passes).
    pub tally: Option<Tally>,
    /// File contributions by their emitter's light group.
    pub groups: bool,
    /// The camera sample whose passes and groups receive them.
    pub out: &'a mut CameraSample,
}

impl Filing<'_> {
    /// True when there is something to file.
    #[inline]
    pub fn any(&self) -> bool {
        self.tally.is_some() || self.groups
    }
}
