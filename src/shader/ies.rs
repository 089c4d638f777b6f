//! Blender's IES Texture node as Cycles evaluates it: an IESNA LM-63 photometric file read into
//! a grid of intensities over horizontal and vertical angles (`util/ies.cpp`: type B and C
//! files mirrored to the full sphere, candela converted to W/sr by 4π/177.83), looked up by
//! Catmull-Rom interpolation in both angles (`kernel/util/ies.h`). A malformed file is an
//! error with its reason, never a panic; evaluation allocates nothing.

/// Cycles' candela-to-watt factor: 4π / 177.83 (D65's luminous efficacy, lm/W).
const CANDELA_TO_WATT: f64 = 0.0706650768394;
/// The most angles a file may declare on one axis (real files hold a few hundred).
const MAX_ANGLES: usize = 100_000;
/// The most intensities a file may declare.
const MAX_VALUES: usize = 4_000_000;

/// A parsed profile: angles in radians, horizontal over [0, 2π], vertical starting at 0 or π/2.
#[derive(Clone, Debug, PartialEq)]
pub struct IesProfile {
    /// Horizontal angles, increasing, the last 2π.
    h: Vec<f32>,
    /// Vertical angles, increasing.
    v: Vec<f32>,
    /// Intensities (W/sr scaled), `h.len()` rows of `v.len()`.
    values: Vec<f32>,
}

/// The file's numbers after its TILT line, read one by one.
struct Tokens<'a> {
    words: std::str::SplitAsciiWhitespace<'a>,
}

impl Tokens<'_> {
    fn number(&mut self, what: &str) -> Result<f64, String> {
        let w = self.words.next().ok_or_else(|| format!("the file ends before its {what}"))?;
        let x: f64 = w.parse().map_err(|_| format!("its {what} '{w}' is not a number"))?;
        if x.is_finite() { Ok(x) } else { Err(format!("its {what} is not finite")) }
    }

    fn count(&mut self, what: &str) -> Result<usize, String> {
        let x = self.number(what)?;
        if x.fract() != 0.0 || !(1.0..=MAX_ANGLES as f64).contains(&x) {
            return Err(format!("its {what} {x} is not a count in 1..={MAX_ANGLES}"));
        }
        Ok(x as usize)
    }
}

impl IesProfile {
    /// Parses an LM-63 file's text (commas count as spaces, as Cycles reads them).
    pub fn parse(text: &str) -> Result<IesProfile, String> {
        let text = text.replace(',', " ");
        let tilt = text.find("\nTILT=").ok_or("it has no TILT= line")?;
        let after = &text[tilt + 1..];
        let rest = if let Some(inc) = after.strip_prefix("TILT=INCLUDE") {
            let mut t = Tokens { words: inc.split_ascii_whitespace() };
            t.number("lamp-to-luminaire geometry")?;
            let n = t.count("number of tilt angles")?;
            for _ in 0..2 * n {
                t.number("tilt angles and factors")?;
            }
            // The numbers after the tilt block's.
            t.words
        } else {
            let line_end = after.find('\n').ok_or("the file ends after its TILT line")?;
            after[line_end + 1..].split_ascii_whitespace()
        };
        let mut t = Tokens { words: rest };
        t.number("number of lamps")?;
        t.number("lumens per lamp")?;
        let mut factor = t.number("candela multiplier")?;
        let v_num = t.count("number of vertical angles")?;
        let h_num = t.count("number of horizontal angles")?;
        if v_num * h_num > MAX_VALUES {
            return Err(format!("it declares {v_num}×{h_num} intensities, more than {MAX_VALUES}"));
        }
        let kind = t.number("photometric type")?;
        let type_b = match kind as i64 {
            1 if kind == 1.0 => false,
            2 if kind == 2.0 => true,
            _ => return Err(format!("its photometric type {kind} is not B (2) or C (1), which Cycles reads")),
        };
        t.number("units")?;
        t.number("width")?;
        t.number("length")?;
        t.number("height")?;
        factor *= t.number("ballast factor")?;
        factor *= t.number("ballast-lamp photometric factor")?;
        t.number("input watts")?;
        factor *= CANDELA_TO_WATT;
        let v: Vec<f32> =
            (0..v_num).map(|_| t.number("vertical angles").map(|x| x as f32)).collect::<Result<_, _>>()?;
        let h: Vec<f32> =
            (0..h_num).map(|_| t.number("horizontal angles").map(|x| x as f32)).collect::<Result<_, _>>()?;
        let mut rows = Vec::with_capacity(h_num);
        for _ in 0..h_num {
            let row: Vec<f32> = (0..v_num)
                .map(|_| t.number("candela values").map(|x| (x * factor) as f32))
                .collect::<Result<_, _>>()?;
            rows.push(row);
        }
        let (h, v, rows) = if type_b { Self::type_b(h, v, rows)? } else { Self::type_c(h, v, rows)? };
        for (axis, a) in [("horizontal", &h), ("vertical", &v)] {
            if a.len() < 2 || a.windows(2).any(|w| !(w[0] < w[1])) {
                return Err(format!("its {axis} angles are not at least two increasing values"));
            }
        }
        let to_rad = |a: Vec<f32>| a.into_iter().map(|x| x * (std::f32::consts::PI / 180.0)).collect();
        Ok(IesProfile { h: to_rad(h), v: to_rad(v), values: rows.concat() })
    }

