//! `couplet validate`: the named validation cases (DESIGN.md, "Validation cases and
//! reports"). A case is a shipped scene, the overrides of its CI-sized `--quick` version,
//! and the comparison of its recording with a reference. A run prints a markdown table
//! (quantity, measured, reference, tolerance, PASS/FAIL) with the wall time, writes it
//! to `OUT/report.md` with CSV time series and SVG plots, and fails when a judged row
//! fails. Rows without a tolerance are reported, not judged (for instance a coarse run's
//! distance from a correlation that only a finer resolution can meet).

use crate::record::{BodySample, Particle, Recording, track};
use crate::run::{RunError, RunOptions, resolve_scene, run};
use couplet_protocol::Scene;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

// The cases by family, the sweep and the report's files; each module takes what it
// needs from here with `use super::*`, and the cases table below names their analyses.
mod fluid;
mod joubert;
mod report_files;
mod robinson;
mod sweep;

pub use self::fluid::morris_channel_velocity;
pub use self::joubert::joubert_terminal_velocity;
pub use self::sweep::{
    Gathered, SWEEP_ROW_FILE, SweepPoint, SweepSpec, sweep, sweep_gather, sweep_point, sweep_specs,
};
use self::{fluid::*, joubert::*, report_files::*, robinson::*, sweep::*};

/// Why a validation could not run (a failed comparison is a [`Report`], not an error).
#[derive(Debug, thiserror::Error)]
pub enum ValidateError {
    #[error("no validation case `{0}`; `couplet validate --list` names them")]
    Unknown(String),
    #[error("case `{case}` has no variant `{asked}`; its variants: {known}")]
    UnknownVariant {
        case: String,
        asked: String,
        known: String,
    },
    #[error("scene file {0} not found (run from the repository root, or pass --scenes DIR)")]
    NoScene(PathBuf),
    #[error(transparent)]
    Run(#[from] RunError),
    #[error("reading the recording: {0}")]
    Recording(String),
    #[error("{what}: {source}")]
    Io {
        what: String,
        source: std::io::Error,
    },
    #[error("{0}")]
    Analysis(String),
    #[error("case `{0}` has no sweep (no spacings or schemes to run)")]
    NoSweep(String),
    #[error("case `{case}`'s sweep has {count} points, 0 to {}: there is no point {point}", count - 1)]
    PointOutOfRange {
        case: String,
        point: usize,
        count: usize,
    },
    #[error("{}: not a row of this sweep: {why}", file.display())]
    BadRow { file: PathBuf, why: String },
    #[error(
        "no row of case `{case}`'s sweep under {} (none of its {count} points has written its {SWEEP_ROW_FILE})",
        out.display()
    )]
    NoRows {
        case: String,
        out: PathBuf,
        count: usize,
    },
}

impl ValidateError {
    /// Ctrl-C or SIGTERM stopped a run ([`RunError::Interrupted`]).
    pub fn is_interrupted(&self) -> bool {
        matches!(self, Self::Run(e) if e.is_interrupted())
    }
}

/// A case's judgement of its variants' reports against each other.
type Compare = fn(&[Report], &mut Report) -> Result<(), String>;

/// A case's variant: (label, overrides).
type Variant = (&'static str, &'static [&'static str]);

/// One named case.
pub struct Case {
    pub name: &'static str,
    /// The scene file in `scenes/`.
    pub scene: &'static str,
    /// What is compared with what.
    pub about: &'static str,
    /// Overrides of the `--quick` (CI) version, `PATH=VALUE`, and why.
    pub quick: &'static [&'static str],
    pub quick_why: &'static str,
    /// `--sweep`: the spacings (m) and the schemes (label, overrides) run on top of the
    /// quick version, every pair once.
    pub sweep_spacings: &'static [f64],
    pub sweep_schemes: &'static [(&'static str, &'static [&'static str])],
    /// The periodic axes along which the flow does not vary and which run on a thin
    /// span: each sweep point makes that span (the domain's and the first fluid block's)
    /// as many of its own spacings as the quick's is of the quick's, so that a finer
    /// point adds no layers along it. Empty: the sweep keeps the quick's domain.
    pub sweep_thin_axes: &'static [usize],
    /// Runs that make up one validation, each (label, overrides) on top of the quick
    /// and sweep overrides and under the command line's: Joubert's shapes or boxes,
    /// compared with each other by `compare`. Empty: one run.
    pub variants: &'static [Variant],
    /// The `--quick` version's variants where their sizes differ from the full ones' (the
    /// CPB's column width is a whole number of lattice spacings of each ε); empty: the
    /// same `variants`.
    pub quick_variants: &'static [Variant],
    analyse: fn(&Scene, &Recording, &mut Report) -> Result<(), String>,
    /// Judges the variants' reports against each other (their `values`).
    compare: Option<Compare>,
}

/// One line of the report.
#[derive(Debug, Clone)]
pub struct Row {
    pub quantity: String,
    pub measured: String,
    pub reference: String,
    pub tolerance: String,
    /// `None`: reported, not judged.
    pub pass: Option<bool>,
}

/// A time series written as CSV (and plotted against `reference` when it has one).
#[derive(Debug, Clone, Default)]
pub struct Series {
    pub name: String,
    pub x_label: String,
    pub y_label: String,
    pub points: Vec<(f64, f64)>,
    /// Reference points drawn as markers.
    pub reference: Vec<(f64, f64)>,
}

impl Series {
    /// A body's downward velocity against time, the form every settling case plots.
    pub(super) fn downward_velocity(
        name: impl Into<String>,
        track: &[crate::record::BodySample],
        reference: Vec<(f64, f64)>,
    ) -> Series {
        Series {
            name: name.into(),
            x_label: "t (s)".into(),
            y_label: "downward velocity (m/s)".into(),
            points: track.iter().map(|b| (b.time, -b.velocity[1])).collect(),
            reference,
        }
    }
}

/// The outcome of a case.
#[derive(Debug, Clone, Default)]
pub struct Report {
    pub case: String,
    pub quick: bool,
    /// A point of `--sweep` (its index and spacing, m): the quick's run at that spacing,
    /// titled so rather than "quick".
    pub sweep_point: Option<(usize, f64)>,
    /// Analysed from a run made elsewhere (`--recording`): neither the quick nor the full
    /// version is known to be what ran, and the wall time is not this process's.
    pub from_recording: bool,
    pub rows: Vec<Row>,
    pub series: Vec<Series>,
    pub wall_s: f64,
    pub out: PathBuf,
    /// The case's error measure (name, value as a fraction) for `--sweep` tables.
    pub headline: Option<(String, f64)>,
    /// Fluid particles of the run (first snapshot).
    pub particles: usize,
    /// Named results a `compare` step reads across variants (e.g. "cd", "cd_paper").
    pub values: Vec<(&'static str, f64)>,
    /// The command line's `--set`s (path, value), applied after the case's, the
    /// version's and each variant's own: a variant's label names the case's settings
    /// ("water, α = 0.1"), which one of these may have changed.
    pub command_line: Vec<(String, String)>,
}

impl Report {
    fn judge(
        &mut self,
        quantity: impl Into<String>,
        measured: String,
        reference: String,
        tolerance: String,
        pass: Option<bool>,
    ) {
        self.rows.push(Row {
            quantity: quantity.into(),
            measured,
            reference,
            tolerance,
            pass,
        });
    }

    /// The named result `key` (see [`Report::values`]).
    pub fn value(&self, key: &str) -> Option<f64> {
        self.values.iter().find(|(k, _)| *k == key).map(|(_, v)| *v)
    }

    /// Every judged row passed.
    pub fn passed(&self) -> bool {
        self.rows.iter().all(|r| r.pass != Some(false))
    }

