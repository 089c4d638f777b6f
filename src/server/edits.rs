//! Edits applied to a loaded scene in place: the view, a material's factors, an
//! object's transform, a light, the world. Each says what it invalidates, so that the
//! server rebuilds only that (`Invalidates`): a camera or material edit keeps the BVH,
//! a transform moves the object's triangles into a small BVH beside the scene's
//! (`Accel::relocate`), so that dragging one object in a large scene costs the object's
//! build, not the scene's.

use super::protocol::{CameraEdit, LightEdit, MaterialEdit};
use crate::light::{AreaLight, Environment, Light};
use crate::math::Rgb;
use crate::scene::{Camera, Projection, Scene};
use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};

/// What an edit makes stale, beyond the frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Invalidates {
    /// Nothing the render keeps between frames (the view; the integrator's photon maps
    /// do not depend on it).
    View,
    /// The integrator's scene-dependent state (photon maps, BDPT's light tables).
    Shading,
    /// Triangles moved: the BVH places them anew (`Accel::relocate`).
    Geometry,
}

/// The view: a camera prepared for a frame and the window of it to render.
#[derive(Clone, Debug)]
pub struct View {
    /// The camera.
    pub camera: Camera,
    /// Full frame size.
    pub resolution: (u32, u32),
    /// Rendered window (x0, y0, x1, y1) in pixels.
    pub window: [u32; 4],
}

/// Largest frame side the viewport accepts (as `caustic render`'s range).
const MAX_SIDE: u32 = 65_536;

fn finite(v: &[f32]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// The view a camera edit describes, or why it is invalid.
pub fn view_from_edit(e: &CameraEdit) -> Result<View, String> {
    let [w, h] = e.resolution;
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
        return Err(format!("resolution {w}x{h} is out of range (each side 1..={MAX_SIDE})"));
    }
    if !finite(&e.matrix) || !finite(&e.shift) {
        return Err("the camera matrix and shift must be finite".into());
    }
    let m = Mat4::from_cols_array(&e.matrix);
    if m.determinant().abs() < 1e-12 {
        return Err("the camera matrix is singular".into());
    }
    let projection = match e.projection.as_str() {
        "perspective" => {
            let yfov = e.yfov.ok_or("a perspective camera needs yfov")?;
            if !(yfov > 0.0 && yfov < std::f32::consts::PI) {
                return Err(format!("yfov {yfov} must be in (0, π) radians"));
            }
            if let Some(a) = e.aspect
                && !(a > 0.0 && a.is_finite())
            {
                return Err(format!("aspect {a} must be positive"));
            }
            Projection::Perspective { yfov, aspect: e.aspect }
        }
        "orthographic" => {
            let (x, y) = (e.xmag.ok_or("an orthographic camera needs xmag")?, e.ymag.ok_or("and ymag")?);
            if !(x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite()) {
                return Err(format!("xmag {x} and ymag {y} must be positive"));
            }
            Projection::Orthographic { xmag: x, ymag: y }
        }
        other => return Err(format!("unknown projection '{other}' (perspective or orthographic)")),
    };
    let mut camera = Camera::from_matrix("viewport".into(), &m, projection);
    camera.shift = Vec2::from(e.shift);
    if let Some([near, far]) = e.clip {
        if !(near >= 0.0 && far > near) {
            return Err(format!("clip {near}..{far} must satisfy 0 <= near < far"));
        }
        camera.clip = (near, far);
    }
    let window = match e.border {
        None => [0, 0, w, h],
        Some(b) => {
            if !(finite(&b) && 0.0 <= b[0] && b[0] < b[2] && b[2] <= 1.0 && 0.0 <= b[1] && b[1] < b[3] && b[3] <= 1.0) {
                return Err(format!("border {b:?} must be fractions x0 < x1, y0 < y1 in [0, 1]"));
            }
            let px = |f: f32, n: u32, up: bool| {
                let v = f * n as f32;
                (if up { v.ceil() } else { v.floor() } as u32).min(n)
            };
            let (x0, y0) = (px(b[0], w, false), px(b[1], h, false));
            [x0, y0, px(b[2], w, true).max(x0 + 1).min(w), px(b[3], h, true).max(y0 + 1).min(h)]
        }
    };
    Ok(View { camera, resolution: (w, h), window })
}

