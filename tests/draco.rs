//! `KHR_draco_mesh_compression`: a sphere (positions, normals, UVs, 8-bit vertex colours)
//! written twice, plain and Draco-compressed by `draco-core`'s encoder (positions quantized
//! to 14 bits, normals 10, UVs 12): the compressed file loads to the same triangles within
//! quantization and renders the same image; corrupt or inconsistent Draco data is refused
//! with an error naming the mesh, never a panic.

mod common;

use base64::Engine;
use caustic::memory::MemoryBudget;
use common::*;
use draco_core::{
    DataType, EncoderBuffer, EncoderOptions, FaceIndex, GeometryAttributeType, MeshEncoder, PointAttribute, PointIndex,
};
use serde_json::{Value, json};
use std::path::Path;
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);
const EXT: &str = "KHR_draco_mesh_compression";
const POSITION_BITS: i32 = 14;

/// A UV sphere of radius 1 with a seam (vertices repeated along it) and a colour gradient.
struct Sphere {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
    colors: Vec<[u8; 4]>,
    indices: Vec<u32>,
}

fn sphere(rings: u32, segments: u32) -> Sphere {
    let mut s = Sphere { positions: vec![], normals: vec![], uvs: vec![], colors: vec![], indices: vec![] };
    for r in 0..=rings {
        let v = r as f32 / rings as f32;
        let theta = v * std::f32::consts::PI;
        for k in 0..=segments {
            let u = k as f32 / segments as f32;
            let phi = u * std::f32::consts::TAU;
            let p = [theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()];
            s.positions.push(p);
            s.normals.push(p);
            s.uvs.push([u, v]);
            s.colors.push([(255.0 * u) as u8, (255.0 * v) as u8, 128, 255]);
        }
    }
    let row = segments + 1;
    for r in 0..rings {
        for k in 0..segments {
            let (a, b, c, d) = (r * row + k, r * row + k + 1, (r + 1) * row + k, (r + 1) * row + k + 1);
            // Counter-clockwise seen from outside; the poles' zero-area halves are left out.
            if r != 0 {
                s.indices.extend([a, b, c]);
            }
            if r != rings - 1 {
                s.indices.extend([b, d, c]);
            }
        }
    }
    s
}

/// The sphere as a Draco bitstream and the Draco attribute id of each glTF semantic.
fn encode(s: &Sphere) -> (Vec<u8>, Value) {
    let n = s.positions.len();
    let mut mesh = draco_core::Mesh::new();
    let mut add = |kind, comps: u8, ty, normalized, bytes: Vec<u8>| {
        let mut a = PointAttribute::new();
        a.init(kind, comps, ty, normalized, n);
        a.buffer_mut().write(0, &bytes);
        mesh.add_attribute(a)
    };
    let floats = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let pos = add(GeometryAttributeType::Position, 3, DataType::Float32, false, floats(s.positions.as_flattened()));
    let nrm = add(GeometryAttributeType::Normal, 3, DataType::Float32, false, floats(s.normals.as_flattened()));
    let uv = add(GeometryAttributeType::TexCoord, 2, DataType::Float32, false, floats(s.uvs.as_flattened()));
    let col = add(GeometryAttributeType::Color, 4, DataType::Uint8, true, s.colors.as_flattened().to_vec());
    mesh.set_num_faces(s.indices.len() / 3);
    for (f, t) in s.indices.chunks_exact(3).enumerate() {
        mesh.set_face(FaceIndex(f as u32), [PointIndex(t[0]), PointIndex(t[1]), PointIndex(t[2])]);
    }
    let mut options = EncoderOptions::new();
    options.set_attribute_quantization(pos, POSITION_BITS);
    options.set_attribute_quantization(nrm, 10);
    options.set_attribute_quantization(uv, 12);
    let mut encoder = MeshEncoder::new();
    encoder.set_mesh(mesh);
    let mut out = EncoderBuffer::new();
    encoder.encode(&options, &mut out).expect("draco encode");
    (out.data().to_vec(), json!({ "POSITION": pos, "NORMAL": nrm, "TEXCOORD_0": uv, "COLOR_0": col }))
}

