//! Diagnostic: what the fluid's force on a rigid block of unresolved grains is made of,
//! at one snapshot of a run (the constant-porosity block, ARCHITECTURE.md). From the
//! snapshot's fluid (positions, pressures, densities, velocities) and the grains' states
//! at the nearest body time it sums, grain by grain, with the same kernel and formulas
//! as the fluid server's CPU twins:
//!
//! - the `energy-pair` pressure force f_j = −V_j Σ_a V_a P_a ∇_j W_ja
//!   ([`couplet_fluid::unresolved_coupling::grain_pressure_force_cpu`]), split into the
//!   part of the pressure level at the grain, −P̂_j V_j ∇S_j (P̂_j the Shepard-interpolated
//!   pressure, S_j = Σ_a V_a W_ja the fluid's Shepard sum at the grain), and the rest,
//!   −V_j Σ_a V_a (P_a − P̂_j) ∇_j W_ja;
//! - the continuum's −V_j ∂P/∂y, from the fluid's pressure averaged in horizontal layers;
//! - the drag of the scene's law on the slip at the grain's porosity (Robinson eq. 9 at
//!   the grain, the Shepard-interpolated fluid velocity, eq. 8);
//!
//! and prints their sums over the block and over each grain layer, in units of the
//! grains' weight, beside the recorded load nearest the snapshot. A steady fall in the
//! model of Robinson eqs. (5) and (23) splits the weight as drag ε(1 − ρ_f/ρ_p) and
//! pressure ρ_f/ρ_p + (1 − ε)(1 − ρ_f/ρ_p).
//!
//! Then the fluid through the block in bins a quarter of a lattice spacing thick: its
//! pressure less the least-squares line through the block's interior, its volume, ρ/ε,
//! the summation density Σ_b m_b W_ab over ε, vertical velocity, ε and Σ_b m_b W_ab.
//! This found the odd-even row mode of the pressure among grains (ARCHITECTURE.md).
//!
//! The fluid's masses are not recorded: they are those `initial_particles` gives the
//! scene now, or with `--lattice-masses` the porosity of each particle's starting point
//! times the lattice mass (how the fluid among grains started before 2026-11-29).
//!
//! `cargo run --release -p couplet-orchestrator --example block_forces -- OUT/run.mcap
//! --at MS [--lattice-masses]`
use couplet_fluid::drag::{DragInput, DragLaw, drag_force};
use couplet_fluid::porosity::{PorosityField, Solid};
use couplet_fluid::{Kind, SphConstants, initial_particles};
use couplet_orchestrator::record::read_recording;
use couplet_protocol::cell_hash::CellHash;
use couplet_protocol::{Scene, Shape};
use std::collections::{BTreeMap, HashMap};

