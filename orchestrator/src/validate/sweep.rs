//! `couplet validate NAME --sweep`: a case's quick run at each of its spacings and
//! schemes, one point at a time or all, each point's row in its folder, and the table
//! and plots of error against wall time and particle count gathered from the rows.

use super::*;

/// One run of a sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepPoint {
    pub scheme: String,
    pub spacing: f64,
    pub particles: usize,
    pub wall_s: f64,
    pub headline: Option<(String, f64)>,
    pub passed: bool,
    /// Why the run did not finish, if it did not.
    pub failure: Option<String>,
}

/// Where a point of a case's sweep sits in its order, and what it runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepSpec {
    /// 0-based, in the sweep's order (`--point K`, the array index of a fan-out).
    pub index: usize,
    pub scheme: &'static str,
    pub scheme_overrides: &'static [&'static str],
    /// m.
    pub spacing: f64,
}

impl SweepSpec {
    /// The run's folder under the sweep's `OUT`.
    pub fn dir(&self, out: &Path) -> PathBuf {
        out.join(format!("{}-{:e}", slug(self.scheme), self.spacing))
    }

    /// The row a point leaves for `--gather`, beside its run.
    pub fn row_file(&self, out: &Path) -> PathBuf {
        self.dir(out).join(SWEEP_ROW_FILE)
    }
}

/// The file name of a sweep point's row, in the point's run folder.
pub const SWEEP_ROW_FILE: &str = "sweep-point.json";

/// The points of case `name`'s sweep, in the order the sweep runs them: coarse first,
/// every scheme at each spacing, so that an interrupted sweep still compares the schemes
/// at the spacings it finished.
pub fn sweep_specs(name: &str) -> Result<Vec<SweepSpec>, ValidateError> {
    let case = find(name)?;
    let specs: Vec<SweepSpec> = case
        .sweep_spacings
        .iter()
        .flat_map(|&spacing| {
            case.sweep_schemes
                .iter()
                .map(move |&(scheme, scheme_overrides)| (scheme, scheme_overrides, spacing))
        })
        .enumerate()
        .map(|(index, (scheme, scheme_overrides, spacing))| SweepSpec {
            index,
            scheme,
            scheme_overrides,
            spacing,
        })
        .collect();
    if specs.is_empty() {
        return Err(ValidateError::NoSweep(name.to_owned()));
    }
    Ok(specs)
}

pub(super) fn default_sweep_out(name: &str) -> PathBuf {
    PathBuf::from("out")
        .join("validate")
        .join(format!("{name}-sweep"))
}

/// `couplet validate NAME --sweep`: the quick version at every spacing × scheme of the
/// case, each into `OUT/<scheme>-<spacing>/` with its row beside it; the table
/// (markdown and CSV) and a plot of the error against wall time go to `OUT`. Returns the
/// markdown.
pub fn sweep(
    name: &str,
    only: &[String],
    out: Option<PathBuf>,
    extra: &[(String, String)],
    scenes_dir: Option<&Path>,
    progress: bool,
) -> Result<String, ValidateError> {
    let specs = sweep_specs(name)?;
    let out = out.unwrap_or_else(|| default_sweep_out(name));
    let mut points = Vec::new();
    let mut md = String::new();
    for spec in &specs {
        points.push(sweep_point_into(
            name, spec, only, &out, extra, scenes_dir, progress,
        )?);
        // Written after every run, so an interrupted sweep keeps what it measured.
        md = write_sweep(name, &out, &points)?;
    }
    Ok(md)
}