/// The scene around the sphere: a camera at +Z, a sun from the upper left, a white material.
fn document(buffer: &[u8], views: Value, accessors: Value, primitive: Value, draco: bool) -> Value {
    let mut doc = json!({
        "asset": { "version": "2.0" },
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": { "KHR_lights_punctual": { "lights": [{ "type": "directional", "intensity": 2000.0 }] } },
        "scene": 0,
        "scenes": [{ "nodes": [0, 1, 2] }],
        "nodes": [
            { "mesh": 0 },
            { "camera": 0, "translation": [0.0, 0.0, 3.5] },
            { "rotation": look_rotation([0.5, -0.6, -1.0]), "extensions": { "KHR_lights_punctual": { "light": 0 } } },
        ],
        "cameras": [{ "type": "perspective", "perspective": { "yfov": 0.7, "aspectRatio": 1.0, "znear": 0.05 } }],
        "materials": [{ "pbrMetallicRoughness": { "baseColorFactor": [0.9, 0.9, 0.9, 1.0], "roughnessFactor": 0.6 } }],
        "meshes": [{ "name": "ball", "primitives": [primitive] }],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{
            "byteLength": buffer.len(),
            "uri": format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(buffer)),
        }],
    });
    if draco {
        doc["extensionsUsed"].as_array_mut().unwrap().push(json!(EXT));
        doc["extensionsRequired"] = json!([EXT]);
    }
    doc
}

/// The accessors both files declare: POSITION, NORMAL, TEXCOORD_0, COLOR_0, indices.
fn accessors(s: &Sphere, views: Option<[usize; 5]>) -> Value {
    let n = s.positions.len();
    let mut acc = json!([
        { "componentType": 5126, "count": n, "type": "VEC3", "min": [-1.0, -1.0, -1.0], "max": [1.0, 1.0, 1.0] },
        { "componentType": 5126, "count": n, "type": "VEC3" },
        { "componentType": 5126, "count": n, "type": "VEC2" },
        { "componentType": 5121, "normalized": true, "count": n, "type": "VEC4" },
        { "componentType": 5125, "count": s.indices.len(), "type": "SCALAR" },
    ]);
    if let Some(views) = views {
        for (a, v) in acc.as_array_mut().unwrap().iter_mut().zip(views) {
            a["bufferView"] = json!(v);
        }
    }
    acc
}

