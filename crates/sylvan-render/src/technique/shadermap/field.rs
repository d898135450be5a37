//! The forest field on the terrain: the tables on the GPU and the field's parameters, bound as
//! the terrain's group 1 (`field.wgsl`), and the `shadermap` technique that owns it.

use super::density::DensityRaster;
use super::gpu::{GpuTables, f32_to_f16, tables_wgsl};
use super::tables::ShaderMapTables;
use crate::RenderError;
use crate::technique::zfield::ZFieldDrawParams;
use crate::technique::{DrawContext, DrawCounts, FrameInput, Technique};
use bytemuck::{Pod, Zeroable};
use sylvan_gpu::Gpu;
use wgpu::util::DeviceExt;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuFieldParams {
    density: [f32; 4],
    crowns: [f32; 4],
    tree_albedo: [f32; 4],
    light: [f32; 4],
    handover: [f32; 4],
    sky: [f32; 4],
    species: [[f32; 4]; MAX_SPECIES],
}

/// Most species the field weighs per-species handovers for (as the GPU cull holds).
pub const MAX_SPECIES: usize = crate::world::MAX_SPECIES;

/// Where and how the field takes over from the trees (BN12 §7).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Handover {
    /// s_max: the distance from which the field alone draws the forest (m; 0: the field
    /// everywhere, no trees drawn).
    pub s_max: f32,
    /// ν of eq. 22–25 forced to this value (`None`: BN12's smoothstep(0, 0.8, s/s_max)).
    pub nu: Option<f32>,
    /// The trees fade over [0.8, 1] × s_max while the ground takes their share (eq. 26–27);
    /// `false`: a hard switch at s_max (a negative control for popping).
    pub fade: bool,
    /// A tree shorter than this on screen (pixels) is left to the field (BN12 §4's 3 px):
    /// each tree ends at min(s_max, its height × pixels per metre / this), the field taking
    /// each species' share from its own end; 0: every tree is drawn to s_max.
    pub handover_px: f32,
}

/// The field's GPU resources: group 1 of the terrain's forest pipeline, group 2 of the
/// `zfield` trees before it. Binding 0 the field's parameters, 1–4 the tables, 5 the density
/// raster (`Rgba16Float`, two layers: Λ_h and the crown areas, each over its peak; the top
/// areas weighted by the local albedo over the terrain's mean; sampled with the tables'
/// clamped linear sampler).
#[derive(Clone)]
pub struct ForestField {
    /// The group's layout (binding 0 the field, 1–4 the tables, 5 the density).
    pub layout: wgpu::BindGroupLayout,
    /// The group.
    pub bind: wgpu::BindGroup,
    /// GPU bytes.
    pub bytes: u64,
    /// [`Handover::handover_px`].
    pub handover_px: f32,
}