/// `couplet validate NAME --sweep --point K`: runs only the K-th point of the sweep
/// (0-based, [`sweep_specs`] order) into `OUT/<scheme>-<spacing>/` and writes its row
/// there for [`sweep_gather`]. Fanned out, one process per point, the points of a sweep
/// share one `OUT` (a shared volume) and write disjoint folders. A run that fails is a
/// row of the table, not an error: only what stops the row being written is.
pub fn sweep_point(
    name: &str,
    point: usize,
    only: &[String],
    out: Option<PathBuf>,
    extra: &[(String, String)],
    scenes_dir: Option<&Path>,
    progress: bool,
) -> Result<(SweepPoint, PathBuf), ValidateError> {
    let specs = sweep_specs(name)?;
    let spec = specs
        .get(point)
        .ok_or_else(|| ValidateError::PointOutOfRange {
            case: name.to_owned(),
            point,
            count: specs.len(),
        })?;
    let out = out.unwrap_or_else(|| default_sweep_out(name));
    let p = sweep_point_into(name, spec, only, &out, extra, scenes_dir, progress)?;
    Ok((p, spec.row_file(&out)))
}

/// Runs one point of the sweep and writes its row file.
pub(super) fn sweep_point_into(
    name: &str,
    spec: &SweepSpec,
    only: &[String],
    out: &Path,
    extra: &[(String, String)],
    scenes_dir: Option<&Path>,
    progress: bool,
) -> Result<SweepPoint, ValidateError> {
    let case = find(name)?;
    let variants = chosen_variants(case, true, only)?;
    let o = sweep_point_overrides(case, spec, scenes_dir)?;
    eprintln!(
        "sweep {name}: point {} ({}, δ = {:e} m) …",
        spec.index, spec.scheme, spec.spacing
    );
    let t0 = Instant::now();
    // A run that fails (a blow-up, say) is a result of the sweep, not its end; Ctrl-C or
    // SIGTERM is its end, and leaves no row for the point.
    let point = match run_case(
        case,
        &variants,
        true,
        Some(spec),
        &o,
        extra,
        spec.dir(out),
        scenes_dir,
        &HowToRun {
            progress,
            ..Default::default()
        },
    ) {
        Ok(r) => SweepPoint {
            scheme: spec.scheme.into(),
            spacing: spec.spacing,
            particles: r.particles,
            wall_s: r.wall_s,
            headline: r.headline.clone(),
            passed: r.passed(),
            failure: None,
        },
        Err(e) if e.is_interrupted() => return Err(e),
        Err(e) => SweepPoint {
            scheme: spec.scheme.into(),
            spacing: spec.spacing,
            particles: 0,
            wall_s: t0.elapsed().as_secs_f64(),
            headline: None,
            passed: false,
            failure: Some(e.to_string()),
        },
    };
    write_sweep_row(name, spec, out, &point)?;
    Ok(point)
}

/// The overrides of sweep point `spec`, under the command line's: the quick's, the
/// scheme's, the spacing, and along each of `case.sweep_thin_axes` the domain and the
/// first block cut to as many of the point's spacings as the quick has of its own.
pub(super) fn sweep_point_overrides(
    case: &Case,
    spec: &SweepSpec,
    scenes_dir: Option<&Path>,
) -> Result<Vec<(String, String)>, ValidateError> {
    let mut o = pairs(case.quick);
    o.extend(pairs(spec.scheme_overrides));
    // The quick's scene, before the point's spacing, gives each thin span in spacings.
    let quick = if case.sweep_thin_axes.is_empty() {
        None
    } else {
        Some(resolve_scene(&scene_path(case, scenes_dir)?, &o)?.0)
    };
    o.push(("fluid.spacing".into(), format!("{:e}", spec.spacing)));
    let Some(quick) = quick else {
        return Ok(o);
    };
    let (d, block) = quick
        .fluid
        .as_ref()
        .and_then(|f| Some((f.spacing, f.blocks.first()?)))
        .ok_or_else(|| {
            ValidateError::Analysis(format!(
                "case `{}`: a thin span needs a fluid block to cut",
                case.name
            ))
        })?;
    for &k in case.sweep_thin_axes {
        let (lo, hi) = (quick.domain.min[k], quick.domain.max[k]);
        let span = (hi - lo) / d * spec.spacing;
        o.push((format!("domain.max.{k}"), format!("{:e}", lo + span)));
        o.push((
            format!("fluid.blocks.0.max.{k}"),
            format!("{:e}", block.min[k] + span),
        ));
    }
    Ok(o)
}

