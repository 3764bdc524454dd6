//! A run's outputs, fed from one place in the coupling loop: the MCAP recording
//! (`run.mcap`, always; `record.rs`), the body time series `bodies.csv` (`[output]
//! body_csv`, default on) and the ParaView files (`[output] vtk`, default off; `vtk.rs`).
//!
//! `bodies.csv` has one row per body per recorded body time (the times of
//! `/bodies/states`), in the order the DEM reports the bodies:
//!
//! | column | unit | what |
//! |---|---|---|
//! | `time_s` | s | the body time |
//! | `body`, `name` | | scene index and name (quoted when it holds a comma or a quote) |
//! | `x_m`, `y_m`, `z_m` | m | centre of mass |
//! | `qx`, `qy`, `qz`, `qw` | | unit quaternion, body to world |
//! | `vx_m_per_s` … `vz_m_per_s` | m/s | velocity of the centre of mass |
//! | `wx_rad_per_s` … `wz_rad_per_s` | rad/s | angular velocity, world frame |
//! | `fx_N` … `fz_N`, `mx_N_m` … `mz_N_m` | N, N·m | the fluid's force and moment about the centre of mass over the window that ended at `time_s` (the `/bodies/loads` message of that window, stamped with its start); empty for a body the fluid sends no load to |
//!
//! Numbers are written as the shortest decimal that reads back as the same `f64`. The
//! file is flushed after every window, so a killed run leaves every window before the
//! last one whole.

use crate::record::{RecordError, Recorder, SceneBody, motion_of};
use crate::vtk::{BodyMotion, VtkWriter, body_mesh};
use couplet_dem::BodyGeometry;
use couplet_protocol::{BodyLoad, BodyState, ParticleRecord, Scene, SideReport};
use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// The run's MCAP recording, in the output folder.
pub const MCAP_FILE: &str = "run.mcap";
/// The body time series, in the output folder.
pub const BODY_CSV_FILE: &str = "bodies.csv";

/// The header row of `bodies.csv`.
pub const BODY_CSV_HEADER: &str = "time_s,body,name,x_m,y_m,z_m,qx,qy,qz,qw,\
vx_m_per_s,vy_m_per_s,vz_m_per_s,wx_rad_per_s,wy_rad_per_s,wz_rad_per_s,\
fx_N,fy_N,fz_N,mx_N_m,my_N_m,mz_N_m";

/// Everything a run writes besides `scene.toml`.
pub struct Outputs {
    mcap: Recorder,
    csv: Option<BodyCsv>,
    vtk: Option<VtkWriter>,
    names: Vec<String>,
    /// Every scene body's last known motion: its scene pose until the DEM reports it (a
    /// scene whose only bodies are fluid obstacles runs no DEM server).
    motion: Vec<BodyMotion>,
    /// A scene without fluid has no particle snapshots: its VTK body frames follow
    /// `time.output_interval` on the recorded body times instead.
    has_fluid: bool,
    output_interval: f64,
    next_body_frame: f64,
    /// States recorded this window, waiting for the window's loads to make CSV rows.
    pending: Option<(f64, Vec<BodyState>)>,
    pending_loads: Vec<BodyLoad>,
}

impl Outputs {
    /// Opens `OUT/run.mcap` and, as the scene's `[output]` asks, `OUT/bodies.csv` and the
    /// VTK files; removes the CSV and VTK files an earlier run left in `out` that this
    /// run will not rewrite, so that the folder never mixes two runs.
    pub fn create(out: &Path, scene: &Scene, text: &str) -> Result<Self, RecordError> {
        let bodies = scene
            .bodies
            .iter()
            .enumerate()
            .map(|(index, b)| {
                let geometry =
                    BodyGeometry::from_shape(&b.shape).map_err(|source| RecordError::Shape {
                        index,
                        name: b.name.clone(),
                        source,
                    })?;
                Ok(SceneBody {
                    name: b.name.clone(),
                    geometry,
                    start: BodyMotion {
                        position: b.position,
                        orientation: couplet_protocol::vec3::quat_from_scaled_axis(b.rotation),
                        velocity: b.velocity,
                        angular_velocity: b.angular_velocity,
                    },
                })
            })
            .collect::<Result<Vec<_>, RecordError>>()?;
        let mcap = Recorder::create(&out.join(MCAP_FILE), &scene.meta.name, text, &bodies)?;
        let csv_path = out.join(BODY_CSV_FILE);
        let csv = if scene.output.body_csv {
            Some(BodyCsv::create(csv_path)?)
        } else {
            remove_stale(&csv_path)?;
            None
        };
        let vtk = if scene.output.vtk {
            let meshes = bodies.iter().map(|b| body_mesh(&b.geometry)).collect();
            Some(VtkWriter::create(out, meshes)?)
        } else {
            VtkWriter::remove_stale(out)?;
            None
        };
        Ok(Self {
            mcap,
            csv,
            vtk,
            names: bodies.iter().map(|b| b.name.clone()).collect(),
            motion: bodies.iter().map(|b| b.start).collect(),
            has_fluid: scene.fluid.is_some(),
            output_interval: scene.time.output_interval,
            next_body_frame: 0.0,
            pending: None,
            pending_loads: Vec::new(),
        })
    }