    pub fn markdown(&self) -> String {
        let mut t = if self.from_recording {
            format!("## {} (analysed from a recording)\n\n", self.case)
        } else {
            let kind = match (self.sweep_point, self.quick) {
                (Some((k, d)), _) => format!("sweep point {k}, δ = {d:e} m"),
                (None, true) => "quick".into(),
                (None, false) => "full".into(),
            };
            format!(
                "## {} ({kind}), wall time {:.1} s\n\n",
                self.case, self.wall_s
            )
        };
        if !self.command_line.is_empty() {
            let sets: Vec<String> = self
                .command_line
                .iter()
                .map(|(k, v)| format!("`{k}={v}`"))
                .collect();
            let _ = writeln!(
                t,
                "Set on the command line, over the case's and its variants' settings (which \
                 the labels name): {}\n",
                sets.join(", ")
            );
        }
        t.push_str(
            "| quantity | measured | reference | tolerance | result |\n|---|---|---|---|---|\n",
        );
        for r in &self.rows {
            let verdict = match r.pass {
                Some(true) => "PASS",
                Some(false) => "FAIL",
                None => "reported",
            };
            // A '|' inside a cell would end it (|v|, a failure message): shown as '∣'.
            let cell = |c: &str| c.replace('|', "∣");
            let _ = writeln!(
                t,
                "| {} | {} | {} | {} | {verdict} |",
                cell(&r.quantity),
                cell(&r.measured),
                cell(&r.reference),
                cell(&r.tolerance)
            );
        }
        t
    }
}

/// The cases, in `--list` order.
pub fn cases() -> &'static [Case] {
    &CASES
}

/// The settling sphere's `--quick` overrides, shared by the density sweep.
const SETTLING_SPHERE_QUICK: &[&str] = &[
    "fluid.spacing=1e-3",
    "fluid.support=2.4",
    "domain.max=[0.015, 0.03, 0.015]",
    "fluid.blocks.0.max=[0.015, 0.03, 0.015]",
    "bodies.0.position=[0.0075, 0.02, 0.0075]",
    "time.end=0.5",
];
const SETTLING_SPHERE_QUICK_WHY: &str = "δ = 1 mm (r = 1.25 δ), support 2.4 δ, box cut to 30 mm with the release at 20 mm, to t = 0.5 s (the sphere lands at about 0.33 s): under three minutes on lavapipe (186 s to 0.6 s on 2026-11-26, Mesa 25; plateau 0.0594 m/s, change over the last fifth 0.70 %, final vertical speed 2e-20 m/s; cut to 0.5 s the same day to keep CI near 40 minutes: the same plateau, final vertical speed 0, rolling 0.43 % of the plateau over the last 0.1 s)";

/// The quick version of the §4.2–4.3 box cases: the sphere's quick spacing and support,
/// with the box cut to 30 mm and the release at 20 mm through single components (a
/// variant sets the box's x and z).
const SHAPE_QUICK: &[&str] = &[
    "fluid.spacing=1e-3",
    "domain.max.1=0.03",
    "fluid.blocks.0.max.1=0.03",
    "bodies.0.position.1=0.02",
    "time.end=0.6",
];
const SHAPE_QUICK_WHY: &str = "δ = 1 mm, box cut to 30 mm with the release at 20 mm: 6750 fluid particles, 1–3 minutes per body on lavapipe (Mesa 25). At this δ the ring's hole and the cross's arms are about one spacing across: a run of the pipeline for every shape, not a resolution of the shapes, so Re and C_D are reported and each body's fluid force is judged against its submerged weight. Shape-drag, 2026-11-26 (Γ = 2, markers weighing their patches, shifting counting them so; 744 s for the four): force balance sphere 1.19 %, cylinder 0.77 %, ring 0.18 %, cross 0.13 % (the cross tilting 64°); Re 14.72, 12.75, 16.35, 11.59; C_D ratios to the sphere 1.393, 1.133, 1.292 against Joubert's 1.271, 1.529, 1.083 (order sphere < ring < cross < cylinder; his: sphere < cross < cylinder < ring); the cross at Γ = 4 as it runs since 2026-11-27 (below): force 0.29 %, Re 13.78, tilt 5.8°. Ring-walls, the same day (356 s for the three boxes): force balance 0.18 %, 1.10 %, 0.40 %; Re 16.35, 14.29, 11.83; C_D ratios to the full box 1.321 and 1.914 against Joubert's 1.382 and 2.391. CI runs the shape-drag ring and cross cut further (tests/tests/validation/shape_drag.rs). The full shape-drag on an NVIDIA H200 (2026-11-26, δ = 0.25 mm, 836 k particles per shape, four side by side, cut at t = 0.85 s): sphere Re 12.56 against Table 5's 13.15 (−4.5 %), cylinder 11.18 against 11.95 (−6.5 %, measured 0.9 mm above its floor stretch), force balance 0.21 % and 0.08 %, C_D ratio 1.324 against Joubert's 1.271; the ring blew up at t = 0.130 s in its hole, which had no fill behind its faces (since backed: ARCHITECTURE.md, \"Thin walls are backed patch by patch\"; so backed, on an NVIDIA H100 on 2026-11-27 it ran through at δ = 0.25 mm: Re 11.29 in the full box, −10.08 %, and 9.78 and 7.68 in the 2/3 and 1/2 boxes against 10.68 and 8.12, C_D ratios to the full box 1.329 and 2.155 against 1.38 and 2.39; with particle shifting stopping δ/2 short of a surface, alone on an H200 on 2026-12-04, Re 11.33 against 12.55, −9.74 %, force 0.12 % off its submerged weight, results/2026-12-04-h200/ring), and the cross at 0.259 s in a corner between its arms, where the carve-out had dropped the fluid layer half a spacing above its side arms to f32 round-off (kept since: ARCHITECTURE.md, \"A face half a spacing from the lattice keeps its fluid layer\"; so kept, on an H200 on 2026-11-27 the cross blew up at 0.2795 s after bursts of force from fluid pressed onto its leading faces, and at Γ = 4 fell smoothly to 0.6 s at Re 9.69, −14.8 %, force within 0.003 % of its submerged weight, C_D 1.359 times the sphere's against Joubert's 1.083: the cross variant runs at Γ = 4 since, ARCHITECTURE.md, \"Joubert's cross at δ = 0.25 mm runs with Γ = 4\"). Before particle shifting weighed markers by their patches (ARCHITECTURE.md, \"Particle shifting counts a marker as the patch it stands for\") the ring's hole held a fluid particle that shifting drove against its flow: the ring's fluid force swung from −2.6 to +4 times its weight, the quick cut to 0.4 s blew up at 0.3157 s and the 2/3 box's force balance was 9.61 % off; before markers weighed their patches the ring blew up in its hole's column at 0.0313 s, and without the mass correction (2026-11-25) the cylinder blew up at t = 0.27 s and the ring at 0.019 s";

/// Joubert's ring (Table 3: 12 trapezoidal prisms, r_i = 0.725, r_o = 1.45 mm, height
/// 1.75 mm, axis along y), as a `--set` shape value.
macro_rules! joubert_ring {
    () => {
        "{ ring = { sides = 12, inner_radius = 7.25e-4, outer_radius = 1.45e-3, half_height = 8.75e-4 } }"
    };
}

/// Joubert §4.4's two runs: the scene's five spheres, then five rings (Table 3's ring,
/// axis along y) at the same places.
const FIVE_BODY_VARIANTS: &[Variant] = &[
    ("spheres", &[]),
    (
        "rings",
        &[
            "bodies.0.name=\"ring-0\"",
            concat!("bodies.0.shape=", joubert_ring!()),
            "bodies.1.name=\"ring-1\"",
            concat!("bodies.1.shape=", joubert_ring!()),
            "bodies.2.name=\"ring-2\"",
            concat!("bodies.2.shape=", joubert_ring!()),
            "bodies.3.name=\"ring-3\"",
            concat!("bodies.3.shape=", joubert_ring!()),
            "bodies.4.name=\"ring-4\"",
            concat!("bodies.4.shape=", joubert_ring!()),
        ],
    ),
];

/// The five-bodies quick version: δ = 0.5 mm to 0.1 s (see its `quick_why`).
const FIVE_BODY_QUICK: &[&str] = &["fluid.spacing=5e-4", "time.end=0.1"];

/// `sphere-density-sweep`'s full case: the settling sphere (whose scene runs δ = 0.625 mm
/// with the Wendland kernel at 3δ) at Joubert §4.2's δ = 0.25 mm, quintic kernel, support
/// 2.4δ, at the three densities of his Fig. 21. Released at 40 mm; eqs. (37)–(38) give 24,
/// 48 and 80 mm/s, so ρs = 1100 lands at about 1.7 s (an H200 run cut at 0.85 s was at
/// 21.45 mm, falling at 24.1 mm/s) and runs to 1.9 s; the scene's 1.0 s lands the others.
const SPHERE_DENSITIES: &[Variant] = &[
    (
        "ρs = 1100",
        &[
            "fluid.spacing=2.5e-4",
            "fluid.kernel=\"quintic\"",
            "fluid.support=2.4",
            "bodies.0.density=1100",
            "time.end=1.9",
        ],
    ),
    (
        "ρs = 1250",
        &[
            "fluid.spacing=2.5e-4",
            "fluid.kernel=\"quintic\"",
            "fluid.support=2.4",
            "bodies.0.density=1250",
        ],
    ),
    (
        "ρs = 1500",
        &[
            "fluid.spacing=2.5e-4",
            "fluid.kernel=\"quintic\"",
            "fluid.support=2.4",
            "bodies.0.density=1500",
        ],
    ),
];