fn primitive() -> Value {
    json!({ "attributes": { "POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2, "COLOR_0": 3 }, "indices": 4, "material": 0 })
}

/// The plain file's document.
fn plain(s: &Sphere) -> Value {
    let mut buffer = Vec::new();
    let mut views = Vec::new();
    let mut push = |bytes: Vec<u8>| {
        views.push(json!({ "buffer": 0, "byteOffset": buffer.len(), "byteLength": bytes.len() }));
        buffer.extend(bytes);
        buffer.resize(buffer.len().next_multiple_of(4), 0);
    };
    let floats = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    push(floats(s.positions.as_flattened()));
    push(floats(s.normals.as_flattened()));
    push(floats(s.uvs.as_flattened()));
    push(s.colors.as_flattened().to_vec());
    push(s.indices.iter().flat_map(|i| i.to_le_bytes()).collect());
    document(&buffer, json!(views), accessors(s, Some([0, 1, 2, 3, 4])), primitive(), false)
}

/// The compressed file's document: accessors without views, the bitstream in view 0.
fn compressed(s: &Sphere) -> Value {
    let (bits, ids) = encode(s);
    let mut prim = primitive();
    prim["extensions"] = json!({ EXT: { "bufferView": 0, "attributes": ids } });
    let views = json!([{ "buffer": 0, "byteLength": bits.len() }]);
    document(&bits, views, accessors(s, None), prim, true)
}

fn write(dir: &Path, name: &str, doc: &Value) -> std::path::PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_vec(doc).unwrap()).unwrap();
    path
}

/// Loads `doc` in process; the error message on failure.
fn load(doc: &Value) -> Result<caustic::scene::Scene, String> {
    let bytes = serde_json::to_vec(doc).unwrap();
    caustic::scene::gltf::load_bytes(&bytes, Path::new("."), "test.gltf", &MemoryBudget::unlimited())
        .map_err(|e| e.to_string())
}

#[test]
fn compressed_sphere_loads_the_same_triangles_within_quantization() {
    let s = sphere(16, 32);
    let a = load(&plain(&s)).expect("plain sphere");
    let b = load(&compressed(&s)).expect("compressed sphere");
    let (ma, mb) = (&a.mesh, &b.mesh);
    assert_eq!(ma.triangles.len(), s.indices.len() / 3);
    assert_eq!(mb.triangles.len(), ma.triangles.len(), "triangle counts");
    // Quantization: 14 bits over the range 2, half a step of error at most per coordinate.
    let step = 2.0 / ((1 << POSITION_BITS) - 1) as f32;
    let bounds = |m: &caustic::scene::Mesh| {
        m.positions
            .iter()
            .fold((glam::Vec3::INFINITY, glam::Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)))
    };
    let ((alo, ahi), (blo, bhi)) = (bounds(ma), bounds(mb));
    let delta = (alo - blo).abs().max((ahi - bhi).abs()).max_element();
    assert!(delta <= step, "bounding boxes differ by {delta} (> one step {step})");
    // Every decoded vertex is an original one (matched on position and UV: the seam and the
    // poles repeat positions), moved by less than a step, with its normal and exact colour.
    let key = |m: &caustic::scene::Mesh, i: usize| (m.positions[i], m.uv0[i]);
    let mut map = vec![0usize; mb.positions.len()];
    for (j, slot) in map.iter_mut().enumerate() {
        let (p, uv) = key(mb, j);
        let (best, _) = (0..ma.positions.len())
            .map(|i| (i, (key(ma, i).0 - p).length() + (key(ma, i).1 - uv).length()))
            .min_by(|x, y| x.1.total_cmp(&y.1))
            .unwrap();
        let d = (ma.positions[best] - p).abs().max_element();
        assert!(d <= step, "decoded vertex {j} lies {d} from the nearest original vertex");
        assert!((ma.uv0[best] - uv).length() < 1e-3, "vertex {j}: uv {uv} against {}", ma.uv0[best]);
        assert!(ma.normals[best].dot(mb.normals[j]) > 0.9995, "vertex {j}: normal {}", mb.normals[j]);
        assert!((ma.colors[best] - mb.colors[j]).abs().max_element() < 1e-6, "vertex {j}: colour");
        *slot = best;
    }
    // The same triangles, with the same winding (as cyclic triples of original vertices).
    let canonical = |t: [usize; 3]| {
        let r = (0..3).min_by_key(|&k| t[k]).unwrap();
        [t[r], t[(r + 1) % 3], t[(r + 2) % 3]]
    };
    let mut want: Vec<[usize; 3]> = ma.triangles.iter().map(|t| canonical(t.map(|i| i as usize))).collect();
    let mut got: Vec<[usize; 3]> = mb.triangles.iter().map(|t| canonical(t.map(|i| map[i as usize]))).collect();
    want.sort();
    got.sort();
    assert_eq!(got, want, "the decoded triangles are not the original ones");
}

