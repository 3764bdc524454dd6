//! ParaView output (`[output] vtk = true`): body surfaces as triangle meshes, and the VTK
//! XML files of a run.
//!
//! At every particle snapshot a run writes `vtk/fluid_NNNNNN.vtp` (PolyData: the fluid
//! particles as points with one vertex cell each, PointData `velocity`, `pressure`,
//! `density`) and `vtk/bodies_NNNNNN.vtp` (every body's surface triangulated at its pose,
//! CellData `body` = scene index, PointData `velocity` = the rigid-body velocity
//! v + ω × (x − c) at each vertex), and rewrites the collections `fluid.pvd` and
//! `bodies.pvd` in the output folder (`timestep` = simulation time, s). Each file is
//! written beside its final name and renamed into place, frame first and collection
//! second, so that a run killed at any instant leaves collections that list only
//! complete frames.
//!
//! Data arrays are `format="binary"`: base64 inline, each array one stream of a UInt64
//! byte count and the little-endian values, about 55 bytes per fluid particle. ASCII
//! would print a float32 in up to 15 characters against base64's 5.3, and the appended
//! raw format is not XML (its raw bytes are not text), so no XML parser could check the
//! files; base64 inline is exact and reads back with any XML reader. VTK 9.7's
//! `vtkXMLPolyDataReader` reads these files (checked by hand on a run of
//! `tests/tests/recordings.rs`'s scene, 2026-11-25: point and cell counts, arrays, and
//! the bodies' volumes).

use crate::record::RecordError;
use base64::engine::general_purpose::STANDARD;
use base64::write::EncoderWriter;
use couplet_dem::BodyGeometry;
use couplet_dem::geometry::Polyhedron;
use couplet_protocol::ParticleRecord;
use couplet_protocol::vec3::{cross, dot, rotate, sub};
use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Longitudes of a sphere's mesh. 24 × 12 quads hold the mesh's area within 1.5 % and its
/// volume within 2.9 % of the sphere's (`tests::uv_sphere_converges_to_the_sphere`),
/// finer than a screen shows at the sizes ParaView opens a run at, and 528 triangles a
/// sphere keep a frame of a thousand grains under 20 MB.
pub const SPHERE_SEGMENTS: u32 = 24;
/// Latitude bands of a sphere's mesh (half the longitudes: square quads at the equator).
pub const SPHERE_BANDS: u32 = 12;
/// Sides of a cylinder's mesh: an inscribed 32-gon holds 99.4 % of the circle's area.
pub const CYLINDER_SEGMENTS: u32 = 32;

/// A closed triangle mesh in the body frame, counter-clockwise seen from outside.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex coordinates, m.
    pub points: Vec<[f64; 3]>,
    /// Vertex indices of each triangle.
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Surface area, m².
    pub fn area(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.points[i as usize]);
                0.5 * dot(cross(sub(b, a), sub(c, a)), cross(sub(b, a), sub(c, a))).sqrt()
            })
            .sum()
    }

    /// Enclosed volume, m³, by the divergence theorem: Σ a · (b × c) / 6 over the
    /// triangles (positive when they face outwards).
    pub fn volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.points[i as usize]);
                dot(a, cross(b, c)) / 6.0
            })
            .sum()
    }

    fn push_fan(&mut self, corners: &[[f64; 3]]) {
        let base = self.points.len() as u32;
        self.points.extend_from_slice(corners);
        for k in 1..corners.len().saturating_sub(1) as u32 {
            self.triangles.push([base, base + k, base + k + 1]);
        }
    }
}

