//! The scene's working colour space (Blender 5.0's Color Management > Working Space): the
//! linear space Cycles renders in. Colours the .blend holds are already in it; what Caustic
//! decodes or computes as RGB itself (colour images, Blackbody, Wavelength, the Sky Texture)
//! comes out in linear Rec.709 and is taken into it by one 3×3 matrix, the add-on's
//! (`extras.caustic.working_space`, Blender's own OCIO transform). Luminance (Cycles'
//! `rgb_to_y`, read by colour → float conversions) is weighed in it.

use glam::{Mat3, Vec3};

/// Linear Rec.709 luminance weights (Caustic's `math::luminance`).
pub const REC709_LUMINANCE: Vec3 = Vec3::new(0.2126, 0.7152, 0.0722);

/// CIE XYZ (D65) to linear Rec.709 (columns), as [`WorkingSpace::xyz_to_rgb_clamped`] writes it out.
pub const XYZ_TO_REC709: Mat3 = Mat3::from_cols(
    Vec3::new(3.240_454_2, -0.969_266, 0.055_643_4),
    Vec3::new(-1.537_138_5, 1.876_010_8, -0.204_025_9),
    Vec3::new(-0.498_531_4, 0.041_556, 1.057_225_2),
);

/// The working space as the renderer uses it: Rec.709 → working matrix and luminance row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorkingSpace {
    /// Linear Rec.709 → working space; `None` for Rec.709 itself (nothing is converted).
    from_rec709: Option<Mat3>,
    /// The luminance weights of working-space RGB.
    luminance: Vec3,
    /// CIE XYZ (D65) → working space.
    xyz_to_rgb: Mat3,
}

impl Default for WorkingSpace {
    fn default() -> Self {
        WorkingSpace { from_rec709: None, luminance: REC709_LUMINANCE, xyz_to_rgb: XYZ_TO_REC709 }
    }
}

/// The contract's form (`extras.caustic.working_space`).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorkingSpaceSettings {
    /// Blender's name for it ("ACEScg", "Linear Rec.2020"), for messages.
    pub name: String,
    /// Linear Rec.709 → working space, rows.
    pub from_rec709: [[f32; 3]; 3],
}

impl WorkingSpace {
    /// The space of the contract's matrix; refused unless finite and invertible. The identity
    /// is Rec.709 (bit for bit the render without the key).
    pub fn new(s: &WorkingSpaceSettings) -> Result<WorkingSpace, String> {
        let m = Mat3::from_cols_array_2d(&s.from_rec709).transpose();
        let what = format!("working_space '{}': from_rec709", s.name);
        if !m.is_finite() {
            return Err(format!("{what} has non-finite entries"));
        }
        // Rec.709 and the spaces Blender offers have determinants near 1; a matrix far from
        // invertible cannot be a change of primaries.
        if m.determinant().abs() < 1e-3 {
            return Err(format!("{what} is not invertible (determinant {})", m.determinant()));
        }
        if m == Mat3::IDENTITY {
            return Ok(WorkingSpace::default());
        }
        // Y of a working-space colour: Rec.709's Y row of the same colour in Rec.709.
        let luminance = m.inverse().transpose() * REC709_LUMINANCE;
        Ok(WorkingSpace { from_rec709: Some(m), luminance, xyz_to_rgb: m * XYZ_TO_REC709 })
    }

    /// The space the settings name (Rec.709 without the key).
    pub fn of(settings: Option<&WorkingSpaceSettings>) -> Result<WorkingSpace, String> {
        settings.map_or(Ok(WorkingSpace::default()), WorkingSpace::new)
    }

    /// A linear Rec.709 colour in the working space.
    #[inline]
    pub fn from_rec709(&self, c: Vec3) -> Vec3 {
        match self.from_rec709 {
            Some(m) => m * c,
            None => c,
        }
    }

    /// The Rec.709 → working matrix, `None` for Rec.709 itself.
    #[inline]
    pub fn matrix(&self) -> Option<Mat3> {
        self.from_rec709
    }