/// Joubert Table 3's four shapes, the sphere first (the reference of Table 5's ratios).
const SHAPE_VARIANTS: &[Variant] = &[
    ("sphere", &[]),
    (
        "cylinder",
        &[
            "bodies.0.name=\"cylinder\"",
            "bodies.0.shape={ prism = { sides = 12, radius = 1.25e-3, half_height = 8.75e-4 } }",
        ],
    ),
    (
        "ring",
        &[
            "bodies.0.name=\"ring\"",
            concat!("bodies.0.shape=", joubert_ring!()),
        ],
    ),
    (
        "cross",
        &[
            "bodies.0.name=\"cross\"",
            "bodies.0.shape={ cross = { base = 2.25e-3, width = 7.5e-4, height = 1e-3 } }",
            // Γ = 4, not the scene's 2 (Joubert eq. 14 asks only Γ ≥ 1): at δ = 0.25 mm
            // on an H200 (2026-11-27) the cross at Γ = 2 took bursts of force (−0.5 to
            // 3.5 times its weight) from 0.125 s, fluid pressed onto its leading faces,
            // and blew up at 0.2795 s in the corner under a side arm; at Γ = 4 it fell
            // smoothly to 0.6 s (force within ±0.6 % of its weight from 0.3 s), at the
            // same speed as Γ = 2 to within 0.5 % up to 0.25 s. Particle shifting drew
            // that fluid there and now stops δ/2 short of a surface, and with that Γ = 2
            // ran smoothly to t = 1 s at full size (H200, 2026-11-29); but the quick
            // cross (δ = 1 mm) at Γ = 2 tumbled to 48.7° and missed its force balance by
            // 3.32 % in CI's run (`shape_drag.rs`), so the variant, one scheme for both,
            // stays at Γ = 4. ARCHITECTURE.md, "Joubert's cross at δ = 0.25 mm runs with
            // Γ = 4".
            "effects.mass_correction=4.0",
        ],
    ),
];

/// Joubert §4.3's boxes: L = B of 15 mm, 2/3 and 1/2 of it, the ring on the centre line.
const RING_BOXES: &[Variant] = &[
    ("full box", &[]),
    (
        "2/3 box",
        &[
            "domain.max.0=0.01",
            "domain.max.2=0.01",
            "fluid.blocks.0.max.0=0.01",
            "fluid.blocks.0.max.2=0.01",
            "bodies.0.position.0=0.005",
            "bodies.0.position.2=0.005",
        ],
    ),
    (
        "1/2 box",
        &[
            "domain.max.0=0.0075",
            "domain.max.2=0.0075",
            "fluid.blocks.0.max.0=0.0075",
            "fluid.blocks.0.max.2=0.0075",
            "bodies.0.position.0=0.00375",
            "bodies.0.position.2=0.00375",
        ],
    ),
];

/// Poiseuille and Couette: Morris, Fox & Zhu's resolution, and one sweep for both.
const CHANNEL_QUICK_WHY: &str = "the scene itself: Morris et al.'s L/20 with 1 664 particles takes 1.5–4 minutes on lavapipe, no cheaper version keeps their resolution";
const CHANNEL_SWEEP_SPACINGS: &[f64] = &[5e-5, 1e-3 / 30.0, 2.5e-5];
const CHANNEL_SWEEP_SCHEMES: &[(&str, &[&str])] = &[
    ("corrected Laplacian", &[]),
    ("Morris Laplacian", &["effects.laplacian_correction=false"]),
    (
        "corrected gradient + Laplacian",
        &["effects.gradient_correction=true"],
    ),
    (
        "Joubert walls, corrected gradient + Laplacian",
        &[
            "effects.gradient_correction=true",
            "domain.wall_model=\"joubert\"",
        ],
    ),
];