/// A sphere of `radius` meshed on `segments` longitudes and `bands` latitude bands, poles
/// on ±y; vertices on the sphere, so the mesh is inscribed and converges from below.
pub fn uv_sphere(radius: f64, segments: u32, bands: u32) -> TriMesh {
    use std::f64::consts::PI;
    let (n, m) = (segments.max(3), bands.max(2));
    // (sin θ sin φ, cos θ, sin θ cos φ) is the textbook spherical parametrisation with its
    // axes permuted cyclically, so ∂θ × ∂φ still points outwards.
    let at = |k: u32, j: u32| {
        let (theta, phi) = (PI * k as f64 / m as f64, 2.0 * PI * j as f64 / n as f64);
        [
            radius * theta.sin() * phi.sin(),
            radius * theta.cos(),
            radius * theta.sin() * phi.cos(),
        ]
    };
    let mut mesh = TriMesh::default();
    mesh.points.push([0.0, radius, 0.0]);
    for k in 1..m {
        for j in 0..n {
            mesh.points.push(at(k, j));
        }
    }
    mesh.points.push([0.0, -radius, 0.0]);
    let south = mesh.points.len() as u32 - 1;
    let ring = |k: u32, j: u32| 1 + (k - 1) * n + j % n;
    for j in 0..n {
        mesh.triangles.push([0, ring(1, j), ring(1, j + 1)]);
        for k in 1..m - 1 {
            let (a, b, c, d) = (
                ring(k, j),
                ring(k + 1, j),
                ring(k + 1, j + 1),
                ring(k, j + 1),
            );
            mesh.triangles.push([a, b, c]);
            mesh.triangles.push([a, c, d]);
        }
        mesh.triangles
            .push([ring(m - 1, j), south, ring(m - 1, j + 1)]);
    }
    mesh
}

/// A cylinder along y (couplet's cylinder axis) of `radius` and `half_height`: an
/// inscribed prism of `segments` sides with flat caps.
pub fn cylinder_mesh(radius: f64, half_height: f64, segments: u32) -> TriMesh {
    use std::f64::consts::PI;
    let n = segments.max(3);
    let rim = |j: u32, y: f64| {
        let phi = 2.0 * PI * j as f64 / n as f64;
        [radius * phi.sin(), y, radius * phi.cos()]
    };
    let mut mesh = TriMesh::default();
    // Side: ∂φ × ∂y is outward for this parametrisation.
    for j in 0..n {
        mesh.push_fan(&[
            rim(j, -half_height),
            rim(j + 1, -half_height),
            rim(j + 1, half_height),
            rim(j, half_height),
        ]);
    }
    // Caps: counter-clockwise about +y on top, about −y below.
    let top: Vec<[f64; 3]> = (0..n).map(|j| rim(j, half_height)).collect();
    let bottom: Vec<[f64; 3]> = (0..n).rev().map(|j| rim(j, -half_height)).collect();
    mesh.push_fan(&top);
    mesh.push_fan(&bottom);
    mesh
}

/// Convex polyhedra's faces fanned into triangles (each face convex, counter-clockwise
/// from outside), with vertices of their own per face so that edges stay sharp.
pub fn polyhedra_mesh(parts: &[Polyhedron]) -> TriMesh {
    let mut mesh = TriMesh::default();
    for p in parts {
        for f in &p.faces {
            mesh.push_fan(&p.face_points(f));
        }
    }
    mesh
}

/// The body-frame surface of a body: a UV sphere, a box's six faces, a prism standing for
/// a cylinder, or the faces of its convex parts.
pub fn body_mesh(geometry: &BodyGeometry) -> TriMesh {
    match geometry {
        BodyGeometry::Sphere { radius } => uv_sphere(*radius, SPHERE_SEGMENTS, SPHERE_BANDS),
        BodyGeometry::Box { half_extents } => polyhedra_mesh(&[Polyhedron::cuboid(*half_extents)]),
        BodyGeometry::Cylinder {
            radius,
            half_height,
        } => cylinder_mesh(*radius, *half_height, CYLINDER_SEGMENTS),
        BodyGeometry::Polyhedra(parts) => polyhedra_mesh(parts),
    }
}