    /// Luminance of a working-space colour (Cycles' `linear_rgb_to_gray`).
    #[inline]
    pub fn luminance(&self, c: Vec3) -> f32 {
        if self.from_rec709.is_none() { crate::math::luminance(c) } else { self.luminance.dot(c) }
    }

    /// CIE XYZ (D65) to the working space, negative parts clamped (Cycles'
    /// `xyz_to_rgb_clamped`: clamped in the working space, not in Rec.709).
    #[inline]
    pub fn xyz_to_rgb_clamped(&self, xyz: Vec3) -> Vec3 {
        if self.from_rec709.is_some() {
            return (self.xyz_to_rgb * xyz).max(Vec3::ZERO);
        }
        let r = 3.240_454_2 * xyz.x - 1.537_138_5 * xyz.y - 0.498_531_4 * xyz.z;
        let g = -0.969_266 * xyz.x + 1.876_010_8 * xyz.y + 0.041_556 * xyz.z;
        let b = 0.055_643_4 * xyz.x - 0.204_025_9 * xyz.y + 1.057_225_2 * xyz.z;
        Vec3::new(r, g, b).max(Vec3::ZERO)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Blender 5.0's linear Rec.709 → ACEScg (`mathutils.Color.from_rec709_linear_to_scene_linear`
    /// under ACEScg), rows.
    const ACESCG: [[f32; 3]; 3] = [
        [0.613_097_4, 0.339_522_6, 0.047_378_9],
        [0.070_193_65, 0.916_353_9, 0.013_451_946],
        [0.020_615_596, 0.109_569_97, 0.869_814_46],
    ];

    fn acescg() -> WorkingSpace {
        WorkingSpace::new(&WorkingSpaceSettings { name: "ACEScg".into(), from_rec709: ACESCG }).unwrap()
    }

    #[test]
    fn converts_by_rows_and_keeps_white() {
        let s = acescg();
        let red = s.from_rec709(Vec3::X);
        assert_eq!(red, Vec3::new(ACESCG[0][0], ACESCG[1][0], ACESCG[2][0]));
        // Both spaces are D65-ish white balanced: white stays white to the matrix's rounding.
        assert!((s.from_rec709(Vec3::ONE) - Vec3::ONE).abs().max_element() < 1e-3);
    }

    #[test]
    fn luminance_is_invariant_and_matches_blender() {
        let s = acescg();
        for c in [Vec3::X, Vec3::Y, Vec3::Z, Vec3::new(0.3, 0.5, 0.9)] {
            let y709 = crate::math::luminance(c);
            assert!((s.luminance(s.from_rec709(c)) - y709).abs() < 1e-5, "{c}");
        }
        // Blender's ACEScg Y row (`from_scene_linear_to_xyz_d65` of the primaries): the
        // 4th decimal is Rec.709 weights' rounding (0.2126 vs 0.2126729).
        let blender = Vec3::new(0.267_672_24, 0.674_340_1, 0.057_988_33);
        assert!((s.luminance - blender).abs().max_element() < 2e-4, "{}", s.luminance);
    }

    #[test]
    fn rec709_is_untouched_and_bad_matrices_refused() {
        let id =
            WorkingSpaceSettings { name: "x".into(), from_rec709: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] };
        assert_eq!(WorkingSpace::new(&id).unwrap(), WorkingSpace::default());
        let c = Vec3::new(0.1, 0.2, 0.3);
        assert_eq!(WorkingSpace::default().from_rec709(c), c);
        assert_eq!(WorkingSpace::default().xyz_to_rgb, XYZ_TO_REC709);
        let flat = WorkingSpaceSettings { name: "x".into(), from_rec709: [[1.0, 0.0, 0.0]; 3] };
        assert!(WorkingSpace::new(&flat).unwrap_err().contains("not invertible"));
        let nan = WorkingSpaceSettings { name: "x".into(), from_rec709: [[f32::NAN; 3]; 3] };
        assert!(WorkingSpace::new(&nan).unwrap_err().contains("non-finite"));
    }
}