static CASES: [Case; 17] = [
    Case {
        name: "hydrostatic-tank",
        scene: "hydrostatic-tank.toml",
        about: "water at rest in a closed box: time-averaged pressure against ρ0 g (H − y) away from walls and surface; fluid mass",
        quick: &[
            "fluid.spacing=0.02",
            "fluid.support=2.0",
            "fluid.sound_speed=17.5",
            "effects.artificial_viscosity=0.2",
            "fluid.kinematic_viscosity=0.0",
            "time.end=0.3",
            "time.output_interval=0.01",
        ],
        quick_why: "δ = 0.02 m with support 2δ (the in-process test's settings) to t = 0.3 s: about a minute on lavapipe",
        sweep_spacings: &[0.04, 0.02, 0.01],
        sweep_schemes: &[
            ("standard", &[]),
            ("δ-SPH 0.1", &["effects.density_diffusion=0.1"]),
            ("shifting 0.1", &["effects.particle_shifting=0.1"]),
        ],
        sweep_thin_axes: &[],
        analyse: hydrostatic,
        variants: &[],
        quick_variants: &[],
        compare: None,
    },
    Case {
        name: "settling-sphere",
        scene: "settling-sphere.toml",
        about: "Joubert §4.2: a sphere settling in a closed box — plateau, landing, rest; plateau velocity against Joubert eqs. (37)–(38)",
        quick: SETTLING_SPHERE_QUICK,
        quick_why: SETTLING_SPHERE_QUICK_WHY,
        sweep_spacings: &[1e-3, 8e-4, 6.25e-4],
        sweep_schemes: &[
            ("corrected + mass correction Γ = 2 + shifting", &[]),
            ("corrected + shifting", &["effects.mass_correction=0"]),
            (
                "shifting only",
                &[
                    "effects.gradient_correction=false",
                    "effects.mass_correction=0",
                ],
            ),
            (
                "standard",
                &[
                    "effects.gradient_correction=false",
                    "effects.mass_correction=0",
                    "effects.particle_shifting=0",
                ],
            ),
        ],
        sweep_thin_axes: &[],
        analyse: settling_sphere,
        variants: &[],
        quick_variants: &[],
        compare: None,
    },
    Case {
        name: "single-particle-sedimentation",
        scene: "single-particle-sedimentation.toml",
        about: "Robinson §4–5 (SPS): one unresolved grain settling from rest in the three fluids of Table 1 (water, air, water–glycerol), each two-way and one-way, at Robinson §5.1's resolution (10 × 15 × 10 fluid particles, h/d = 6) — velocity against the Stokes transient of Robinson eq. (34), error < 2 % of v_t after one relaxation time t_d (air: after a quarter of the fall, which ends on the floor before t_d); `--sweep --variant water` is Robinson §5.2's resolution study (h/d = 6, 3, 2, 1.5), two-way and one-way",
        quick: &["fluid.spacing=5e-4", "fluid.support=2.0"],
        quick_why: "δ = 0.5 mm at h = δ (h/d = 5, inside Robinson's study of 1.5–6): 800 fluid particles, seconds on lavapipe; the three fluids two-way and water one-way",
        // Robinson §5.2's four resolutions, 10 to 40 fluid particles across the 4 mm
        // period at his h = 1.5 δ (eq. 19). On lavapipe the finest takes about 30 minutes.
        sweep_spacings: &[4e-4, 2e-4, 1.3333333333333333e-4, 1e-4],
        // The scheme sets the coupling; a variant named "…, one-way" stays one-way under
        // both, so sweep the two-way variants (`--variant water`).
        sweep_schemes: &[
            ("two-way (Robinson eqs. 26–27)", &["fluid.support=3.0"]),
            ("one-way", &["fluid.support=3.0", "coupling.two_way=false"]),
        ],
        sweep_thin_axes: &[],
        analyse: single_particle_sedimentation,
        variants: SPS_FLUIDS,
        quick_variants: SPS_QUICK_FLUIDS,
        compare: Some(sps_two_way_against_one_way),
    },
    Case {
        name: "constant-porosity-block",
        scene: "constant-porosity-block.toml",
        about: "Robinson §6 (CPB, Fig. 9): a rigid block of unresolved grains at porosity ε = 0.6, 0.7, 0.8, 0.9 settling through water and water–glycerol, two-way with the superficial-density fluid at h = 2d — settling speed against Robinson eq. (35), within 5 % (§6.2); ε = 1 is the single grain of single-particle-sedimentation",
        quick: &[
            "time.end=0.016",
            "time.output_interval=1e-3",
            "time.body_output_interval=2e-4",
        ],
        quick_why: "each column cut to 8–10 lattice spacings (1.1–1.4 mm) across at the same resolution (ε = 0.8 at h/d = 1.88: 11 fluid spacings across its 10 lattice spacings, so that the fluid's lattice is not the grains'), to t = 16 ms: the block takes its weight over the scene's 8 ms ramp (gravity.excess_weight_ramp) and 8–16 ms are judged; 2700–4300 fluid particles and 1100–2600 grains (the block fills the column's upper half, as Robinson's), 3–6 minutes per variant on lavapipe. Measured 2026-12-05 (session 67): water ε = 0.6 +3.87 %, 0.7 +1.40 %, 0.8 +0.47 %, 0.9 −0.45 %; water–glycerol 0.6 +4.90 % (+3.69 % over 20–40 ms when run to 40 ms), 0.7 +3.69 %, 0.8 +3.78 %, 0.9 +2.10 %; each within 2.2 % of eq. (35) over the grains' own porosities, which the kernel smooths across the block's faces (Robinson §6's explanation of his few per cent): that reference lies 5.5–5.6 % above eq. (35) at ε = 0.6, 3.5–3.7 % at 0.7, 1.5–1.6 % at 0.8, 0.2 % at 0.9. With the 2.4 mm block of before (session 66) it lay 7.0–7.2 % above at ε = 0.6 and the quicks read up to +7.52 % there. Released at once, as until that day, the block rang the open column's quarter-wave acoustic mode (period 4H/c ≈ 2.4 ms) at about its excess weight over its area over ρc: ±128 % of eq. (35) in water at ε = 0.6, ±158 % in water–glycerol at 0.8, ±1100 % at 0.6 (ARCHITECTURE.md, \"Bodies can take their weight over a ramp\"; results/2026-12-01-lavapipe-cpb/comparison.md). Figures there from before 2026-12-05 are of f32 sums that rounded the slow increments away (ARCHITECTURE.md, \"Positions and densities are summed with compensation\")",
        sweep_spacings: &[],
        sweep_schemes: &[],
        sweep_thin_axes: &[],
        analyse: constant_porosity_block,
        variants: CPB_VARIANTS,
        quick_variants: CPB_QUICK_VARIANTS,
        compare: Some(cpb_porosity_series),
    },
    Case {
        name: "rayleigh-taylor",
        scene: "rayleigh-taylor.toml",
        about: "Robinson §7 (RTI, Figs. 13–14): the ε = 0.8 block of free grains over clear fluid, its lower face disturbed by Robinson eq. (39), in water–glycerol with α = 0.1 and α = 0 and in water with α = 0 and δ-SPH — growth rate of the lowest grain's depth between the two-fluid model's rates (eqs. 37–38) at ε = 0.93 and ε = 0.8",
        quick: RTI_QUICK,
        quick_why: "water with α = 0 (Robinson's Fig. 13) and δ-SPH 0.1 on ρ/ε holding the block's faces, in a column cut to 16 lattice spacings (2.2 mm) across, so the wave number is 1.9 times Robinson's, with 18 fluid spacings across it, to t = 0.06 s: 15 552 fluid particles and 4352 grains, about 37 minutes on lavapipe (water–glycerol's growth at a narrow width is viscous, a few 1/s, and would need seconds). Measured 2026-12-05 (2200 s, windows of 9 fluid steps, h/c_s): the lowest grain 35.537 1/s over 27–60 ms against the bounds 28.467–50.279 1/s; the lowest layer's mode cos kx cos kz 43.969 1/s over 26–60 ms, 25 to 227 µm (results/2026-12-05-lavapipe-rti-window/rti-wide-a0-dsph-60ms). The other three corners of α and δ-SPH (results/2026-12-06-lavapipe-rti-alpha/comparison.md): α = 0.1 with δ-SPH 18.062 1/s, below both bounds as Robinson's water with α = 0.1, in the quietest fluid of all; α = 0.1 without δ-SPH 38.904 1/s, a fit over the burst of a fluid turned noisy at 35 ms (12–20 1/s in each 10 ms until then); α = 0 without δ-SPH blew up at 37.3 ms from its faces (ARCHITECTURE.md, \"A window longer than the sound's crossing of h\"). Not narrower: at 1.1 mm across the interface, the porosity smoothed over a support of 3δ, is a third of the wavelength wide, the layer's mode levelled off at about 0.1 mm, and the lowest grain read whatever stretch its fit picked, 10.9 to 27.2 1/s (ARCHITECTURE.md, \"The narrow RTI quick is no proxy\")",
        sweep_spacings: &[],
        sweep_schemes: &[],
        sweep_thin_axes: &[],
        analyse: rayleigh_taylor,
        variants: RTI_VARIANTS,
        quick_variants: RTI_QUICK_VARIANTS,
        compare: None,
    },
    Case {
        name: "sedimentation-regimes",
        scene: "sedimentation-regimes.toml",
        about: "DEMocritus §4.2: one unresolved grain (d = 0.1 m, ρs/ρf = 2.7) settling in the Newton, Allen and Stokes regimes — one-way, terminal velocity against the drag law's own force balance at the porosity the lone grain sees (< 2 %: the coupling; that porosity ≥ 0.98) and against DEMocritus eq. (46) (within the law's known gap to eq. 46 plus 2 %)",
        quick: &["fluid.spacing=0.2", "fluid.support=3.0"],
        quick_why: "δ = 0.2 m (the grain half a spacing) at support 3δ, a radius of 0.6 m where the full case's is 0.5 m: the lone grain sees ε0 = 0.992 (0.986 in full); 1000 fluid particles, 43 s on lavapipe. At support 2.5δ (the full case's radius, ε0 = 0.986) the Newton grain's speed still swung ±0.5 % with the closed box's acoustic period at the end (0.58 % over the last tenth, 2026-11-29); at 3δ 0.09 %, every row passing",
        sweep_spacings: &[0.2, 0.1],
        sweep_schemes: &[("one-way, Di Felice drag", &[])],
        sweep_thin_axes: &[],
        analyse: sedimentation_regimes,
        variants: REGIMES,
        quick_variants: &[],
        compare: None,
    },
    Case {
        name: "settling-cylinder",
        scene: "settling-cylinder.toml",
        about: "Joubert §3.2/§4.1: the 12-face cylinder settling in a closed box, periodic along its axis — Re at the terminal velocity against Table 2 at the same spacing (coarse 17.03 at δ = 0.25 mm, medium 15.71, fine 14.64) within 5 %, and reported against a converged 2D lattice Boltzmann solution of the same body and channel (Re 13.65, tests/src/bin/lbm-reference.rs); C_D by force balance reported",
        quick: &[
            "fluid.spacing=1e-3",
            "domain.max=[0.02, 0.04, 0.008]",
            "fluid.blocks.0.max=[0.02, 0.04, 0.008]",
            "bodies.0.shape.prism.half_height=4e-3",
            "bodies.0.position=[0.01, 0.032, 0.004]",
            "time.end=0.55",
        ],
        quick_why: "δ = 1 mm (r = 1.25 δ), the box cut to 20 × 40 mm with the release at 32 mm, the z span 8 mm (the grid needs a period of 2.5 supports), to t = 0.55 s (the fall ends at 0.497 s; cut from 0.6 s on 2026-11-27 to keep CI near 40 minutes: force 0.06 % off, plateau change 0.19 %, Re 14.60): 6400 fluid particles, about five minutes on lavapipe; the force balance is judged, the plateau and Re are reported (Table 2 has no figure at this δ). At r = 1.25δ the 12-gon rocks: without the mass correction two runs that differed only in the DEM's round-off gave a change over the last fifth of 2.74 % and 6.57 %, so the plateau is judged from r = 2δ only; in a 30 mm box the fall ended before the velocity's overshoot had settled (6.5 %). Without the mass correction an NVIDIA H200 (2026-11-26) missed the force balance by 14.9 % (the fluid force swung by ±70 % as the cylinder drifted 0.85 mm sideways); with Γ = 1 there it was 0.07 % off (Re 15.11), with the scene's Γ = 2 on lavapipe 0.06 % (Re 14.90, a change of 0.25 % over the last fifth). The full case on the H200: δ = 0.25 mm with Γ = 1 ran to 0.8 s, plateau 58.7 mm/s, Re 14.68 against Table 2's 17.03, force balance 0.12 %; δ = 0.175 mm blew up at t = 0.097 s without the mass correction and at 0.137 s with Γ = 1, and with Γ = 2 fell steadily until cut at 0.443 s, Re ≈ 14.5 against 15.71",
        sweep_spacings: &[1e-3, 5e-4, 2.5e-4],
        sweep_schemes: &[
            ("corrected + mass correction Γ = 2 + shifting", &[]),
            ("corrected + shifting", &["effects.mass_correction=0"]),
            (
                "standard + shifting",
                &[
                    "effects.gradient_correction=false",
                    "effects.mass_correction=0",
                ],
            ),
        ],
        sweep_thin_axes: &[],
        analyse: settling_cylinder,
        variants: &[],
        quick_variants: &[],
        compare: None,
    },
    Case {
        name: "sphere-density-sweep",
        scene: "settling-sphere.toml",
        about: "Joubert §4.2, Fig. 21: the settling sphere's plateau velocity against Joubert eqs. (37)–(38), next to Joubert's own error at its density (ρs = 1100, 1250, 1500 kg/m³: 0.11, 9.21, 13.52 %); the full case runs the three densities at Joubert's δ = 0.25 mm (quintic kernel, support 2.4 δ), where they are judged; `--quick` runs ρs = 1250 at the settling sphere's quick δ, `--sweep` the three densities at each spacing of it",
        quick: SETTLING_SPHERE_QUICK,
        quick_why: SETTLING_SPHERE_QUICK_WHY,
        sweep_spacings: &[1e-3, 8e-4, 6.25e-4],
        sweep_schemes: &[
            // Eqs. (37)–(38) give 24 mm/s: the quick box's 14 mm fall takes 0.6 s.
            ("ρs = 1100", &["bodies.0.density=1100", "time.end=1.2"]),
            ("ρs = 1250", &["bodies.0.density=1250"]),
            ("ρs = 1500", &["bodies.0.density=1500"]),
        ],
        sweep_thin_axes: &[],
        analyse: sphere_density,
        variants: SPHERE_DENSITIES,
        // One run, not labelled by a density: the sweep's schemes set the density.
        quick_variants: &[("sphere", &[])],
        compare: None,
    },
    Case {
        name: "shape-drag",
        scene: "shape-drag.toml",
        about: "Joubert §4.2, Tables 3–5: sphere, 12-face cylinder, ring and cross settling in the 15 × 50 × 15 mm box — Re at the plateau against Table 5 (13.15, 11.95, 12.55, 11.37) within 10 %, C_D by eq. (36) from the measured force as ratios to the sphere's against 14.76 : 18.76 : 22.57 : 15.98 within 10 %, and in the same order; judged at Joubert's δ = 0.25 mm; Re also reported against a 3D lattice Boltzmann solution of the same body and box (tests/src/bin/lbm-reference.rs)",
        quick: SHAPE_QUICK,
        quick_why: SHAPE_QUICK_WHY,
        sweep_spacings: &[1e-3, 5e-4, 2.5e-4],
        sweep_schemes: &[("corrected + mass correction Γ = 2 + shifting", &[])],
        sweep_thin_axes: &[],
        variants: SHAPE_VARIANTS,
        quick_variants: &[],
        analyse: settling_shape,
        compare: Some(cd_ratios),
    },
    Case {
        name: "ring-walls",
        scene: "ring-walls.toml",
        about: "Joubert §4.3, Table 6: the ring settling in the full, 2/3 and 1/2 box — Re at the plateau against 12.55, 10.68, 8.12 within 10 %, C_D by eq. (36) from the measured force as ratios to the full box's against 1 : 1.38 : 2.39 within 10 %; judged at Joubert's δ = 0.25 mm; Re also reported against a 3D lattice Boltzmann solution of the same body and box (tests/src/bin/lbm-reference.rs)",
        quick: SHAPE_QUICK,
        quick_why: SHAPE_QUICK_WHY,
        sweep_spacings: &[1e-3, 5e-4, 2.5e-4],
        sweep_schemes: &[("corrected + mass correction Γ = 2 + shifting", &[])],
        sweep_thin_axes: &[],
        variants: RING_BOXES,
        quick_variants: &[],
        analyse: settling_shape,
        compare: Some(cd_ratios),
    },
    Case {
        name: "dkt",
        scene: "dkt.toml",
        about: "Joubert §3.3: drafting, kissing and tumbling of two 12-face cylinders — the trailing body drafts (falls > 5 % faster), they kiss (centres within 2r + δ), tumble (their line turns past horizontal), and never overlap beyond the DEM's contact slop; heights, x and velocities plotted",
        quick: &[
            "fluid.spacing=5e-4",
            "fluid.support=2.4",
            "domain.max=[0.014, 0.038, 0.003]",
            "fluid.blocks.0.max=[0.014, 0.038, 0.003]",
            "bodies.0.shape.prism.half_height=1.5e-3",
            "bodies.1.shape.prism.half_height=1.5e-3",
            "bodies.0.position=[0.007, 0.03, 0.0015]",
            "bodies.1.position=[0.00695, 0.033, 0.0015]",
            "time.end=0.5",
        ],
        quick_why: "δ = 0.5 mm (r = 2 δ) at support 2.4 δ (Joubert's in §4.2), the z span 3 mm (the grid needs a period of 2.5 supports), the box cut to 14 × 38 mm with the pair released 30 and 33 mm up, the upper one 0.05 mm (0.1 δ) off the centre line, to t = 0.5 s: 12 768 lattice sites less the bodies, about 8 minutes on lavapipe; at r = 2 δ the wake is barely resolved, so the phases are a run of the pipeline. The box and the offset were cut on 2026-11-27 to bring CI under 40 minutes: the tumbling is an instability growing from the offset, and at 0.1 δ it passes 90° about 0.15 s sooner than at the scene's 0.01 mm (0.02 δ here). Measured 2026-11-27 to t = 0.6 s (585 s): drafting 34.22 %, kissing 1.9460 mm at t = 0.356 s (the 12-gons touch at 1.932 mm), tumbling 119.5° (past 90° at 0.458 s), overlap 1.4e-7 m; the same box with the 0.01 mm offset (646 s) passed the kiss (1.9327 mm at 0.389 s) but had turned only 73.9° by 0.6 s. The quick before (a 20 × 40 mm box, the 0.01 mm offset, to 0.6 s; 19 200 sites, 12–15 minutes): drafting 33.35 %, kissing 1.9350 mm at t = 0.371 s, tumbling 104.4° (past 90° at 0.560 s), overlap 4.8e-7 m. The one before that (support 3 δ, z span 4 mm, a 30 mm box, the pair at 20 and 23 mm) reached the floor before it tumbled (20.9°). Before rapier's contact recycling was switched off the resting pair sank 12.6 µm into each other",
        sweep_spacings: &[5e-4, 2.5e-4, 1e-4],
        sweep_schemes: &[("corrected + mass correction Γ = 2 + shifting", &[])],
        sweep_thin_axes: &[],
        variants: &[],
        quick_variants: &[],
        analyse: dkt,
        compare: None,
    },
    Case {
        name: "five-bodies",
        scene: "five-bodies.toml",
        about: "Joubert §4.4: five spheres, then five rings, settling together from a staggered start in the 10 × 50 × 8 mm box with symmetry planes in x — the spheres descend faster (mean descent speed over the rings' > 1) and the rings rotate more; each body's height plotted (Figs. 25–26)",
        quick: FIVE_BODY_QUICK,
        quick_why: "δ = 0.5 mm to t = 0.1 s: 32 000 fluid particles, 3–6 minutes per variant on lavapipe; by 0.1 s the bodies are near their terminal speed but the rings have had little time to tip (Joubert's snapshots run to 0.7 s). The scene's walls are Adami's, its x faces symmetry planes that mirror the fluid's velocity (ARCHITECTURE.md, \"Symmetry planes of Adami's walls mirror the fluid's velocity\"); both variants run to the end there (2026-11-26, 403 s for the two on lavapipe, particle shifting counting markers by their patches): mean descent speed 28.05 mm/s for the spheres against 20.12 mm/s for the rings (1.394), largest rotation 0.43° against 1.72° (with shifting counting every marker whole: 28.23 and 20.69 mm/s, 0.47° and 2.72°; with every marker at the lattice mass too: 28.27 and 20.84 mm/s, 0.51° and 2.51°). On Adami's no-slip walls all round they fell at 27.75 and 20.27 mm/s. On Joubert's one-layer walls with eq. (27) on the planes both blow up (a particle crosses the one-layer walls at their edges): the spheres at t = 0.0574 s, the rings at 0.0658 s (2026-11-26)",
        sweep_spacings: &[1e-3, 5e-4, 2.5e-4],
        sweep_schemes: &[("corrected + mass correction Γ = 2 + shifting", &[])],
        sweep_thin_axes: &[],
        analyse: five_bodies,
        variants: FIVE_BODY_VARIANTS,
        quick_variants: &[],
        compare: Some(five_bodies_compare),
    },
    Case {
        name: "dam-break",
        scene: "dam-break.toml",
        about: "water column of width a and height 2a collapsing on a dry floor: surge front Z = x/a against T = t √(2g/a), Martin & Moyce (1952)",
        quick: &["fluid.spacing=0.01", "time.output_interval=0.01"],
        quick_why: "δ = a/10: about two minutes on lavapipe",
        sweep_spacings: &[0.02, 0.01, 0.005],
        sweep_schemes: &[
            ("δ-SPH 0.1", &[]),
            ("standard", &["effects.density_diffusion=0"]),
        ],
        sweep_thin_axes: &[],
        analyse: dam_break,
        variants: &[],
        quick_variants: &[],
        compare: None,
    },
    Case {
        name: "poiseuille",
        scene: "poiseuille.toml",
        about: "start-up plane Poiseuille flow between fixed plates: L2 error of u(y, t) against the series solution of Morris, Fox & Zhu (1997), during start-up and at the steady state",
        quick: &[],
        quick_why: CHANNEL_QUICK_WHY,
        sweep_spacings: CHANNEL_SWEEP_SPACINGS,
        sweep_schemes: CHANNEL_SWEEP_SCHEMES,
        sweep_thin_axes: &[0, 2],
        analyse: channel_flow,
        variants: &[],
        quick_variants: &[],
        compare: None,
    },
    Case {
        name: "couette",
        scene: "couette.toml",
        about: "start-up plane Couette flow (top plate sliding at V0): L2 error of u(y, t) against the series solution of Morris, Fox & Zhu (1997), during start-up and at the steady state",
        quick: &[],
        quick_why: CHANNEL_QUICK_WHY,
        sweep_spacings: CHANNEL_SWEEP_SPACINGS,
        sweep_schemes: CHANNEL_SWEEP_SCHEMES,
        sweep_thin_axes: &[0, 2],
        analyse: channel_flow,
        variants: &[],
        quick_variants: &[],
        compare: None,
    },
    Case {
        name: "taylor-green",
        scene: "taylor-green.toml",
        about: "Taylor–Green vortex at Re = 100, periodic in x, y and a thin z span: decay rate of the kinetic energy against the analytic 2b = −16π²ν/L²",
        quick: &[
            "fluid.spacing=0.04",
            "domain.max=[1.0, 1.0, 0.32]",
            "fluid.blocks.0.max=[1.0, 1.0, 0.32]",
            "time.end=0.3",
        ],
        quick_why: "δ = L/25 (z span kept at 8 spacings) to t = 0.3 s: 5 000 particles, a few minutes on lavapipe",
        sweep_spacings: &[0.04, 0.02],
        sweep_schemes: &[
            ("Joubert (corrected + shifting)", &[]),
            (
                "standard + shifting",
                &[
                    "effects.gradient_correction=false",
                    "effects.laplacian_correction=false",
                ],
            ),
        ],
        sweep_thin_axes: &[2],
        analyse: taylor_green,
        variants: &[],
        quick_variants: &[],
        compare: None,
    },
    Case {
        name: "lid-driven-cavity",
        scene: "lid-driven-cavity.toml",
        about: "Joubert §3.1: lid-driven cavity at Re = 100, u(y) on the vertical and v(x) on the horizontal centreline against Ghia, Ghia & Shin (1982); Joubert's figures judged at δ ≤ L/100",
        quick: &[
            "fluid.spacing=0.1",
            "domain.max=[1.0, 1.0, 0.8]",
            "fluid.blocks.0.max=[1.0, 1.0, 0.8]",
            "time.end=15",
        ],
        quick_why: "δ = L/10 (z span kept at 8 spacings) to t = 15 s: 800 fluid particles, 146 s on lavapipe (2026-11-26, beside another run); the centreline errors are judged against coarse bounds (COARSE_CAVITY), Joubert's own figures only at δ ≤ L/100. On an NVIDIA H200 (2026-11-26), without the mass correction: δ = L/50 (z span 0.16 m) to t = 30 s in 327 s with other runs on the GPU, u 0.57 % / 0.11 % and v 0.65 % / 0.28 % (largest / mean), inside Joubert's δ = L/100 figures; the full δ = L/100 blew up at t = 9.5 s (a particle near the floor at x = 0.88 m decompressed to 436 kg/m³). With the scene's mass correction Γ = 1 the full δ = L/100 ran to t = 21 s (cut by the time limit) inside Joubert's figures: u 0.52 % / 0.13 %, v 0.74 % / 0.34 %",
        sweep_spacings: &[0.04, 0.02, 0.01],
        sweep_schemes: &[
            (
                "Joubert (corrected + mass correction Γ = 1 + shifting)",
                &[],
            ),
            (
                "Joubert without mass correction",
                &["effects.mass_correction=0"],
            ),
            (
                "standard + shifting",
                &[
                    "effects.gradient_correction=false",
                    "effects.laplacian_correction=false",
                    "effects.mass_correction=0",
                ],
            ),
        ],
        sweep_thin_axes: &[2],
        analyse: lid_driven_cavity,
        variants: &[],
        quick_variants: &[],
        compare: None,
    },
];

