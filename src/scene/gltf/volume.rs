//! Volume objects (`CAUSTIC_volume`, a root extension): each names a grid file beside the
//! glTF (`medium::grid_file`), the grids its shader reads, its placement and its
//! Principled Volume parameters. The loader reads the file, builds the grid medium and
//! bounds it with a box of twelve triangles whose material has no surface and holds the
//! grid, so that paths enter and leave it as any volume (the medium stack's rule).

use super::Loader;
use crate::error::Result;
use crate::medium::grid::{Field, VolumeShader};
use crate::medium::grid_file::GridFile;
use crate::medium::procedural_source::ProceduralSource;
use crate::medium::volume_grids::{
    MAX_GRID_SLOTS, VolumeGrids, graph_grid_medium, majorant_scratch_bytes, reads_only_grids,
};
use crate::medium::{GridMedium, HomogeneousMedium};
use crate::scene::mesh::AttributeKey;
use crate::scene::{Material, Mesh};
use glam::{Affine3A, Mat4, Vec2, Vec3, Vec4};
use serde::Deserialize;

/// The extension's name.
pub(super) const EXTENSION: &str = "CAUSTIC_volume";

/// `extensions.CAUSTIC_volume` at the root.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct VolumesExt {
    volumes: Vec<VolumeExt>,
}

/// One volume object.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct VolumeExt {
    /// Blender's object name.
    name: String,
    /// The grid file, relative to the glTF.
    uri: String,
    /// glTF world ← the file's object space, column-major 4×4.
    matrix: [f32; 16],
    /// Grid names the shader reads (null: the shader reads none of that kind).
    density_grid: Option<String>,
    #[serde(default)]
    temperature_grid: Option<String>,
    #[serde(default)]
    color_grid: Option<String>,
    /// The Principled Volume's parameters (unused where `graph` is given).
    shader: ShaderExt,
    /// The material's Volume output as a node graph (`CAUSTIC_materials_medium.graph`'s
    /// format), whose Attribute nodes read the file's grids by name.
    #[serde(default)]
    graph: Option<crate::shader::graph::NodesExt>,
    /// The graph's shader-tree root node.
    #[serde(default)]
    graph_shader: Option<usize>,
}

/// The Principled Volume's inputs (docs/contract.md).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ShaderExt {
    density: f32,
    color: [f32; 3],
    absorption_color: [f32; 3],
    anisotropy: f32,
    emission: [f32; 3],
    blackbody_intensity: f32,
    blackbody_tint: [f32; 3],
    temperature: f32,
    /// Blender's Volume Scatter Phase by its enum name (docs/contract.md), and the inputs the
    /// non-Henyey-Greenstein ones read.
    #[serde(default = "super::extensions::hg_phase")]
    phase: String,
    #[serde(default = "super::extensions::phase_alpha")]
    phase_alpha: f32,
    #[serde(default = "super::extensions::phase_ior")]
    phase_ior: f32,
    #[serde(default = "super::extensions::phase_backscatter")]
    phase_backscatter: f32,
    #[serde(default = "super::extensions::phase_diameter")]
    phase_diameter: f32,
}

/// The box's faces as corner indices (bit 0: x, bit 1: y, bit 2: z); each triangle is
/// turned outward after the transform.
const FACES: [[u32; 4]; 6] = [[0, 2, 6, 4], [1, 5, 7, 3], [0, 4, 5, 1], [2, 3, 7, 6], [0, 1, 3, 2], [4, 6, 7, 5]];

