//! Per-frame uniforms (`shaders/frame.wgsl`), the view, and cascaded shadow maps.

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3, Vec4};
use sylvan_gpu::{DEPTH_FORMAT, Gpu, layout};

/// Number of shadow cascades (matches `CASCADES` in `frame.wgsl`).
pub const CASCADES: usize = 4;

/// The frame uniform block, laid out as `Frame` in `frame.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct GpuFrame {
    pub view_proj: [[f32; 4]; 4],
    pub inv_view_proj: [[f32; 4]; 4],
    pub cascade_view_proj: [[[f32; 4]; 4]; CASCADES],
    pub camera: [f32; 4],
    pub sun_dir: [f32; 4],
    pub sun_color: [f32; 4],
    pub sky_zenith: [f32; 4],
    pub sky_horizon: [f32; 4],
    pub sky_ground: [f32; 4],
    pub cascade_far: [f32; 4],
    pub shadow_params: [f32; 4],
    pub target: [f32; 4],
    /// The ground cover (`world::cover`): x tile side (m), y atlas cells per side, z BN12's a3,
    /// w 1 when the ground's sky is occluded.
    pub cover: [f32; 4],
    /// x trees per m² where no cover tile is held; y mean tree height (m); z distance where
    /// trees end (m); w the stored density's top (trees per m²).
    pub cover_extra: [f32; 4],
    /// x the cover's texel side (m); y its mip levels.
    pub cover_lod: [f32; 4],
}

/// A perspective view: where the eye is and what it sees.
#[derive(Debug, Clone, Copy)]
pub struct View {
    /// Eye position.
    pub eye: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    /// Width / height.
    pub aspect: f32,
    /// Near plane distance (metres).
    pub near: f32,
    /// Far plane distance (metres).
    pub far: f32,
}

impl View {
    /// World → view matrix (right-handed, Y up).
    pub fn view(&self) -> Mat4 {
        let dir = (self.target - self.eye).normalize_or(Vec3::NEG_Z);
        let up = if dir.y.abs() > 0.999 {
            Vec3::Z
        } else {
            Vec3::Y
        };
        Mat4::look_at_rh(self.eye, self.target, up)
    }

    /// Reversed-Z perspective projection (depth 1 at the near plane, 0 at the far plane).
    pub fn proj(&self) -> Mat4 {
        Mat4::perspective_rh(self.fov_y, self.aspect, self.far, self.near)
    }

    /// World → clip.
    pub fn view_proj(&self) -> Mat4 {
        self.proj() * self.view()
    }

    /// The 8 world-space corners of the slice of the frustum between view depths `near` and `far`.
    pub fn slice_corners(&self, near: f32, far: f32) -> [Vec3; 8] {
        let inv_view = self.view().inverse();
        let t = (self.fov_y * 0.5).tan();
        let mut out = [Vec3::ZERO; 8];
        for (i, d) in [near, far].into_iter().enumerate() {
            let (h, w) = (t * d, t * d * self.aspect);
            for (j, (sx, sy)) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                .into_iter()
                .enumerate()
            {
                out[i * 4 + j] = inv_view.transform_point3(Vec3::new(sx * w, sy * h, -d));
            }
        }
        out
    }
}

/// Frustum planes (inward normals, `dot(n, p) + d ≥ 0` inside) extracted from a clip matrix.
#[derive(Debug, Clone, Copy)]
pub struct Frustum {
    planes: [Vec4; 6],
}

impl Frustum {
    /// Planes of `clip` (wgpu depth range 0..1; works for reversed Z too).
    pub fn from_matrix(clip: Mat4) -> Self {
        let r = [clip.row(0), clip.row(1), clip.row(2), clip.row(3)];
        let raw = [
            r[3] + r[0],
            r[3] - r[0],
            r[3] + r[1],
            r[3] - r[1],
            r[2],
            r[3] - r[2],
        ];
        let planes = raw.map(|p| p / p.truncate().length().max(1e-12));
        Self { planes }
    }

    /// The six planes (xyz normal pointing inside, w offset; normalised).
    pub fn planes(&self) -> &[Vec4; 6] {
        &self.planes
    }