    /// Type C (Cycles' `process_type_c`): horizontal angles from 0 (or 90, rotated), one
    /// quadrant or a half mirrored to the full turn, a missing 360° row added when the
    /// spacing says it; vertical angles from 0, or from 90 to 180.
    #[allow(clippy::type_complexity)]
    fn type_c(
        mut h: Vec<f32>,
        v: Vec<f32>,
        mut rows: Vec<Vec<f32>>,
    ) -> Result<(Vec<f32>, Vec<f32>, Vec<Vec<f32>>), String> {
        if h[0] == 90.0 {
            h.iter_mut().for_each(|a| *a -= 90.0);
        }
        if h[0] != 0.0 {
            return Err(format!("its first horizontal angle {} is not 0 or 90 (type C)", h[0]));
        }
        if h.len() == 1 {
            h.push(360.0);
            rows.push(rows[0].clone());
        }
        let mirror = |h: &mut Vec<f32>, rows: &mut Vec<Vec<f32>>, about: f32| {
            for i in (0..h.len() - 1).rev() {
                h.push(about - h[i]);
                rows.push(rows[i].clone());
            }
        };
        if *h.last().unwrap() == 90.0 {
            mirror(&mut h, &mut rows, 180.0);
        }
        if *h.last().unwrap() == 180.0 {
            mirror(&mut h, &mut rows, 360.0);
        }
        let n = h.len();
        if h[n - 1] != 360.0 {
            let (last_step, first_step, gap) = (h[n - 1] - h[n - 2], h[1] - h[0], 360.0 - h[n - 1]);
            if last_step == gap || first_step == gap {
                h.push(360.0);
                rows.push(rows[0].clone());
            } else {
                return Err(format!("its horizontal angles end at {} (not 360 nor one step before it)", h[n - 1]));
            }
        }
        let (first, last) = (v[0], v[v.len() - 1]);
        if !(first == 0.0 || (first == 90.0 && last == 180.0)) {
            return Err(format!("its vertical angles run from {first} to {last} (type C: from 0, or 90 to 180)"));
        }
        Ok((h, v, rows))
    }

