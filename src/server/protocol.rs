//! The render server's wire format (`docs/protocol.md`, version [`VERSION`]): each
//! message is a little-endian u32 header length, a u32 payload length, a UTF-8 JSON
//! object (the header, with a "type") and the payload bytes. This file reads and writes
//! messages and parses request headers; it knows nothing of scenes or rendering.

use serde::Deserialize;
use std::io::{Read, Write};

/// Protocol version: bumped on every change a client must know about.
pub const VERSION: u32 = 3;

/// Longest header accepted: a camera edit is a few hundred bytes; a megabyte is far
/// beyond any legitimate header and small enough to hold without a budget.
pub const MAX_HEADER: u32 = 1 << 20;

/// Longest payload accepted: a glTF binary of a large scene (1 GiB); beyond that, pass a path.
pub const MAX_PAYLOAD: u32 = 1 << 30;

/// One message as read from the stream: its header text and payload.
pub struct RawMessage {
    /// The header's bytes (JSON, not yet parsed).
    pub header: Vec<u8>,
    /// The payload.
    pub payload: Vec<u8>,
}

/// Why the next message could not be read.
#[derive(Debug)]
pub enum ReadError {
    /// The input ended cleanly between messages.
    Eof,
    /// The input ended inside a message (the message is lost; nothing follows).
    Truncated(String),
    /// A length prefix beyond the limits: the stream cannot be resynchronised.
    Framing(String),
}

/// Reads exactly `buf.len()` bytes; Ok(false) when the input ended first.
fn read_full(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<bool> {
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..]) {
            Ok(0) => return Ok(false),
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(true)
}

/// Reads the next message.
pub fn read_message(r: &mut impl Read) -> Result<RawMessage, ReadError> {
    let mut first = [0u8; 1];
    match r.read(&mut first) {
        Ok(0) => return Err(ReadError::Eof),
        Ok(_) => {}
        Err(e) => return Err(ReadError::Truncated(format!("cannot read the input: {e}"))),
    }
    let mut rest = [0u8; 7];
    let io = |e: std::io::Error| ReadError::Truncated(format!("cannot read the input: {e}"));
    if !read_full(r, &mut rest).map_err(io)? {
        return Err(ReadError::Truncated("the input ended inside a length prefix".into()));
    }
    let header_len = u32::from_le_bytes([first[0], rest[0], rest[1], rest[2]]);
    let payload_len = u32::from_le_bytes([rest[3], rest[4], rest[5], rest[6]]);
    if header_len > MAX_HEADER {
        return Err(ReadError::Framing(format!("header length {header_len} exceeds the limit of {MAX_HEADER} bytes")));
    }
    if payload_len > MAX_PAYLOAD {
        return Err(ReadError::Framing(format!(
            "payload length {payload_len} exceeds the limit of {MAX_PAYLOAD} bytes"
        )));
    }
    let mut header = vec![0u8; header_len as usize];
    if !read_full(r, &mut header).map_err(io)? {
        return Err(ReadError::Truncated(format!("the input ended inside a header of {header_len} bytes")));
    }
    let mut payload = vec![0u8; payload_len as usize];
    if !read_full(r, &mut payload).map_err(io)? {
        return Err(ReadError::Truncated(format!("the input ended inside a payload of {payload_len} bytes")));
    }
    Ok(RawMessage { header, payload })
}

/// Writes one message (header JSON and payload) and flushes it.
pub fn write_message(w: &mut impl Write, header: &serde_json::Value, payload: &[u8]) -> std::io::Result<()> {
    let h = serde_json::to_vec(header).expect("a JSON value always serialises");
    w.write_all(&(h.len() as u32).to_le_bytes())?;
    w.write_all(&(payload.len() as u32).to_le_bytes())?;
    w.write_all(&h)?;
    w.write_all(payload)?;
    w.flush()
}

/// Pixel format of frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum FrameFormat {
    /// IEEE half floats (what a display texture wants; half the bytes).
    #[default]
    F16,
    /// IEEE single floats.
    F32,
    /// 8 bits per channel, colour sRGB-encoded and clamped to [0, 1], alpha linear: for a
    /// display that shows the frame as it is, without colour management of its own.
    U8,
}

impl FrameFormat {
    /// Name on the wire.
    pub fn name(self) -> &'static str {
        match self {
            FrameFormat::F16 => "f16",
            FrameFormat::F32 => "f32",
            FrameFormat::U8 => "u8",
        }
    }
}