fn fail(msg: String) -> ! {
    eprintln!("block_forces: {msg}");
    std::process::exit(1)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(path), Some(at)) = (
        args.first(),
        (args.iter().position(|a| a == "--at"))
            .and_then(|i| args.get(i + 1))
            .and_then(|v| v.parse::<f64>().ok()),
    ) else {
        eprintln!("usage: block_forces RUN.mcap --at MS [--lattice-masses]");
        std::process::exit(2);
    };
    let lattice_masses = args.iter().any(|a| a == "--lattice-masses");
    let path = std::path::Path::new(path);
    let scene = Scene::load(&path.with_file_name("scene.toml"))
        .unwrap_or_else(|e| fail(format!("scene.toml beside the recording: {e}")));
    let c = SphConstants::from_scene(&scene).unwrap_or_else(|e| fail(e.to_string()));
    let rec = read_recording(path).unwrap_or_else(|e| fail(e));
    let set = initial_particles(&scene, &c).unwrap_or_else(|e| fail(e.to_string()));
    let fluid_ids: Vec<usize> = (0..set.len())
        .filter(|&i| set.kinds.kind(set.id[i]) == Kind::Fluid)
        .collect();
    let (t, ps) = (rec.snapshots.iter())
        .min_by(|a, b| (a.0 - 1e-3 * at).abs().total_cmp(&(b.0 - 1e-3 * at).abs()))
        .unwrap_or_else(|| fail("no fluid snapshots".into()));
    if ps.len() != fluid_ids.len() {
        fail(format!(
            "the snapshot holds {} particles, the scene starts {} fluid particles",
            ps.len(),
            fluid_ids.len()
        ));
    }
    let field = PorosityField::of_scene(&c, &scene);
    // The grains: every body of the first lattice's translation group.
    let lattice = (scene.grain_lattices.first())
        .unwrap_or_else(|| fail("the scene has no [[grain_lattices]]".into()));
    let members: Vec<usize> = (0..scene.bodies.len())
        .filter(|&i| scene.bodies[i].translation_group.as_deref() == Some(lattice.name.as_str()))
        .collect();
    let radius = match scene.bodies[members[0]].shape {
        Shape::Sphere { radius } => radius,
        _ => fail("the block's grains are not spheres".into()),
    };
    let volume = 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3);
    let solids_at = |pos: &[[f64; 3]]| -> Vec<Solid> {
        pos.iter()
            .map(|&position| Solid { position, volume })
            .collect()
    };
    let masses: Vec<f64> = if lattice_masses {
        let start: Vec<[f64; 3]> = members.iter().map(|&i| scene.bodies[i].position).collect();
        let points: Vec<[f64; 3]> = fluid_ids.iter().map(|&i| set.pos[i]).collect();
        (field.porosity(&points, &solids_at(&start)).iter())
            .map(|e| e * c.mass)
            .collect()
    } else {
        fluid_ids.iter().map(|&i| set.mass[i]).collect()
    };
    // The grains' states at the body time nearest the snapshot.
    let tb = (rec.bodies.iter())
        .map(|b| b.time)
        .min_by(|a, b| (a - t).abs().total_cmp(&(b - t).abs()))
        .unwrap_or_else(|| fail("no body states".into()));
    let mut state: HashMap<usize, ([f64; 3], [f64; 3])> = HashMap::new();
    for b in rec.bodies.iter().filter(|b| b.time == tb) {
        state.insert(b.body, (b.position, b.velocity));
    }
    let grains: Vec<([f64; 3], [f64; 3])> = (members.iter())
        .map(|i| {
            *state
                .get(i)
                .unwrap_or_else(|| fail(format!("no state of body {i} at {tb}")))
        })
        .collect();
    let gpos: Vec<[f64; 3]> = grains.iter().map(|g| g.0).collect();
    let eps_grain = field.porosity(&gpos, &solids_at(&gpos));

    let fluid: Vec<([f64; 3], [f64; 3], f64, f64)> = (ps.iter())
        .map(|p| {
            let v = |k: usize| f64::from(p[k]);
            ([v(0), v(1), v(2)], [v(4), v(5), v(6)], v(3), v(7))
        })
        .collect();
    // The fluid binned in cells of the support's size, the periodic axes wrapped (the
    // hash the porosity's grains use): `near(x)` is every fluid particle in the 27 cells
    // around x, each once.
    let r = c.support_radius();
    let mut hash = CellHash::default();
    let at: Vec<[f64; 3]> = fluid.iter().map(|f| f.0).collect();
    hash.build(
        &at,
        r,
        [0.0; 3],
        std::array::from_fn(|k| (c.period[k] > 0.0).then_some(c.period[k])),
    );
    let near = |x: [f64; 3]| hash.candidates(x).map(|a| a as usize);
    let law = DragLaw::from(scene.coupling.drag);
    let f = scene
        .fluid
        .as_ref()
        .unwrap_or_else(|| fail("no fluid".into()));
    let g = c.gravity_fluid.iter().map(|x| x * x).sum::<f64>().sqrt();
    let grain_weight = lattice.density * volume * g;

    // The continuum's pressure gradient: the pressure averaged in layers one fluid
    // spacing thick, differentiated centrally between the layers' mean heights.
    let dy = f.spacing;
    let mut layers: BTreeMap<i64, (f64, f64, f64)> = BTreeMap::new();
    for fl in &fluid {
        let e = layers.entry((fl.0[1] / dy).floor() as i64).or_default();
        *e = (e.0 + 1.0, e.1 + fl.0[1], e.2 + fl.2);
    }
    let profile: Vec<(f64, f64)> = layers.values().map(|e| (e.1 / e.0, e.2 / e.0)).collect();
    let dpdy = |y: f64| -> f64 {
        let i = (profile.windows(2))
            .position(|w| w[1].0 >= y)
            .unwrap_or(profile.len() - 2)
            .clamp(1, profile.len() - 3);
        // The two intervals around y, each a central difference.
        let s = |k: usize| (profile[k + 1].1 - profile[k].1) / (profile[k + 1].0 - profile[k].0);
        let w = ((y - profile[i].0) / (profile[i + 1].0 - profile[i].0)).clamp(0.0, 1.0);
        0.5 * (s(i - 1) + s(i)) * (1.0 - w) + 0.5 * (s(i) + s(i + 1)) * w
    };

    #[derive(Default, Clone, Copy)]
    struct Sums {
        n: f64,
        shepard: f64,
        p_hat: f64,
        pressure: f64,
        level: f64,
        rest: f64,
        continuum: f64,
        drag: f64,
        eps: f64,
        slip: f64,
    }
    let y_min = gpos.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
    let spacing_grains = (volume / (1.0 - lattice.porosity)).cbrt();
    let mut by_layer: BTreeMap<i64, Sums> = BTreeMap::new();
    let mut total = Sums::default();
    for (j, &(xj, vj)) in grains.iter().enumerate() {
        let (mut s, mut sp, mut su) = (0.0, 0.0, [0.0; 3]);
        let (mut grad_s, mut fp) = ([0.0; 3], [0.0; 3]);
        for a in near(xj) {
            let (xa, ua, pa, rho_a) = fluid[a];
            let rv = c.pair_vec(xj, xa);
            let d = rv.iter().map(|x| x * x).sum::<f64>().sqrt();
            if d >= r {
                continue;
            }
            let va = masses[a] / rho_a;
            let w = c.kernel.w(d);
            let gf = c.kernel.grad_factor(d);
            s += va * w;
            sp += va * w * pa;
            for k in 0..3 {
                su[k] += va * w * ua[k];
                grad_s[k] += va * gf * rv[k];
                fp[k] -= volume * va * pa * gf * rv[k];
            }
        }
        let p_hat = sp / s;
        let u_f: [f64; 3] = su.map(|x| x / s);
        let level = -p_hat * volume * grad_s[1];
        let drag = drag_force(
            law,
            &DragInput {
                porosity: eps_grain[j],
                diameter: 2.0 * radius,
                density: f.density,
                viscosity: f.density * f.kinematic_viscosity,
                slip: std::array::from_fn(|k| u_f[k] - vj[k]),
            },
        );
        let one = Sums {
            n: 1.0,
            shepard: s,
            p_hat,
            pressure: fp[1] / grain_weight,
            level: level / grain_weight,
            rest: (fp[1] - level) / grain_weight,
            continuum: -volume * dpdy(xj[1]) / grain_weight,
            drag: drag[1] / grain_weight,
            eps: eps_grain[j],
            slip: u_f[1] - vj[1],
        };
        let layer = ((xj[1] - y_min) / spacing_grains).round() as i64;
        for acc in [by_layer.entry(layer).or_default(), &mut total] {
            acc.n += one.n;
            acc.shepard += one.shepard;
            acc.p_hat += one.p_hat;
            acc.pressure += one.pressure;
            acc.level += one.level;
            acc.rest += one.rest;
            acc.continuum += one.continuum;
            acc.drag += one.drag;
            acc.eps += one.eps;
            acc.slip += one.slip;
        }
    }
    let (eps, ratio) = (lattice.porosity, f.density / lattice.density);
    println!(
        "snapshot t {t:.4e} s, grains at {tb:.4e} s: {} grains, block velocity {:+.4e} m/s",
        grains.len(),
        grains[0].1[1]
    );
    println!(
        "a steady fall (Robinson eqs. 5, 23): drag {:.4}, pressure {:.4} of the weight",
        eps * (1.0 - ratio),
        ratio + (1.0 - eps) * (1.0 - ratio)
    );
    let line = |label: String, s: &Sums| {
        let n = s.n;
        println!(
            "{label}: S {:.5}, P̂ {:7.2} Pa, ε {:.4}, slip {:+.3e} m/s | pressure {:+.4} = level {:+.4} + rest {:+.4} (continuum {:+.4}) | drag {:+.4} | sum {:+.4}",
            s.shepard / n,
            s.p_hat / n,
            s.eps / n,
            s.slip / n,
            s.pressure / n,
            s.level / n,
            s.rest / n,
            s.continuum / n,
            s.drag / n,
            (s.pressure + s.drag) / n
        );
    };
    for (k, s) in &by_layer {
        line(format!("layer {k:2}"), s);
    }
    line("block   ".into(), &total);
    // The fluid's pressure through the block, in bins a quarter of a lattice spacing
    // thick, less the least-squares line through the interior (two spacings in from
    // each face), with the fluid's volume per bin volume.
    let layers_n = by_layer.len() as f64;
    let inside = |y: f64| {
        let u = (y - y_min) / spacing_grains;
        (2.0..=layers_n - 3.0).contains(&u)
    };
    let (mut n, mut sy, mut sp, mut syy, mut syp) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for fl in fluid.iter().filter(|fl| inside(fl.0[1])) {
        let (y, p) = (fl.0[1], fl.2);
        n += 1.0;
        sy += y;
        sp += p;
        syy += y * y;
        syp += y * p;
    }
    let slope = (n * syp - sy * sp) / (n * syy - sy * sy);
    let icpt = (sp - slope * sy) / n;
    println!(
        "pressure through the block's interior: {slope:.1} Pa/m (hydrostatic {:.1}); less that line, by quarter lattice spacing from the lowest layer:",
        -f.density * c.gravity_fluid[1]
    );
    let area: f64 = (0..3).filter(|&k| k != 1).map(|k| c.period[k]).product();
    // Each particle's summation density Σ_b m_b W_ab (fluid only: the block is far
    // from the walls) beside its density, both over its porosity at the snapshot.
    let points: Vec<[f64; 3]> = fluid.iter().map(|fl| fl.0).collect();
    let eps_fluid = field.porosity(&points, &solids_at(&gpos));
    // What sets a closed column's pressure level: the fluid's volume Σ m_a/ρ_a and its
    // intrinsic volume Σ ε_a m_a/ρ_a (the grains' volume is the difference).
    let fluid_volume: f64 = (fluid.iter().enumerate())
        .map(|(a, fl)| masses[a] / fl.3)
        .sum();
    let intrinsic: f64 = (fluid.iter().enumerate())
        .map(|(a, fl)| eps_fluid[a] * masses[a] / fl.3)
        .sum();
    println!(
        "fluid volume Σ m/ρ {:.6} mm³, intrinsic Σ ε m/ρ {:.6} mm³, grains Σ V_j {:.6} mm³, mean pressure {:.2} Pa",
        fluid_volume * 1e9,
        intrinsic * 1e9,
        grains.len() as f64 * volume * 1e9,
        fluid.iter().map(|fl| fl.2).sum::<f64>() / fluid.len() as f64
    );
    let summation = |a: usize| -> f64 {
        near(fluid[a].0)
            .map(|b| {
                let rv = c.pair_vec(fluid[a].0, fluid[b].0);
                let d = rv.iter().map(|x| x * x).sum::<f64>().sqrt();
                if d < r {
                    masses[b] * c.kernel.w(d)
                } else {
                    0.0
                }
            })
            .sum()
    };
    let mut bins: BTreeMap<i64, [f64; 8]> = BTreeMap::new();
    for (a, fl) in fluid.iter().enumerate() {
        let u = (fl.0[1] - y_min) / spacing_grains;
        if !(-1.0..=layers_n).contains(&u) {
            continue;
        }
        let e = bins.entry((u * 4.0).floor() as i64).or_default();
        let sum = summation(a);
        for (k, v) in [
            1.0,
            fl.2 - (icpt + slope * fl.0[1]),
            masses[a] / fl.3,
            fl.3 / eps_fluid[a],
            sum / eps_fluid[a],
            fl.1[1],
            eps_fluid[a],
            sum,
        ]
        .into_iter()
        .enumerate()
        {
            e[k] += v;
        }
    }
    for (k, [n, dp, v, rho, sum, uy, e, sm]) in &bins {
        println!(
            "  {:+6.2} Δr: {n:4} particles, p − line {:+7.2} Pa, Σ V_a / bin volume {:.4}, ρ/ε {:.4}, Σ m W/ε {:.4}, u_y {:+.3e}, ε {:.6}, Σ m W {:.4}",
            *k as f64 / 4.0,
            dp / n,
            v / (area * 0.25 * spacing_grains),
            rho / n,
            sum / n,
            uy / n,
            e / n,
            sm / n
        );
    }
    let tl = (rec.loads.iter())
        .map(|l| l.time)
        .min_by(|a, b| (a - t).abs().total_cmp(&(b - t).abs()));
    if let Some(tl) = tl {
        let recorded: f64 = (rec.loads.iter())
            .filter(|l| l.time == tl && members.binary_search(&l.body).is_ok())
            .map(|l| l.force[1])
            .sum();
        println!(
            "recorded load at {tl:.4e} s: {:+.4} of the weight (the window's mean over its stages)",
            recorded / (grain_weight * grains.len() as f64)
        );
    }
}
