// ---- body_non_penetration.wgsl (CPU twin: body_non_penetration.rs) ----
// After the step's last position change (the corrector's eq. 23 and the shift), once
// per step: a fluid particle behind the tangent plane of its nearest surface marker
// within δ, d = (x_i − x_m)·n_m < 0, is mirrored back across that plane,
// x_i ← x_i − 2 d n_m, and the inward part of its velocity relative to the marker,
// (u_i − u_m)·n_m < 0, is removed. Fill points (area 0) are not the surface. Then a
// fluid particle behind a wall face (WALL_LO/WALL_HI, ∓1e30 where none) is mirrored
// back across it, x_k ← 2 face − x_k, and loses its velocity into the wall (walls move
// only tangentially). Each particle moved, by either, is counted once in status[3],
// read at the window's end and reported. In a scene without resolved bodies the
// second entry point, `wall_non_penetration`, does the wall part alone (it binds no
// markers and no grid).
// Needs: prelude, SPH constants, StepParams, grid_common, marker_update (library).
// Its library part, `nearest_surface_marker`, is shared with particle shifting's body
// variant (particle_shifting_surface.wgsl); a kernel using it declares `pos`, `vel`,
// `id` and `markers_in`.

// The surface marker (area > 0; fill points are not the surface) nearest to p_i within
// δ: r = p_i − x_m, its outward normal and velocity. Ties go to the first in slot order
// (the sort is stable).
struct NearestSurface {
    found: bool,
    r: vec3<f32>,
    normal: vec3<f32>,
    vel: vec3<f32>,
}

fn nearest_surface_marker(p_i: vec3<f32>) -> NearestSurface {
    let c_i = cell_coord(p_i);
    var best = SPACING * SPACING;
    var s = NearestSurface(false, vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    // Only the cells within δ: at support 2.4 δ that is 27 of the 125 (DKT quick,
    // 2026-11-28: body_non_penetration 8.07 ms a step before).
    let reach = cells_within(SPACING);
    for (var dz = -reach.z; dz <= reach.z; dz++) {
        for (var dy = -reach.y; dy <= reach.y; dy++) {
            let rs = row_ranges_within(c_i, dy, dz, reach.x);
            for (var k = 0u; k < row_length(rs); k++) {
                let j = row_slot(rs, k);
                if !is_marker(id[j]) {
                    continue;
                }
                let m = markers_in[marker_index(id[j])];
                let r = pair_vec(p_i, pos[j].xyz);
                let r2 = dot(r, r);
                if m.pos_area.w > 0.0 && r2 < best {
                    best = r2;
                    s = NearestSurface(true, r, m.normal.xyz, vel[j].xyz);
                }
            }
        }
    }
    return s;
}

// ---- kernels ----
@group(0) @binding(0) var<storage, read_write> pos: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> vel: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> id: array<u32>;
@group(2) @binding(0) var<storage, read> markers_in: array<Marker>;
@group(3) @binding(1) var<storage, read_write> status: array<atomic<u32>, 5>;

// Fluid threads write only their own particle and read only markers: no race.
@compute @workgroup_size(WORKGROUP_SIZE)
fn body_non_penetration(@builtin(workgroup_id) wid: vec3<u32>,
                        @builtin(local_invocation_index) lid: u32,
                        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg);
    if i >= params.n_total || !is_fluid(id[i]) {
        return;
    }
    let p_i = pos[i].xyz;
    let m = nearest_surface_marker(p_i);
    var p = p_i;
    var u = vel[i].xyz;
    var moved = false;
    let d = dot(m.r, m.normal);
    if m.found && d < 0.0 {
        p -= 2.0 * d * m.normal;
        u -= min(dot(u - m.vel, m.normal), 0.0) * m.normal;
        moved = true;
    }
    // A body landing on a wall pressed the fluid between them through it (the
    // settling-sphere quick with the mass correction, 2026-11-26).
    let at_wall = inside_walls(p, u);
    if moved || at_wall.moved {
        store_moved(i, at_wall.p, at_wall.u);
    }
}

// Fluid kept inside the wall faces in a scene without resolved bodies: the
// water–glycerol RTI at α = 0 (2026-12-06) had two fluid particles above its lid at
// 110 ms, among the wall particles, uncounted.
@compute @workgroup_size(WORKGROUP_SIZE)
fn wall_non_penetration(@builtin(workgroup_id) wid: vec3<u32>,
                        @builtin(local_invocation_index) lid: u32,
                        @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg);
    if i >= params.n_total || !is_fluid(id[i]) {
        return;
    }
    let at_wall = inside_walls(pos[i].xyz, vel[i].xyz);
    if at_wall.moved {
        store_moved(i, at_wall.p, at_wall.u);
    }
}

struct Mirrored {
    moved: bool,
    p: vec3<f32>,
    u: vec3<f32>,
}

// p mirrored back across every wall face it is beyond (WALL_LO/WALL_HI, ∓1e30 where
// none), x_k ← 2 face − x_k, and u's velocity into that wall removed.
fn inside_walls(p_in: vec3<f32>, u_in: vec3<f32>) -> Mirrored {
    let below = p_in < WALL_LO;
    let above = p_in > WALL_HI;
    var p = select(p_in, WALL_LO + (WALL_LO - p_in), below);
    p = select(p, WALL_HI + (WALL_HI - p), above);
    var u = select(u_in, max(u_in, vec3<f32>(0.0)), below);
    u = select(u, min(u, vec3<f32>(0.0)), above);
    return Mirrored(any(below) || any(above), p, u);
}

fn store_moved(i: u32, p: vec3<f32>, u: vec3<f32>) {
    pos[i] = vec4<f32>(p, pos[i].w);
    vel[i] = vec4<f32>(u, vel[i].w);
    atomicAdd(&status[3], 1u);
}
