//! Fixtures of the `hbt` tests: an isotropic test tree, every `hbt` parameter in one struct
//! ([`HbtParams`]), small bake parameters, renders, and the one-tree scene of the switch tests.

use glam::Vec3;
use sylvan_render::bake::CachePolicy;
use sylvan_render::technique::hbt::{self, HbtBakeParams, HbtDrawParams};
use sylvan_render::technique::params::settings_of;
use sylvan_scene::{Camera, TreeInstance};

/// The test tree with every leaf card turned to a random orientation about its centre, so the
/// crown looks alike from every side (the plain test tree's cards face only ±Y and ±Z).
pub fn isotropic_tree() -> sylvan_plant::Plant {
    let mut plant = super::test_tree();
    let mut state = 99u32;
    let mut rnd = move || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (state >> 8) as f32 / (1u32 << 24) as f32
    };
    let leaves = &mut plant.leaves;
    for quad in 0..leaves.positions.len() / 4 {
        let q = glam::Quat::from_euler(
            glam::EulerRot::YXZ,
            rnd() * std::f32::consts::TAU,
            rnd() * std::f32::consts::TAU,
            rnd() * std::f32::consts::TAU,
        );
        let vs = quad * 4..quad * 4 + 4;
        let centre = vs
            .clone()
            .map(|i| Vec3::from(leaves.positions[i]))
            .sum::<Vec3>()
            / 4.0;
        for i in vs {
            let p = Vec3::from(leaves.positions[i]) - centre;
            leaves.positions[i] = (centre + q * p).to_array();
            leaves.normals[i] = (q * Vec3::from(leaves.normals[i])).to_array();
        }
    }
    plant
}

/// Every `hbt` parameter in one struct, for terse tests: `bake()` and `draw()` split it into
/// the technique's two parameter types (`levels` ≥ 2 bakes the level below, as a user would
/// expect), `settings()` hands it to a renderer.
#[derive(Debug, Clone, PartialEq)]
pub struct HbtParams {
    pub levels: u32,
    pub view_level: u32,
    pub light_level: u32,
    pub branch_view_level: u32,
    pub branch_light_level: u32,
    pub max_branch_objects: u32,
    pub cube_resolution: u32,
    pub tile: u32,
    pub supersample: u32,
    pub shadow_resolution: u32,
    pub tree_from_branches: bool,
    pub small_branches: bool,
    pub open_texel_pixels: f32,
    pub mesh_texel_pixels: f32,
    pub mesh_per_branch: bool,
    pub measured_switch: bool,
    pub band: f32,
    pub shadows: hbt::HbtShadows,
    pub scene_visibility: bool,
    pub min_weight: f32,
    pub projection: hbt::HbtProjection,
    pub fixed_light: Option<[f32; 3]>,
    pub lod_bias: f32,
    pub shadow_margin: f32,
}

impl Default for HbtParams {
    fn default() -> Self {
        let (b, d) = (HbtBakeParams::default(), HbtDrawParams::default());
        Self {
            levels: d.levels,
            view_level: b.view_level,
            light_level: b.light_level,
            branch_view_level: b.branch_view_level,
            branch_light_level: b.branch_light_level,
            max_branch_objects: b.max_branch_objects,
            cube_resolution: b.cube_resolution,
            tile: b.tile,
            supersample: b.supersample,
            shadow_resolution: b.shadow_resolution,
            tree_from_branches: b.tree_from_branches,
            small_branches: b.small_branches,
            open_texel_pixels: d.open_texel_pixels,
            mesh_texel_pixels: d.mesh_texel_pixels,
            mesh_per_branch: d.mesh_per_branch,
            measured_switch: d.measured_switch,
            band: d.band,
            shadows: d.shadows,
            scene_visibility: d.scene_visibility,
            min_weight: d.min_weight,
            projection: d.projection,
            fixed_light: d.fixed_light,
            lod_bias: d.lod_bias,
            shadow_margin: d.shadow_margin,
        }
    }
}