/// Applies a material edit. Node-graph materials are not edited here: their colours
/// live in the graph, which the `material_graph` request replaces (`graph_edit`).
pub fn material(scene: &mut Scene, e: &MaterialEdit) -> Result<Invalidates, String> {
    // Every material of the name: objects merged in later (`merge`) bring their own copies.
    let mut named: Vec<&mut crate::scene::Material> = scene.materials.iter_mut().filter(|m| m.name == e.name).collect();
    if named.is_empty() {
        return Err(format!("no material named '{}'", e.name));
    }
    if named.iter().any(|m| m.nodes.is_some()) {
        return Err(format!(
            "material '{}' is a shader node graph: its factors live in the graph (material_graph); send load",
            e.name
        ));
    }
    let unit = |name: &str, v: Option<f32>| match v {
        Some(x) if !(0.0..=1.0).contains(&x) => Err(format!("{name} {x} must be in [0, 1]")),
        _ => Ok(()),
    };
    unit("metallic", e.metallic)?;
    unit("roughness", e.roughness)?;
    unit("transmission", e.transmission)?;
    if let Some(c) = e.base_color
        && !c.iter().all(|x| (0.0..=1.0).contains(x))
    {
        return Err(format!("base_color {c:?} must be in [0, 1]"));
    }
    // Cycles keeps an IOR below 1 (down to 1e-5), as the loaders do.
    if let Some(ior) = e.ior
        && !(ior >= 0.0 && ior.is_finite())
    {
        return Err(format!("ior {ior} must be a finite number of at least 0"));
    }
    for m in &mut named {
        if let Some(c) = e.base_color {
            m.base_color = Vec4::from(c);
        }
        if let Some(v) = e.metallic {
            m.metallic = v;
        }
        if let Some(v) = e.roughness {
            m.roughness = v;
        }
        if let Some(v) = e.ior {
            m.ior = v.max(crate::bsdf::pbr::MIN_IOR);
        }
        if let Some(v) = e.transmission {
            m.transmission = v;
        }
    }
    // Photon maps were traced with the old reflectances.
    Ok(Invalidates::Shading)
}

/// Moves the mesh instance `name` to world matrix `matrix`: its vertices, normals and
/// tangents are carried by new · old⁻¹, and its shader-graph instance data with them.
pub fn transform(scene: &mut Scene, name: &str, matrix: &[f32; 16]) -> Result<Invalidates, String> {
    if !finite(matrix) {
        return Err("the matrix must be finite".into());
    }
    let new = Mat4::from_cols_array(matrix);
    // The newest instance of the name: an `objects` request retires the older ones.
    let Some(span) = scene.instances.iter_mut().rfind(|s| s.name == name) else {
        return Err(format!("no mesh object named '{name}'"));
    };
    let (d_old, d_new) = (span.world.determinant(), new.determinant());
    if d_new.abs() < 1e-12 {
        return Err(format!("the matrix of '{name}' is singular"));
    }
    if d_old.signum() != d_new.signum() {
        // The loader reverses the winding of mirrored instances; a flip needs it redone.
        return Err(format!("the transform mirrors '{name}' relative to the loaded one; send load"));
    }
    let delta = new * span.world.inverse();
    let linear = Mat3::from_mat4(delta);
    let normal_m = linear.inverse().transpose();
    let mesh = &mut scene.mesh;
    for v in span.vertices.start as usize..span.vertices.end as usize {
        mesh.positions[v] = delta.transform_point3(mesh.positions[v]);
        if let Some(u) = mesh.undisplaced.get_mut(v) {
            *u = delta.transform_point3(*u);
        }
        mesh.normals[v] = (normal_m * mesh.normals[v]).normalize_or(mesh.normals[v]);
        if let Some(t) = mesh.tangents.get_mut(v)
            && t.truncate() != Vec3::ZERO
        {
            *t = (linear * t.truncate()).normalize_or_zero().extend(t.w);
        }
    }
    if let Some(o) = span.object
        && let Some(obj) = scene.objects.get_mut(o as usize)
    {
        obj.world_to_object *= delta.inverse();
        obj.location = delta.transform_point3(obj.location);
    }
    span.world = new;
    recompute_bounds(scene);
    Ok(Invalidates::Geometry)
}