/// Where a body is and how it moves, for one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyMotion {
    /// Centre of mass, m.
    pub position: [f64; 3],
    /// Unit quaternion `[x, y, z, w]`, body → world.
    pub orientation: [f64; 4],
    /// m/s.
    pub velocity: [f64; 3],
    /// rad/s, world frame.
    pub angular_velocity: [f64; 3],
}

/// One `.pvd` collection, rewritten whole after every frame.
#[derive(Debug)]
struct Collection {
    /// `OUT/NAME.pvd`.
    path: PathBuf,
    /// `NAME` (the frames are `vtk/NAME_NNNNNN.vtp`).
    name: &'static str,
    /// Simulation time of each frame written, s.
    times: Vec<f64>,
}

impl Collection {
    fn frame_name(&self, index: usize) -> String {
        format!("{}_{index:06}.vtp", self.name)
    }

    fn rewrite(&self) -> Result<(), RecordError> {
        let mut text = String::from(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\" byte_order=\"LittleEndian\">\n  <Collection>\n",
        );
        for (i, t) in self.times.iter().enumerate() {
            // `{:e}` is the shortest text that reads back as the same f64.
            let _ = writeln!(
                text,
                "    <DataSet timestep=\"{t:e}\" group=\"\" part=\"0\" file=\"{VTK_DIR}/{}\"/>",
                self.frame_name(i)
            );
        }
        text.push_str("  </Collection>\n</VTKFile>\n");
        write_then_rename(&self.path, |w| w.write_all(text.as_bytes()))
    }
}

/// The folder of the frames, inside the output folder.
pub const VTK_DIR: &str = "vtk";

/// Writes the VTK files of a run: frames under `OUT/vtk/`, collections in `OUT`.
#[derive(Debug)]
pub struct VtkWriter {
    dir: PathBuf,
    fluid: Collection,
    bodies: Collection,
    /// Body-frame surface of every scene body, scene order.
    meshes: Vec<TriMesh>,
}

impl VtkWriter {
    /// Creates `OUT/vtk/` after removing what an earlier run left ([`Self::remove_stale`]).
    pub fn create(out: &Path, meshes: Vec<TriMesh>) -> Result<Self, RecordError> {
        Self::remove_stale(out)?;
        let dir = out.join(VTK_DIR);
        std::fs::create_dir_all(&dir).map_err(|source| RecordError::Io {
            path: dir.clone(),
            what: "cannot create the VTK folder",
            source,
        })?;
        let collection = |name| Collection {
            path: out.join(format!("{name}.pvd")),
            name,
            times: Vec::new(),
        };
        Ok(Self {
            dir,
            fluid: collection("fluid"),
            bodies: collection("bodies"),
            meshes,
        })
    }

    /// Removes the collections and frames an earlier run left in `out`: re-running into
    /// one folder is the usual way to redo a run, and a stale frame past this run's last,
    /// or a collection of a run that wrote none this time, would mix two runs. Only
    /// files of the names this module writes are touched.
    pub fn remove_stale(out: &Path) -> Result<(), RecordError> {
        remove_if_present(&out.join("fluid.pvd"))?;
        remove_if_present(&out.join("bodies.pvd"))?;
        let dir = out.join(VTK_DIR);
        let entries = match std::fs::read_dir(&dir) {
            Ok(e) => e,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
            Err(source) => {
                return Err(RecordError::Io {
                    path: dir,
                    what: "cannot list the VTK folder",
                    source,
                });
            }
        };
        for e in entries {
            let e = e.map_err(|source| RecordError::Io {
                path: dir.clone(),
                what: "cannot list the VTK folder",
                source,
            })?;
            let name = e.file_name();
            let name = name.to_string_lossy();
            let ours = ["fluid_", "bodies_"].iter().any(|p| name.starts_with(p))
                && (name.ends_with(".vtp") || name.ends_with(".vtp.partial"));
            if ours {
                remove_if_present(&e.path())?;
            }
        }
        Ok(())
    }

