//! The tables on the GPU (`field_tables.wgsl`): (𝔾, 𝕋) on the ridge-aligned axes
//! ([`RidgeTables`]) as an `Rg16Float` 3D texture (x: φ, y: δ node, z: λ node × θ̄ node), and
//! (𝔼, 𝔻, 𝔼ₙ) per (θv node, λ node) as an `Rgba16Float` 2D texture; a uniform with the sizes and
//! the density nodes. Hardware trilinear filtering in each λ slab (z clamped to the slab's
//! texel centres), the two slabs mixed in the shader: two fetches per lookup.

use super::ridge::RidgeTables;
use super::tables::ShaderMapTables;
use crate::RenderError;
use crate::technique::common;
use bytemuck::{Pod, Zeroable};
use sylvan_gpu::Gpu;
use wgpu::util::DeviceExt;

/// Most density nodes the uniform holds.
pub const MAX_LAMBDAS: usize = 16;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuTableInfo {
    /// θ̄ nodes, δ nodes, φ nodes, λ nodes.
    dims: [f32; 4],
    /// x: crown shape h; yzw unused.
    shape: [f32; 4],
    /// The density nodes (trees per m²), 4 per row.
    lambdas: [[f32; 4]; MAX_LAMBDAS / 4],
}

/// The tables' textures and uniform.
pub struct GpuTables {
    /// (𝔾, 𝕋), `Rg16Float` 3D.
    pub gt: wgpu::TextureView,
    /// (𝔼, 𝔻, 𝔼ₙ, 0), `Rgba16Float` 2D, x: θv node, y: λ node.
    pub dec: wgpu::TextureView,
    /// `TableInfo` of `field_tables.wgsl`.
    pub info: wgpu::Buffer,
    /// Linear, clamped.
    pub sampler: wgpu::Sampler,
    /// GPU bytes.
    pub bytes: u64,
}

/// `v` as IEEE half-precision bits, rounded to nearest even; overflow to infinity, NaN kept.
pub fn f32_to_f16(v: f32) -> u16 {
    let x = v.to_bits();
    let sign = ((x >> 16) & 0x8000) as u16;
    let exp = ((x >> 23) & 0xff) as i32;
    let man = x & 0x7f_ffff;
    if exp == 0xff {
        return sign | 0x7c00 | if man != 0 { 0x200 } else { 0 };
    }
    let e = exp - 127 + 15;
    if e >= 0x1f {
        return sign | 0x7c00;
    }
    if e <= 0 {
        if e < -10 {
            return sign;
        }
        // Subnormal: the implicit bit joins the mantissa, shifted into place.
        let m = man | 0x80_0000;
        let shift = (14 - e) as u32;
        let half = 1u32 << (shift - 1);
        let rest = m & ((1 << shift) - 1);
        let mut h = m >> shift;
        if rest > half || (rest == half && h & 1 == 1) {
            h += 1;
        }
        return sign | h as u16;
    }
    let rest = man & 0x1fff;
    let mut h = ((e as u32) << 10) | (man >> 13);
    if rest > 0x1000 || (rest == 0x1000 && h & 1 == 1) {
        h += 1; // may carry into the exponent, which is the right rounding
    }
    sign | h as u16
}

impl GpuTables {
    /// Uploads `t` (resampled onto the ridge-aligned axes).
    pub fn upload(gpu: &Gpu, t: &ShaderMapTables) -> Result<Self, RenderError> {
        t.check().map_err(|why| {
            RenderError::Option(format!("shadermap tables: {why} — re-bake them"))
        })?;
        if t.lambdas.len() > MAX_LAMBDAS {
            return Err(RenderError::Option(format!(
                "shadermap tables with {} density nodes, more than the {MAX_LAMBDAS} the shader holds — re-bake with shadermap.lambda ≤ {MAX_LAMBDAS}",
                t.lambdas.len()
            )));
        }
        let r = RidgeTables::new(t);
        let device = &gpu.device;
        let max3 = device.limits().max_texture_dimension_3d;
        let depth = t.lambdas.len() as u32 * r.theta;
        if r.phi.max(r.delta).max(depth) > max3 {
            return Err(RenderError::Option(format!(
                "shadermap tables of {} × {} × {depth} exceed the device's 3D textures ({max3}) — re-bake with fewer nodes",
                r.phi, r.delta
            )));
        }
        let gt_bits: Vec<u16> =
            r.gt.iter()
                .flat_map(|v| [f32_to_f16(v[0]), f32_to_f16(v[1])])
                .collect();
        let gt = crate::texture::upload_raw(
            gpu,
            "shadermap_gt",
            [r.phi, r.delta, depth],
            wgpu::TextureDimension::D3,
            wgpu::TextureFormat::Rg16Float,
            bytemuck::cast_slice(&gt_bits),
        );
        let (nt, nl) = (t.theta as usize, t.lambdas.len());
        let mut dec_bits = Vec::with_capacity(nt * nl * 4);
        for l in 0..nl {
            for v in 0..nt {
                dec_bits.extend([
                    f32_to_f16(t.e_node(l, v)),
                    f32_to_f16(t.d[l]),
                    f32_to_f16(t.e_side_node(l, v)),
                    0,
                ]);
            }
        }
        let dec = crate::texture::upload_raw(
            gpu,
            "shadermap_dec",
            [nt as u32, nl as u32, 1],
            wgpu::TextureDimension::D2,
            wgpu::TextureFormat::Rgba16Float,
            bytemuck::cast_slice(&dec_bits),
        );
        let mut info = GpuTableInfo {
            dims: [r.theta as f32, r.delta as f32, r.phi as f32, nl as f32],
            shape: [t.h, 0.0, 0.0, 0.0],
            lambdas: [[0.0; 4]; MAX_LAMBDAS / 4],
        };
        for (i, &l) in t.lambdas.iter().enumerate() {
            info.lambdas[i / 4][i % 4] = l;
        }
        let info = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("shadermap_table_info"),
            contents: bytemuck::bytes_of(&info),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let sampler = common::trilinear_sampler(gpu, "shadermap_tables");
        Ok(Self {
            bytes: (gt_bits.len() * 2 + dec_bits.len() * 2) as u64 + info.size(),
            gt: gt.create_view(&Default::default()),
            dec: dec.create_view(&Default::default()),
            info,
            sampler,
        })
    }
}