#[test]
fn compressed_sphere_renders_the_same_image() {
    let dir = temp_dir();
    let s = sphere(16, 32);
    let a = write(dir.path(), "plain.gltf", &plain(&s));
    let b = write(dir.path(), "draco.gltf", &compressed(&s));
    let flags = ["--resolution", "48x48", "--spp", "64"];
    let ia = render_image(&a, &dir.path().join("plain.exr"), &flags, LIMIT);
    let ib = render_image(&b, &dir.path().join("draco.exr"), &flags, LIMIT);
    let lum = |p: &[f32; 4]| (p[0] + p[1] + p[2]) as f64 / 3.0;
    let mean = |img: &[[f32; 4]]| img.iter().map(lum).sum::<f64>() / img.len() as f64;
    let (ma, mb) = (mean(&ia), mean(&ib));
    assert!(ma > 0.05, "the sphere is lit (mean {ma})");
    let ratio = mb / ma;
    // The same sample sequences over geometry moved by < 1e-4: the images differ only at
    // the silhouette's few pixels and by the normals' quantization.
    assert!((ratio - 1.0).abs() < 0.005, "image means {mb} / {ma} = {ratio}");
    let diff = ia.iter().zip(&ib).map(|(x, y)| (lum(x) - lum(y)).abs()).sum::<f64>() / ia.len() as f64;
    eprintln!("image means: plain {ma}, Draco {mb}, ratio {ratio}; mean |difference| {diff}");
    assert!(diff / ma < 0.02, "mean absolute pixel difference {diff} against mean {ma}");
}

#[test]
fn inconsistent_draco_primitives_are_refused_naming_the_mesh() {
    let s = sphere(4, 8);
    let good = compressed(&s);
    type Mutation = Box<dyn Fn(&mut Value)>;
    let cases: Vec<(&str, Mutation, &str)> = vec![
        (
            "missing attribute id",
            Box::new(|d| d["meshes"][0]["primitives"][0]["extensions"][EXT]["attributes"]["NORMAL"] = json!(7)),
            "id 7",
        ),
        ("POSITION count", Box::new(|d| d["accessors"][0]["count"] = json!(3)), "POSITION accessor declares only 3"),
        ("indices count", Box::new(|d| d["accessors"][4]["count"] = json!(6)), "declare 45 vertices and 6 indices"),
        ("component count", Box::new(|d| d["accessors"][2]["type"] = json!("VEC3")), "components"),
        ("not a triangle list", Box::new(|d| d["meshes"][0]["primitives"][0]["mode"] = json!(5)), "mode 5"),
        (
            "morph targets",
            Box::new(|d| d["meshes"][0]["primitives"][0]["targets"] = json!([{ "POSITION": 1 }])),
            "morph",
        ),
        ("short view", Box::new(|d| d["bufferViews"][0]["byteLength"] = json!(1 << 20)), "outside"),
    ];
    for (what, mutate, needle) in cases {
        let mut doc = good.clone();
        mutate(&mut doc);
        let e = load(&doc).expect_err(what);
        assert!(e.contains("mesh 0 ('ball')") && e.contains(EXT), "{what}: {e}");
        assert!(e.contains(needle), "{what}: '{e}' does not say '{needle}'");
    }
}

#[test]
fn damaged_bitstreams_are_refused_or_decoded_never_a_panic() {
    let s = sphere(6, 12);
    let (bits, ids) = encode(&s);
    let mut damaged = Vec::new();
    for cut in [0, 4, 5, 11, bits.len() / 3, bits.len() / 2, bits.len() - 1] {
        damaged.push(bits[..cut].to_vec());
    }
    // Single bytes flipped across the stream (header, connectivity, attributes).
    for k in 0..120 {
        let mut b = bits.clone();
        let at = (k * 7919) % b.len();
        b[at] ^= 1 << (k % 8);
        damaged.push(b);
    }
    let mut refused = 0;
    for (k, b) in damaged.iter().enumerate() {
        let mut prim = primitive();
        prim["extensions"] = json!({ EXT: { "bufferView": 0, "attributes": ids.clone() } });
        let views = json!([{ "buffer": 0, "byteLength": b.len() }]);
        let doc = document(b, views, accessors(&s, None), prim, true);
        if let Err(e) = load(&doc) {
            assert!(!e.contains("parser failed") && !e.contains("decoder failure"), "damage {k}: a panic: {e}");
            refused += 1;
        }
    }
    assert!(refused >= 7, "only {refused} damaged streams refused (every truncation should be)");
}
