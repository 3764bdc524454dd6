//! Fluid–grain drag laws of unresolved coupling (issue 5), the CPU twin of
//! `shaders/drag.wgsl`: the force the fluid exerts on one grain of diameter d at local
//! porosity ε, for the slip `u_f − v_p` between the interpolated fluid velocity and
//! the grain.
//!
//! * Stokes, Robinson eq. (28): `f = 3π μ d u_s`.
//! * Coulson–Richardson, Robinson eq. (29): `f = π/4 d² ρ |u_s| u_s (1.84 Re^-0.31 +
//!   0.293 Re^0.06)^3.45`. Robinson prints `ρ |u_s|` without the second velocity, which
//!   is not a force; the Khan–Richardson form it quotes is `R'/(ρ u²)`, so the force is
//!   `R' π d²/4` with `R' = ρ u² (…)^3.45` (`validation/sphere_drag_correlations.csv`,
//!   column `Cd_CoulsonRichardson_form` = 2 (…)^3.45).
//! * Dallavalle with Di Felice's voidage, Robinson eqs. (30)–(33): `f = 1/8 C_d ε^-χ π d²
//!   ρ |u_s| u_s`, `C_d = (0.63 + 4.8/√Re)²`, `χ = 3.7 − 0.65 exp(−(1.5 − log₁₀ Re)²/2)`.
//! * Ergun / Wen–Yu, DEMocritus eqs. (36)–(37): `f = β V/(1 − ε) (u_f − v_p)` with
//!   Ergun's β below ε = 0.8 and Wen–Yu's above (Schiller–Naumann C_D at `Re = ε ρ
//!   |u_f − v_p| d / μ`). β jumps at the switch (by 4 % at Re = 8, per the reference
//!   table); [`DragLaw::ErgunWenYuBlend`] weights the two with Huilin & Gidaspow's (2003)
//!   `φ = 1/2 + arctan(262.5 (ε − 0.8))/π` instead, which is continuous.
//!
//! In Robinson's laws the superficial slip `u_s = ε (u_f − v_p)` and `Re = ρ |u_s| d/μ`.
//! All laws give zero force at zero slip.

use std::f64::consts::PI;

/// A drag law, as the scene names it and the GPU selects it (`DRAG_*` in `drag.wgsl`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DragLaw {
    /// Robinson eq. (28): creeping flow around one sphere.
    Stokes,
    /// Robinson eq. (29): one sphere at any Re (Khan–Richardson fit).
    CoulsonRichardson,
    /// Robinson eqs. (30)–(33): Dallavalle's C_d with Di Felice's voidage function.
    DiFelice,
    /// DEMocritus eqs. (36)–(37): Ergun below ε = 0.8, Wen–Yu above (Gidaspow's switch).
    ErgunWenYu,
    /// The same two, blended smoothly (Huilin & Gidaspow 2003).
    ErgunWenYuBlend,
}

impl DragLaw {
    /// Every law, in code order.
    pub const ALL: [DragLaw; 5] = [
        DragLaw::Stokes,
        DragLaw::CoulsonRichardson,
        DragLaw::DiFelice,
        DragLaw::ErgunWenYu,
        DragLaw::ErgunWenYuBlend,
    ];

    /// The selector `drag.wgsl` switches on.
    pub fn code(self) -> u32 {
        self as u32
    }
}

/// The WGSL constants naming the laws, generated from [`DragLaw::code`] so that the two
/// sides cannot disagree.
pub fn law_constants_wgsl() -> String {
    DragLaw::ALL
        .iter()
        .map(|l| {
            let name = match l {
                DragLaw::Stokes => "DRAG_STOKES",
                DragLaw::CoulsonRichardson => "DRAG_COULSON_RICHARDSON",
                DragLaw::DiFelice => "DRAG_DI_FELICE",
                DragLaw::ErgunWenYu => "DRAG_ERGUN_WEN_YU",
                DragLaw::ErgunWenYuBlend => "DRAG_ERGUN_WEN_YU_BLEND",
            };
            format!("const {name}: u32 = {}u;\n", l.code())
        })
        .collect()
}

pub const DRAG_WGSL: &str = include_str!("../shaders/drag.wgsl");