/// Hides or shows mesh instance `index`: the server takes its triangles out of the BVH
/// (`Accel::relocate`); here its emissive triangles leave light selection — each becomes a
/// black point light of power 0 in its slot (so that no light index moves, and a scene whose
/// every light is hidden picks only black ones), its triangle and power kept in `saved` — or
/// come back as they were.
pub fn visibility(
    scene: &mut Scene,
    index: usize,
    visible: bool,
    saved: &mut std::collections::HashMap<usize, (u32, f32)>,
) -> Result<Invalidates, String> {
    let span = scene.instances.get(index).ok_or("no such object")?.triangles.clone();
    for (i, (l, p)) in scene.lights.iter_mut().zip(scene.light_power.iter_mut()).enumerate() {
        match *l {
            Light::Triangle { tri } if !visible && span.contains(&tri) => {
                saved.insert(i, (tri, *p));
                let t = scene.mesh.triangles[tri as usize].map(|v| scene.mesh.positions[v as usize]);
                *l = Light::Point { position: (t[0] + t[1] + t[2]) / 3.0, intensity: Rgb::ZERO };
                *p = 0.0;
            }
            Light::Point { .. } if visible => {
                if let Some(&(tri, power)) = saved.get(&i)
                    && span.contains(&tri)
                {
                    saved.remove(&i);
                    *l = Light::Triangle { tri };
                    *p = power;
                }
            }
            _ => {}
        }
    }
    Ok(Invalidates::Geometry)
}

/// The scene's bounds after vertices moved or were added (directional and world lights'
/// powers and photon radii read them), as the loader derives them (`scene::bounds`).
pub(super) fn recompute_bounds(scene: &mut Scene) {
    let s = &*scene;
    let bounds = crate::scene::bounds::of_scene(&s.mesh, &s.curves, &s.points, &s.cameras, &s.lights);
    scene.bounds = bounds;
    refresh_powers(scene);
}

/// Light-selection powers, as the loader computes them (`punctual_power`: by size, a negative
/// light's too), for the lights an edit can change.
fn refresh_powers(scene: &mut Scene) {
    use std::f32::consts::PI;
    let (_, r) = scene.bounding_sphere();
    for (l, p) in scene.lights.iter().zip(scene.light_power.iter_mut()) {
        *p = match l {
            Light::World => scene.world.as_ref().map_or(0.0, |w| PI * w.mean_luminance() * PI * r * r),
            // Emissive triangles keep their loaded power: a rigid move keeps it; a scaled
            // one only makes their selection probability less ideal, never biased.
            Light::Triangle { .. } => *p,
            _ => crate::scene::gltf::punctual_power(l, r),
        };
    }
}