    /// Frames written to each collection so far: (fluid, bodies).
    pub fn frames(&self) -> (usize, usize) {
        (self.fluid.times.len(), self.bodies.times.len())
    }

    /// Writes the next fluid frame and rewrites `fluid.pvd`.
    pub fn fluid(&mut self, time: f64, particles: &[ParticleRecord]) -> Result<(), RecordError> {
        let path = self.dir.join(self.fluid.frame_name(self.fluid.times.len()));
        let n = particles.len();
        let n32 = i32_count(&path, "particles", n)?;
        write_then_rename(&path, |w| {
            write_header(w, time, n, n, 0)?;
            writeln!(
                w,
                "      <PointData Scalars=\"pressure\" Vectors=\"velocity\">"
            )?;
            data_array(w, "Float32", Some("velocity"), 3, |e| {
                particles
                    .iter()
                    .flat_map(|p| p.velocity)
                    .try_for_each(|v| e.write_all(&v.to_le_bytes()))
            })?;
            data_array(w, "Float32", Some("pressure"), 1, |e| {
                particles
                    .iter()
                    .try_for_each(|p| e.write_all(&p.pressure.to_le_bytes()))
            })?;
            data_array(w, "Float32", Some("density"), 1, |e| {
                particles
                    .iter()
                    .try_for_each(|p| e.write_all(&p.density.to_le_bytes()))
            })?;
            writeln!(w, "      </PointData>\n      <Points>")?;
            data_array(w, "Float32", None, 3, |e| {
                particles
                    .iter()
                    .flat_map(|p| p.position)
                    .try_for_each(|v| e.write_all(&v.to_le_bytes()))
            })?;
            writeln!(w, "      </Points>\n      <Verts>")?;
            // One vertex cell per particle: cell i is point i.
            data_array(w, "Int32", Some("connectivity"), 1, |e| {
                (0..n32).try_for_each(|i| e.write_all(&i.to_le_bytes()))
            })?;
            data_array(w, "Int32", Some("offsets"), 1, |e| {
                (1..=n32).try_for_each(|i| e.write_all(&i.to_le_bytes()))
            })?;
            writeln!(w, "      </Verts>")?;
            write_footer(w)
        })?;
        self.fluid.times.push(time);
        self.fluid.rewrite()
    }

