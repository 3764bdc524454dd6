// ---- particle_shifting_surface.wgsl: the shift near a resolved body's surface (CPU twin:
// particle_shifting.rs, `limit_toward_surface`) ----
// Bound in place of the plain shift once bodies exist. Joubert eq. (17)'s sum over
// e_ij / r_ij² has an unstable equilibrium in front of a surface of markers a spacing
// apart: as a particle nears their plane between them, their push along the normal
// fades while the fluid's behind it stays, so a particle that starts a little inside
// that equilibrium is drawn onto the surface at β ‖u‖max Δt a step, whatever its
// velocity (ARCHITECTURE.md, "Joubert's cross at δ = 0.25 mm runs with Γ = 4"). So the
// shift may not carry a particle toward its nearest surface marker (within δ) closer
// than δ/2 in front of the marker's tangent plane, where the carve-out leaves the first
// fluid layer: the part of δr along the inward normal beyond that is dropped, before
// eq. (18)'s Taylor corrections are taken along the δr that remains. Each shift cut
// short is counted in status[4], read at the window's end and reported (`shift_limited`).
// Needs: prelude, SPH constants, StepParams, grid_common, marker_update (library),
// body_non_penetration (library).

@group(2) @binding(0) var<storage, read> markers_in: array<Marker>;
@group(3) @binding(1) var<storage, read_write> status: array<atomic<u32>, 5>;

fn limit_shift(p_i: vec3<f32>, dr: vec3<f32>) -> vec3<f32> {
    let m = nearest_surface_marker(p_i);
    let inward = -dot(dr, m.normal);
    if !m.found || inward <= 0.0 {
        return dr;
    }
    let allowed = max(dot(m.r, m.normal) - 0.5 * SPACING, 0.0);
    let back = inward - min(inward, allowed);
    if back > 0.0 {
        atomicAdd(&status[4], 1u);
    }
    return dr + back * m.normal;
}