    /// `OUT/run.mcap`.
    pub fn mcap_path(&self) -> &Path {
        self.mcap.path()
    }

    /// Body states at a recorded body time.
    pub fn bodies(&mut self, time: f64, states: &[BodyState]) -> Result<(), RecordError> {
        self.mcap.bodies(time, states);
        self.write_pending()?;
        self.pending = Some((time, states.to_vec()));
        self.update_motion(states);
        let due = time >= self.next_body_frame * (1.0 - 1e-9);
        if let Some(vtk) = self.vtk.as_mut().filter(|_| !self.has_fluid && due) {
            vtk.bodies(time, &self.motion)?;
            while self.next_body_frame <= time * (1.0 + 1e-9) {
                self.next_body_frame += self.output_interval;
            }
        }
        Ok(())
    }

    /// The fluid loads of the window, recorded with the body states of its end.
    pub fn loads(&mut self, time: f64, loads: &[BodyLoad]) -> Result<(), RecordError> {
        self.mcap.loads(time, loads);
        self.pending_loads.clear();
        self.pending_loads.extend_from_slice(loads);
        Ok(())
    }

    /// A particle snapshot, with the latest body `states` (those of the same time,
    /// recorded or not) for the VTK body frame.
    pub fn particles(
        &mut self,
        time: f64,
        particles: &[ParticleRecord],
        states: &[BodyState],
    ) -> Result<(), RecordError> {
        self.mcap.particles(time, particles);
        self.update_motion(states);
        if let Some(vtk) = self.vtk.as_mut() {
            vtk.fluid(time, particles)?;
            vtk.bodies(time, &self.motion)?;
        }
        Ok(())
    }

    /// The end of a window: its timings, and the CSV rows of its body states.
    pub fn window(
        &mut self,
        step: u64,
        time: f64,
        window: f64,
        wall_s: f64,
        fluid: Option<&SideReport>,
        dem: Option<&SideReport>,
    ) -> Result<(), RecordError> {
        self.mcap.window(step, time, window, wall_s, fluid, dem);
        self.write_pending()?;
        if let Some(csv) = self.csv.as_mut() {
            csv.flush()?;
        }
        Ok(())
    }

    /// Writes out the recording so far (the CSV is written out every window): what a
    /// checkpoint needs before it counts ([`crate::run::CoupledRun::checkpoint`]).
    pub fn flush(&mut self) -> Result<(), RecordError> {
        self.mcap.flush()
    }

    /// Writes what is pending and closes every file; the MCAP gets its summary.
    pub fn close(&mut self) -> Result<(), RecordError> {
        let rows = self.write_pending();
        let csv = self.csv.as_mut().map_or(Ok(()), BodyCsv::flush);
        // The recording is closed whatever the CSV did: it is the primary record.
        self.mcap.close()?;
        rows.and(csv)
    }

    fn update_motion(&mut self, states: &[BodyState]) {
        for s in states {
            if let Some(m) = self.motion.get_mut(s.body as usize) {
                *m = motion_of(s);
            }
        }
    }

    fn write_pending(&mut self) -> Result<(), RecordError> {
        let Some((time, states)) = self.pending.take() else {
            return Ok(());
        };
        let loads = std::mem::take(&mut self.pending_loads);
        let Some(csv) = self.csv.as_mut() else {
            return Ok(());
        };
        let load_of = loads_by_body(&loads);
        for s in &states {
            let name = self.names.get(s.body as usize).map_or("", String::as_str);
            csv.row(
                time,
                s,
                name,
                load_of.get(s.body as usize).copied().flatten(),
            )?;
        }
        Ok(())
    }
}