/// Applies a light edit to the light named `e.name` (punctual and area lights; the loader
/// lists them first, in the order of `report.lights`).
pub fn light(scene: &mut Scene, e: &LightEdit) -> Result<Invalidates, String> {
    let idx = scene
        .report
        .lights
        .iter()
        .position(|r| r.name == e.name && r.kind != "emissive" && r.kind != "world")
        .filter(|&i| i < scene.lights.len())
        .ok_or_else(|| format!("no light named '{}'", e.name))?;
    // A negative emission subtracts light, as Cycles renders a light of negative power (the
    // client scales the loaded emission by the ratio of its powers, which may change sign).
    if let Some(c) = e.emission
        && !c.iter().all(|x| x.is_finite())
    {
        return Err(format!("emission {c:?} must be finite"));
    }
    let m = match e.matrix {
        Some(a) if !finite(&a) => return Err("the matrix must be finite".into()),
        Some(a) => Some(Mat4::from_cols_array(&a)),
        None => None,
    };
    let emission = e.emission.map(Rgb::from);
    let pos = m.map(|m| m.transform_point3(Vec3::ZERO));
    let dir = m.map(|m| m.transform_vector3(-Vec3::Z).normalize_or(-Vec3::Z));
    match &mut scene.lights[idx] {
        Light::Point { position, intensity } => {
            *position = pos.unwrap_or(*position);
            *intensity = emission.unwrap_or(*intensity);
        }
        Light::Spot { position, direction, intensity, .. } => {
            *position = pos.unwrap_or(*position);
            *direction = dir.unwrap_or(*direction);
            *intensity = emission.unwrap_or(*intensity);
        }
        Light::Directional { direction, irradiance, .. } => {
            *direction = dir.unwrap_or(*direction);
            *irradiance = emission.unwrap_or(*irradiance);
        }
        Light::Sphere { center, radiance, spot, .. } => {
            *center = pos.unwrap_or(*center);
            *radiance = emission.unwrap_or(*radiance);
            // A spot with a radius turns with its object.
            if let Some(cone) = spot {
                cone.direction = dir.unwrap_or(cone.direction);
            }
        }
        Light::Area(a) => {
            if let Some(m) = m {
                // The loaded half-axes keep their lengths; only the frame turns and moves.
                let (sx, sy) = (a.ax.length(), a.ay.length());
                let ax = m.transform_vector3(Vec3::X).normalize_or(Vec3::X) * sx;
                let ay = m.transform_vector3(Vec3::Y).normalize_or(Vec3::Y) * sy;
                let power = a.radiance * (PI_F * a.area);
                let emit = m.transform_vector3(-Vec3::Z);
                let moved = AreaLight::new(a.shape, m.transform_point3(Vec3::ZERO), ax, ay, emit, power)
                    .ok_or_else(|| format!("light '{}' would have no area", e.name))?;
                *a = AreaLight {
                    camera_visible: a.camera_visible,
                    tan_half_spread: a.tan_half_spread,
                    normalize_spread: a.normalize_spread,
                    ..moved
                };
            }
            if let Some(c) = emission {
                a.radiance = c;
            }
        }
        Light::Triangle { .. } | Light::World => return Err(format!("'{}' is not an editable light", e.name)),
    }
    refresh_powers(scene);
    Ok(Invalidates::Shading)
}

const PI_F: f32 = std::f32::consts::PI;

/// A light's emission in the unit of the `light` edit's `emission` (W/sr for point and spot
/// lights, W/m² for a sun, W/(m² sr) for area and sphere lights), so that a client can scale
/// it by the ratio of its own powers without converting units; None for other lights.
pub fn emission(light: &Light) -> Option<[f32; 3]> {
    let c = match light {
        Light::Point { intensity, .. } | Light::Spot { intensity, .. } => *intensity,
        Light::Directional { irradiance, .. } => *irradiance,
        Light::Sphere { radiance, .. } => *radiance,
        Light::Area(a) => a.radiance,
        Light::Triangle { .. } | Light::World => return None,
    };
    Some([c.x, c.y, c.z])
}

/// Sets the world's colour (a constant world, or an image world's multiplier); a scene
/// loaded without a world gets a constant one.
pub fn world(scene: &mut Scene, color: [f32; 3]) -> Result<Invalidates, String> {
    if !color.iter().all(|x| *x >= 0.0 && x.is_finite()) {
        return Err(format!("world color {color:?} must be finite and non-negative"));
    }
    let c = Rgb::from(color);
    match &mut scene.world {
        Some(w) if w.graph.is_some() => {
            return Err("the world is a shader graph: its colour cannot be edited, send load instead".into());
        }
        Some(w) => w.color = c,
        None => {
            scene.world = Some(Environment { color: c, image: None, rotation: 0.0, graph: None, portals: Vec::new() })
        }
    }
    // Lights at infinity sit beside the tree; the order among lights is free, so a world
    // that becomes a light is added last, and one that turns black keeps its slot with power
    // 0 (refresh_powers): no light index moves (`light` finds lights by index, and hidden
    // objects' emitters keep theirs: `visibility`).
    if c != Rgb::ZERO && !scene.lights.iter().any(|l| matches!(l, Light::World)) {
        scene.lights.push(Light::World);
        scene.light_power.push(0.0);
        scene.light_casts_shadow.push(true);
        if !scene.light_lights_catcher.is_empty() {
            scene.light_lights_catcher.push(true);
        }
        if !scene.light_rays.is_empty() {
            scene.light_rays.push(crate::scene::visibility::RayMask::ALL);
        }
        if !scene.light_max_bounces.is_empty() {
            scene.light_max_bounces.push(crate::scene::light_bounces::NO_LIMIT);
        }
    }
    refresh_powers(scene);
    Ok(Invalidates::Shading)
}
