//! The cell offsets of Voronoi's neighbourhoods of radius 1 in 2-D to 4-D, x fastest: the
//! numbers `Coord::offset` computes from the cell's index with divisions, made once (the
//! divisions cost 4 % of a Voronoi-heavy render's instructions).

use glam::{Vec2, Vec3, Vec4};

/// The 9 cell offsets of the 2-D neighbourhood of radius 1 (see `OFFSETS_3D`).
pub(super) const OFFSETS_2D: [Vec2; 9] = {
    let mut t = [Vec2::ZERO; 9];
    let mut i = 0;
    while i < 9 {
        t[i] = Vec2::new((i % 3) as f32 - 1.0, (i / 3) as f32 - 1.0);
        i += 1;
    }
    t
};

/// The 27 cell offsets of the 3-D neighbourhood of radius 1, x fastest: the same numbers
/// `Coord::offset` computes, made once (the divisions cost 4 % of a Voronoi-heavy render).
pub(super) const OFFSETS_3D: [Vec3; 27] = {
    let mut t = [Vec3::ZERO; 27];
    let mut i = 0;
    while i < 27 {
        t[i] = Vec3::new((i % 3) as f32 - 1.0, (i / 3 % 3) as f32 - 1.0, (i / 9) as f32 - 1.0);
        i += 1;
    }
    t
};

/// The 81 cell offsets of the 4-D neighbourhood of radius 1 (see `OFFSETS_3D`).
pub(super) const OFFSETS_4D: [Vec4; 81] = {
    let mut t = [Vec4::ZERO; 81];
    let mut i = 0;
    while i < 81 {
        t[i] =
            Vec4::new((i % 3) as f32 - 1.0, (i / 3 % 3) as f32 - 1.0, (i / 9 % 3) as f32 - 1.0, (i / 27) as f32 - 1.0);
        i += 1;
    }
    t
};