impl Loader<'_> {
    /// Reads the root `CAUSTIC_volume`: the grid media, each with a boundary box appended
    /// to `mesh` and a volume-only material appended to `materials`.
    pub(super) fn volumes(
        &mut self,
        value: &serde_json::Value,
        mesh: &mut Mesh,
        materials: &mut Vec<Material>,
    ) -> Result<Vec<GridMedium>> {
        let Some(ext) = value.pointer(&format!("/extensions/{EXTENSION}")) else {
            return Ok(Vec::new());
        };
        let ext: VolumesExt =
            serde_json::from_value(ext.clone()).map_err(|e| self.err(format!("{EXTENSION} is malformed: {e}")))?;
        let mut grids = Vec::new();
        for v in ext.volumes {
            let what = format!("{EXTENSION} volume '{}'", v.name);
            let grid = self.grid_medium(&what, &v)?;
            let index = grids.len() as u32;
            materials.push(Material {
                name: format!("{} (volume)", v.name),
                null_surface: true,
                // Coefficients live in the grid; this marks the box as bounding a medium.
                medium: Some(HomogeneousMedium::absorbing(Vec3::ZERO)),
                grid: Some(index),
                ..Material::default()
            });
            append_box(mesh, &grid.world_corners(), materials.len() as u32 - 1);
            grids.push(grid);
        }
        Ok(grids)
    }

    /// One volume's grid medium: the file read and checked, the named grids found, the
    /// shader's values checked.
    fn grid_medium(&mut self, what: &str, v: &VolumeExt) -> Result<GridMedium> {
        let s = &v.shader;
        let colours = [s.color, s.absorption_color, s.emission, s.blackbody_tint];
        let scalars = [s.density, s.anisotropy, s.blackbody_intensity, s.temperature];
        if colours.iter().flatten().chain(&scalars).chain(&v.matrix).any(|x| !x.is_finite()) {
            return Err(self.err(format!("{what}: every number must be finite")));
        }
        if !(-1.0..=1.0).contains(&s.anisotropy) {
            return Err(self.err(format!("{what}: anisotropy {} is outside [-1, 1]", s.anisotropy)));
        }
        let bytes = self.resolve_uri(&v.uri, what)?;
        let mut file = GridFile::parse(&bytes, &v.uri, self.file, self.budget).map_err(|e| name_volume(e, what))?;
        drop(bytes);
        let take = |name: &Option<String>, kind: &str| -> Result<Option<Field>> {
            let Some(name) = name else { return Ok(None) };
            let g = file
                .grid(name)
                .ok_or_else(|| self.err(format!("{what}: the {kind} grid '{name}' is not in '{}'", v.uri)))?;
            Ok(Some(Field { values: g.values.clone(), components: g.components }))
        };
        let fields = [
            take(&v.density_grid, "density")?,
            take(&v.temperature_grid, "temperature")?,
            take(&v.color_grid, "colour")?,
        ];
        let m = file.index_to_object;
        let index_to_object = Affine3A::from_mat4(Mat4::from_cols_array(&[
            m[0], m[4], m[8], 0.0, m[1], m[5], m[9], 0.0, m[2], m[6], m[10], 0.0, m[3], m[7], m[11], 1.0,
        ]));
        let world = Affine3A::from_mat4(Mat4::from_cols_array(&v.matrix)) * index_to_object;
        let det = world.matrix3.determinant();
        if !(det.abs() > 1e-30) || !det.is_finite() {
            return Err(self.err(format!("{what}: the grid's transform is singular (determinant {det})")));
        }
        if let Some(graph) = &v.graph {
            return self.graph_volume(what, v, graph, &mut file, world);
        }
        let shader = VolumeShader {
            density: s.density,
            color: Vec3::from(s.color),
            absorption_color: Vec3::from(s.absorption_color),
            anisotropy: s.anisotropy,
            emission: Vec3::from(s.emission),
            blackbody_intensity: s.blackbody_intensity,
            blackbody_tint: Vec3::from(s.blackbody_tint),
            temperature: s.temperature,
        };
        let phase = self.phase(
            what,
            &s.phase,
            [s.anisotropy, s.phase_alpha, s.phase_ior, s.phase_backscatter, s.phase_diameter],
        )?;
        let mut medium = GridMedium::new(v.name.clone(), file.dims, world, fields, shader);
        medium.phase = phase;
        medium.space = self.space;
        Ok(medium)
    }
}