impl ForestField {
    /// Uploads `tables` for a forest whose trees per m² are `density` × `scale`, the trees lit
    /// as `zfield` lights them (`draw`: `sun_scale`, `sky_scale`, `a1`, `a2`), taking over from
    /// the drawn trees as `handover` says.
    pub fn new(
        gpu: &Gpu,
        tables: &ShaderMapTables,
        density: &DensityRaster,
        scale: f32,
        draw: &ZFieldDrawParams,
        handover: Handover,
    ) -> Result<Self, RenderError> {
        let t = GpuTables::upload(gpu, tables)?;
        let device = &gpu.device;
        let all = wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE;
        let mut entries = vec![sylvan_gpu::layout::uniform(0, all)];
        entries.extend(GpuTables::entries(1));
        entries.push(sylvan_gpu::layout::texture(
            5,
            all,
            wgpu::TextureSampleType::Float { filterable: true },
            wgpu::TextureViewDimension::D2Array,
        ));
        let peaks = [0, 1, 2].map(|c| density.max(c));
        let norm = peaks.map(|p| if p > 0.0 { 1.0 / p } else { 0.0 });
        // Layer 1: the top areas weighted by albedo over the terrain's mean albedo, on layer
        // 0's top-area scale (so layer 1 / layer 0's g is the local albedo over the mean).
        let mean = density.mean_albedo();
        let tint = mean.map(|m| if m > 0.0 { norm[1] / m } else { 0.0 });
        let mut bits: Vec<u16> = density
            .texels
            .iter()
            .flat_map(|v| {
                [
                    f32_to_f16(v[0] * norm[0]),
                    f32_to_f16(v[1] * norm[1]),
                    f32_to_f16(v[2] * norm[2]),
                    0,
                ]
            })
            .collect();
        bits.extend(density.texels.iter().flat_map(|v| {
            [
                f32_to_f16(v[3] * tint[0]),
                f32_to_f16(v[4] * tint[1]),
                f32_to_f16(v[5] * tint[2]),
                0,
            ]
        }));
        // Layers 2…: per species Λⁱ E(h²) over its peak, four species a layer.
        let n_species = density.species.len().min(MAX_SPECIES);
        let species_peaks: Vec<f32> = density.species[..n_species]
            .iter()
            .map(|q| q.iter().fold(0.0f32, |a, &v| a.max(v)))
            .collect();
        for layer in 0..n_species.div_ceil(4) {
            bits.extend((0..density.texels.len()).flat_map(|t| {
                let at = |k: usize| {
                    let i = 4 * layer + k;
                    match species_peaks.get(i) {
                        Some(&p) if p > 0.0 => f32_to_f16(density.species[i][t] / p),
                        _ => 0,
                    }
                };
                [at(0), at(1), at(2), at(3)]
            }));
        }
        let [w, h] = density.resolution;
        let used = 2 + n_species.div_ceil(4) as u32;
        // Empty layers where wgpu's GL backend would not sample the array (DESIGN.md, GL).
        let layers = crate::technique::common::gl_array_layers(used, w == h);
        bits.extend(std::iter::repeat_n(
            0u16,
            ((layers - used) * w * h * 4) as usize,
        ));
        let raster = crate::texture::upload_raw(
            gpu,
            "shadermap_density",
            [w, h, layers],
            wgpu::TextureDimension::D2,
            wgpu::TextureFormat::Rgba16Float,
            bytemuck::cast_slice(&bits),
        );
        let raster_view = raster.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadermap_field"),
            entries: &entries,
        });
        let [r, g, b] = tables.tree_albedo;
        let params = GpuFieldParams {
            density: [
                (peaks[0] * scale).max(0.0),
                1.0 / density.size_m[0],
                1.0 / density.size_m[1],
                0.0,
            ],
            crowns: {
                let [a, s] = density.mean_areas();
                [
                    (peaks[1] * scale).max(0.0),
                    (peaks[2] * scale).max(0.0),
                    a,
                    s,
                ]
            },
            tree_albedo: [r, g, b, 0.0],
            light: [draw.sun_scale, draw.sky_scale, draw.a1, draw.a2],
            handover: [
                handover.s_max.max(0.0),
                handover.nu.map_or(-1.0, |n| n.clamp(0.0, 1.0)),
                if handover.fade { 1.0 } else { 0.0 },
                handover.handover_px.max(0.0),
            ],
            sky: [draw.sky_normal_weight, n_species as f32, 0.0, 0.0],
            species: {
                let mut rows = [[0.0; 4]; MAX_SPECIES];
                for (i, row) in rows.iter_mut().enumerate().take(n_species) {
                    let (shape, peak) = (density.shapes[i], species_peaks[i]);
                    *row = [shape.top * peak, shape.side * peak, density.heights[i], 0.0];
                }
                rows
            },
        };
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("shadermap_field_params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let mut resources = vec![buffer.as_entire_binding()];
        resources.extend(t.resources());
        resources.push(wgpu::BindingResource::TextureView(&raster_view));
        let bind =
            crate::technique::common::bind_group(gpu, "shadermap_field", &layout, &resources);
        Ok(Self {
            layout,
            bind,
            bytes: t.bytes + buffer.size() + bits.len() as u64 * 2,
            handover_px: handover.handover_px.max(0.0),
        })
    }
}

/// Who composes the field's WGSL.
#[derive(Debug, Clone, Copy)]
pub(crate) enum FieldUser {
    /// The terrain (`field.wgsl`: `fs_terrain_forest`).
    Terrain,
    /// The `zfield` trees before the field (`field_zfield.wgsl`).
    ZField,
}

/// The field's WGSL in group `group` (binding 0 the field, 1–4 the tables): the tables,
/// `field_common.wgsl`, then `user`'s own part.
pub(crate) fn field_wgsl(group: u32, user: FieldUser) -> String {
    let tail = match user {
        FieldUser::Terrain => include_str!("field.wgsl"),
        FieldUser::ZField => include_str!("field_zfield.wgsl"),
    };
    format!(
        "{}\n{}\n{}",
        tables_wgsl(group, 1),
        include_str!("field_common.wgsl").replace("@group(FIELD)", &format!("@group({group})")),
        tail
    )
}

/// The terrain shader with the field: `terrain.wgsl` then [`field_wgsl`] in group 1.
pub(crate) fn terrain_source() -> String {
    crate::pipeline::with_frame(&format!(
        "{}\n{}",
        include_str!("../../shaders/terrain.wgsl"),
        field_wgsl(1, FieldUser::Terrain)
    ))
}

/// Technique `shadermap` drawn alone: no tree is drawn, the terrain carries the whole forest
/// as BN12's far field.
pub struct ShaderMap {
    pub(crate) field: ForestField,
}

impl Technique for ShaderMap {
    fn name(&self) -> &'static str {
        super::ENTRY.name
    }

    fn prepare_frame(
        &mut self,
        _: &Gpu,
        _: &mut wgpu::CommandEncoder,
        _: &FrameInput<'_>,
    ) -> Result<(), RenderError> {
        Ok(())
    }

    fn draw(&self, _: &mut wgpu::RenderPass<'_>, _: &DrawContext<'_>) -> DrawCounts {
        DrawCounts::default()
    }

    fn bytes(&self) -> u64 {
        self.field.bytes
    }

    fn field(&self) -> Option<&ForestField> {
        Some(&self.field)
    }

    /// Nothing to cull: no tree is drawn.
    fn list_requests(&self) -> Vec<crate::world::ListRequest> {
        Vec::new()
    }
}