    /// Whether an axis-aligned box may be partly inside (no plane has it wholly outside).
    pub fn intersects_box(&self, min: Vec3, max: Vec3) -> bool {
        self.planes.iter().all(|p| {
            let n = p.truncate();
            let corner = Vec3::select(n.cmpge(Vec3::ZERO), max, min);
            n.dot(corner) + p.w >= 0.0
        })
    }

    /// Whether a sphere is at least partly inside.
    pub fn intersects_sphere(&self, centre: Vec3, radius: f32) -> bool {
        self.planes
            .iter()
            .all(|p| p.truncate().dot(centre) + p.w >= -radius)
    }
}

/// Where the cascade split scheme starts (metres from the eye).
pub const SPLIT_NEAR_M: f32 = 4.0;

/// One shadow cascade: its light-space clip matrix and the view depth it covers.
#[derive(Debug, Clone, Copy)]
pub struct Cascade {
    /// World → light clip (orthographic, depth 0..1).
    pub view_proj: Mat4,
    /// Far view distance covered.
    pub far: f32,
}

/// Fits `CASCADES` shadow cascades to `view` up to `shadow_distance`, looking along `-sun`.
/// `caster_reach` is how far towards the sun casters may stand (terrain relief + tree height).
/// Each cascade is a sphere fit snapped to its texel grid, so shadows do not shimmer.
/// `shadow_near` > 0 starts the first cascade there instead of at the eye (nearer receivers
/// are lit): all the maps' texels on one distance band, for a reference of far trees whose
/// shadows converge (`render --shadow-near`).
pub fn fit_cascades(
    view: &View,
    sun: Vec3,
    shadow_near: f32,
    shadow_distance: f32,
    caster_reach: f32,
    resolution: u32,
) -> [Cascade; CASCADES] {
    let far_all = shadow_distance.min(view.far);
    // Splits are computed from a few metres out, not from the near plane: a first cascade only
    // centimetres deep would make every nearby leaf cover the whole map many times over.
    let split_near = SPLIT_NEAR_M.max(shadow_near).min(far_all * 0.5);
    let mut near = if shadow_near > 0.0 {
        split_near
    } else {
        view.near
    };
    std::array::from_fn(|i| {
        // Practical split scheme (log/uniform blend, λ = 0.75).
        let k = (i + 1) as f32 / CASCADES as f32;
        let log = split_near * (far_all / split_near).powf(k);
        let uni = split_near + (far_all - split_near) * k;
        let far = 0.75 * log + 0.25 * uni;
        let corners = view.slice_corners(near, far);
        near = far;
        let centre = corners.iter().copied().sum::<Vec3>() / 8.0;
        let radius = corners
            .iter()
            .map(|c| c.distance(centre))
            .fold(0.0, f32::max)
            .ceil();
        let up = if sun.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
        let back = radius + caster_reach;
        let light_view = Mat4::look_at_rh(Vec3::ZERO, -sun, up);
        // Snap the centre to whole texels in light space.
        let texel = 2.0 * radius / resolution as f32;
        let mut c = light_view.transform_point3(centre);
        c.x = (c.x / texel).floor() * texel;
        c.y = (c.y / texel).floor() * texel;
        let snapped = light_view.inverse().transform_point3(c);
        let eye = snapped + sun * back;
        let view_m = Mat4::look_at_rh(eye, snapped, up);
        let proj = Mat4::orthographic_rh(-radius, radius, -radius, radius, 0.0, back + radius);
        Cascade {
            view_proj: proj * view_m,
            far,
        }
    })
}