    /// Writes the next bodies frame, each scene body `i` at `motion[i]` (one entry per
    /// scene body), and rewrites `bodies.pvd`. A scene without bodies writes none.
    pub fn bodies(&mut self, time: f64, motion: &[BodyMotion]) -> Result<(), RecordError> {
        if self.meshes.is_empty() {
            return Ok(());
        }
        let path = self
            .dir
            .join(self.bodies.frame_name(self.bodies.times.len()));
        let drawn: Vec<(usize, &TriMesh, &BodyMotion)> = self
            .meshes
            .iter()
            .zip(motion)
            .enumerate()
            .map(|(i, (m, b))| (i, m, b))
            .collect();
        let n_points: usize = drawn.iter().map(|(_, m, _)| m.points.len()).sum();
        let n_tris: usize = drawn.iter().map(|(_, m, _)| m.triangles.len()).sum();
        i32_count(&path, "triangle corners", 3 * n_tris)?;
        i32_count(&path, "mesh points", n_points)?;
        let world = |m: &TriMesh, b: &BodyMotion| -> Vec<[f64; 3]> {
            m.points
                .iter()
                .map(|p| {
                    let r = rotate(b.orientation, *p);
                    std::array::from_fn(|k| b.position[k] + r[k])
                })
                .collect()
        };
        write_then_rename(&path, |w| {
            write_header(w, time, n_points, 0, n_tris)?;
            writeln!(w, "      <PointData Vectors=\"velocity\">")?;
            // Rigid-body velocity at each vertex: v + ω × (x − c).
            data_array(w, "Float64", Some("velocity"), 3, |e| {
                for (_, m, b) in &drawn {
                    for p in &m.points {
                        let r = rotate(b.orientation, *p);
                        let spin = cross(b.angular_velocity, r);
                        for k in 0..3 {
                            e.write_all(&(b.velocity[k] + spin[k]).to_le_bytes())?;
                        }
                    }
                }
                Ok(())
            })?;
            writeln!(w, "      </PointData>\n      <CellData Scalars=\"body\">")?;
            data_array(w, "Int32", Some("body"), 1, |e| {
                for (i, m, _) in &drawn {
                    let i = *i as i32;
                    for _ in &m.triangles {
                        e.write_all(&i.to_le_bytes())?;
                    }
                }
                Ok(())
            })?;
            writeln!(w, "      </CellData>\n      <Points>")?;
            data_array(w, "Float64", None, 3, |e| {
                for (_, m, b) in &drawn {
                    for p in world(m, b) {
                        for c in p {
                            e.write_all(&c.to_le_bytes())?;
                        }
                    }
                }
                Ok(())
            })?;
            writeln!(w, "      </Points>\n      <Polys>")?;
            data_array(w, "Int32", Some("connectivity"), 1, |e| {
                let mut base = 0i32;
                for (_, m, _) in &drawn {
                    for t in &m.triangles {
                        for v in t {
                            e.write_all(&(base + *v as i32).to_le_bytes())?;
                        }
                    }
                    base += m.points.len() as i32;
                }
                Ok(())
            })?;
            data_array(w, "Int32", Some("offsets"), 1, |e| {
                (1..=n_tris as i32).try_for_each(|k| e.write_all(&(3 * k).to_le_bytes()))
            })?;
            writeln!(w, "      </Polys>")?;
            write_footer(w)
        })?;
        self.bodies.times.push(time);
        self.bodies.rewrite()
    }
}

/// VTK XML indices here are Int32: a count past it is refused rather than wrapped.
fn i32_count(path: &Path, what: &'static str, n: usize) -> Result<i32, RecordError> {
    i32::try_from(n).map_err(|_| RecordError::TooLarge {
        path: path.to_owned(),
        what,
        count: n,
    })
}