/// Where the scenes are: `scenes_dir`, else `./scenes`, else the repository's.
fn scene_path(case: &Case, scenes_dir: Option<&Path>) -> Result<PathBuf, ValidateError> {
    let candidates = match scenes_dir {
        Some(d) => vec![d.join(case.scene)],
        None => vec![
            PathBuf::from("scenes").join(case.scene),
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("..")
                .join("scenes")
                .join(case.scene),
        ],
    };
    candidates
        .iter()
        .find(|p| p.is_file())
        .cloned()
        .ok_or_else(|| ValidateError::NoScene(candidates[0].clone()))
}

/// How `validate` runs a case's runs: with progress lines, checkpoints every so often,
/// and continuing each run from its newest checkpoint (`crate::resume`).
#[derive(Debug, Clone, Default)]
pub struct HowToRun {
    pub progress: bool,
    /// `RunOptions::checkpoint_every`.
    pub checkpoint_every: Option<std::time::Duration>,
    /// Continue each run from the newest checkpoint in its folder; a run that ran to its
    /// end is analysed from its recording, and one without a checkpoint runs from the
    /// start.
    pub resume: bool,
}

/// Runs case `name` (`quick`: its CI-sized version) with `extra` overrides after the
/// case's own, into `out` (default `out/validate/NAME`), and writes the report there.
/// `only` narrows a case of variants to those named (labels or their folder names);
/// empty: all of them.
pub fn validate(
    name: &str,
    quick: bool,
    only: &[String],
    out: Option<PathBuf>,
    extra: &[(String, String)],
    scenes_dir: Option<&Path>,
    how: &HowToRun,
) -> Result<Report, ValidateError> {
    let case = find(name)?;
    let variants = chosen_variants(case, quick, only)?;
    let base = if quick { pairs(case.quick) } else { Vec::new() };
    let out = out.unwrap_or_else(|| PathBuf::from("out").join("validate").join(name));
    run_case(
        case, &variants, quick, None, &base, extra, out, scenes_dir, how,
    )
}