/// How far along the sun's rays a tree's shadow can fall before the terrain stops it (metres).
///
/// A caster point stands at most `tallest` above its trunk's ground and `crown` beside the
/// trunk. Along a ray descending at the sun's elevation `e` the ground can fall at most
/// `slope` (rise over run, [`sylvan_scene::Terrain::max_slope`]), so where `tan e > slope` the
/// ray is under the terrain after `(tallest + slope · crown) / (sin e − slope · cos e)` and
/// stays there (it falls faster than any slope): whatever lies farther is in the terrain's own
/// shadow. Lower suns use the whole relief: `caster_reach` (relief + tallest + margin) over
/// `sin e`. One metre of margin.
pub fn shadow_reach(sun: Vec3, tallest: f32, crown: f32, slope: f32, caster_reach: f32) -> f32 {
    let sin_e = sun.normalize_or(Vec3::Y).y.max(1e-3);
    let cos_e = (1.0 - sin_e * sin_e).max(0.0).sqrt();
    let whole = caster_reach / sin_e;
    let falls = sin_e - slope * cos_e;
    if falls > 1e-3 {
        whole.min((tallest + slope * crown) / falls + 1.0)
    } else {
        whole
    }
}

/// Which shadow casters can darken something the camera sees, per cascade.
///
/// A cascade shades the receivers whose distance from the eye falls in its shell
/// (`cascade_index` in `frame.wgsl`: from the previous cascade's far to its own) and that the
/// camera sees (inside its side and near planes). A caster matters to the cascade only if its
/// shadow — the segment from it away from the sun, as long as a shadow can fall before the
/// lowest terrain stops it — meets that region. Everything is padded by the caster's radius
/// (it may stand anywhere in its sphere), by how far a receiver's shadow lookup strays from its
/// visible surface (a tree's radius: techniques look up at points inside their bounds; the
/// normal offset; 2 texels of PCF and bilinear comparison) and 1 m, so culling by this changes
/// no pixel. The GPU cull (`world/cull.wgsl`, `caster_keeps`) evaluates the same formula from
/// [`CasterCull::gpu_rows`].
#[derive(Debug, Clone, Copy)]
pub struct CasterCull {
    /// Per cascade: the camera's 4 side planes and its near plane, pushed out by the
    /// cascade's padding (inward normals, as [`Frustum::planes`]).
    planes: [[Vec4; 5]; CASCADES],
    /// Per cascade: x inner and y outer radius of its shell (padded), z the padding.
    shell: [Vec4; CASCADES],
    /// Unit vector towards the sun.
    sun: Vec3,
    /// How far from a caster its shadow can fall (metres along the sun's rays).
    reach: f32,
    /// The eye.
    eye: Vec3,
}

impl CasterCull {
    /// Rows in [`CasterCull::gpu_rows`]: 6 per cascade (5 planes and the shell), then the sun
    /// (xyz) and the reach (w).
    pub const GPU_ROWS: usize = 6 * CASCADES + 1;

    /// The cull for the camera `view` (its clip matrix `view_proj`), `cascades` as fitted for
    /// it, the unit `sun` direction and a shadow `reach` in metres along the sun's rays.
    /// `receiver_pad` is how far from its visible surface a receiver's shadow lookup may be
    /// (the largest tree radius); `resolution` the shadow maps' texels per side.
    pub fn new(
        view: &View,
        view_proj: Mat4,
        cascades: &[Cascade; CASCADES],
        sun: Vec3,
        reach: f32,
        receiver_pad: f32,
        resolution: u32,
    ) -> Self {
        let camera = Frustum::from_matrix(view_proj);
        let forward = (view.target - view.eye).normalize_or(Vec3::NEG_Z);
        let near_plane = forward.extend(-forward.dot(view.eye) - view.near);
        let mut planes = [[Vec4::ZERO; 5]; CASCADES];
        let mut shell = [Vec4::ZERO; CASCADES];
        let mut inner = 0.0;
        for (c, cascade) in cascades.iter().enumerate() {
            // An orthographic cascade maps 2 / |row x| metres onto its resolution.
            let m = cascade.view_proj;
            let row_x = Vec3::new(m.x_axis.x, m.y_axis.x, m.z_axis.x).length();
            let texel = 2.0 / row_x.max(1e-9) / resolution.max(1) as f32;
            // Receivers look up at `world + normal_offset · (cascade + 1)`, |offset| ≤ 0.15.
            let pad = receiver_pad + 2.0 * texel + 0.15 * (c + 1) as f32 + 1.0;
            let side = &camera.planes()[..4];
            for (k, p) in side.iter().chain([&near_plane]).enumerate() {
                planes[c][k] = *p + Vec4::new(0.0, 0.0, 0.0, pad);
            }
            shell[c] = Vec4::new(inner - pad, cascade.far + pad, pad, 0.0);
            inner = cascade.far;
        }
        Self {
            planes,
            shell,
            sun: sun.normalize_or(Vec3::Y),
            reach: reach.max(0.0),
            eye: view.eye,
        }
    }