/// Fluid and grain at one grain: what every law needs.
#[derive(Debug, Clone, Copy)]
pub struct DragInput {
    /// Local porosity ε (fluid volume fraction), in (0, 1].
    pub porosity: f64,
    /// Grain diameter, m.
    pub diameter: f64,
    /// Intrinsic fluid density ρ_f, kg/m³.
    pub density: f64,
    /// Fluid dynamic viscosity μ, Pa·s.
    pub viscosity: f64,
    /// Fluid velocity minus grain velocity, m/s.
    pub slip: [f64; 3],
}

/// Dallavalle's drag coefficient, Robinson eq. (31).
pub fn dallavalle_cd(re: f64) -> f64 {
    (0.63 + 4.8 / re.sqrt()).powi(2)
}

/// Di Felice's exponent χ, Robinson eq. (33).
pub fn di_felice_chi(re: f64) -> f64 {
    3.7 - 0.65 * (-0.5 * (1.5 - re.log10()).powi(2)).exp()
}

/// Schiller–Naumann: `24/Re (1 + 0.15 Re^0.687)` below Re = 1000, 0.44 above (the C_D of
/// Wen–Yu's β in DEMocritus eq. 37, as OpenFOAM's GidaspowErgunWenYu uses it).
pub fn schiller_naumann_cd(re: f64) -> f64 {
    if re < 1000.0 {
        24.0 / re * (1.0 + 0.15 * re.powf(0.687))
    } else {
        0.44
    }
}

/// Khan–Richardson's C_D in the form Coulson & Richardson quote, `2 (1.84 Re^-0.31 +
/// 0.293 Re^0.06)^3.45` (Robinson eq. 29).
pub fn coulson_richardson_cd(re: f64) -> f64 {
    2.0 * (1.84 * re.powf(-0.31) + 0.293 * re.powf(0.06)).powf(3.45)
}

/// Ergun's momentum-exchange coefficient over (1 − ε) (DEMocritus eq. 37, ε ≤ 0.8):
/// `150 (1 − ε) μ/(ε d²) + 1.75 ρ |u − v| / d`, finite at ε = 1.
fn ergun_over_solid(eps: f64, d: f64, rho: f64, mu: f64, speed: f64) -> f64 {
    150.0 * (1.0 - eps) * mu / (eps * d * d) + 1.75 * rho * speed / d
}

/// Wen–Yu's coefficient over (1 − ε) (DEMocritus eq. 37, ε ≥ 0.8): `3/4 C_D ε ρ |u − v|
/// ε^-2.65 / d` with C_D Schiller–Naumann at `Re = ε ρ |u − v| d / μ`; `C_D |u − v|` is
/// formed without dividing by Re, so zero slip is finite.
fn wen_yu_over_solid(eps: f64, d: f64, rho: f64, mu: f64, speed: f64) -> f64 {
    let re = eps * rho * speed * d / mu;
    let cd_speed = if re < 1000.0 {
        24.0 * mu / (eps * rho * d) * (1.0 + 0.15 * re.powf(0.687))
    } else {
        0.44 * speed
    };
    0.75 * cd_speed * eps * rho * eps.powf(-2.65) / d
}

/// Huilin & Gidaspow's (2003) weight of Wen–Yu against Ergun: ½ at ε = 0.8.
pub fn huilin_gidaspow_weight(eps: f64) -> f64 {
    0.5 + (262.5 * (eps - 0.8)).atan() / PI
}

/// Drag force on one grain, N (CPU twin of `drag_force` in `drag.wgsl`).
pub fn drag_force(law: DragLaw, i: &DragInput) -> [f64; 3] {
    let (eps, d, rho, mu) = (i.porosity, i.diameter, i.density, i.viscosity);
    let speed = i.slip.iter().map(|c| c * c).sum::<f64>().sqrt();
    if speed == 0.0 {
        return [0.0; 3];
    }
    // Force per unit slip (u_f − v_p).
    let b = match law {
        // Robinson eq. (28) on u_s = ε (u_f − v_p).
        DragLaw::Stokes => 3.0 * PI * mu * d * eps,
        DragLaw::CoulsonRichardson => {
            let us = eps * speed;
            let re = rho * us * d / mu;
            // Robinson eq. (29): π/4 d² ρ |u_s| (…)^3.45 per unit u_s.
            0.25 * PI * d * d * rho * us * 0.5 * coulson_richardson_cd(re) * eps
        }
        DragLaw::DiFelice => {
            let us = eps * speed;
            let re = rho * us * d / mu;
            // Robinson eq. (30); C_d |u_s| without dividing by Re: (0.63 √Re + 4.8)² μ/(ρ d).
            let cd_us = (0.63 * re.sqrt() + 4.8).powi(2) * mu / (rho * d);
            0.125 * cd_us * eps.powf(-di_felice_chi(re)) * PI * d * d * rho * eps
        }
        DragLaw::ErgunWenYu | DragLaw::ErgunWenYuBlend => {
            let volume = PI * d * d * d / 6.0;
            let beta_over_solid = match law {
                DragLaw::ErgunWenYu if eps < 0.8 => ergun_over_solid(eps, d, rho, mu, speed),
                DragLaw::ErgunWenYu => wen_yu_over_solid(eps, d, rho, mu, speed),
                _ => {
                    let w = huilin_gidaspow_weight(eps);
                    (1.0 - w) * ergun_over_solid(eps, d, rho, mu, speed)
                        + w * wen_yu_over_solid(eps, d, rho, mu, speed)
                }
            };
            // DEMocritus eq. (36): β V / (1 − ε).
            beta_over_solid * volume
        }
    };
    i.slip.map(|c| b * c)
}