/// A camera as the client sees it (glTF axes; see `docs/protocol.md`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraEdit {
    /// Camera-to-world matrix, column-major; the camera looks down its local -Z, +Y up.
    pub matrix: [f32; 16],
    /// "perspective" or "orthographic".
    pub projection: String,
    /// Perspective: vertical field of view in radians.
    pub yfov: Option<f32>,
    /// Perspective: width / height of the frame (default: the resolution's).
    pub aspect: Option<f32>,
    /// Orthographic: half width and half height of the view in scene units.
    pub xmag: Option<f32>,
    /// Orthographic half height.
    pub ymag: Option<f32>,
    /// Lens shift as fractions of the frame's width and height.
    #[serde(default)]
    pub shift: [f32; 2],
    /// Frame size in pixels.
    pub resolution: [u32; 2],
    /// Rendered part of the frame: x0, y0, x1, y1 as fractions, from the top-left corner.
    pub border: Option<[f32; 4]>,
    /// Near and far clipping distances.
    pub clip: Option<[f32; 2]>,
}

/// A material's glTF PBR factors to change (absent fields stay).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialEdit {
    /// Material name.
    pub name: String,
    /// Base colour factor, linear RGBA.
    pub base_color: Option<[f32; 4]>,
    /// Metallic factor.
    pub metallic: Option<f32>,
    /// Roughness factor.
    pub roughness: Option<f32>,
    /// Index of refraction.
    pub ior: Option<f32>,
    /// Transmission factor.
    pub transmission: Option<f32>,
}

/// A light's new emission and placement (absent fields stay).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightEdit {
    /// Light name (Blender's object name), as `loaded` lists it.
    pub name: String,
    /// Emission in the light's own unit (W/sr for point and spot, W/m² for a sun,
    /// radiance for area and sphere lights), linear RGB.
    pub emission: Option<[f32; 3]>,
    /// New light-to-world matrix (glTF axes; the light points down its local -Z).
    pub matrix: Option<[f32; 16]>,
}

/// Render settings (each as the `caustic render` flag of the same name).
#[derive(Clone, Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct SettingsEdit {
    /// "path", "bdpt", "photon" or "vcm".
    pub integrator: Option<String>,
    /// Samples per pixel to stop at.
    pub spp: Option<u32>,
    /// Maximum scattering events per path.
    pub max_depth: Option<u32>,
    /// Seed.
    pub seed: Option<u32>,
    /// "tree" or "power".
    pub light_sampler: Option<String>,
    /// Pixel format of frames.
    pub frame_format: Option<FrameFormat>,
    /// Divisor of the first frame's resolution after an edit (1: no reduced frame).
    pub reduce: Option<u32>,
}

/// A request from the client.
#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Request {
    /// Version handshake.
    Hello {
        /// The client's protocol version.
        version: u32,
    },
    /// Load a scene from `path`, or from the payload (`bytes` long; external files
    /// resolved against `base_dir`).
    Load {
        /// A .gltf or .glb file.
        path: Option<String>,
        /// Payload length, when the scene is the payload.
        bytes: Option<u64>,
        /// Folder of the payload's external files.
        base_dir: Option<String>,
    },
    /// Merge a scene of added or changed objects into the loaded one (`server::merge`): from
    /// `path`, or from the payload (`bytes` long; external files resolved against `base_dir`).
    Objects {
        /// A .gltf or .glb file.
        path: Option<String>,
        /// Payload length, when the scene is the payload.
        bytes: Option<u64>,
        /// Folder of the payload's external files.
        base_dir: Option<String>,
    },
    /// Set the view.
    Camera(CameraEdit),
    /// Change a material's factors.
    Material(MaterialEdit),
    /// Replace a node-graph material's graph (`graph_edit`): every material of the name
    /// gets the program compiled from `nodes`, its `CAUSTIC_materials_nodes` value.
    MaterialGraph {
        /// Material name.
        name: String,
        /// The graph, exactly as the exporter writes the extension's value.
        nodes: serde_json::Value,
    },
    /// Move a mesh object.
    Transform {
        /// Object (node) name.
        name: String,
        /// New world matrix, column-major, glTF axes.
        matrix: [f32; 16],
    },
    /// Hide or show a mesh object (Blender's viewport hiding).
    Visibility {
        /// Object (node) name.
        name: String,
        /// False hides it from every ray and its emission from light selection.
        visible: bool,
    },
    /// Change a light.
    Light(LightEdit),
    /// Change the world's colour (the multiplier of a world image).
    World {
        /// Linear RGB radiance.
        color: [f32; 3],
    },
    /// Change render settings.
    Settings(SettingsEdit),
    /// Start (or restart) progressive rendering.
    RenderStart,
    /// Stop rendering (the last frame stays the client's).
    RenderStop,
    /// End the server.
    Quit,
}