    /// Type B (Cycles' `process_type_b`): the grid transposed, each axis from 0 or −90 to 90
    /// mirrored or shifted to Cycles' ranges, a 360° row added.
    #[allow(clippy::type_complexity)]
    fn type_b(
        h_in: Vec<f32>,
        v_in: Vec<f32>,
        rows_in: Vec<Vec<f32>>,
    ) -> Result<(Vec<f32>, Vec<f32>, Vec<Vec<f32>>), String> {
        // Transposed: the file's vertical angles become the horizontal ones.
        let mut rows: Vec<Vec<f32>> = (0..v_in.len()).map(|i| rows_in.iter().map(|r| r[i]).collect()).collect();
        let (mut h, mut v) = (v_in, h_in);
        let axis_ok = |a: &[f32], name: &str| {
            let last = a[a.len() - 1];
            if last != 90.0 || !(a[0] == 0.0 || a[0] == -90.0) {
                Err(format!("its {name} angles run from {} to {last} (type B: from 0 or -90 to 90)", a[0]))
            } else {
                Ok(())
            }
        };
        axis_ok(&h, "vertical (type B's first axis)")?;
        if h[0] == 0.0 {
            let n = h.len();
            let mut nh = Vec::with_capacity(2 * n - 1);
            let mut nr = Vec::with_capacity(2 * n - 1);
            for i in (1..n).rev() {
                nh.push(90.0 - h[i]);
                nr.push(rows[i].clone());
            }
            for i in 0..n {
                nh.push(90.0 + h[i]);
                nr.push(rows[i].clone());
            }
            h = nh;
            rows = nr;
        } else {
            h.iter_mut().for_each(|a| *a += 90.0);
        }
        h.push(360.0);
        rows.push(rows[0].clone());
        axis_ok(&v, "horizontal (type B's second axis)")?;
        if v[0] == 0.0 {
            let n = v.len();
            let mut nv = Vec::with_capacity(2 * n - 1);
            for i in (1..n).rev() {
                nv.push(90.0 - v[i]);
            }
            for a in &v {
                nv.push(90.0 + a);
            }
            for r in rows.iter_mut() {
                let mut nr: Vec<f32> = r[1..].iter().rev().copied().collect();
                nr.extend_from_slice(r);
                *r = nr;
            }
            v = nv;
        } else {
            v.iter_mut().for_each(|a| *a += 90.0);
        }
        Ok((h, v, rows))
    }

    /// The value at horizontal angle `h` and vertical angle `v` (radians), as Blender 5.0's
    /// Cycles renders it: 0 outside the grid, Catmull-Rom in the vertical angle and then the
    /// horizontal one, negative results clamped to 0. Where a spline's outer point falls off
    /// the grid, Cycles' source (`kernel_ies_interp`) wraps or takes 0; Blender 5.0's Cycles
    /// measures otherwise (an emissive plane reading the node at fixed vectors, values in
    /// `cycles_lookups_at_the_grids_ends`): the 0° end of the vertical angle wraps; past the
    /// other ends the spline repeats its nearer point (the 360° row is not wrapped to 0°:
    /// `2π − 1e-7` rounds to 2π in f32), except past the last vertical angle, where it
    /// repeats the farther one.
    pub fn eval(&self, h: f32, v: f32) -> f32 {
        let (hs, vs) = (&self.h, &self.v);
        let (h_num, v_num) = (hs.len(), vs.len());
        if !(v >= vs[0] && v < vs[v_num - 1] && h >= hs[0] && h < hs[h_num - 1]) {
            return 0.0;
        }
        let wrap_vlow = vs[0] < 1e-7;
        // The cell holding the angle: the last index whose next angle is not below it.
        let hi = hs[1..].iter().position(|&a| a >= h).unwrap_or(h_num - 2);
        let vi = vs[1..].iter().position(|&a| a >= v).unwrap_or(v_num - 2);
        let hf = (h - hs[hi]) / (hs[hi + 1] - hs[hi]);
        let vf = (v - vs[vi]) / (vs[vi + 1] - vs[vi]);
        let column = |row: usize| -> f32 {
            let at = |j: usize| self.values[row * v_num + j];
            let a = if vi > 0 {
                at(vi - 1)
            } else if wrap_vlow {
                at(1)
            } else {
                at(vi)
            };
            let d = if vi + 2 < v_num { at(vi + 2) } else { at(vi + 1) };
            catmull_rom(a, at(vi), at(vi + 1), d, vf)
        };
        let (b, c) = (column(hi), column(hi + 1));
        let a = if hi > 0 { column(hi - 1) } else { b };
        let d = if hi + 2 < h_num { column(hi + 2) } else { b };
        catmull_rom(a, b, c, d, hf).max(0.0)
    }