/// `field_tables.wgsl` with its bindings in group `group`, bindings `first..first + 4`.
pub fn tables_wgsl(group: u32, first: u32) -> String {
    include_str!("field_tables.wgsl")
        .replace("@group(FIELD)", &format!("@group({group})"))
        .replace("@binding(T0)", &format!("@binding({first})"))
        .replace("@binding(T1)", &format!("@binding({})", first + 1))
        .replace("@binding(T2)", &format!("@binding({})", first + 2))
        .replace("@binding(T3)", &format!("@binding({})", first + 3))
}

/// The probe's module: the tables in group 1, `probe.wgsl` in group 0.
pub(crate) fn probe_source() -> String {
    format!("{}\n{}", tables_wgsl(1, 0), include_str!("probe.wgsl"))
}

impl GpuTables {
    /// The tables' layout entries at bindings `first..first + 4` (uniform, 3D and 2D
    /// textures, sampler; visible to every stage), as `tables_wgsl(_, first)` declares them.
    pub fn entries(first: u32) -> [wgpu::BindGroupLayoutEntry; 4] {
        let all = wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE;
        let f = wgpu::TextureSampleType::Float { filterable: true };
        [
            sylvan_gpu::layout::uniform(first, all),
            sylvan_gpu::layout::texture(first + 1, all, f, wgpu::TextureViewDimension::D3),
            sylvan_gpu::layout::texture(first + 2, all, f, wgpu::TextureViewDimension::D2),
            sylvan_gpu::layout::sampler(first + 3, all, wgpu::SamplerBindingType::Filtering),
        ]
    }

    /// What [`GpuTables::entries`] binds, in order.
    pub fn resources(&self) -> [wgpu::BindingResource<'_>; 4] {
        [
            self.info.as_entire_binding(),
            wgpu::BindingResource::TextureView(&self.gt),
            wgpu::BindingResource::TextureView(&self.dec),
            wgpu::BindingResource::Sampler(&self.sampler),
        ]
    }

    /// The shader's lookups at `points` (θv, θl, φ in radians of the transformed space, λ in
    /// trees per m²): (𝔾, 𝕋, 𝔼, 𝔻) each, evaluated on the GPU by `probe.wgsl`.
    pub fn probe(&self, gpu: &Gpu, points: &[[f32; 4]]) -> Result<Vec<[f32; 4]>, RenderError> {
        let device = &gpu.device;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadermap_tables"),
            entries: &Self::entries(0),
        });
        let cs = wgpu::ShaderStages::COMPUTE;
        let io_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadermap_probe_io"),
            entries: &[
                sylvan_gpu::layout::storage(0, cs),
                sylvan_gpu::layout::storage_rw(1, cs),
            ],
        });
        let module = sylvan_gpu::shader(gpu, "shadermap_probe", &probe_source());
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shadermap_probe"),
            bind_group_layouts: &[Some(&io_layout), Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("shadermap_probe"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("probe"),
            compilation_options: Default::default(),
            cache: None,
        });
        let n = points.len().max(1);
        let mut input = points.to_vec();
        input.resize(n, [0.0; 4]);
        let inb = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("shadermap_probe_in"),
            contents: bytemuck::cast_slice(&input),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let outb = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("shadermap_probe_out"),
            size: (n * 16) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let io = common::bind_group(
            gpu,
            "shadermap_probe_io",
            &io_layout,
            &[inb.as_entire_binding(), outb.as_entire_binding()],
        );
        let tables = common::bind_group(gpu, "shadermap_tables", &layout, &self.resources());
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &io, &[]);
            pass.set_bind_group(1, &tables, &[]);
            pass.dispatch_workgroups((n as u32).div_ceil(64), 1, 1);
        }
        gpu.queue.submit([encoder.finish()]);
        let bytes = sylvan_gpu::read_buffer_bytes(gpu, &outb)?;
        let out: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
        Ok(out[..points.len()].to_vec())
    }
}

#[cfg(test)]
mod tests {
    use super::f32_to_f16;

    #[test]
    fn halves_round_to_nearest_even() {
        for (v, bits) in [
            (1.0f32, 0x3c00u16),
            (-2.0, 0xc000),
            (0.5, 0x3800),
            (0.0, 0x0000),
            (65504.0, 0x7bff),
            (1e6, 0x7c00),
            (5.960_464_5e-8, 0x0001),
            (1.0 + 1.0 / 2048.0, 0x3c00), // a tie rounds to even
            (1.0 + 3.0 / 2048.0, 0x3c02),
        ] {
            assert_eq!(f32_to_f16(v), bits, "{v}");
        }
        assert_eq!(f32_to_f16(f32::NAN) & 0x7c00, 0x7c00);
        for i in 0..1000 {
            let v = i as f32 / 997.0 * 3.0;
            let back = crate::bake::f16_to_f32(f32_to_f16(v));
            assert!((back - v).abs() <= v.abs() / 1024.0 + 1e-7, "{v} → {back}");
        }
    }
}