/// Writes `point`, the result of `spec`, as its row file under `out`.
pub(super) fn write_sweep_row(
    name: &str,
    spec: &SweepSpec,
    out: &Path,
    point: &SweepPoint,
) -> Result<(), ValidateError> {
    let dir = spec.dir(out);
    std::fs::create_dir_all(&dir).map_err(|source| ValidateError::Io {
        what: format!("creating {}", dir.display()),
        source,
    })?;
    // The error as text: JSON has no NaN, and a headline may be one (a failed fit).
    let headline = point
        .headline
        .as_ref()
        .map(|(measure, e)| serde_json::json!({ "measure": measure, "error": format!("{e:e}") }));
    let row = serde_json::json!({
        "case": name,
        "index": spec.index,
        "scheme": point.scheme,
        "spacing_m": point.spacing,
        "fluid_particles": point.particles,
        "wall_s": point.wall_s,
        "headline": headline,
        "passed": point.passed,
        "failure": point.failure,
    });
    let path = spec.row_file(out);
    // Written whole then renamed: a gather that runs while a point finishes never
    // reads half a row.
    let tmp = path.with_extension("json.part");
    std::fs::write(&tmp, format!("{row:#}\n"))
        .and_then(|()| std::fs::rename(&tmp, &path))
        .map_err(|source| ValidateError::Io {
            what: format!("writing {}", path.display()),
            source,
        })
}

/// Reads the row file `path` and checks that it is point `spec` of case `name`.
pub(super) fn read_sweep_row(
    name: &str,
    spec: &SweepSpec,
    path: &Path,
) -> Result<SweepPoint, ValidateError> {
    let bad = |why: String| ValidateError::BadRow {
        file: path.to_owned(),
        why,
    };
    let text = std::fs::read_to_string(path).map_err(|source| ValidateError::Io {
        what: format!("reading {}", path.display()),
        source,
    })?;
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| bad(format!("not JSON: {e}")))?;
    let field = |k: &str| v.get(k).ok_or_else(|| bad(format!("no field `{k}`")));
    let string = |k: &str| {
        field(k)?
            .as_str()
            .map(str::to_owned)
            .ok_or_else(|| bad(format!("`{k}` is not a string")))
    };
    let number = |k: &str| {
        field(k)?
            .as_f64()
            .ok_or_else(|| bad(format!("`{k}` is not a number")))
    };
    let integer = |k: &str| {
        field(k)?
            .as_u64()
            .ok_or_else(|| bad(format!("`{k}` is not a whole number")))
    };
    let (case, index, scheme, spacing) = (
        string("case")?,
        integer("index")?,
        string("scheme")?,
        number("spacing_m")?,
    );
    // A row from another case, or from a build whose sweep lists differ, would put a
    // number in the wrong line of the table.
    if case != name
        || index != spec.index as u64
        || scheme != spec.scheme
        || spacing != spec.spacing
    {
        return Err(bad(format!(
            "it is point {index} of `{case}` ({scheme}, δ = {spacing:e} m); this folder of the sweep holds point {} of `{name}` ({}, δ = {:e} m)",
            spec.index, spec.scheme, spec.spacing
        )));
    }
    let headline = match field("headline")? {
        serde_json::Value::Null => None,
        h => {
            let measure = h.get("measure").and_then(|m| m.as_str());
            let error = h
                .get("error")
                .and_then(|e| e.as_str())
                .and_then(|e| e.parse::<f64>().ok());
            match (measure, error) {
                (Some(m), Some(e)) => Some((m.to_owned(), e)),
                _ => {
                    return Err(bad(
                        "`headline` must be null or {\"measure\": text, \"error\": a number as text}"
                            .into(),
                    ));
                }
            }
        }
    };
    let failure = match field("failure")? {
        serde_json::Value::Null => None,
        f => Some(
            f.as_str()
                .ok_or_else(|| bad("`failure` must be null or text".into()))?
                .to_owned(),
        ),
    };
    Ok(SweepPoint {
        scheme,
        spacing,
        particles: integer("fluid_particles")? as usize,
        wall_s: number("wall_s")?,
        headline,
        passed: field("passed")?
            .as_bool()
            .ok_or_else(|| bad("`passed` is not true or false".into()))?,
        failure,
    })
}