fn remove_if_present(path: &Path) -> Result<(), RecordError> {
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

/// Writes `path.partial` with `body`, then renames it over `path`: readers see either the
/// old file or the whole new one.
fn write_then_rename(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), RecordError> {
    let mut partial = path.as_os_str().to_owned();
    partial.push(".partial");
    let partial = PathBuf::from(partial);
    let io = |what| {
        let path = path.to_owned();
        move |source| RecordError::Io { path, what, source }
    };
    let file = File::create(&partial).map_err(io("cannot create"))?;
    let mut w = BufWriter::new(file);
    body(&mut w).map_err(io("cannot write"))?;
    w.into_inner()
        .map_err(|e| e.into_error())
        .map_err(io("cannot write"))?;
    std::fs::rename(&partial, path).map_err(io("cannot move the finished file into place"))
}

fn write_header(
    w: &mut impl Write,
    time: f64,
    points: usize,
    verts: usize,
    polys: usize,
) -> std::io::Result<()> {
    write!(
        w,
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n  <PolyData>\n    <FieldData>\n"
    )?;
    // ParaView reads `TimeValue` as the time of a file opened on its own.
    write!(
        w,
        "      <DataArray type=\"Float64\" Name=\"TimeValue\" NumberOfTuples=\"1\" format=\"binary\">"
    )?;
    encode(w, |e| e.write_all(&time.to_le_bytes()))?;
    write!(
        w,
        "</DataArray>\n    </FieldData>\n    <Piece NumberOfPoints=\"{points}\" NumberOfVerts=\"{verts}\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"{polys}\">\n"
    )
}

fn write_footer(w: &mut impl Write) -> std::io::Result<()> {
    writeln!(w, "    </Piece>\n  </PolyData>\n</VTKFile>")
}

/// One `<DataArray>` of `components` per tuple, its values written by `values`.
fn data_array<W: Write>(
    w: &mut W,
    ty: &str,
    name: Option<&str>,
    components: usize,
    values: impl FnOnce(&mut Vec<u8>) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let name = name.map_or(String::new(), |n| format!(" Name=\"{n}\""));
    write!(
        w,
        "        <DataArray type=\"{ty}\"{name} NumberOfComponents=\"{components}\" format=\"binary\">"
    )?;
    encode(w, values)?;
    writeln!(w, "</DataArray>")
}

/// Base64 of a UInt64 byte count followed by the bytes, one stream (VTK's layout of an
/// uncompressed inline binary array).
fn encode<W: Write>(
    w: &mut W,
    values: impl FnOnce(&mut Vec<u8>) -> std::io::Result<()>,
) -> std::io::Result<()> {
    // The count comes first, so the values are gathered before anything is encoded.
    let mut bytes = Vec::new();
    values(&mut bytes)?;
    let mut e = EncoderWriter::new(w, &STANDARD);
    e.write_all(&(bytes.len() as u64).to_le_bytes())?;
    e.write_all(&bytes)?;
    e.finish()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use couplet_protocol::Shape;
    use std::f64::consts::PI;

    /// An inscribed UV sphere converges to the sphere from below, its errors falling
    /// about fourfold per doubling of the resolution (second order in the edge length).
    /// Measured relative deficits: area 1.42 %, volume 2.82 % at 24 × 12 (the mesh
    /// written), 0.357 % and 0.712 % at 48 × 24, 0.089 % and 0.178 % at 96 × 48; the
    /// tolerances are these plus a few per cent of themselves.
    #[test]
    fn uv_sphere_converges_to_the_sphere() {
        let r = 1.25e-3;
        let (area, volume) = (4.0 * PI * r * r, 4.0 / 3.0 * PI * r.powi(3));
        let mut last = (1.0, 1.0);
        for (n, tol_area, tol_volume) in [
            (24, 0.0146, 0.029),
            (48, 3.7e-3, 7.3e-3),
            (96, 9.2e-4, 1.84e-3),
        ] {
            let m = uv_sphere(r, n, n / 2);
            let da = 1.0 - m.area() / area;
            let dv = 1.0 - m.volume() / volume;
            assert!(da > 0.0 && da < tol_area, "{n}: area deficit {da}");
            assert!(dv > 0.0 && dv < tol_volume, "{n}: volume deficit {dv}");
            assert!(
                last.0 / da > 3.8 && last.1 / dv > 3.8 || n == 24,
                "{n}: {last:?} → {da} {dv}"
            );
            last = (da, dv);
            for p in &m.points {
                assert!(
                    (dot(*p, *p).sqrt() - r).abs() < 1e-15,
                    "vertex off the sphere"
                );
            }
        }
    }

    /// A box's mesh encloses 8abc with area 8(ab + bc + ca), to round-off.
    #[test]
    fn box_mesh_is_exact() {
        let [a, b, c] = [0.015, 0.02, 0.005];
        let m = body_mesh(&BodyGeometry::Box {
            half_extents: [a, b, c],
        });
        assert_eq!(m.triangles.len(), 12);
        assert!((m.volume() / (8.0 * a * b * c) - 1.0).abs() < 1e-14);
        assert!((m.area() / (8.0 * (a * b + b * c + c * a)) - 1.0).abs() < 1e-14);
    }

    /// A cylinder's mesh is the inscribed n-gon prism along y: volume (n/2) r² sin(2π/n)·2h
    /// to round-off, within 0.65 % of π r²·2h at n = 32; every vertex within its radius
    /// of the y axis and its half height of the mid-plane.
    #[test]
    fn cylinder_mesh_is_the_inscribed_prism_along_y() {
        let (r, h, n) = (1.0e-3, 2.0e-3, CYLINDER_SEGMENTS);
        let m = cylinder_mesh(r, h, n);
        let polygon = 0.5 * n as f64 * r * r * (2.0 * PI / n as f64).sin();
        assert!((m.volume() / (polygon * 2.0 * h) - 1.0).abs() < 1e-13);
        assert!(1.0 - m.volume() / (PI * r * r * 2.0 * h) < 0.0065);
        let side = n as f64 * 2.0 * r * (PI / n as f64).sin() * 2.0 * h;
        assert!((m.area() / (2.0 * polygon + side) - 1.0).abs() < 1e-13);
        for p in &m.points {
            assert!((p[0].hypot(p[2]) - r).abs() < 1e-15 || p[0].hypot(p[2]) == 0.0);
            assert!((p[1].abs() - h).abs() < 1e-18);
        }
    }

    /// Polyhedral shapes mesh face by face, so the mesh's volume is the geometry's
    /// (Joubert's 12-face prism, ring and cross) to round-off.
    #[test]
    fn polyhedra_mesh_encloses_the_geometry() {
        for shape in [
            Shape::Prism {
                sides: 12,
                radius: 1.25e-3,
                half_height: 2e-3,
            },
            Shape::Ring {
                sides: 12,
                inner_radius: 0.725e-3,
                outer_radius: 1.45e-3,
                half_height: 0.875e-3,
            },
            Shape::Cross {
                base: 2.25e-3,
                width: 0.75e-3,
                height: 1e-3,
            },
        ] {
            let g = BodyGeometry::from_shape(&shape).unwrap();
            let m = body_mesh(&g);
            assert!(
                (m.volume() / g.volume() - 1.0).abs() < 1e-12,
                "{shape:?}: {} vs {}",
                m.volume(),
                g.volume()
            );
        }
    }

    /// After every frame the collections are whole XML listing exactly the frames written
    /// so far, each present, and no partial file is left: what a run killed between two
    /// frames leaves ParaView.
    #[test]
    fn collections_are_whole_after_every_frame() {
        let dir = tempfile::tempdir().unwrap();
        let mesh = body_mesh(&BodyGeometry::Sphere { radius: 0.1 });
        let mut w = VtkWriter::create(dir.path(), vec![mesh]).unwrap();
        let still = BodyMotion {
            position: [0.5; 3],
            orientation: [0.0, 0.0, 0.0, 1.0],
            velocity: [0.0; 3],
            angular_velocity: [0.0, 1.0, 0.0],
        };
        let particles = vec![ParticleRecord::default(); 10];
        for k in 1..=3 {
            let t = k as f64 * 0.01;
            w.fluid(t, &particles).unwrap();
            w.bodies(t, &[still]).unwrap();
            for name in ["fluid", "bodies"] {
                let text = std::fs::read_to_string(dir.path().join(format!("{name}.pvd"))).unwrap();
                let doc = roxmltree::Document::parse(&text).unwrap();
                let sets: Vec<_> = doc
                    .descendants()
                    .filter(|n| n.has_tag_name("DataSet"))
                    .collect();
                assert_eq!(sets.len(), k, "{name}.pvd after frame {k}");
                for (i, d) in sets.iter().enumerate() {
                    let file = d.attribute("file").unwrap();
                    assert_eq!(file, format!("vtk/{name}_{i:06}.vtp"));
                    assert!(dir.path().join(file).exists());
                    let step: f64 = d.attribute("timestep").unwrap().parse().unwrap();
                    assert_eq!(step, (i + 1) as f64 * 0.01);
                }
            }
        }
        let partial = std::fs::read_dir(dir.path().join(VTK_DIR))
            .unwrap()
            .filter(|e| {
                e.as_ref()
                    .unwrap()
                    .file_name()
                    .to_string_lossy()
                    .ends_with(".partial")
            })
            .count();
        assert_eq!(partial, 0);
        assert_eq!(w.frames(), (3, 3));
    }
}