/// Each body's load by body index (`None` for a body without one), to pair every state
/// with its load in one pass. Searching the loads for each state was quadratic: a
/// record of 15 300 grains took 158 ms with the search and 97 ms without, one run each
/// on this repository's two-core machine (`couplet run scenes/rayleigh-taylor.toml
/// --windows 8 --set time.body_output_interval=1e-6`, its `then recording` figure).
pub(crate) fn loads_by_body(loads: &[BodyLoad]) -> Vec<Option<&BodyLoad>> {
    let n = loads.iter().map(|l| l.body as usize + 1).max().unwrap_or(0);
    let mut by_body = vec![None; n];
    for l in loads {
        by_body[l.body as usize] = Some(l);
    }
    by_body
}

fn remove_stale(path: &Path) -> Result<(), RecordError> {
    match std::fs::remove_file(path) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(source) => Err(RecordError::Io {
            path: path.to_owned(),
            what: "cannot remove the earlier run's file",
            source,
        }),
    }
}

/// `bodies.csv`.
struct BodyCsv {
    path: PathBuf,
    w: BufWriter<File>,
}

impl BodyCsv {
    fn create(path: PathBuf) -> Result<Self, RecordError> {
        let io = |what| {
            let path = path.clone();
            move |source| RecordError::Io { path, what, source }
        };
        let mut w = BufWriter::new(File::create(&path).map_err(io("cannot create"))?);
        writeln!(w, "{BODY_CSV_HEADER}").map_err(io("cannot write"))?;
        Ok(Self { path, w })
    }

    fn row(
        &mut self,
        time: f64,
        s: &BodyState,
        name: &str,
        load: Option<&BodyLoad>,
    ) -> Result<(), RecordError> {
        // `{:e}`: the shortest decimal that reads back as the same f64.
        let mut line = format!("{time:e},{},{}", s.body, csv_field(name));
        let numbers = s
            .position
            .iter()
            .chain(&s.orientation)
            .chain(&s.linear_velocity)
            .chain(&s.angular_velocity);
        // Written into the line, not formatted apart and copied (an allocation a number).
        for v in numbers {
            let _ = write!(line, ",{v:e}");
        }
        match load {
            Some(l) => {
                for v in l.force.iter().chain(&l.moment) {
                    let _ = write!(line, ",{v:e}");
                }
            }
            None => line.push_str(",,,,,,"),
        }
        writeln!(self.w, "{line}").map_err(|source| RecordError::Io {
            path: self.path.clone(),
            what: "cannot write",
            source,
        })
    }

    fn flush(&mut self) -> Result<(), RecordError> {
        self.w.flush().map_err(|source| RecordError::Io {
            path: self.path.clone(),
            what: "cannot write",
            source,
        })
    }
}

/// RFC 4180: a field holding a comma, a quote or a line break is quoted, quotes doubled.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A DEM-only scene (no fluid, so no particle snapshots): two bodies, one of them a
    /// 12-face prism.
    const DEM_ONLY: &str = r#"