    /// Whether a caster inside the sphere (`centre`, `radius`) may shade a receiver that
    /// cascade `cascade` serves.
    pub fn keeps(&self, cascade: usize, centre: Vec3, radius: f32) -> bool {
        let s = self.sun;
        // Points of the shadow segment: centre − t · sun, t from −radius (the caster's far
        // side) to the reach (+ 2 radii: casters may push their depth away from the sun).
        let (mut t0, mut t1) = (-radius, self.reach + 2.0 * radius);
        for p in &self.planes[cascade] {
            let a = p.truncate().dot(centre) + p.w + radius;
            let b = p.truncate().dot(s);
            if b > 0.0 {
                t1 = t1.min(a / b);
            } else if b < 0.0 {
                t0 = t0.max(a / b);
            } else if a < 0.0 {
                return false;
            }
        }
        if t0 > t1 {
            return false;
        }
        // The shell: the part of the segment inside the planes must come within the outer
        // radius and reach beyond the inner one (its distance from the eye is continuous).
        let shell = self.shell[cascade];
        let d = centre - self.eye;
        let nearest = d.dot(s).clamp(t0, t1);
        let min_distance = (d - s * nearest).length();
        let max_distance = (d - s * t0).length().max((d - s * t1).length());
        min_distance <= shell.y + radius && max_distance >= shell.x - radius
    }

    /// The cull as the GPU cull's uniform rows (see [`CasterCull::GPU_ROWS`]): per cascade its
    /// 5 planes and the shell (x inner, y outer), then the sun (xyz) and the reach (w); the
    /// eye is the cull's own `eye_far`.
    pub fn gpu_rows(&self) -> [[f32; 4]; Self::GPU_ROWS] {
        let mut rows = [[0.0; 4]; Self::GPU_ROWS];
        for c in 0..CASCADES {
            for (k, p) in self.planes[c].iter().enumerate() {
                rows[6 * c + k] = p.to_array();
            }
            rows[6 * c + 5] = self.shell[c].to_array();
        }
        rows[6 * CASCADES] = self.sun.extend(self.reach).to_array();
        rows
    }

    /// The eye the shells are centred on.
    pub fn eye(&self) -> Vec3 {
        self.eye
    }
}

/// The group-0 layouts, the shadow-map array and its sampler: made once per renderer.
pub struct FrameResources {
    /// Layout for main passes: frame uniforms, shadow maps, comparison sampler.
    pub main_layout: wgpu::BindGroupLayout,
    /// Layout for shadow passes: frame uniforms only.
    pub shadow_layout: wgpu::BindGroupLayout,
    /// Frame uniforms of the camera view.
    pub uniforms: wgpu::Buffer,
    /// One uniform block per cascade (its `view_proj` is the cascade's).
    pub cascade_uniforms: Vec<wgpu::Buffer>,
    /// Main bind group.
    pub main_bind: wgpu::BindGroup,
    /// One shadow-pass bind group per cascade.
    pub cascade_binds: Vec<wgpu::BindGroup>,
    /// One depth view per cascade layer (render attachments).
    pub cascade_views: Vec<wgpu::TextureView>,
    /// One view per cascade layer of the translucent casters' layer (the shadow passes' colour
    /// attachment, [`SHADOW_TRANSLUCENT_FORMAT`]): Σσ, Σσz and their count over every
    /// translucent caster in front of the opaque ones, and the nearest one's depth, so
    /// semi-transparent casters (`zfield`, BN12 §5) cast soft shadows that accumulate where
    /// crowns overlap. Empty when the frame has no translucent casters: the shadow passes are
    /// then depth only, and the main passes read a 1×1 layer of zeros (no caster).
    pub translucent_views: Vec<wgpu::TextureView>,
    /// Shadow-map resolution per cascade.
    pub shadow_resolution: u32,
    /// The main pass's attachments, which every main-pass pipeline is built for.
    pub target: crate::pipeline::MainTarget,
    shadow_map: wgpu::Texture,
    shadow_translucent: wgpu::Texture,
}

