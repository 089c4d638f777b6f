//! Blender's shutter: when it opens and closes around the frame (Position Start, Center
//! or End, Shutter in frames), and the rolling shutter, as Cycles maps a camera sample's
//! random number to its time (`kernel/camera/camera.h`, flat shutter curve).

/// The shutter of a render with motion blur.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shutter {
    /// Opening time in frames relative to the frame (Center: −length/2).
    pub open: f32,
    /// Closing time in frames.
    pub close: f32,
    /// Rolling shutter (Blender's type Top-Bottom): the scanline's share of the exposure
    /// (Blender's Rolling Shutter Duration, 0..1); None without a rolling shutter.
    pub rolling: Option<f32>,
}

impl Shutter {
    /// The time (frames) of a camera sample with random number `u` in [0, 1) on the pixel
    /// row `row` of a frame `height` rows tall (row 0 at the top).
    ///
    /// Cycles draws t = u over the open shutter; a rolling shutter scans from the top
    /// (t = row / height there) and its duration d blends the two:
    /// t = (u − ½) d + (row/height − ½)(1 − d) + ½.
    #[inline]
    pub fn time(&self, u: f32, row: u32, height: u32) -> f32 {
        let t = match self.rolling {
            None => u,
            Some(d) => {
                let scan = row as f32 / height as f32;
                (u - 0.5) * d + (scan - 0.5) * (1.0 - d) + 0.5
            }
        };
        self.open + t * (self.close - self.open)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn global_shutter_spans_open_to_close() {
        let s = Shutter { open: -0.25, close: 0.25, rolling: None };
        assert_eq!(s.time(0.0, 7, 10), -0.25);
        assert_eq!(s.time(0.5, 7, 10), 0.0);
        assert_eq!(s.time(1.0, 0, 10), 0.25);
    }

    #[test]
    fn rolling_shutter_scans_from_the_top() {
        // Duration 0: the time is the scanline's alone, top at the opening.
        let s = Shutter { open: 0.0, close: 1.0, rolling: Some(0.0) };
        assert_eq!(s.time(0.9, 0, 10), 0.0);
        assert_eq!(s.time(0.1, 5, 10), 0.5);
        // Duration 0.1 (Blender's default): a tenth of the shutter per row, centred on its scan time.
        let s = Shutter { open: 0.0, close: 1.0, rolling: Some(0.1) };
        let (lo, hi) = (s.time(0.0, 5, 10), s.time(1.0, 5, 10));
        assert!((lo - 0.45).abs() < 1e-6 && (hi - 0.55).abs() < 1e-6, "{lo} {hi}");
    }
}