    /// The value toward unit direction `dir` in the light's frame (Blender axes): vertical
    /// angle from −Z (straight down), horizontal angle atan2(x, y) + π, as Cycles' node.
    pub fn eval_direction(&self, dir: glam::Vec3) -> f32 {
        let d = dir.normalize_or_zero();
        let v = (-d.z).clamp(-1.0, 1.0).acos();
        let h = d.x.atan2(d.y) + std::f32::consts::PI;
        self.eval(h, v)
    }
}

/// Cycles' `cubic_interp`: the Catmull-Rom spline through b (x = 0) and c (x = 1).
#[inline]
fn catmull_rom(a: f32, b: f32, c: f32, d: f32, x: f32) -> f32 {
    0.5 * (((d + 3.0 * (b - c) - a) * x + (2.0 * a - 5.0 * b + 4.0 * c - d)) * x + (c - a)) * x + b
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A type C file with one horizontal angle (rotationally symmetric): 0°..90° every 30°.
    const ROUND: &str = "IESNA:LM-63-2002\n[TEST] small\nTILT=NONE\n1 1000 1 4 1 1 2 0 0 0\n1 1 100\n\
        0 30 60 90\n0\n1000 800 400 0\n";

    #[test]
    fn values_on_the_grid_are_the_files_times_cyclesfactor() {
        let p = IesProfile::parse(ROUND).unwrap();
        let k = CANDELA_TO_WATT as f32;
        // On grid points Catmull-Rom returns the point's value (x = 0).
        for (deg, cd) in [(0.0f32, 1000.0f32), (30.0, 800.0), (60.0, 400.0)] {
            let got = p.eval(0.0, deg.to_radians());
            assert!((got - cd * k).abs() <= 1e-4 * cd * k, "{deg}°: {got} vs {}", cd * k);
        }
        // Straight down from the light: vertical angle 0, horizontal angle atan2(0, 0) + π = π,
        // halfway between the 0° and 360° rows, which are the same row: with the ends
        // repeated, Catmull-Rom of (1000, 1000, 1000, 1000) is 1000 cd (with zeros past the
        // ends, as Cycles' source reads, 1125: an overshoot Blender 5.0's Cycles does not render).
        let down = p.eval_direction(glam::Vec3::new(0.0, 0.0, -1.0));
        assert!((down - 1000.0 * k).abs() < 1e-3, "{down} vs {}", 1000.0 * k);
        // Beyond the last vertical angle (90°): 0, as in Cycles.
        assert_eq!(p.eval_direction(glam::Vec3::new(0.0, 0.3, 1.0)), 0.0);
    }

    /// Blender 5.0.1's Cycles read at fixed vectors (an emissive plane whose Strength is the
    /// node's Fac, the pixel over the node at a grid point for scale), in candela: five
    /// distinct rows (0°, 90°, 180°, 270°, 360°: 1000, 500, 200, 300, 700, flat in the
    /// vertical angle) at 45° and 315°; one row over 0-45-90° (1000, 800, 600) and one over
    /// 90-135-180° (600, 800, 1000) between their angles. The values Cycles' source gives
    /// instead (wrapping 0°/360°, or 0 past an end) are 812.5, 518.75, 725, 725 and 925.
    #[test]
    fn cycles_lookups_at_the_grids_ends() {
        let k = CANDELA_TO_WATT as f32;
        let file = |v: &str, h: &str, rows: &str, nv: usize, nh: usize| {
            IesProfile::parse(&format!(
                "IESNA:LM-63-2002\n[TEST] t\nTILT=NONE\n1 1000 1 {nv} {nh} 1 2 0 0 0\n1 1 100\n{v}\n{h}\n{rows}\n"
            ))
            .unwrap()
        };
        let rows =
            file("0 45 90", "0 90 180 270 360", "1000 1000 1000 500 500 500 200 200 200 300 300 300 700 700 700", 3, 5);
        let low = file("0 45 90", "0", "1000 800 600", 3, 1);
        let high = file("90 135 180", "0", "600 800 1000", 3, 1);
        let rad = |d: f32| d.to_radians();
        for (p, h, v, cd) in [
            (&rows, 45.0, 45.0, 768.75),
            (&rows, 315.0, 45.0, 531.25),
            (&low, 90.0, 67.5, 687.5),
            (&low, 90.0, 22.5, 925.0),
            (&high, 90.0, 112.5, 687.5),
            (&high, 90.0, 157.5, 912.5),
        ] {
            let got = p.eval(rad(h), rad(v)) / k;
            assert!((got - cd).abs() < 0.02, "h {h} v {v}: {got} cd, Cycles {cd}");
        }
    }

    /// Halfway between 30° and 60°: Catmull-Rom of (1000, 800, 400, 0) at x = ½, by hand:
    /// 0.5 × ((((0 + 3(800 − 400) − 1000) ½ + (2000 − 4000 + 1600 − 0)) ½ + (400 − 1000)) ½) + 800
    /// = 0.5 × (((200 × ½ − 400) × ½ − 600) × ½) + 800 = 0.5 × (−750 × ½) + 800 = 612.5 cd.
    #[test]
    fn between_grid_points_it_is_catmull_rom() {
        let p = IesProfile::parse(ROUND).unwrap();
        let got = p.eval(0.0, 45f32.to_radians());
        let want = 612.5 * CANDELA_TO_WATT as f32;
        assert!((got - want).abs() <= 1e-4 * want, "{got} vs {want}");
    }

    /// Every malformed file is refused with a reason, never a panic.
    #[test]
    fn malformed_files_are_refused() {
        for (text, reason) in [
            ("no tilt here", "TILT"),
            ("x\nTILT=NONE\n1 1000 1 4 1 1 2 0 0 0\n1 1 100\n0 30 60 90\n0\n1000 800", "ends"),
            ("x\nTILT=NONE\n1 1000 1 4 1 3 2 0 0 0\n1 1 100\n0 30 60 90\n0\n1 1 1 1", "type"),
            ("x\nTILT=NONE\n1 1000 1 4 1 1 2 0 0 0\n1 1 100\n0 60 30 90\n0\n1 1 1 1", "increasing"),
            ("x\nTILT=NONE\n1 1000 1 -4 1 1 2 0 0 0\n", "count"),
            ("x\nTILT=NONE\n1 1000 1 4 1 1 2 0 0 0\n1 1 100\n0 30 60 abc\n0\n1 1 1 1", "number"),
            ("x\nTILT=NONE\n1 1000 1 4 1 1 2 0 0 0\n1 1 100\n10 30 60 90\n0\n1 1 1 1", "vertical"),
            ("x\nTILT=NONE\n1 1000 1 99999 99999 1 2 0 0 0\n", "intensities"),
            ("x\nTILT=INCLUDE\n1 2 0 1", "ends"),
        ] {
            let err = IesProfile::parse(text).expect_err(text);
            assert!(err.contains(reason), "{text:?}: {err}");
        }
    }

    /// A type C quadrant (0°, 90° horizontally) is mirrored to the full turn, and commas
    /// separate numbers as spaces do.
    #[test]
    fn a_quadrant_is_mirrored() {
        let text = "x\nTILT=NONE\n1,1000,1,2,2,1,2,0,0,0\n1 1 100\n0 90\n0 90\n10 0\n20 0\n";
        let p = IesProfile::parse(text).unwrap();
        assert_eq!(p.h.len(), 5);
        let k = CANDELA_TO_WATT as f32;
        // 90° and 270° hold the 90° row, 0° and 180° the 0° row.
        assert!((p.eval(90f32.to_radians(), 0.0) - 20.0 * k).abs() < 1e-5);
        assert!((p.eval(270f32.to_radians(), 0.0) - 20.0 * k).abs() < 1e-5);
        assert!((p.eval(180f32.to_radians(), 0.0) - 10.0 * k).abs() < 1e-5);
    }
}
