//! Loads a scene and prints the loader's per-phase profile and the BVH build time as JSON
//! (bench/load.py reads it).
//!
//! `cargo run --release --example load_profile -- SCENE.gltf`

fn main() {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: load_profile SCENE.gltf");
        std::process::exit(2);
    };
    match caustic::scene::gltf::load(std::path::Path::new(&path)) {
        Ok(scene) => {
            let r = &scene.report;
            let tris: Vec<[glam::Vec3; 3]> =
                scene.mesh.triangles.iter().map(|t| t.map(|i| scene.mesh.positions[i as usize])).collect();
            let bvh = caustic::accel::Accel::build(&tris).build_time.as_secs_f64();
            let out = serde_json::json!({
                "file": r.file,
                "triangles": r.triangles,
                "emissive_triangles": scene.lights.iter().filter(|l| matches!(l, caustic::light::Light::Triangle { .. })).count(),
                "textures": scene.textures.iter().map(|t| format!("{}x{}", t.width, t.height)).collect::<Vec<_>>(),
                "profile": r.profile,
                "bvh": bvh,
            });
            println!("{}", serde_json::to_string_pretty(&out).unwrap_or_default());
        }
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(3);
        }
    }
}
