// ---- marker_update.wgsl (CPU twin: marker_update.rs) ----
// Markers arrive once per window as coupling points in DEM order; marker particle of id
// `marker_base + k` takes point k. Inside the window it moves with the point's own
// velocity, x = x_n + v τ (τ = time since the window start, kept on the GPU in `clock`);
// the body's rotation inside a window is neglected (first order in ω Δt_w).
// Needs: prelude, SPH constants, StepParams, markers (library below).

// One coupling point, the GPU layout of couplet_protocol::CouplingPoint (48 bytes);
// positions are relative to the solver's origin.
struct Marker {
    // xyz position, m; w = area ΔS, m².
    pos_area: vec4<f32>,
    // xyz velocity, m/s; w = body index (bitcast u32).
    vel_body: vec4<f32>,
    // xyz outward unit normal.
    normal: vec4<f32>,
}

// Body state at the window start: centre of mass (relative to the origin) and its velocity.
struct Body {
    cg: vec4<f32>,
    vel: vec4<f32>,
}

struct Clock {
    // Time since the window start, s.
    tau: f32,
    substep: u32,
    _pad0: u32,
    _pad1: u32,
}

// ---- kernels ----
@group(0) @binding(0) var<storage, read_write> pos: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> vel: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> id: array<u32>;
@group(2) @binding(0) var<storage, read> markers_in: array<Marker>;
@group(2) @binding(2) var<storage, read_write> clock: Clock;

@compute @workgroup_size(WORKGROUP_SIZE)
fn marker_update(@builtin(workgroup_id) wid: vec3<u32>,
                 @builtin(local_invocation_index) lid: u32,
                 @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg);
    if i >= params.n_total || !is_marker(id[i]) {
        return;
    }
    let m = markers_in[marker_index(id[i])];
    pos[i] = vec4<f32>(m.pos_area.xyz + clock.tau * m.vel_body.xyz, pos[i].w);
    vel[i] = vec4<f32>(m.vel_body.xyz, 0.0);
}

// One thread: τ += Δt at the end of a substep.
@compute @workgroup_size(1)
fn advance_clock() {
    clock.tau += params.dt;
    clock.substep += 1u;
}