/// Momentum-exchange coefficient β: drag per unit mixture volume per unit slip,
/// `n_p |f| / |u_f − v_p|` with `n_p = (1 − ε) / (π d³/6)` grains per unit volume (how
/// `validation/porous_drag_beta_examples.csv` states every law).
pub fn momentum_exchange(law: DragLaw, i: &DragInput) -> f64 {
    let f = drag_force(law, i);
    let speed = i.slip.iter().map(|c| c * c).sum::<f64>().sqrt();
    let n = (1.0 - i.porosity) / (PI * i.diameter.powi(3) / 6.0);
    n * f.iter().map(|c| c * c).sum::<f64>().sqrt() / speed
}

/// One row of the `drag_table` parity kernel (WGSL `DragCase`: a `vec3<f32>` then five
/// scalars, 32 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct DragCase {
    slip: [f32; 3],
    law: u32,
    eps: f32,
    d: f32,
    rho: f32,
    mu: f32,
}

/// Evaluates `drag_force` of `drag.wgsl` on the GPU for each case (the parity test's
/// GPU side; the coupling kernel fuses the same functions).
pub fn drag_table_gpu(
    gpu: &crate::gpu::Gpu,
    cases: &[(DragLaw, DragInput)],
) -> Result<Vec<[f32; 3]>, crate::gpu::GpuError> {
    use wgpu::util::DeviceExt;
    let rows: Vec<DragCase> = cases
        .iter()
        .map(|(law, i)| DragCase {
            slip: i.slip.map(|c| c as f32),
            law: law.code(),
            eps: i.porosity as f32,
            d: i.diameter as f32,
            rho: i.density as f32,
            mu: i.viscosity as f32,
        })
        .collect();
    let input = gpu
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("drag cases"),
            contents: bytemuck::cast_slice(&rows),
            usage: wgpu::BufferUsages::STORAGE,
        });
    let output = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("drag forces"),
        size: (16 * rows.len().max(1)) as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let consts = law_constants_wgsl();
    let module = crate::shaders::module(gpu, "drag_table", &[&consts, DRAG_WGSL]);
    let pipeline = crate::shaders::compute_pipeline(gpu, "drag_table", &module, "drag_table");
    let group = crate::shaders::bind_buffers(
        gpu,
        "drag_table",
        &pipeline.get_bind_group_layout(0),
        &[&input, &output],
    );
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        crate::shaders::dispatch_linear(&mut pass, rows.len() as u32);
    }
    gpu.queue.submit([encoder.finish()]);
    let out = gpu.read_buffer::<[f32; 4]>(&output, 0, rows.len() as u64)?;
    Ok(out.into_iter().map(|v| [v[0], v[1], v[2]]).collect())
}

impl From<couplet_protocol::DragLawName> for DragLaw {
    fn from(n: couplet_protocol::DragLawName) -> Self {
        use couplet_protocol::DragLawName as N;
        match n {
            N::Stokes => DragLaw::Stokes,
            N::CoulsonRichardson => DragLaw::CoulsonRichardson,
            N::DiFelice => DragLaw::DiFelice,
            N::ErgunWenYu => DragLaw::ErgunWenYu,
            N::ErgunWenYuBlend => DragLaw::ErgunWenYuBlend,
        }
    }
}