/// The variants a run of `case` makes: its quick ones under `--quick` where it has
/// them, narrowed to `only` (labels or their folder names, see [`slug`]) unless empty.
fn chosen_variants(
    case: &Case,
    quick: bool,
    only: &[String],
) -> Result<Vec<Variant>, ValidateError> {
    let all = if quick && !case.quick_variants.is_empty() {
        case.quick_variants
    } else {
        case.variants
    };
    if let Some(asked) = only
        .iter()
        .find(|a| !all.iter().any(|(l, _)| *l == a.as_str() || slug(l) == **a))
    {
        return Err(ValidateError::UnknownVariant {
            case: case.name.into(),
            asked: asked.clone(),
            known: if all.is_empty() {
                "none".into()
            } else {
                all.iter()
                    .map(|(l, _)| format!("\"{l}\""))
                    .collect::<Vec<_>>()
                    .join(", ")
            },
        });
    }
    Ok(all
        .iter()
        .filter(|(l, _)| only.is_empty() || only.iter().any(|a| *l == a.as_str() || slug(l) == *a))
        .copied()
        .collect())
}

/// Analyses the run in `dir` (`scene.toml`, `run.mcap`) as case `name` without running
/// it, and writes the report and its series to `out` (made if missing; `dir` itself when
/// the caller has no other). A case of variants is analysed as one of them (no
/// comparison across variants).
pub fn analyse_recording(name: &str, dir: &Path, out: &Path) -> Result<Report, ValidateError> {
    let case = find(name)?;
    let (scene, _) = resolve_scene(&dir.join("scene.toml"), &[])?;
    let rec = crate::resume::read_chain(dir).map_err(ValidateError::Recording)?;
    std::fs::create_dir_all(out).map_err(|source| ValidateError::Io {
        what: format!("creating {}", out.display()),
        source,
    })?;
    let report = Report {
        from_recording: true,
        ..analysed(case, &scene, &rec, out.to_owned())?
    };
    write_outputs(&report)?;
    Ok(report)
}

