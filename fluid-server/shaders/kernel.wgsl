// ---- kernel.wgsl: smoothing kernels (CPU twin: kernel.rs) ----
// Needs the SPH constants (constants.rs): KERNEL_QUINTIC, H, INV_H, SIGMA.
// W(r) = σ f(q), q = r/h; ∇_i W(r_i − r_j) = F(r) r_ij with F = W'(r)/r.

// Wendland (1995) C2, support 2h: f(q) = (1 − q/2)⁴ (2q + 1).
fn wendland_c2_w(q: f32) -> f32 {
    let t = max(1.0 - 0.5 * q, 0.0);
    let t2 = t * t;
    return SIGMA * t2 * t2 * (2.0 * q + 1.0);
}

// W'(r)/r = −5 σ/h² (1 − q/2)³.
fn wendland_c2_grad_factor(q: f32) -> f32 {
    let t = max(1.0 - 0.5 * q, 0.0);
    return -5.0 * SIGMA * INV_H * INV_H * t * t * t;
}

// Joubert eq. (6) (Morris 1997), support 3h: (3−q)⁵ − 6(2−q)⁵ + 15(1−q)⁵.
fn quintic_w(q: f32) -> f32 {
    let a = max(3.0 - q, 0.0);
    let b = max(2.0 - q, 0.0);
    let c = max(1.0 - q, 0.0);
    let a2 = a * a;
    let b2 = b * b;
    let c2 = c * c;
    return SIGMA * (a2 * a2 * a - 6.0 * b2 * b2 * b + 15.0 * c2 * c2 * c);
}

// W'(r)/r = σ/(h² q) (−5(3−q)⁴ + 30(2−q)⁴ − 75(1−q)⁴). For q ≤ 1 the bracket divided by q
// is the cubic −50q³ + 120q² − 120 (expanded exactly): evaluating the bracket there would
// cancel ~400-sized terms down to ~120 q in f32.
fn quintic_grad_factor(q: f32) -> f32 {
    if q <= 1.0 {
        return SIGMA * INV_H * INV_H * ((-50.0 * q + 120.0) * q * q - 120.0);
    }
    let a = max(3.0 - q, 0.0);
    let b = max(2.0 - q, 0.0);
    let a2 = a * a;
    let b2 = b * b;
    return SIGMA * INV_H * INV_H * (-5.0 * a2 * a2 + 30.0 * b2 * b2) / q;
}

fn kernel_w(r: f32) -> f32 {
    let q = r * INV_H;
    if KERNEL_QUINTIC {
        return quintic_w(q);
    }
    return wendland_c2_w(q);
}

fn kernel_grad_factor(r: f32) -> f32 {
    let q = r * INV_H;
    if KERNEL_QUINTIC {
        return quintic_grad_factor(q);
    }
    return wendland_c2_grad_factor(q);
}

// With a smoothing length h of its own (Robinson eq. 19): σ ∝ 1/h³, so with s = H/h,
// W(r, h) = s³ σ f(r/h) and F(r, h) = s⁵ (σ/H²) F̂(r/h), the fixed-h functions at q = r/h.
fn kernel_w_h(r: f32, h: f32) -> f32 {
    let s = H / h;
    let q = r / h;
    if KERNEL_QUINTIC {
        return s * s * s * quintic_w(q);
    }
    return s * s * s * wendland_c2_w(q);
}

fn kernel_grad_factor_h(r: f32, h: f32) -> f32 {
    let s = H / h;
    let s2 = s * s;
    let q = r / h;
    if KERNEL_QUINTIC {
        return s2 * s2 * s * quintic_grad_factor(q);
    }
    return s2 * s2 * s * wendland_c2_grad_factor(q);
}

// Robinson eq. (19): h = H (V/δ³)^(1/3), V = m/ρ (σ of eq. 19 is H/δ).
fn variable_h_of(m: f32, rho: f32) -> f32 {
    return H * pow(m / (rho * SPACING * SPACING * SPACING), 1.0 / 3.0);
}

// W(r) at the smoothing length `h` with variable h, at H otherwise (compiled out).
fn w_at(r: f32, h: f32) -> f32 {
    if VARIABLE_H {
        return kernel_w_h(r, h);
    }
    return kernel_w(r);
}

// F(r) at the smoothing length `h` with variable h, at H otherwise (compiled out).
fn grad_factor_at(r: f32, h: f32) -> f32 {
    if VARIABLE_H {
        return kernel_grad_factor_h(r, h);
    }
    return kernel_grad_factor(r);
}

// The squared support radius of smoothing length `h` (SUPPORT_RADIUS2 at H).
fn support2_at(h: f32) -> f32 {
    if VARIABLE_H {
        let s = h / H;
        return SUPPORT_RADIUS2 * s * s;
    }
    return SUPPORT_RADIUS2;
}
// ---- end of kernel.wgsl ----

// ---- kernels ----
// Kernel twin test only: W(r) and F(r) for a list of distances.
@group(0) @binding(0) var<storage, read> kernel_r: array<f32>;
@group(0) @binding(1) var<storage, read_write> kernel_out: array<vec2<f32>>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn kernel_eval(@builtin(workgroup_id) wid: vec3<u32>,
               @builtin(local_invocation_index) lid: u32,
               @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = linear_id(wid, lid, nwg);
    if i >= arrayLength(&kernel_r) {
        return;
    }
    let r = kernel_r[i];
    kernel_out[i] = vec2<f32>(kernel_w(r), kernel_grad_factor(r));
}