impl Loader<'_> {
    /// A volume object whose material is a node graph: the graph compiled, each attribute
    /// it reads by name given the file's grid of that name (none: Cycles' not-found 0).
    fn graph_volume(
        &mut self,
        what: &str,
        v: &VolumeExt,
        graph: &crate::shader::graph::NodesExt,
        file: &mut GridFile,
        world: Affine3A,
    ) -> Result<GridMedium> {
        let Some(root) = v.graph_shader else {
            return Err(self.err(format!("{what}: a graph needs graph_shader")));
        };
        let mut volume = self.volume_program(&v.name, graph, root, what)?;
        for w in std::mem::take(&mut volume.warnings) {
            self.warn(format!("{what}: {w}"));
        }
        if volume.program.attributes.len() > MAX_GRID_SLOTS {
            return Err(self.err(format!(
                "{what}: its graph reads {} attributes; at most {MAX_GRID_SLOTS} are supported",
                volume.program.attributes.len()
            )));
        }
        let mut slots = Vec::with_capacity(volume.program.attributes.len());
        for (key, _) in &volume.program.attributes {
            let AttributeKey::Named(name) = key else {
                slots.push(None);
                continue;
            };
            // Moved out of the file, not copied: the budget charged these voxels once.
            let grid = file.grids.iter_mut().find(|g| g.name == *name);
            if grid.is_none() {
                self.warn(format!(
                    "{what}: its graph reads the grid '{name}', which is not in '{}' (the object has no such \
                     grid, or it has no active voxels); it reads 0, as in Cycles",
                    v.uri
                ));
            }
            slots.push(grid.map(|g| Field { values: std::mem::take(&mut g.values), components: g.components }));
        }
        let grid_only = reads_only_grids(graph);
        if grid_only {
            self.budget.check_peak(format!("{what}: majorant scratch"), majorant_scratch_bytes(file.dims))?;
        }
        let grids = VolumeGrids { dims: file.dims, index_from_world: world.inverse(), slots };
        let source = ProceduralSource { volume, object: crate::shader::geom::NO_OBJECT, grids: Some(grids) };
        graph_grid_medium(v.name.clone(), file.dims, world, source, grid_only)
            .map_err(|m| self.err(format!("{what}: {m}")))
    }
}

/// A grid file's scene error with the volume object named in front (the file's own names only its uri).
fn name_volume(e: crate::error::Error, what: &str) -> crate::error::Error {
    match e {
        crate::error::Error::Scene { file, message } => {
            crate::error::Error::Scene { file, message: format!("{what}: {message}") }
        }
        other => other,
    }
}

/// Appends the box with world-space `corners` (indexed as [`FACES`]) to `mesh`, every
/// triangle wound counter-clockwise seen from outside, with material `material`.
fn append_box(mesh: &mut Mesh, corners: &[Vec3; 8], material: u32) {
    let base = mesh.positions.len() as u32;
    let centre = corners.iter().copied().sum::<Vec3>() / 8.0;
    for &c in corners {
        mesh.positions.push(c);
        mesh.normals.push((c - centre).normalize_or(Vec3::Y));
        mesh.tangents.push(Vec4::ZERO);
        mesh.uv0.push(Vec2::ZERO);
        mesh.uv1.push(Vec2::ZERO);
        mesh.colors.push(Vec4::ONE);
    }
    for f in FACES {
        for tri in [[f[0], f[1], f[2]], [f[0], f[2], f[3]]] {
            let p = tri.map(|i| corners[i as usize]);
            let outward = (p[1] - p[0]).cross(p[2] - p[0]).dot((p[0] + p[1] + p[2]) / 3.0 - centre) > 0.0;
            let t = if outward { tri } else { [tri[0], tri[2], tri[1]] };
            mesh.triangles.push(t.map(|i| base + i));
            mesh.tri_material.push(material);
        }
    }
}
