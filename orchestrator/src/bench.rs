//! `couplet bench`: a scene headless, timed. Reports the figures BENCHMARKS.md asks for:
//! particles, neighbours per particle, fluid steps/s, particle-steps/s, pair
//! interactions/s, time per GPU stage, and the exchange's share of a coupling window.

use crate::run::{RunError, RunOptions, resolve_scene, run};
use couplet_fluid::gpu::Gpu;
use couplet_fluid::solver::FluidSolver;
use couplet_fluid::timing::StageTimer;
use std::fmt::Write;
use std::path::Path;
use std::time::Instant;

#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    Run(#[from] RunError),
    #[error(transparent)]
    Gpu(#[from] couplet_fluid::gpu::GpuError),
    #[error(transparent)]
    Fluid(#[from] couplet_fluid::FluidError),
    #[error("the scene has no fluid: `couplet bench` times the fluid server")]
    NoFluid,
}

/// Warm-up steps before timing: the first dispatches compile pipelines lazily on some drivers.
const WARMUP_STEPS: u32 = 3;

pub fn bench(
    scene_path: &Path,
    steps: u32,
    overrides: &[(String, String)],
) -> Result<String, BenchError> {
    let (scene, _) = resolve_scene(scene_path, overrides)?;
    if scene.fluid.is_none() {
        return Err(BenchError::NoFluid);
    }
    let gpu = Gpu::new()?;
    let mut solver = FluidSolver::new(&gpu, &scene)?;
    let dt = solver.limits().dt;

    // Bodies, if any, are frozen where the scene puts them: the fluid's cost does not
    // depend on where they are. Their markers come from the DEM crate's generator.
    if scene.has_resolved_bodies() {
        let markers =
            couplet_dem::markers::MarkerSet::from_scene(&scene).map_err(|e| RunError::Io {
                what: "generating markers for the bench".into(),
                source: std::io::Error::other(e.to_string()),
            })?;
        let states = starting_states(&scene)?;
        let mut points = Vec::new();
        markers.world_points(&states, &mut points);
        solver.set_bodies(&gpu, &states, &points, &[])?;
    }

    // After the markers: they add particles and carve fluid out of the bodies.
    let counts = solver.counts();
    let total = (counts.fluid + counts.wall + counts.markers) as f64;
    solver.advance(&gpu, dt * WARMUP_STEPS as f64, None)?;
    let neighbours = solver.neighbour_stats(&gpu)?;
    // Every particle takes part in one neighbour pass per derivative evaluation — fluid
    // particles in the fused continuity + momentum pass, wall and marker particles in the
    // boundary-pressure pass — and a predictor–corrector step evaluates twice (Joubert
    // eqs. 20–21). Neighbours are counted for fluid particles (walls see fewer).
    let passes = 2.0;

    // Wall clock without per-stage instrumentation …
    let t = Instant::now();
    let (record0, submit0) = solver.record_seconds();
    solver.advance(&gpu, dt * steps as f64, None)?;
    let wall = t.elapsed().as_secs_f64();
    let (record, submit) = solver.record_seconds();
    let (record, submit) = (record - record0, submit - submit0);
    // Every buffer the run keeps, after both kinds of step and a read-back; before the
    // stage timer's query buffers.
    let memory = gpu.buffer_memory()?;
    let cell_bytes = solver.grid_cell_bytes();
    // … then the same number of steps again with every stage timed.
    let mut timer = StageTimer::new(&gpu, 64);
    solver.advance(&gpu, dt * steps as f64, Some(&mut timer))?;
    let stages = timer.collect(&gpu)?;

    let steps_f = steps as f64;
    let mut o = String::new();
    let w = &mut o;
    let _ = writeln!(
        w,
        "scene: {} (δ = {} m)",
        scene.meta.name,
        scene.fluid.as_ref().map_or(0.0, |f| f.spacing)
    );
    let _ = writeln!(w, "adapter: {}", gpu.describe());
    let _ = writeln!(
        w,
        "precision: f32; neighbour build (counting sort) included in every step"
    );
    let _ = writeln!(
        w,
        "particles: {} ({} fluid, {} wall, {} markers)",
        total, counts.fluid, counts.wall, counts.markers
    );
    let _ = writeln!(
        w,
        "neighbours per fluid particle (inside the support): {neighbours:.1}"
    );
    let _ = writeln!(w, "neighbour passes per step: {passes}");
    let _ = writeln!(
        w,
        "lanes per fluid particle in the rates pass: {} (neighbour_grid::dense_team_lanes)",
        solver.constants().dense_lanes
    );
    let _ = writeln!(w, "steps timed: {steps}, wall {wall:.3} s");
    // Where the GPU runs behind the CPU and record + submit near the wall time per
    // step, the step is bound by the CPU (encoding, bind groups, submission), not the
    // GPU; on lavapipe the submit waits for the work, so there it is the wall time and
    // the recording alone is the CPU's own share.
    let _ = writeln!(
        w,
        "CPU time a step: {:.3} ms to record, {:.3} ms to submit, of {:.3} ms wall",
        record / steps_f * 1e3,
        submit / steps_f * 1e3,
        wall / steps_f * 1e3
    );
    let _ = writeln!(w, "fluid steps/s: {:.2}", steps_f / wall);
    let _ = writeln!(w, "particle-steps/s: {:.3e}", total * steps_f / wall);
    let _ = writeln!(
        w,
        "pair-interactions/s: {:.3e}",
        total * neighbours * passes * steps_f / wall
    );
    let _ = writeln!(
        w,
        "{}",
        memory_lines(&gpu, &solver, memory, cell_bytes, total)
    );
    let _ = writeln!(
        w,
        "\ntime per stage ({}), per step:",
        if gpu.timestamps {
            "GPU timestamp queries"
        } else {
            "wall time per submitted pass"
        }
    );
    let stage_total: f64 = stages.iter().map(|s| s.1).sum();
    for (name, secs) in &stages {
        let _ = writeln!(
            w,
            "  {name:<24} {:>10.3} ms  {:>5.1} %",
            secs / steps_f * 1e3,
            100.0 * secs / stage_total.max(1e-30)
        );
    }

    if !scene.grains().is_empty() {
        let states = starting_states(&scene)?;
        let _ = writeln!(w, "\n{}", grain_porosity_time(&scene, &states, &solver));
        let _ = writeln!(
            w,
            "{}",
            grain_window_start_time(&states, &gpu, &mut solver)?
        );
    }

    if scene.needs_dem() {
        let windows = 50u64.max(steps as u64 / scene.coupling.window_substeps as u64);
        let out = std::env::temp_dir().join(format!("couplet-bench-{}", std::process::id()));
        let s = run(&RunOptions {
            scene: scene_path.to_owned(),
            out: Some(out.clone()),
            overrides: overrides.to_vec(),
            max_windows: Some(windows),
            record: false,
            progress: false,
            run_id: None,
            external: Vec::new(),
            checkpoint_every: None,
            restore: None,
        })?;
        let _ = std::fs::remove_dir_all(&out);
        let _ = writeln!(
            w,
            "\ncoupled exchange over {} windows (separate processes, iceoryx2):",
            s.windows
        );
        let _ = writeln!(w, "  window wall time       {:>10.1} µs", s.window_wall_us);
        let _ = writeln!(
            w,
            "  fluid compute          {:>10.1} µs",
            s.fluid_compute_us
        );
        let _ = writeln!(w, "  DEM compute            {:>10.1} µs", s.dem_compute_us);
        let _ = writeln!(
            w,
            "  exchange (both ways)   {:>10.1} µs  = {:.2} % of the window",
            s.exchange_us,
            100.0 * s.exchange_us / s.window_wall_us.max(1e-30)
        );
        if scene.loads_known_at_window_start() {
            let _ = writeln!(
                w,
                "  (loads sent before the fluid advances: the DEM steps beside the fluid, \
                 so their times overlap in the wall time)"
            );
        }
    } else {
        let _ = writeln!(
            w,
            "\nexchange: none (no DEM server for this scene: nothing crosses between processes)"
        );
    }
    Ok(o)
}

/// What the fluid's GPU buffers take, per particle and in all, and how many particles of
/// this scene's kind the BENCHMARKS.md target's 80 GB device would hold
/// (`../shared/BENCHMARKS.md`: ≥ 400 M particles in 80 GB, ≤ 190 B a particle).
fn memory_lines(
    gpu: &Gpu,
    solver: &FluidSolver,
    memory: u64,
    cell_bytes: u64,
    particles: f64,
) -> String {
    const MIB: f64 = 1024.0 * 1024.0;
    const TARGET_DEVICE: f64 = 80e9;
    let per_particle = memory as f64 / particles;
    let particle_part = memory.saturating_sub(cell_bytes) as f64 / particles;
    // Each per-particle buffer is one binding: the adapter's largest storage binding caps
    // the particles of one solver at its widest, whatever the memory.
    let binding = gpu.storage_binding_limit;
    let (widest, stride) = solver.widest_particle_buffer();
    format!(
        "GPU buffer memory (wgpu-hal's count of live buffers, after the warm-up): {:.2} MiB, \
         {per_particle:.1} B a particle; of it the neighbour grid's {} cells {:.2} MiB \
         ({:.1} B a cell), the rest {particle_part:.1} B a particle\n\
         at {per_particle:.1} B a particle an 80 GB device holds {:.0} M such particles; \
         one binding ({binding} B at most here) holds the widest buffer, `{widest}` at \
         {stride} B a particle, for {:.2} M",
        memory as f64 / MIB,
        solver.grid_cells(),
        cell_bytes as f64 / MIB,
        cell_bytes as f64 / f64::from(solver.grid_cells().max(1)),
        TARGET_DEVICE / per_particle / 1e6,
        (binding / stride) as f64 / 1e6,
    )
}

/// The bodies' states where the scene puts them, from its DEM engine.
fn starting_states(
    scene: &couplet_protocol::Scene,
) -> Result<Vec<couplet_protocol::BodyState>, BenchError> {
    let engine = couplet_dem::registry::create_engine(scene).map_err(|e| RunError::Io {
        what: "creating the DEM engine for the bench".into(),
        source: std::io::Error::other(e.to_string()),
    })?;
    let mut states = Vec::new();
    engine.states(&mut states);
    Ok(states)
}

/// The fluid server's CPU share of a window with unresolved grains: the porosity at
/// every grain (Robinson eq. 9, `GrainPorosity`, f64) at the grains' starting places, as
/// a run computes it once a window between the GPU's steps, so that on a fast GPU it can
/// set the window's pace (a coupled run's "fluid compute" includes it): the first window
/// builds the neighbour lists, the others sum them; the fastest of five each.
fn grain_porosity_time(
    scene: &couplet_protocol::Scene,
    states: &[couplet_protocol::BodyState],
    solver: &FluidSolver,
) -> String {
    use couplet_fluid::porosity::{GrainPorosity, PorosityField, Solid};
    let solids: Vec<Solid> = (scene.grains().into_iter())
        .map(|i| Solid {
            position: states[i].position,
            volume: states[i].volume,
        })
        .collect();
    let field = PorosityField::of_scene(solver.constants(), scene);
    let (mut first, mut later) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..5 {
        let mut lists = GrainPorosity::new(field);
        let t = Instant::now();
        std::hint::black_box(lists.porosity(&solids));
        first = first.min(t.elapsed().as_secs_f64());
        let t = Instant::now();
        std::hint::black_box(lists.porosity(&solids));
        later = later.min(t.elapsed().as_secs_f64());
    }
    format!(
        "grain porosity (Robinson eq. 9 at {} grains, CPU f64, once a window): {:.3} ms a window \
         from the neighbour lists, {:.3} ms when they are built; {} thread(s)",
        solids.len(),
        later * 1e3,
        first * 1e3,
        PorosityField::threads(solids.len())
    )
}

/// The whole of a grain window's start on the fluid side, as a coupled run pays it before
/// the fluid's first step (`FluidSolver::grain_loads`: the porosity at the grains on the
/// CPU, then on the GPU the sort, `sample_grains`, the porosity at the fluid particles
/// and the EOS at it, the samples read back, and with two-way coupling the reaction
/// spread): wall time, the fastest and the mean of ten after one untimed, at the
/// grains' starting places (their lists built by the untimed one). Less the porosity
/// above, what is left is the GPU's share and its two waits. Then ten more with every
/// GPU stage timed, as the steps' table times them, each stage's mean a window start.
fn grain_window_start_time(
    states: &[couplet_protocol::BodyState],
    gpu: &Gpu,
    solver: &mut FluidSolver,
) -> Result<String, BenchError> {
    solver.grain_loads(gpu, states, None)?;
    let (mut fastest, mut total) = (f64::INFINITY, 0.0);
    const TIMED: u32 = 10;
    for _ in 0..TIMED {
        let t = Instant::now();
        std::hint::black_box(solver.grain_loads(gpu, states, None)?);
        let s = t.elapsed().as_secs_f64();
        fastest = fastest.min(s);
        total += s;
    }
    let mut timer = StageTimer::new(gpu, 64);
    for _ in 0..TIMED {
        solver.grain_loads(gpu, states, Some(&mut timer))?;
        timer.collect(gpu)?;
    }
    let mut o = format!(
        "grain window start (porosity, sort, sample_grains, fluid porosity and EOS, read back{}): \
         {:.3} ms fastest, {:.3} ms mean of {TIMED}; its GPU stages, a window start:",
        if solver.constants().grain_reaction {
            ", reaction spread"
        } else {
            ""
        },
        fastest * 1e3,
        total / f64::from(TIMED) * 1e3
    );
    for (name, secs) in timer.totals() {
        let _ = write!(
            o,
            "\n  {name:<24} {:>10.3} ms",
            secs / f64::from(TIMED) * 1e3
        );
    }
    Ok(o)
}

/// `couplet bench-dem`: the soft-sphere engine alone on `spheres` spheres (r = 1 mm,
/// ρ = 2500, e = 0.5, μ = 0.5) on a cubic lattice of spacing 1.98 mm, so that every
/// sphere starts pressed against its six neighbours and the contacts stay busy while
/// the block relaxes under gravity; `steps` steps at the engine's stable step after 10
/// of warm-up. Reports steps/s, sphere-steps/s and contacts per sphere (BENCHMARKS.md
/// units for particle methods).
pub fn bench_dem(spheres: usize, contact: &str, steps: u32) -> Result<String, BenchError> {
    use couplet_dem::DemEngine;
    let (r, pitch) = (1e-3, 1.98e-3);
    let side = (spheres as f64).cbrt().ceil() as usize;
    let extent = side as f64 * pitch + 4.0 * r;
    let law = match contact {
        "linear" => "contact = \"linear\"\nstiffness = 100.0",
        _ => "contact = \"hertz-mindlin\"\nyoungs_modulus = 1e7",
    };
    let text = format!(
        "[meta]\nname = \"bench-dem\"\n[time]\nend = 1.0\noutput_interval = 0.1\n\
         [domain]\nmin = [0, 0, 0]\nmax = [{extent}, {}, {extent}]\n\
         [dem]\nengine = \"soft-sphere\"\n[dem.soft_sphere]\n{law}\n\
         [[bodies]]\nname = \"grain\"\nshape.sphere.radius = {r}\ndensity = 2500.0\n\
         position = [{r}, {r}, {r}]\nrestitution = 0.5\nfriction = 0.5\n",
        2.0 * extent
    );
    let mut scene = couplet_protocol::Scene::parse(&text, Path::new("bench-dem")).map_err(|e| {
        RunError::Io {
            what: "building the bench scene".into(),
            source: std::io::Error::other(e.to_string()),
        }
    })?;
    let template = scene.bodies.pop().expect("the template body");
    for k in 0..spheres {
        let (i, j, l) = (k % side, (k / side) % side, k / (side * side));
        let mut b = template.clone();
        b.name = format!("grain{k}");
        b.position = [i, j, l].map(|c| 2.0 * r + c as f64 * pitch);
        scene.bodies.push(b);
    }
    let dem_err = |e: couplet_dem::DemError| RunError::Io {
        what: "the soft-sphere bench".into(),
        source: std::io::Error::other(e.to_string()),
    };
    let built = Instant::now();
    let mut engine = couplet_dem::SoftSphereEngine::new(&scene).map_err(dem_err)?;
    let build_s = built.elapsed().as_secs_f64();
    let dt = engine.stable_dt();
    for _ in 0..10 {
        engine.step(dt).map_err(dem_err)?;
    }
    let t = Instant::now();
    for _ in 0..steps {
        engine.step(dt).map_err(dem_err)?;
    }
    let secs = t.elapsed().as_secs_f64();
    let mut o = String::new();
    let _ = writeln!(o, "soft-sphere DEM, contact = {contact}, {spheres} spheres");
    let _ = writeln!(o, "  setup                {build_s:.3} s");
    let _ = writeln!(o, "  step                 {dt:.3e} s (t_c / 50)");
    let _ = writeln!(o, "  threads              {}", engine.force_threads());
    let _ = writeln!(
        o,
        "  contacts per sphere  {:.2}",
        2.0 * engine.contact_count() as f64 / spheres as f64
    );
    let _ = writeln!(o, "  steps/s              {:.1}", steps as f64 / secs);
    let _ = writeln!(
        o,
        "  sphere-steps/s       {:.3e}",
        steps as f64 * spheres as f64 / secs
    );
    Ok(o)
}