impl HbtParams {
    pub fn bake(&self) -> HbtBakeParams {
        HbtBakeParams {
            view_level: self.view_level,
            light_level: self.light_level,
            tile: self.tile,
            supersample: self.supersample,
            shadow_resolution: self.shadow_resolution,
            branches: self.levels >= 2,
            branch_view_level: self.branch_view_level,
            branch_light_level: self.branch_light_level,
            max_branch_objects: self.max_branch_objects,
            cube_resolution: self.cube_resolution,
            tree_from_branches: self.tree_from_branches,
            small_branches: self.small_branches,
            compose_min_weight: HbtBakeParams::default().compose_min_weight,
        }
    }

    pub fn draw(&self) -> HbtDrawParams {
        HbtDrawParams {
            levels: self.levels,
            open_texel_pixels: self.open_texel_pixels,
            mesh_texel_pixels: self.mesh_texel_pixels,
            mesh_per_branch: self.mesh_per_branch,
            measured_switch: self.measured_switch,
            band: self.band,
            shadows: self.shadows,
            scene_visibility: self.scene_visibility,
            min_weight: self.min_weight,
            projection: self.projection,
            fixed_light: self.fixed_light,
            lod_bias: self.lod_bias,
            shadow_margin: self.shadow_margin,
        }
    }

    /// Whether these options need the CPU-driven frame (the GPU-driven one opens trees as a
    /// whole, facing, with cascaded sun shadows and no scene-level cube-maps).
    pub fn cpu_driven(&self) -> bool {
        self.mesh_per_branch
            || self.small_branches
            || self.scene_visibility
            || self.projection != hbt::HbtProjection::Facing
            || self.shadows != hbt::HbtShadows::Cascades
    }

    pub fn settings(&self) -> Vec<sylvan_scene::Setting> {
        let mut s = settings_of("hbt", &self.bake());
        s.extend(settings_of("hbt", &self.draw()));
        s
    }
}

/// Small but faithful bake parameters for tests (18 × 18 directions, 32 px), the BTF levels
/// only (level 3 would draw near trees as their meshes, which is `geometry`).
pub fn params() -> HbtParams {
    HbtParams {
        levels: 2,
        view_level: 1,
        light_level: 1,
        tile: 32,
        supersample: 2,
        shadow_resolution: 128,
        ..Default::default()
    }
}

pub fn render(
    gpu: &sylvan_gpu::Gpu,
    scene: &sylvan_scene::Scene,
    technique: &str,
    hbt: &HbtParams,
    spp: u32,
) -> image::RgbImage {
    let options = sylvan_render::RenderOptions {
        width: 160,
        height: 160,
        spp,
        technique: technique.into(),
        settings: hbt.settings(),
        cpu_driven: hbt.cpu_driven(),
        cache: CachePolicy::Off,
        ..Default::default()
    };
    super::render_with_options(gpu, scene, &[isotropic_tree()], &options).0
}

/// Renders `scene` with `plants` at `size`² (one frame).
pub fn render_with(
    gpu: &sylvan_gpu::Gpu,
    scene: &sylvan_scene::Scene,
    plants: &[sylvan_plant::Plant],
    technique: &str,
    hbt: &HbtParams,
    size: u32,
    spp: u32,
) -> image::RgbImage {
    let options = sylvan_render::RenderOptions {
        width: size,
        height: size,
        spp,
        technique: technique.into(),
        settings: hbt.settings(),
        cpu_driven: hbt.cpu_driven(),
        cache: CachePolicy::Off,
        ..Default::default()
    };
    super::render_with_options(gpu, scene, plants, &options).0
}

/// One tree of `plant`, `height` m tall, seen from `dist` m at mid-height through a camera
/// of vertical field `fov` (degrees), on flat ground lit from azimuth 150°, elevation 40°.
pub fn one_tree_scene(height: f32, dist: f32, fov: f32) -> sylvan_scene::Scene {
    let at = Vec3::new(60.0, 0.0, 60.0);
    let trees = vec![TreeInstance {
        position: at,
        species: 0,
        seed: 0,
        height,
        rotation: 0.3,
    }];
    let camera = Camera {
        position: Vec3::new(at.x, height * 0.5, at.z - dist),
        look_at: Vec3::new(at.x, height * 0.5, at.z),
        fov_deg: fov,
    };
    super::scene(
        super::terrain(160.0, 33, |_, _| 0.0),
        trees,
        camera,
        super::sun(150.0, 40.0),
    )
}
