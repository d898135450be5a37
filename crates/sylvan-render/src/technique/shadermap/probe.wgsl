// Evaluates the table lookups of `field_tables.wgsl` (group 1) at given points: the check that
// the shader and `RidgeTables::sample` agree (`GpuTables::probe`).

// x: θv, y: θl, z: φ (radians), w: λ (trees per m²).
@group(0) @binding(0) var<storage, read> probe_in: array<vec4<f32>>;
// x: 𝔾, y: 𝕋, z: 𝔼, w: 𝔻.
@group(0) @binding(1) var<storage, read_write> probe_out: array<vec4<f32>>;

@compute @workgroup_size(64)
fn probe(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= arrayLength(&probe_in)) {
        return;
    }
    let p = probe_in[id.x];
    probe_out[id.x] = vec4<f32>(table_gt(p.x, p.y, p.z, p.w), table_dec(p.x, p.w).xy);
}