[meta]
name = "dem-only"
[time]
end = 0.1
output_interval = 0.02
[domain]
min = [0, 0, 0]
max = [1, 1, 1]
[output]
vtk = true
[[bodies]]
name = "ball, small"
shape.sphere.radius = 0.05
density = 1000.0
position = [0.5, 0.5, 0.5]
[[bodies]]
name = "prism"
shape.prism = { sides = 12, radius = 0.05, half_height = 0.1 }
density = 1000.0
position = [0.2, 0.5, 0.5]
rotation = [0.0, 0.0, 1.5707963267948966]
"#;

    fn state(body: u32, t: f64) -> BodyState {
        BodyState {
            position: [0.5, 0.5 - t, 0.5],
            body,
            motion: 2,
            orientation: [0.0, 0.0, 0.0, 1.0],
            linear_velocity: [0.0, -1.0, 0.0],
            angular_velocity: [0.0, 0.0, 0.0],
            mass: 1.0,
            volume: 1e-3,
        }
    }

    /// Without fluid, VTK body frames follow the output interval on the body times; CSV
    /// rows carry their window's loads (empty where a body has none) and quote names
    /// with commas; every file is complete after `close`.
    #[test]
    fn dem_only_outputs_follow_the_output_interval() {
        let dir = tempfile::tempdir().unwrap();
        let scene = Scene::parse(DEM_ONLY, Path::new("dem-only.toml")).unwrap();
        let mut o = Outputs::create(dir.path(), &scene, DEM_ONLY).unwrap();
        // Windows of 5 ms: frames at 0 (the first body time) and every 20 ms after.
        let window = 0.005;
        for step in 0..20u64 {
            let t = (step + 1) as f64 * window;
            o.bodies(t, &[state(0, t), state(1, t)]).unwrap();
            let load = BodyLoad {
                force: [0.0, step as f64, 0.0],
                body: 0,
                _pad: 0,
                moment: [0.0; 3],
            };
            o.loads(t - window, &[load]).unwrap();
            o.window(step, t - window, window, 0.0, None, None).unwrap();
        }
        let (fluid, bodies) = o.vtk.as_ref().unwrap().frames();
        o.close().unwrap();
        // Body times 5, 10, …, 100 ms; the first at or after 0, 20, 40, 60, 80, 100 ms.
        assert_eq!((fluid, bodies), (0, 6));
        let pvd = std::fs::read_to_string(dir.path().join("bodies.pvd")).unwrap();
        assert_eq!(pvd.matches("<DataSet").count(), 6);
        assert!(!dir.path().join("fluid.pvd").exists());
        let csv = std::fs::read_to_string(dir.path().join(BODY_CSV_FILE)).unwrap();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], BODY_CSV_HEADER);
        assert_eq!(lines.len(), 1 + 40);
        assert!(
            lines[1].starts_with("5e-3,0,\"ball, small\",5e-1,"),
            "{}",
            lines[1]
        );
        // Window 3's load on body 0; body 1 has none.
        assert!(
            lines[7].ends_with(",0e0,3e0,0e0,0e0,0e0,0e0"),
            "{}",
            lines[7]
        );
        assert!(lines[8].ends_with(",,,,,,"), "{}", lines[8]);
        assert_eq!(
            lines[8].split(',').count(),
            BODY_CSV_HEADER.split(',').count()
        );
    }

    /// Regression (a record's CSV quadratic in the bodies): each state is paired with
    /// its own body's load in one pass, whatever order the loads come in, and a body
    /// without a load gets none.
    #[test]
    fn a_quadratic_body_record_pairs_each_state_with_its_own_load() {
        let load = |body: u32| BodyLoad {
            force: [body as f64, 0.0, 0.0],
            body,
            _pad: 0,
            moment: [0.0; 3],
        };
        let loads = [load(4), load(0), load(2)];
        let by_body = loads_by_body(&loads);
        assert_eq!(by_body.len(), 5);
        for (body, l) in by_body.iter().enumerate() {
            match l {
                Some(l) => assert_eq!((l.body as usize, l.force[0]), (body, body as f64)),
                None => assert!([1, 3].contains(&body), "body {body}"),
            }
        }
        assert!(loads_by_body(&[]).is_empty());
    }

    /// Re-running into a folder with VTK off removes the earlier run's VTK files and
    /// CSV off its CSV, so the folder never mixes two runs.
    #[test]
    fn a_rerun_removes_the_files_it_will_not_rewrite() {
        let dir = tempfile::tempdir().unwrap();
        let scene = Scene::parse(DEM_ONLY, Path::new("dem-only.toml")).unwrap();
        let mut o = Outputs::create(dir.path(), &scene, DEM_ONLY).unwrap();
        o.bodies(0.0, &[state(0, 0.0)]).unwrap();
        o.close().unwrap();
        assert!(dir.path().join("vtk/bodies_000000.vtp").exists());
        let off = DEM_ONLY.replace("vtk = true", "vtk = false\nbody_csv = false");
        let scene = Scene::parse(&off, Path::new("dem-only.toml")).unwrap();
        let mut o = Outputs::create(dir.path(), &scene, &off).unwrap();
        o.close().unwrap();
        assert!(!dir.path().join("vtk/bodies_000000.vtp").exists());
        assert!(!dir.path().join("bodies.pvd").exists());
        assert!(!dir.path().join(BODY_CSV_FILE).exists());
        assert!(dir.path().join(MCAP_FILE).exists());
    }
}