/// A `resolution²` texture of `format` with one layer per cascade (a render attachment, sampled
/// by the main passes): the texture, its array view and one view per layer.
fn cascade_layers(
    gpu: &Gpu,
    label: &str,
    format: wgpu::TextureFormat,
    resolution: u32,
) -> (wgpu::Texture, wgpu::TextureView, Vec<wgpu::TextureView>) {
    let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: resolution,
            height: resolution,
            depth_or_array_layers: CASCADES as u32,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    });
    let array = texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    });
    let layers = (0..CASCADES as u32)
        .map(|layer| {
            texture.create_view(&wgpu::TextureViewDescriptor {
                label: Some(label),
                dimension: Some(wgpu::TextureViewDimension::D2),
                base_array_layer: layer,
                array_layer_count: Some(1),
                ..Default::default()
            })
        })
        .collect();
    (texture, array, layers)
}

/// The format of the cascades' translucent layer: r Σσ, g Σσz, b n over the n translucent
/// casters (σ = −ln(1 − α), z their depth; blended with `Add`, cleared to 0) and a the
/// nearest one's depth (blended with `Min`, cleared to 1: none).
pub const SHADOW_TRANSLUCENT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// Bytes per shadow-map texel: depth (4), and the translucent layer (8) when a technique casts
/// translucent shadows.
pub fn shadow_texel_bytes(translucent: bool) -> u64 {
    if translucent { 12 } else { 4 }
}

impl FrameResources {
    /// Creates layouts, buffers and a `resolution²` shadow map per cascade (with the
    /// translucent layer when `translucent`: a technique casts soft shadows), for main passes
    /// into `target`, binding the ground `cover`.
    pub fn new(
        gpu: &Gpu,
        resolution: u32,
        target: crate::pipeline::MainTarget,
        cover: &crate::world::cover::GroundCover,
        translucent: bool,
    ) -> Self {
        let device = &gpu.device;
        let main_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("frame_main_layout"),
            entries: &[
                layout::uniform(0, wgpu::ShaderStages::VERTEX_FRAGMENT),
                layout::texture(
                    1,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::TextureSampleType::Depth,
                    wgpu::TextureViewDimension::D2Array,
                ),
                layout::sampler(
                    2,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::SamplerBindingType::Comparison,
                ),
                layout::texture(
                    3,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::TextureSampleType::Float { filterable: true },
                    wgpu::TextureViewDimension::D2,
                ),
                layout::texture(
                    4,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::TextureSampleType::Uint,
                    wgpu::TextureViewDimension::D2,
                ),
                layout::sampler(
                    5,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::SamplerBindingType::Filtering,
                ),
                layout::texture(
                    6,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::TextureSampleType::Float { filterable: false },
                    wgpu::TextureViewDimension::D2Array,
                ),
            ],
        });
        let shadow_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("frame_shadow_layout"),
            entries: &[layout::uniform(0, wgpu::ShaderStages::VERTEX_FRAGMENT)],
        });
        let make_uniform = |label: &str| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: std::mem::size_of::<GpuFrame>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let uniforms = make_uniform("frame_uniforms");
        let cascade_uniforms: Vec<_> = (0..CASCADES)
            .map(|_| make_uniform("cascade_uniforms"))
            .collect();
        let (shadow_map, array_view, cascade_views) =
            cascade_layers(gpu, "shadow_map", DEPTH_FORMAT, resolution);
        let (shadow_translucent, translucent_array, mut translucent_views) = cascade_layers(
            gpu,
            "shadow_translucent",
            SHADOW_TRANSLUCENT_FORMAT,
            if translucent { resolution } else { 1 },
        );
        if !translucent {
            translucent_views.clear();
        }
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("shadow_sampler"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            compare: Some(wgpu::CompareFunction::LessEqual),
            ..Default::default()
        });
        let main_bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("frame_main_bind"),
            layout: &main_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniforms.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&array_view),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Sampler(&sampler),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(cover.view()),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(cover.tags_view()),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: wgpu::BindingResource::Sampler(cover.sampler()),
                },
                wgpu::BindGroupEntry {
                    binding: 6,
                    resource: wgpu::BindingResource::TextureView(&translucent_array),
                },
            ],
        });
        let cascade_binds = cascade_uniforms
            .iter()
            .map(|b| {
                device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("cascade_bind"),
                    layout: &shadow_layout,
                    entries: &[wgpu::BindGroupEntry {
                        binding: 0,
                        resource: b.as_entire_binding(),
                    }],
                })
            })
            .collect();
        Self {
            main_layout,
            shadow_layout,
            uniforms,
            cascade_uniforms,
            main_bind,
            cascade_binds,
            cascade_views,
            translucent_views,
            shadow_resolution: resolution,
            target,
            shadow_map,
            shadow_translucent,
        }
    }

    /// Whether the shadow passes have the translucent layer (a technique casts soft shadows:
    /// `PassKind::ShadowTranslucent` pipelines need it).
    pub fn translucent(&self) -> bool {
        !self.translucent_views.is_empty()
    }

    /// GPU bytes of the shadow maps (depth and the translucent layer).
    pub fn bytes(&self) -> u64 {
        let texels = |t: &wgpu::Texture| {
            let s = t.size();
            s.width as u64 * s.height as u64 * s.depth_or_array_layers as u64
        };
        texels(&self.shadow_map) * shadow_texel_bytes(false)
            + texels(&self.shadow_translucent)
                * (shadow_texel_bytes(true) - shadow_texel_bytes(false))
    }
}