fn find(name: &str) -> Result<&'static Case, ValidateError> {
    cases()
        .iter()
        .find(|c| c.name == name)
        .ok_or_else(|| ValidateError::Unknown(name.to_owned()))
}

fn pairs(list: &[&str]) -> Vec<(String, String)> {
    list.iter()
        .map(|kv| {
            let (k, v) = kv.split_once('=').expect("case overrides are PATH=VALUE");
            (k.to_owned(), v.to_owned())
        })
        .collect()
}

/// The overrides one run of a case takes: the version's (`base`: the full case's none,
/// the quick's, a sweep point's), its variant's, then the command line's (`extra`).
fn run_overrides(
    base: &[(String, String)],
    variant: &[&str],
    extra: &[(String, String)],
) -> Vec<(String, String)> {
    let mut o = base.to_vec();
    o.extend(pairs(variant));
    o.extend_from_slice(extra);
    o
}

/// Runs `case` with `base` then `extra` overrides into `out`, compares, writes the
/// report. A case with variants runs each into `out/<variant>/` with its overrides
/// between `base` and `extra`, and writes the combined report, with the comparison
/// across variants, to `out`. `point` is the sweep point it runs, if it is one (its
/// reports are titled so).
#[allow(clippy::too_many_arguments)]
fn run_case(
    case: &Case,
    variants: &[Variant],
    quick: bool,
    point: Option<&SweepSpec>,
    base: &[(String, String)],
    extra: &[(String, String)],
    out: PathBuf,
    scenes_dir: Option<&Path>,
    how: &HowToRun,
) -> Result<Report, ValidateError> {
    let with = |variant: &[&str]| run_overrides(base, variant, extra);
    // What every report of this call carries: the sweep point and the command line's
    // overrides, which its title names.
    let stamped = |r: Report| Report {
        sweep_point: point.map(|p| (p.index, p.spacing)),
        command_line: extra.to_vec(),
        ..r
    };
    if variants.is_empty() {
        let report = stamped(run_one(case, quick, with(&[]), out, scenes_dir, how)?);
        write_outputs(&report)?;
        return Ok(report);
    }
    let mut parts = Vec::new();
    let mut failed = Vec::new();
    for (label, variant) in variants {
        eprintln!("validate {}: {label} …", case.name);
        let t0 = Instant::now();
        // A variant that fails (a blow-up, say) is a result of the case: the others run.
        let r = match run_one(
            case,
            quick,
            with(variant),
            out.join(slug(label)),
            scenes_dir,
            how,
        ) {
            // Ctrl-C or SIGTERM ends the case, not just this variant.
            Err(e) if e.is_interrupted() => return Err(e),
            Ok(r) => {
                let r = stamped(Report {
                    case: format!("{} ({label})", case.name),
                    ..r
                });
                write_outputs(&r)?;
                r
            }
            Err(e) => {
                eprintln!("validate {}: {label} failed: {e}", case.name);
                failed.push(*label);
                let mut r = stamped(Report {
                    case: format!("{} ({label})", case.name),
                    quick,
                    wall_s: t0.elapsed().as_secs_f64(),
                    ..Default::default()
                });
                r.judge(
                    "run",
                    format!("failed: {e}"),
                    "runs to the end".into(),
                    "exact".into(),
                    Some(false),
                );
                r
            }
        };
        parts.push(r);
    }
    let mut report = stamped(Report {
        case: case.name.to_owned(),
        quick,
        wall_s: parts.iter().map(|r| r.wall_s).sum(),
        out: out.clone(),
        particles: parts.iter().map(|r| r.particles).max().unwrap_or(0),
        ..Default::default()
    });
    for ((label, _), r) in variants.iter().zip(&parts) {
        for row in &r.rows {
            report.rows.push(Row {
                quantity: format!("{label}: {}", row.quantity),
                ..row.clone()
            });
        }
    }
    // The sweep's error measure: the worst variant's (named so where there are several).
    report.headline = parts
        .iter()
        .filter_map(|r| r.headline.clone())
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(name, e)| match parts.len() {
            1 => (name, e),
            _ => (format!("{name} (worst variant)"), e),
        });
    let every = chosen_variants(case, quick, &[])?.len();
    match case.compare {
        Some(_) if variants.len() < every => report.judge(
            "comparison across variants",
            format!("not made: {} of {every} variants chosen", variants.len()),
            "every variant".into(),
            "reported".into(),
            None,
        ),
        Some(_) if !failed.is_empty() => report.judge(
            "comparison across variants",
            format!("not made: {} did not run", failed.join(", ")),
            "every variant".into(),
            "exact".into(),
            Some(false),
        ),
        Some(compare) => compare(&parts, &mut report).map_err(ValidateError::Analysis)?,
        None => {}
    }
    std::fs::create_dir_all(&out).map_err(|source| ValidateError::Io {
        what: format!("creating {}", out.display()),
        source,
    })?;
    write_outputs(&report)?;
    Ok(report)
}

/// One run of `case` with `overrides` into `out`, analysed (not yet written). With
/// `how.resume` it continues from the newest checkpoint in `out`, or is only analysed
/// when its recording runs to the end; the analysis reads every sitting
/// ([`crate::resume::read_chain`]).
fn run_one(
    case: &Case,
    quick: bool,
    overrides: Vec<(String, String)>,
    out: PathBuf,
    scenes_dir: Option<&Path>,
    how: &HowToRun,
) -> Result<Report, ValidateError> {
    use crate::resume::{Resume, continue_run, resume_point};
    let scene_file = scene_path(case, scenes_dir)?;
    let (scene, text) = resolve_scene(&scene_file, &overrides)?;
    let t0 = Instant::now();
    let opts = RunOptions {
        scene: scene_file,
        out: Some(out.clone()),
        overrides,
        max_windows: None,
        record: true,
        progress: how.progress,
        run_id: None,
        external: Vec::new(),
        checkpoint_every: how.checkpoint_every,
        restore: None,
    };
    let start = if how.resume {
        resume_point(&out, &text, scene.time.end)
            .map_err(|e| ValidateError::Run(RunError::Resume(e)))?
    } else {
        Resume::Start(String::new())
    };
    let ran = match start {
        Resume::Finished => {
            eprintln!(
                "validate {}: {} ran to its end before: analysed from its recording",
                case.name,
                out.display()
            );
            None
        }
        Resume::Start(why) => {
            if how.resume {
                eprintln!(
                    "validate {}: nothing to resume ({why}): from the start",
                    case.name
                );
            }
            Some(run(&opts))
        }
        Resume::Continue { step, checkpoint } => {
            eprintln!(
                "validate {}: resuming {} at window {step} from {}",
                case.name,
                out.display(),
                checkpoint.display()
            );
            Some(continue_run(&opts, &out, step, &checkpoint))
        }
    };
    let summary = ran
        .transpose()
        .map_err(|mut e| {
            if let RunError::Interrupted { windows, how: what, .. } = &mut e
                && *windows > 0
            {
                *what += &format!(
                    "; `couplet validate {} --recording {}` analyses what ran",
                    case.name,
                    out.display()
                );
                if how.checkpoint_every.is_some() {
                    *what += ", and the same command with `--resume` continues it from its newest checkpoint";
                }
            }
            e
        })?;
    if let Some(s) = summary.as_ref().filter(|_| how.progress) {
        eprintln!("{}", s.per_window());
    }
    let rec = crate::resume::read_chain(&out).map_err(ValidateError::Recording)?;
    // Over every sitting: this one's and the earlier ones' (from the checkpoint, or the
    // recording of a run that had ended).
    let wall_s = match &summary {
        Some(s) => t0.elapsed().as_secs_f64() + s.earlier_wall_s,
        None => rec.last_window.map_or(f64::NAN, |w| w.wall_s),
    };
    Ok(Report {
        quick,
        wall_s,
        ..analysed(case, &scene, &rec, out)?
    })
}

