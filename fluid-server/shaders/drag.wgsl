// ---- drag.wgsl: fluid–grain drag laws of unresolved coupling (CPU twin: drag.rs) ----
// Robinson eqs. (28)–(33), DEMocritus eqs. (36)–(37); DRAG_* come from
// drag::law_constants_wgsl(). The library part is meant to be fused into the coupling
// kernel that interpolates the fluid at each grain; `drag_table` evaluates it on a
// list of inputs for the parity test.

const DRAG_PI: f32 = 3.14159265358979;

// Schiller–Naumann C_D times the slip, formed without dividing by Re (finite at zero slip).
fn drag_sn_cd_speed(re: f32, speed: f32, eps: f32, rho: f32, mu: f32, d: f32) -> f32 {
    if re < 1000.0 {
        return 24.0 * mu / (eps * rho * d) * (1.0 + 0.15 * pow(re, 0.687));
    }
    return 0.44 * speed;
}

// Ergun's β / (1 − ε), DEMocritus eq. (37), ε ≤ 0.8.
fn drag_ergun_over_solid(eps: f32, d: f32, rho: f32, mu: f32, speed: f32) -> f32 {
    return 150.0 * (1.0 - eps) * mu / (eps * d * d) + 1.75 * rho * speed / d;
}

// Wen–Yu's β / (1 − ε), DEMocritus eq. (37), ε ≥ 0.8, Re = ε ρ |u − v| d / μ.
fn drag_wen_yu_over_solid(eps: f32, d: f32, rho: f32, mu: f32, speed: f32) -> f32 {
    let re = eps * rho * speed * d / mu;
    return 0.75 * drag_sn_cd_speed(re, speed, eps, rho, mu, d) * eps * rho * pow(eps, -2.65) / d;
}

// Drag force on one grain of diameter d at porosity eps for slip = u_f − v_p.
fn drag_force(law: u32, eps: f32, d: f32, rho: f32, mu: f32, slip: vec3<f32>) -> vec3<f32> {
    let speed = length(slip);
    if speed == 0.0 {
        return vec3<f32>(0.0);
    }
    var b: f32;
    switch law {
        case DRAG_STOKES: {
            // Robinson eq. (28) on u_s = ε (u_f − v_p).
            b = 3.0 * DRAG_PI * mu * d * eps;
        }
        case DRAG_COULSON_RICHARDSON: {
            // Robinson eq. (29) with its missing |u_s| restored (drag.rs).
            let us = eps * speed;
            let re = rho * us * d / mu;
            let r = pow(1.84 * pow(re, -0.31) + 0.293 * pow(re, 0.06), 3.45);
            b = 0.25 * DRAG_PI * d * d * rho * us * r * eps;
        }
        case DRAG_DI_FELICE: {
            // Robinson eqs. (30)–(33).
            let us = eps * speed;
            let re = rho * us * d / mu;
            let cd_us = (0.63 * sqrt(re) + 4.8) * (0.63 * sqrt(re) + 4.8) * mu / (rho * d);
            let l = 1.5 - log(re) / log(10.0);
            let chi = 3.7 - 0.65 * exp(-0.5 * l * l);
            b = 0.125 * cd_us * pow(eps, -chi) * DRAG_PI * d * d * rho * eps;
        }
        default: {
            // DEMocritus eq. (36): β V / (1 − ε); Gidaspow's switch or Huilin–Gidaspow's blend.
            var over_solid: f32;
            if law == DRAG_ERGUN_WEN_YU {
                if eps < 0.8 {
                    over_solid = drag_ergun_over_solid(eps, d, rho, mu, speed);
                } else {
                    over_solid = drag_wen_yu_over_solid(eps, d, rho, mu, speed);
                }
            } else {
                let w = 0.5 + atan(262.5 * (eps - 0.8)) / DRAG_PI;
                over_solid = (1.0 - w) * drag_ergun_over_solid(eps, d, rho, mu, speed)
                    + w * drag_wen_yu_over_solid(eps, d, rho, mu, speed);
            }
            b = over_solid * DRAG_PI * d * d * d / 6.0;
        }
    }
    return b * slip;
}

// ---- parity kernel ----
struct DragCase {
    slip: vec3<f32>,
    law: u32,
    eps: f32,
    d: f32,
    rho: f32,
    mu: f32,
}

@group(0) @binding(0) var<storage, read> drag_cases: array<DragCase>;
@group(0) @binding(1) var<storage, read_write> drag_out: array<vec4<f32>>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn drag_table(@builtin(workgroup_id) wid: vec3<u32>,
              @builtin(local_invocation_index) lid: u32,
              @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg);
    if i >= arrayLength(&drag_cases) {
        return;
    }
    let c = drag_cases[i];
    drag_out[i] = vec4<f32>(drag_force(c.law, c.eps, c.d, c.rho, c.mu, c.slip), 0.0);
}