/// A debug colouring of the frame (`shadow_params.z` in `frame.wgsl`), for the viewer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DebugView {
    /// The normal image.
    #[default]
    None,
    /// Trees tinted by the technique that drew them (geometry orange, z-fields yellow: `Entry::debug_color`), the terrain grey.
    Technique,
    /// Terrain and trees tinted by the shadow cascade covering them (red, green, blue, yellow).
    Cascades,
    /// Coverage: every tree white at its opacity, the bare terrain black, and the forest field
    /// (`shadermap`) grey at the share of its pixel that trees cover (1 − Gd; beside drawn
    /// trees, the share it takes from them as they fade). The mean radiance of a crop
    /// (`render --measure`) is then the fraction of it covered by trees, whatever drew them.
    Coverage,
}

impl DebugView {
    /// Every debug view with its label, in the order of the viewer's panel.
    pub const ALL: [(&'static str, DebugView); 4] = [
        ("none", DebugView::None),
        ("technique", DebugView::Technique),
        ("shadow cascades", DebugView::Cascades),
        ("coverage", DebugView::Coverage),
    ];

    /// The view named `name` (a label of [`DebugView::ALL`], or `cascades`), or a one-line
    /// error listing the names.
    pub fn parse(name: &str) -> Result<DebugView, String> {
        let wanted = if name == "cascades" {
            "shadow cascades"
        } else {
            name
        };
        Self::ALL
            .iter()
            .find(|(n, _)| *n == wanted)
            .map(|(_, d)| *d)
            .ok_or_else(|| {
                format!("'{name}' is not a debug view — use none, technique, cascades or coverage")
            })
    }

    /// The value the shaders read from `shadow_params.z`.
    pub fn code(self) -> f32 {
        match self {
            DebugView::None => 0.0,
            DebugView::Technique => 1.0,
            DebugView::Cascades => 2.0,
            DebugView::Coverage => 3.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (xorshift) for the property tests.
    struct Rng(u64);
    impl Rng {
        fn unit(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
        fn range(&mut self, lo: f32, hi: f32) -> f32 {
            lo + (hi - lo) * self.unit()
        }
    }

    fn view() -> View {
        View {
            eye: Vec3::new(10.0, 40.0, -5.0),
            target: Vec3::new(300.0, 0.0, 200.0),
            fov_y: 50f32.to_radians(),
            aspect: 16.0 / 9.0,
            near: 0.1,
            far: 5000.0,
        }
    }

    /// Every caster standing on the sun's side of a visible receiver, within the reach, is
    /// kept by the cascade that shades the receiver — for suns high, low, behind and in front.
    #[test]
    fn caster_cull_keeps_every_caster_that_shades_a_visible_receiver() {
        let view = view();
        let view_proj = view.view_proj();
        let camera = Frustum::from_matrix(view_proj);
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        for (azimuth, elevation) in [(0.0f32, 40.0f32), (140.0, 12.0), (200.0, 70.0), (90.0, 5.0)] {
            let (a, e) = (azimuth.to_radians(), elevation.to_radians());
            let sun = Vec3::new(a.sin() * e.cos(), e.sin(), a.cos() * e.cos());
            let cascades = fit_cascades(&view, sun, 0.0, 1500.0, 400.0, 2048);
            let reach = shadow_reach(sun, 30.0, 8.0, 0.3, 400.0);
            let cull = CasterCull::new(&view, view_proj, &cascades, sun, reach, 12.0, 2048);
            let mut checked = 0;
            while checked < 4000 {
                // A receiver the camera sees, and the cascade that shades it.
                let x = Vec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), 0.0);
                let p = view.eye
                    + (view.target - view.eye).normalize() * rng.range(0.2, 1600.0)
                    + x * rng.range(0.0, 600.0);
                let d = p.distance(view.eye);
                if !camera.intersects_sphere(p, 0.0) || d >= cascades[CASCADES - 1].far {
                    continue;
                }
                let c = cascades.iter().position(|k| d < k.far).unwrap();
                // A caster towards the sun, its sphere anywhere around the ray.
                let r = rng.range(0.5, 12.0);
                let off = Vec3::new(
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                )
                .clamp_length_max(1.0)
                    * r;
                let centre = p + sun * rng.range(0.0, reach) + off;
                assert!(
                    cull.keeps(c, centre, r),
                    "sun {azimuth},{elevation}: cascade {c} drops the caster at {centre} (r {r}) of {p}"
                );
                checked += 1;
            }
        }
    }

    /// The cull does cull: casters beside the view, behind the eye away from the sun or past
    /// the reach are dropped, and a cascade drops casters of the other cascades' shells.
    #[test]
    fn caster_cull_drops_casters_that_shade_nothing_seen() {
        let view = view();
        let sun = Vec3::new(0.3, 0.8, -0.5).normalize();
        let cascades = fit_cascades(&view, sun, 0.0, 1500.0, 400.0, 2048);
        let cull = CasterCull::new(&view, view.view_proj(), &cascades, sun, 300.0, 12.0, 2048);
        let forward = (view.target - view.eye).normalize();
        // Far behind the eye.
        assert!(!cull.keeps(0, view.eye - forward * 800.0 - sun * 50.0, 5.0));
        // Below the eye, its shadow falling out of the view.
        assert!(!cull.keeps(0, view.eye - Vec3::Y * 30.0, 5.0));
        // The far cascade does not need a caster over a point 20 m ahead: its shadow falls
        // 300 m at most, short of the far cascade's shell.
        let near = view.eye + forward * 20.0 + sun * 10.0;
        assert!(cull.keeps(0, near, 5.0));
        assert!(!cull.keeps(CASCADES - 1, near, 5.0));
        // A caster far past the reach, on the sun's side of a seen point.
        let seen = view.eye + forward * 100.0;
        assert!(cull.keeps(0, seen + sun * 250.0, 5.0));
        assert!(!cull.keeps(0, seen + sun * 2000.0, 5.0));
        // How far shadows fall: the whole relief for a low sun, less on gentle slopes.
        let high = Vec3::new(0.0, 1.0, 1.0).normalize();
        assert!(shadow_reach(high, 30.0, 8.0, 0.2, 400.0) < 400.0 / high.y);
        let low = Vec3::new(0.0, 0.1, 1.0).normalize();
        assert!((shadow_reach(low, 30.0, 8.0, 0.2, 400.0) - 400.0 / low.y).abs() < 0.1);
    }
}
