// ---- grain_reaction_add.wgsl: add_grain_reaction, after each fluid_rates: the grains'
// reaction (Robinson eq. 26 per unit mass, grain_reaction_read.wgsl) joins du/dt, held
// over the window like the grains' loads on the DEM side. CPU twin: a sum. ----
// Needs: prelude, StepParams, grain_reaction_read.

@group(0) @binding(4) var<storage, read> id: array<u32>;
@group(0) @binding(6) var<storage, read_write> dvel: array<vec4<f32>>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn add_grain_reaction(@builtin(workgroup_id) wid: vec3<u32>,
                      @builtin(local_invocation_index) lid: u32,
                      @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg);
    if i >= params.n_total || !is_fluid(id[i]) {
        return;
    }
    dvel[i] = vec4<f32>(dvel[i].xyz + grain_reaction(i), 0.0);
}
