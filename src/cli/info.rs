//! `caustic info`: what Caustic loads from a scene, as text or JSON.

use super::args::*;
use crate::error::Result;
use crate::memory::MemoryBudget;
use crate::scene;
use serde_json::json;

/// `caustic info`.
pub fn run_info(args: &InfoArgs) -> Result<()> {
    let budget = MemoryBudget::from_flag(args.memory_limit.as_deref())?;
    let scene = scene::gltf::load_within(&args.scene, &budget)?;
    let r = &scene.report;
    if args.json {
        let v = json!({
            "file": r.file,
            "load_profile": r.profile,
            "triangles": r.triangles,
            "meshes": r.meshes,
            "instances": r.instances,
            "degenerate_triangles": r.degenerate_triangles,
            "strands": r.strands,
            "curve_segments": r.curve_segments,
            "curve_bytes": r.curve_bytes,
            "points": r.points,
            "point_bytes": r.point_bytes,
            "emissive_triangles": scene.lights.iter().filter(|l| matches!(l, crate::light::Light::Triangle { .. })).count(),
            "punctual_lights": scene.lights.iter().filter(|l| !matches!(l, crate::light::Light::Triangle { .. } | crate::light::Light::Area(_))).count(),
            "area_lights": scene.lights.iter().filter(|l| matches!(l, crate::light::Light::Area(_))).count(),
            "materials": r.materials,
            "lights": r.lights,
            "cameras": r.cameras,
            "bounds": r.bounds,
            "extensions_used": r.extensions_used,
            "settings": scene.settings,
            "warnings": scene.warnings,
        });
        outln!("{}", serde_json::to_string_pretty(&v).unwrap_or_default());
        return Ok(());
    }
    outln!("{}", r.file);
    outln!(
        "  triangles: {} ({} meshes, {} instances, {} degenerate dropped)",
        r.triangles,
        r.meshes,
        r.instances,
        r.degenerate_triangles
    );
    if r.strands > 0 {
        outln!(
            "  strands: {} ({} segments, {:.1} MiB with their BVH)",
            r.strands,
            r.curve_segments,
            r.curve_bytes as f64 / (1u64 << 20) as f64
        );
    }
    if r.points > 0 {
        outln!("  points: {} ({:.1} MiB with their BVH)", r.points, r.point_bytes as f64 / (1u64 << 20) as f64);
    }
    outln!("  bounds: {:?} .. {:?}", r.bounds[0], r.bounds[1]);
    if !r.extensions_used.is_empty() {
        outln!("  extensions used: {}", r.extensions_used.join(", "));
    }
    outln!("  materials:");
    for m in &r.materials {
        outln!("    {}: {}", m.name, if m.features.is_empty() { "factors only".into() } else { m.features.join(", ") });
    }
    outln!("  lights:");
    for l in &r.lights {
        let tri = if l.kind == "emissive" { format!(" ({} triangles)", l.triangles) } else { String::new() };
        outln!("    {} '{}': {:.4} W{}", l.kind, l.name, l.power, tri);
    }
    outln!("  cameras:");
    for c in &r.cameras {
        let mut extra = String::new();
        if let Some([x, y]) = c.shift {
            extra += &format!(", shift {x} x {y} frames");
        }
        if let Some(d) = &c.depth_of_field {
            extra += &format!(", depth of field: {d}");
        }
        outln!("    {} ({}{extra})", c.name, c.kind);
    }
    if !scene.warnings.is_empty() {
        outln!("  warnings:");
        for w in &scene.warnings {
            outln!("    {w}");
        }
    }
    Ok(())
}