/// The report of `case` on the recording `rec` of `scene`, to be written to `out`.
fn analysed(
    case: &Case,
    scene: &Scene,
    rec: &Recording,
    out: PathBuf,
) -> Result<Report, ValidateError> {
    let mut report = Report {
        case: case.name.to_owned(),
        out,
        particles: rec.snapshots.first().map_or(0, |s| s.1.len()),
        ..Default::default()
    };
    // A recording its run never closed is analysed up to its last complete record; this row
    // fails it, and says how far it goes.
    let closed = match (&rec.truncated, rec.snapshots.last(), rec.bodies.last()) {
        (None, ..) => rec.has_summary.to_string(),
        (Some(_), s, b) => format!(
            "false (cut off: last snapshot t = {}, last body state t = {})",
            s.map_or("none".into(), |s| format!("{:.6} s", s.0)),
            b.map_or("none".into(), |b| format!("{:.6} s", b.time)),
        ),
    };
    if let Some(why) = &rec.truncated {
        eprintln!("warning: {why}");
    }
    report.judge(
        "recording closed properly",
        closed,
        "true".into(),
        "exact".into(),
        Some(rec.has_summary),
    );
    if !rec.gaps.is_empty() {
        let (value, lost) = gap_losses(scene, rec);
        report.judge(
            "windows in no sitting's recording (a sitting killed before it wrote them out)",
            value,
            "every snapshot and body record the scene asks for".into(),
            "none lost".into(),
            Some(lost == 0),
        );
    }
    if let Some(t) = rec.first_reflected {
        report.judge(
            "fluid particle-steps mirrored back out of a body or across a wall face (couplet_fluid::body_non_penetration; not in the papers, not judged)",
            format!("{}, the first in the window from t = {t:.4e} s", rec.reflected),
            "0 where the fluid keeps off its walls and bodies".into(),
            "reported".into(),
            None,
        );
    }
    (case.analyse)(scene, rec, &mut report).map_err(ValidateError::Analysis)?;
    Ok(report)
}

/// What the gaps of a resumed run's recording ([`crate::record::Gap`]) lost: the fluid
/// snapshots and body records that the scene's output intervals put in them and that
/// are not in the recording. A record at interval multiple kΔ falls in the first window
/// that ends at kΔ or later (`CoupledRun::advance`, to 1e-9 Δ), so a gap's due times
/// are the multiples in (from_time, to_time]; body records without
/// `time.body_output_interval` are due every window. Returns the row's text and the
/// number lost.
fn gap_losses(scene: &Scene, rec: &Recording) -> (String, usize) {
    let multiples = |iv: f64, a: f64, b: f64| {
        let e = 1e-9 * iv;
        (((b + e) / iv).floor() - ((a + e) / iv).floor()).max(0.0) as usize
    };
    let within = |t: f64, a: f64, b: f64| t > a && t <= b;
    let (mut due, mut lost) = ([0usize; 2], [0usize; 2]);
    let mut spans = Vec::new();
    for g in &rec.gaps {
        let (a, b) = (g.from_time, g.to_time);
        spans.push(format!(
            "{}–{} (t = {a:.6} … {b:.6} s)",
            g.from_step,
            g.to_step - 1
        ));
        let snaps = match scene.fluid {
            Some(_) => multiples(scene.time.output_interval, a, b),
            None => 0,
        };
        let found = rec.snapshots.iter().filter(|s| within(s.0, a, b)).count();
        let bodies = match scene.time.body_output_interval {
            Some(iv) => multiples(iv, a, b),
            None if scene.bodies.is_empty() => 0,
            None => (g.to_step - g.from_step) as usize,
        };
        let mut times: Vec<f64> = (rec.bodies.iter())
            .map(|s| s.time)
            .filter(|&t| within(t, a, b))
            .collect();
        times.dedup();
        due[0] += snaps;
        due[1] += bodies;
        lost[0] += snaps.saturating_sub(found);
        lost[1] += bodies.saturating_sub(times.len());
    }
    let text = format!(
        "windows {}: snapshots lost {} of {} due there, body records lost {} of {}",
        spans.join(", "),
        lost[0],
        due[0],
        lost[1],
        due[1]
    );
    (text, lost[0] + lost[1])
}

/// A fraction as a percentage: two decimals, or three significant digits below 0.01 %
/// (so that a tiny error does not read as 0.00 %).
fn pct(x: f64) -> String {
    if x != 0.0 && (100.0 * x).abs() < 0.01 {
        format!("{:.2e} %", 100.0 * x)
    } else {
        format!("{:.2} %", 100.0 * x)
    }
}

/// The solution of the 3 × 3 system m x = v by Cramer's rule; None when m is singular
/// to round-off.
pub(super) fn solve3(m: [[f64; 3]; 3], v: [f64; 3]) -> Option<[f64; 3]> {
    let det = |a: [[f64; 3]; 3]| {
        a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
    };
    let d = det(m);
    let scale = m.iter().flatten().map(|x| x.abs()).fold(0.0, f64::max);
    if !(d.abs() > 1e-12 * scale.powi(3)) {
        return None;
    }
    Some(std::array::from_fn(|c| {
        let mut a = m;
        for r in 0..3 {
            a[r][c] = v[r];
        }
        det(a) / d
    }))
}

/// The least-squares slope of y against x through `points`; None with fewer than two
/// points or one x only.
pub(super) fn least_squares_slope(points: &[(f64, f64)]) -> Option<f64> {
    let n = points.len() as f64;
    if n < 2.0 {
        return None;
    }
    let (mx, my) = (
        points.iter().map(|p| p.0).sum::<f64>() / n,
        points.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The rate n of a(t) ∝ e^(n t): the least-squares slope of ln a against t; None with a
/// non-positive amplitude, fewer than two points or one time only.
pub(super) fn exponential_rate(points: &[(f64, f64)]) -> Option<f64> {
    if points.iter().any(|p| !(p.1 > 0.0)) {
        return None;
    }
    let logs: Vec<(f64, f64)> = points.iter().map(|&(t, a)| (t, a.ln())).collect();
    least_squares_slope(&logs)
}

/// Each fluid particle averaged over the snapshots of the last `span` seconds.
fn time_average(rec: &Recording, span: f64) -> Result<Vec<Particle>, String> {
    let (t_last, _) = rec.snapshots.last().ok_or("no particle snapshots")?;
    let tail: Vec<&Vec<Particle>> = rec
        .snapshots
        .iter()
        .filter(|(t, _)| *t > t_last - span + 1e-9)
        .map(|(_, s)| s)
        .collect();
    let n = tail[0].len();
    Ok((0..n)
        .map(|i| {
            let mut a = [0f32; 8];
            for s in &tail {
                for (k, v) in a.iter_mut().enumerate() {
                    *v += s[i][k] / tail.len() as f32;
                }
            }
            a
        })
        .collect())
}

/// Volume of the domain box, m³.
fn scene_volume(scene: &Scene) -> f64 {
    (0..3)
        .map(|k| scene.domain.max[k] - scene.domain.min[k])
        .product()
}

#[cfg(test)]
mod tests;