/// What [`sweep_gather`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct Gathered {
    /// The table of the rows found, as `--sweep` prints it.
    pub markdown: String,
    /// Points with no row yet, with the file each should have written.
    pub missing: Vec<(usize, PathBuf)>,
}

/// `couplet validate NAME --sweep --gather`: reads the rows the points wrote under
/// `OUT` and writes the sweep's table, CSV and plot there, exactly as `--sweep` run in
/// one process would. Points without a row are left out of the table and listed.
pub fn sweep_gather(name: &str, out: Option<PathBuf>) -> Result<Gathered, ValidateError> {
    let specs = sweep_specs(name)?;
    let out = out.unwrap_or_else(|| default_sweep_out(name));
    let mut points = Vec::new();
    let mut missing = Vec::new();
    for spec in &specs {
        let path = spec.row_file(&out);
        if path.is_file() {
            points.push(read_sweep_row(name, spec, &path)?);
        } else {
            missing.push((spec.index, path));
        }
    }
    if points.is_empty() {
        return Err(ValidateError::NoRows {
            case: name.to_owned(),
            out,
            count: specs.len(),
        });
    }
    Ok(Gathered {
        markdown: write_sweep(name, &out, &points)?,
        missing,
    })
}

/// A folder name for a scheme label: "corrected + shifting" → "corrected-shifting".
pub(super) fn slug(label: &str) -> String {
    label
        .split(|c: char| !c.is_alphanumeric() && c != '.')
        .filter(|w| !w.is_empty())
        .collect::<Vec<_>>()
        .join("-")
}

pub(super) fn write_sweep(
    name: &str,
    out: &Path,
    points: &[SweepPoint],
) -> Result<String, ValidateError> {
    let measure = points
        .iter()
        .find_map(|p| p.headline.as_ref().map(|h| h.0.clone()))
        .unwrap_or_default();
    let mut md = format!(
        "## {name} sweep: {measure} against cost\n\n| scheme | δ (m) | fluid particles | wall time (s) | error | all rows pass |\n|---|---|---|---|---|---|\n"
    );
    let mut csv = String::from("scheme,spacing_m,fluid_particles,wall_s,error,passed\n");
    for p in points {
        let e = p.headline.as_ref().map_or(f64::NAN, |h| h.1);
        let error = match &p.failure {
            Some(f) => format!("run failed: {}", f.replace('|', "/")),
            None => pct(e),
        };
        let _ = writeln!(
            md,
            "| {} | {:e} | {} | {:.1} | {error} | {} |",
            p.scheme, p.spacing, p.particles, p.wall_s, p.passed
        );
        let _ = writeln!(
            csv,
            "{},{:e},{},{:.3},{:e},{}",
            p.scheme, p.spacing, p.particles, p.wall_s, e, p.passed
        );
    }
    let io = |what: String| move |source| ValidateError::Io { what, source };
    std::fs::create_dir_all(out).map_err(io(format!("creating {}", out.display())))?;
    let title = |x: &str| format!("{name} sweep: {measure} against {x}");
    let by_wall = sweep_svg(&title("wall time"), "wall time (s)", points, |p| p.wall_s);
    let by_particles = sweep_svg(&title("fluid particles"), "fluid particles", points, |p| {
        p.particles as f64
    });
    for (file, text) in [
        ("sweep.md", md.clone()),
        ("sweep.csv", csv),
        ("sweep.svg", by_wall),
        ("sweep-particles.svg", by_particles),
    ] {
        let path = out.join(file);
        std::fs::write(&path, text).map_err(io(format!("writing {}", path.display())))?;
    }
    Ok(md)
}