/// IEEE binary16 of `x`, rounded to nearest even; beyond the range gives ±infinity,
/// NaN stays NaN. Written out rather than taken from a crate for one function.
pub fn f16_bits(x: f32) -> u16 {
    let b = x.to_bits();
    let sign = ((b >> 16) & 0x8000) as u16;
    let exp = ((b >> 23) & 0xff) as i32;
    let man = b & 0x7f_ffff;
    if exp == 0xff {
        return sign | 0x7c00 | if man != 0 { 0x200 } else { 0 };
    }
    let e = exp - 127 + 15;
    if e >= 0x1f {
        return sign | 0x7c00;
    }
    if e <= 0 {
        // Subnormal half (or zero): shift the implicit-1 mantissa into place, rounding.
        if e < -10 {
            return sign;
        }
        let m = man | 0x80_0000;
        let shift = (14 - e) as u32;
        let half = 1u32 << (shift - 1);
        let rem = m & ((1 << shift) - 1);
        let mut r = m >> shift;
        if rem > half || (rem == half && r & 1 == 1) {
            r += 1;
        }
        return sign | r as u16;
    }
    let mut r = ((e as u32) << 10) | (man >> 13);
    let rem = man & 0x1fff;
    if rem > 0x1000 || (rem == 0x1000 && r & 1 == 1) {
        r += 1; // may carry into the exponent, which is the correct rounding up
    }
    sign | r as u16
}

/// RGBA pixels as the payload of a frame, in `format`, rows in the given order.
pub fn encode_pixels(pixels: &[[f32; 4]], format: FrameFormat) -> Vec<u8> {
    match format {
        FrameFormat::F32 => pixels.iter().flatten().flat_map(|v| v.to_le_bytes()).collect(),
        FrameFormat::F16 => pixels.iter().flatten().flat_map(|v| f16_bits(*v).to_le_bytes()).collect(),
        FrameFormat::U8 => {
            pixels.iter().flat_map(|p| [srgb_byte(p[0]), srgb_byte(p[1]), srgb_byte(p[2]), unit_byte(p[3])]).collect()
        }
    }
}

/// A linear value in [0, 1] (clamped; NaN as 0) to a byte, rounded to nearest.
fn unit_byte(v: f32) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    (v * 255.0 + 0.5) as u8
}

/// A linear value to an sRGB-encoded byte (IEC 61966-2-1's transfer function).
fn srgb_byte(v: f32) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    let e = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
    unit_byte(e)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_are_srgb_encoded_colour_and_linear_alpha() {
        let px = [[0.0, 1.0, 0.5, 0.5], [0.002, 2.0, -1.0, f32::NAN]];
        // sRGB(0.5) = 1.055 · 0.5^(1/2.4) − 0.055 = 0.7354 → 187.5 → 188; 0.002 is on the
        // linear segment: 12.92 · 0.002 · 255 = 6.59 → 7; out-of-range values clamp.
        assert_eq!(encode_pixels(&px, FrameFormat::U8), vec![0, 255, 188, 128, 7, 255, 0, 0]);
    }

    #[test]
    fn half_floats_match_the_standard_at_its_landmarks() {
        assert_eq!(f16_bits(0.0), 0x0000);
        assert_eq!(f16_bits(-0.0), 0x8000);
        assert_eq!(f16_bits(1.0), 0x3c00);
        assert_eq!(f16_bits(-2.0), 0xc000);
        assert_eq!(f16_bits(65504.0), 0x7bff);
        assert_eq!(f16_bits(65520.0), 0x7c00); // rounds up past the largest half
        assert_eq!(f16_bits(f32::INFINITY), 0x7c00);
        assert!(f16_bits(f32::NAN) & 0x7c00 == 0x7c00 && f16_bits(f32::NAN) & 0x3ff != 0);
        assert_eq!(f16_bits(6.103_515_6e-5), 0x0400); // smallest normal
        assert_eq!(f16_bits(5.960_464_5e-8), 0x0001); // smallest subnormal
        assert_eq!(f16_bits(1.0 + 1.0 / 2048.0), 0x3c00); // a tie rounds to even
        assert_eq!(f16_bits(1.0 + 3.0 / 2048.0), 0x3c02);
    }

    #[test]
    fn messages_round_trip_and_bad_lengths_are_framing_errors() {
        let mut buf = Vec::new();
        write_message(&mut buf, &serde_json::json!({"type": "quit"}), b"xy").unwrap();
        let m = read_message(&mut buf.as_slice()).unwrap();
        assert_eq!(m.header, br#"{"type":"quit"}"#);
        assert_eq!(m.payload, b"xy");
        let huge = [0xff, 0xff, 0xff, 0xff, 0, 0, 0, 0];
        assert!(matches!(read_message(&mut huge.as_slice()), Err(ReadError::Framing(_))));
        assert!(matches!(read_message(&mut &buf[..buf.len() - 1]), Err(ReadError::Truncated(_))));
        assert!(matches!(read_message(&mut &[][..]), Err(ReadError::Eof)));
    }
}
