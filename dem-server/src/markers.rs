//! Coupling points ("markers") of resolved bodies: the body surface meshed at the
//! fluid spacing δ (Joubert 2020 §2.6), one marker per surface patch with the patch's
//! exact area, so that the discrete sums of Joubert eqs. (31)–(32) integrate over
//! the true surface. Analytic shapes are meshed through a parameterisation, rectangular
//! faces bilinearly, other faces by a square lattice clipped to the face, compounds by
//! their outer surface only.

use crate::engine::DemError;
use crate::geometry::{BodyGeometry, Face, GEOMETRY_REL_TOL, Polyhedron};
use couplet_protocol::scene::{EffectsSpec, FluidSpec, WallModel};
use couplet_protocol::vec3::{add, cross, dot, norm, quat_from_scaled_axis, rotate, scale, sub};
use couplet_protocol::{BodyState, CouplingPoint, Scene, Shape};
use std::f64::consts::PI;
use std::ops::Range;

/// Most markers one body may have: 2²⁵ points are 1.6 GB of `CouplingPoint`s, beyond
/// any fluid the GPU holds around them.
pub const MAX_MARKERS_PER_BODY: usize = 1 << 25;

/// One marker in the body frame (origin at the centre of mass).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalMarker {
    /// Position on the surface, m.
    pub position: [f64; 3],
    /// Outward unit normal.
    pub normal: [f64; 3],
    /// Area of the surface patch the marker stands for (ΔS_i of Joubert eq. 31), m².
    pub area: f64,
}

/// Markers of `shape` (body frame) at spacing δ = `spacing`. The areas sum to the
/// surface area to round-off: the sphere's to 4πr², the cylinder's to 2πr·2h + 2πr²,
/// a hull's to its face areas, a compound's to the area of its outer surface (markers
/// on a face shared with another part are dropped, so their patches are exactly the
/// shared faces when those faces coincide; a partly shared face loses the markers
/// whose centres are covered).
pub fn generate_markers(shape: &Shape, spacing: f64) -> Result<Vec<LocalMarker>, DemError> {
    markers_of(&BodyGeometry::from_shape(shape)?, spacing)
}

/// Markers of an already built body geometry; see [`generate_markers`].
pub fn markers_of(geometry: &BodyGeometry, spacing: f64) -> Result<Vec<LocalMarker>, DemError> {
    if !(spacing.is_finite() && spacing > 0.0) {
        return Err(DemError::Spacing { value: spacing });
    }
    let area = surface_area_bound(geometry);
    let estimated = area / (spacing * spacing);
    // Rounding up the counts per direction at most doubles them in each direction.
    if !(estimated * 4.0 < MAX_MARKERS_PER_BODY as f64) {
        return Err(DemError::TooManyMarkers {
            area,
            spacing,
            estimated,
            limit: MAX_MARKERS_PER_BODY,
        });
    }
    let mut out = Vec::with_capacity(estimated as usize + 16);
    match geometry {
        BodyGeometry::Sphere { radius } => sphere(*radius, spacing, &mut out),
        BodyGeometry::Box { half_extents } => {
            polyhedron(&Polyhedron::cuboid(*half_extents), spacing, &mut out)
        }
        BodyGeometry::Cylinder {
            radius,
            half_height,
        } => cylinder(*radius, *half_height, spacing, &mut out),
        BodyGeometry::Polyhedra(parts) if parts.len() == 1 => {
            polyhedron(&parts[0], spacing, &mut out)
        }
        BodyGeometry::Polyhedra(parts) => {
            // Joubert §2.6: only the outer surface of a non-convex particle is meshed.
            let tol = GEOMETRY_REL_TOL * geometry.size();
            for (i, part) in parts.iter().enumerate() {
                let mut own = Vec::new();
                polyhedron(part, spacing, &mut own);
                out.extend(own.into_iter().filter(|m| {
                    parts
                        .iter()
                        .enumerate()
                        .all(|(j, other)| j == i || other.outside_distance(m.position) > tol)
                }));
            }
        }
    }
    Ok(out)
}

/// Fill points of a resolved body under Adami's wall model: the body-frame cubic lattice
/// of spacing δ at (i + ½)δ from the centre of mass, each point at least δ inside the
/// surface — the markers on the surface are the first layer, the fill goes on a lattice
/// spacing behind them — and less than `reach` − δ/2 deep (deeper, no fluid particle,
/// which stands at least δ/2 outside, reaches it), with area 0 and the outward normal of
/// the nearest surface. Faces for which `pressed(normal)` holds (body frame: those
/// pressed against the domain, which carry no markers) are not surface. Adami's walls
/// fill the support behind each face with layers of wall particles; a body's one layer
/// of markers left the fluid beside it a truncated support, and fluid crossed that layer
/// into the body (the DKT quick run at r = 2δ: 16 fluid particles inside the leading
/// cylinder by t = 0.06 s with the standard scheme; with the corrected one the body's
/// bottom decompressed to ρ = 168 kg/m³ at 0.093 s). Points only δ/2 deep, right behind
/// the markers, made the wake of the r = 1.25δ cylinder of `couplet validate
/// settling-cylinder --quick` decompress and blow up at 0.14 s. A body with no point δ
/// deep (a sphere of r < 1.87δ, on the ½-offset lattice) gets none. The lattice's ½
/// offsets put a body spanning a periodic axis with a whole number of spacings on the
/// fluid's layers. Then the markers of a filled body that the lattice leaves bare (a
/// thin wall's) get backing points behind them (`backing_points`).
pub fn fill_points(
    geometry: &BodyGeometry,
    spacing: f64,
    reach: f64,
    pressed: impl Fn([f64; 3]) -> bool,
) -> Result<Vec<LocalMarker>, DemError> {
    if !(spacing.is_finite() && spacing > 0.0) {
        return Err(DemError::Spacing { value: spacing });
    }
    let estimated = geometry.volume() / spacing.powi(3);
    if !(estimated * 2.0 < MAX_MARKERS_PER_BODY as f64) {
        return Err(DemError::TooManyMarkers {
            area: geometry.volume() / spacing,
            spacing,
            estimated,
            limit: MAX_MARKERS_PER_BODY,
        });
    }
    let surface = Surface::of(geometry, &pressed);
    let (lo, hi) = surface.bounds;
    let index_range = |k: usize| {
        let first = (lo[k] / spacing - 0.5).ceil() as i64;
        let last = (hi[k] / spacing - 0.5).floor() as i64;
        first..=last
    };
    let (min_depth, max_depth) = (spacing * (1.0 - 1e-9), reach - 0.5 * spacing);
    let mut out = Vec::new();
    for i in index_range(0) {
        for j in index_range(1) {
            for k in index_range(2) {
                let p = [i, j, k].map(|n| (n as f64 + 0.5) * spacing);
                if let Some((depth, normal)) = surface.depth(p)
                    && depth >= min_depth
                    && depth < max_depth
                {
                    out.push(LocalMarker {
                        position: p,
                        normal,
                        area: 0.0,
                    });
                }
            }
        }
    }
    let markers: Vec<LocalMarker> = markers_of(geometry, spacing)?
        .into_iter()
        .filter(|m| !pressed(m.normal))
        .collect();
    let backing = backing_points(&surface, &markers, &out, spacing, reach);
    out.extend(backing);
    Ok(out)
}

/// Fill behind the patches the lattice leaves bare. The lattice keeps a point only at
/// least δ behind every face and gives it to its nearest face, so a wall thinner than
/// about four spacings holds a band of fill under two spacings wide, and the lattice's
/// accidents decide which side it backs: in Joubert's ring at δ = 0.25 mm (walls 2.8δ
/// thick, 7δ tall) the 96 lattice points lie 1.1–1.3δ behind the outer faces, 16 to a
/// layer, the hole's faces got none and the caps a fifth of a layer, so the fluid in
/// the hole saw one layer of markers and the ring blew up there (ARCHITECTURE.md, "Thin
/// walls are backed patch by patch"). A marker's first backing point is q = x − δ n,
/// one spacing behind it along its inward normal, where the fill's first layer belongs.
/// The marker is backed when a fill point lies within δ of q whose nearest face does not
/// face away from the marker's (normals at most 90° apart: a point on a box's edge
/// diagonal, as near to both faces, backs both), as on a face the lattice fills (its
/// band of points [δ, reach − δ/2) deep always has one there). A bare marker gets q and
/// the points further behind it, kδ deep for k = 1, 2, … while kδ < `reach` − δ/2 (the
/// lattice's depth range), each kept only if no other face is nearer to it than its own
/// (the far face of a thin wall, a convex edge's wedge) and none of its side's fill
/// (the lattice's or backing kept before it) lies closer than δ: the backing is never
/// denser than the lattice, except across a thin wall (as the lattice's own fill of the
/// other side stands), so on a convex curve, where the inward normals meet, the backing
/// points of neighbouring markers do not pile up. A body the lattice leaves
/// unfilled (under about 3.7 spacings across: the quick settling sphere and cylinder,
/// r = 1.25δ) stays so: q there lies a fraction of δ from the centre, where every
/// marker's q would crowd into one spot.
fn backing_points(
    surface: &Surface,
    markers: &[LocalMarker],
    lattice: &[LocalMarker],
    spacing: f64,
    reach: f64,
) -> Vec<LocalMarker> {
    use std::collections::HashMap;
    if lattice.is_empty() {
        return Vec::new();
    }
    // Fill by cells of δ: the points within δ of x lie in the 27 cells around x's.
    let cell = |p: [f64; 3]| p.map(|x| (x / spacing).floor() as i64);
    let mut grid: HashMap<[i64; 3], Vec<LocalMarker>> = HashMap::new();
    for f in lattice {
        grid.entry(cell(f.position)).or_default().push(*f);
    }
    // Whether fill of the side of `normal` (not facing away) lies within `r` of `x`.
    let sided =
        |grid: &HashMap<[i64; 3], Vec<LocalMarker>>, x: [f64; 3], normal: [f64; 3], r: f64| {
            let c = cell(x);
            (0..27).any(|n| {
                let key = [c[0] + n % 3 - 1, c[1] + n / 3 % 3 - 1, c[2] + n / 9 - 1];
                grid.get(&key)
                    .into_iter()
                    .flatten()
                    .any(|f| dot(f.normal, normal) > -1e-6 && norm(sub(f.position, x)) <= r)
            })
        };
    let mut out = Vec::new();
    for m in markers.iter().filter(|m| m.area > 0.0) {
        if sided(
            &grid,
            sub(m.position, scale(m.normal, spacing)),
            m.normal,
            spacing,
        ) {
            continue;
        }
        let mut k = 1.0;
        while k * spacing < reach - 0.5 * spacing {
            let q = sub(m.position, scale(m.normal, k * spacing));
            let own_face = surface.depth(q).is_some_and(|(depth, normal)| {
                depth >= k * spacing * (1.0 - 1e-9) && dot(normal, m.normal) > 1.0 - 1e-6
            });
            if own_face && !sided(&grid, q, m.normal, spacing * (1.0 - 1e-9)) {
                let point = LocalMarker {
                    position: q,
                    normal: m.normal,
                    area: 0.0,
                };
                grid.entry(cell(q)).or_default().push(point);
                out.push(point);
            }
            k += 1.0;
        }
    }
    out
}

/// A body's outer surface for depth queries (body frame), without the faces pressed
/// against the domain.
struct Surface<'a> {
    geometry: &'a BodyGeometry,
    pressed: &'a dyn Fn([f64; 3]) -> bool,
    /// A compound's outer faces: corners and outward normal (faces shared with another
    /// part are inside the body).
    faces: Vec<(Vec<[f64; 3]>, [f64; 3])>,
    /// Bounding box.
    bounds: ([f64; 3], [f64; 3]),
}

impl<'a> Surface<'a> {
    fn of(geometry: &'a BodyGeometry, pressed: &'a dyn Fn([f64; 3]) -> bool) -> Self {
        let (mut faces, bounds) = (
            Vec::new(),
            match geometry {
                BodyGeometry::Sphere { radius } => ([-radius; 3], [*radius; 3]),
                BodyGeometry::Box { half_extents } => (half_extents.map(|h| -h), *half_extents),
                BodyGeometry::Cylinder {
                    radius,
                    half_height,
                } => (
                    [-radius, -half_height, -radius],
                    [*radius, *half_height, *radius],
                ),
                BodyGeometry::Polyhedra(parts) => {
                    parts.iter().flat_map(|p| p.vertices.iter()).fold(
                        ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
                        |(lo, hi), v| {
                            (
                                std::array::from_fn(|k| lo[k].min(v[k])),
                                std::array::from_fn(|k| hi[k].max(v[k])),
                            )
                        },
                    )
                }
            },
        );
        if let BodyGeometry::Polyhedra(parts) = geometry {
            let tol = GEOMETRY_REL_TOL * geometry.size();
            for (i, part) in parts.iter().enumerate() {
                for f in &part.faces {
                    let pts = part.face_points(f);
                    let c = scale(
                        pts.iter().fold([0.0; 3], |a, p| add(a, *p)),
                        1.0 / pts.len() as f64,
                    );
                    let shared = parts
                        .iter()
                        .enumerate()
                        .any(|(j, other)| j != i && other.outside_distance(c) <= tol);
                    if !shared && !pressed(f.normal) {
                        faces.push((pts, f.normal));
                    }
                }
            }
        }
        Surface {
            geometry,
            pressed,
            faces,
            bounds,
        }
    }

    /// Distance from `p` inside the body to its surface, and the outward normal there;
    /// `None` outside.
    fn depth(&self, p: [f64; 3]) -> Option<(f64, [f64; 3])> {
        let along = |k: usize, s: f64| {
            let mut n = [0.0; 3];
            n[k] = if s < 0.0 { -1.0 } else { 1.0 };
            n
        };
        // Candidate (distance, normal) pairs of the primitives; pressed faces are not
        // surface.
        let nearest = |c: &mut dyn Iterator<Item = (f64, [f64; 3])>| {
            c.filter(|(_, n)| !(self.pressed)(*n))
                .min_by(|a, b| a.0.total_cmp(&b.0))
        };
        let (d, n) = match self.geometry {
            BodyGeometry::Sphere { radius } => {
                let r = norm(p);
                let n = if r > 0.0 {
                    scale(p, 1.0 / r)
                } else {
                    [0.0, 1.0, 0.0]
                };
                (radius - r, n)
            }
            BodyGeometry::Box { half_extents } => {
                if (0..3).any(|k| p[k].abs() >= half_extents[k]) {
                    return None;
                }
                nearest(&mut (0..3).map(|k| (half_extents[k] - p[k].abs(), along(k, p[k]))))?
            }
            BodyGeometry::Cylinder {
                radius,
                half_height,
            } => {
                let rho = p[0].hypot(p[2]);
                if rho >= *radius || p[1].abs() >= *half_height {
                    return None;
                }
                let radial = if rho > 0.0 {
                    [p[0] / rho, 0.0, p[2] / rho]
                } else {
                    [1.0, 0.0, 0.0]
                };
                nearest(
                    &mut [
                        (radius - rho, radial),
                        (half_height - p[1].abs(), along(1, p[1])),
                    ]
                    .into_iter(),
                )?
            }
            BodyGeometry::Polyhedra(parts) => {
                if !parts.iter().any(|part| part.outside_distance(p) < 0.0) {
                    return None;
                }
                self.faces
                    .iter()
                    .map(|(pts, n)| (polygon_distance(p, pts, *n), *n))
                    .min_by(|a, b| a.0.total_cmp(&b.0))?
            }
        };
        (d > 0.0).then_some((d, n))
    }
}

/// Distance from `p` to the convex polygon `pts` (counter-clockwise about `n`, its unit
/// normal): to the plane where the foot falls inside, else to the nearest edge.
fn polygon_distance(p: [f64; 3], pts: &[[f64; 3]], n: [f64; 3]) -> f64 {
    let h = dot(sub(p, pts[0]), n);
    let foot = sub(p, scale(n, h));
    let inside = (0..pts.len()).all(|k| {
        let (a, b) = (pts[k], pts[(k + 1) % pts.len()]);
        dot(cross(sub(b, a), sub(foot, a)), n) >= 0.0
    });
    if inside {
        return h.abs();
    }
    (0..pts.len())
        .map(|k| {
            let (a, b) = (pts[k], pts[(k + 1) % pts.len()]);
            let e = sub(b, a);
            let t = (dot(sub(p, a), e) / dot(e, e)).clamp(0.0, 1.0);
            norm(sub(p, add(a, scale(e, t))))
        })
        .fold(f64::INFINITY, f64::min)
}

/// Surface area, m² (a compound's counts shared faces twice: an upper bound for the budget).
fn surface_area_bound(g: &BodyGeometry) -> f64 {
    match g {
        BodyGeometry::Sphere { radius } => 4.0 * PI * radius * radius,
        BodyGeometry::Box {
            half_extents: [a, b, c],
        } => 8.0 * (a * b + b * c + c * a),
        BodyGeometry::Cylinder {
            radius,
            half_height,
        } => 2.0 * PI * radius * (2.0 * half_height + radius),
        BodyGeometry::Polyhedra(parts) => parts.iter().map(Polyhedron::area).sum(),
    }
}

/// Number of divisions of a length `l` into pieces of about `step`.
fn divisions(l: f64, step: f64) -> usize {
    ((l / step).round() as usize).max(1)
}

/// Sphere, polar axis y: bands of equal polar angle (height ≈ δ), each split into
/// ≈ circumference/δ equal patches; a patch's area is exactly r²·Δφ·(cos θ₀ − cos θ₁),
/// and its marker sits at the area-mid polar angle and the mid azimuth.
fn sphere(r: f64, spacing: f64, out: &mut Vec<LocalMarker>) {
    let n_theta = divisions(PI * r, spacing);
    let d_theta = PI / n_theta as f64;
    for b in 0..n_theta {
        let (c0, c1) = ((b as f64 * d_theta).cos(), ((b + 1) as f64 * d_theta).cos());
        let c_mid = 0.5 * (c0 + c1);
        let s_mid = (1.0 - c_mid * c_mid).max(0.0).sqrt();
        let n_phi = divisions(2.0 * PI * r * s_mid, spacing);
        let d_phi = 2.0 * PI / n_phi as f64;
        let area = r * r * d_phi * (c0 - c1);
        // Alternate bands start half a patch apart so neighbouring bands interleave.
        let phi0 = if b % 2 == 0 { 0.5 } else { 0.0 };
        for k in 0..n_phi {
            let phi = (k as f64 + phi0) * d_phi;
            let n = [s_mid * phi.cos(), c_mid, s_mid * phi.sin()];
            out.push(LocalMarker {
                position: n.map(|x| r * x),
                normal: n,
                area,
            });
        }
    }
}

/// Cylinder along y: the side as rings × segments of the (φ, y) parameterisation, each
/// cap as annuli of width ≈ δ split into ≈ circumference/δ sectors of exact area.
fn cylinder(r: f64, h: f64, spacing: f64, out: &mut Vec<LocalMarker>) {
    let n_y = divisions(2.0 * h, spacing);
    let n_phi = divisions(2.0 * PI * r, spacing).max(3);
    let (dy, d_phi) = (2.0 * h / n_y as f64, 2.0 * PI / n_phi as f64);
    let side_area = dy * r * d_phi;
    for j in 0..n_y {
        let y = -h + (j as f64 + 0.5) * dy;
        let phi0 = if j % 2 == 0 { 0.5 } else { 0.0 };
        for k in 0..n_phi {
            let phi = (k as f64 + phi0) * d_phi;
            let n = [phi.cos(), 0.0, phi.sin()];
            out.push(LocalMarker {
                position: [r * n[0], y, r * n[2]],
                normal: n,
                area: side_area,
            });
        }
    }
    let n_r = divisions(r, spacing);
    let dr = r / n_r as f64;
    for side in [1.0, -1.0] {
        for k in 0..n_r {
            let (r0, r1) = (k as f64 * dr, (k + 1) as f64 * dr);
            let r_mid = (0.5 * (r0 * r0 + r1 * r1)).sqrt(); // splits the annulus into equal areas
            let n_seg = divisions(2.0 * PI * r_mid, spacing);
            let area = PI * (r1 * r1 - r0 * r0) / n_seg as f64;
            // A single patch is the whole central disc: its marker belongs at the centre.
            let rho = if n_seg == 1 { 0.0 } else { r_mid };
            let d_phi = 2.0 * PI / n_seg as f64;
            for s in 0..n_seg {
                let phi = (s as f64 + 0.5) * d_phi;
                out.push(LocalMarker {
                    position: [rho * phi.cos(), side * h, rho * phi.sin()],
                    normal: [0.0, side, 0.0],
                    area,
                });
            }
        }
    }
}

/// Every face of a convex polyhedron (Joubert §2.6): rectangles bilinearly, other
/// faces by a clipped square lattice ([`polygon_cells`]).
fn polyhedron(p: &Polyhedron, spacing: f64, out: &mut Vec<LocalMarker>) {
    let tol = GEOMETRY_REL_TOL * p.size();
    for f in &p.faces {
        let pts = p.face_points(f);
        if let Some((o, e1, e2)) = rectangle(&pts, tol) {
            rectangle_cells(o, e1, e2, f, spacing, out);
        } else {
            polygon_cells(&pts, f, spacing, out);
        }
    }
}

/// `Some((corner, edge 1, edge 2))` when the four-cornered face is a rectangle.
fn rectangle(p: &[[f64; 3]], tol: f64) -> Option<([f64; 3], [f64; 3], [f64; 3])> {
    if p.len() != 4 {
        return None;
    }
    let e = |a: usize, b: usize| sub(p[b], p[a]);
    let (e1, e2) = (e(0, 1), e(0, 3));
    // Opposite corner where the parallelogram puts it, and a right angle at corner 0.
    let far = add(p[0], add(e1, e2));
    let right = dot(e1, e2).abs() <= tol * (norm(e1) + norm(e2));
    (norm(sub(far, p[2])) <= tol && right).then_some((p[0], e1, e2))
}

fn rectangle_cells(
    o: [f64; 3],
    e1: [f64; 3],
    e2: [f64; 3],
    f: &Face,
    spacing: f64,
    out: &mut Vec<LocalMarker>,
) {
    let (nx, ny) = (divisions(norm(e1), spacing), divisions(norm(e2), spacing));
    let area = norm(e1) * norm(e2) / (nx * ny) as f64;
    for i in 0..nx {
        for j in 0..ny {
            let (s, t) = ((i as f64 + 0.5) / nx as f64, (j as f64 + 0.5) / ny as f64);
            let position = add(o, add(scale(e1, s), scale(e2, t)));
            out.push(LocalMarker {
                position,
                normal: f.normal,
                area,
            });
        }
    }
}

/// Patches smaller than this fraction of δ² join the nearest larger patch.
const MIN_PATCH_PER_SPACING2: f64 = 0.5;

/// A convex face that is not a rectangle, cut by a square lattice of spacing δ laid on
/// its plane (centred on its bounding box): each cell's piece of the face (Sutherland–
/// Hodgman clipping) is a patch with its exact area and a marker at its centroid, and a
/// piece under δ²/2 (at the edges) joins the larger patch with the nearest centroid, its
/// area and first moment added. The areas sum to the face's, and a marker stands for
/// δ²/2 to 3δ²/2 of surface, as a fluid particle's face of the lattice does: the fluid's
/// sums weigh each marker like a fluid particle (V = m/ρ), so markers packed closer than
/// δ act as a denser wall. A fan of triangles from the centroid, each cut into similar
/// sub-triangles, put 12 markers on a 12-gon cap of 4.7 δ² at δ = 1 mm (0.4 δ² each)
/// and the corrected scheme blew up under the flat face within 0.02 s; lattice patches
/// do not (`dem-server/tests/markers.rs`, `polygon_patches_are_about_a_spacing_square`).
/// A face under δ²/2 is one patch.
fn polygon_cells(pts: &[[f64; 3]], f: &Face, spacing: f64, out: &mut Vec<LocalMarker>) {
    let o = pts[0];
    let e1 = scale(sub(pts[1], o), 1.0 / norm(sub(pts[1], o)));
    let e2 = cross(f.normal, e1);
    let q: Vec<[f64; 2]> = pts
        .iter()
        .map(|p| [dot(sub(*p, o), e1), dot(sub(*p, o), e2)])
        .collect();
    let (lo, hi) = q.iter().fold(
        ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
        |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1])],
                [hi[0].max(p[0]), hi[1].max(p[1])],
            )
        },
    );
    let counts = [0, 1].map(|k| (((hi[k] - lo[k]) / spacing).ceil() as usize).max(1));
    let start = [0, 1].map(|k| 0.5 * (lo[k] + hi[k]) - 0.5 * counts[k] as f64 * spacing);
    // (area, first moment) of each cell's piece.
    let mut pieces: Vec<(f64, [f64; 2])> = Vec::new();
    let face_area = polygon_moments(&q).0;
    for i in 0..counts[0] {
        for j in 0..counts[1] {
            let (u0, v0) = (start[0] + i as f64 * spacing, start[1] + j as f64 * spacing);
            let piece = clip_to_box(&q, [u0, v0], [u0 + spacing, v0 + spacing]);
            let (a, m) = polygon_moments(&piece);
            if a > 1e-12 * face_area {
                pieces.push((a, m));
            }
        }
    }
    let small = MIN_PATCH_PER_SPACING2 * spacing * spacing;
    let (mut large, smalls): (Vec<_>, Vec<_>) = pieces.into_iter().partition(|p| p.0 >= small);
    if large.is_empty() {
        large.push(polygon_moments(&q));
    } else {
        for (a, m) in smalls {
            let c = [m[0] / a, m[1] / a];
            let nearest = (0..large.len())
                .min_by(|&x, &y| {
                    let d = |k: usize| {
                        let l = &large[k];
                        (l.1[0] / l.0 - c[0]).powi(2) + (l.1[1] / l.0 - c[1]).powi(2)
                    };
                    d(x).total_cmp(&d(y))
                })
                .expect("large is non-empty");
            let l = &mut large[nearest];
            l.0 += a;
            l.1 = [l.1[0] + m[0], l.1[1] + m[1]];
        }
    }
    for (a, m) in large {
        let (u, v) = (m[0] / a, m[1] / a);
        out.push(LocalMarker {
            position: add(o, add(scale(e1, u), scale(e2, v))),
            normal: f.normal,
            area: a,
        });
    }
}

/// Area and first moment (∫ u, ∫ v) of a simple polygon (shoelace), either orientation.
fn polygon_moments(p: &[[f64; 2]]) -> (f64, [f64; 2]) {
    let (mut a, mut mu, mut mv) = (0.0, 0.0, 0.0);
    for k in 0..p.len() {
        let (x0, x1) = (p[k], p[(k + 1) % p.len()]);
        let c = x0[0] * x1[1] - x1[0] * x0[1];
        a += c;
        mu += (x0[0] + x1[0]) * c;
        mv += (x0[1] + x1[1]) * c;
    }
    let s = a.signum();
    (0.5 * a.abs(), [s * mu / 6.0, s * mv / 6.0])
}

/// The part of the convex polygon `p` inside the box [lo, hi] (Sutherland–Hodgman).
fn clip_to_box(p: &[[f64; 2]], lo: [f64; 2], hi: [f64; 2]) -> Vec<[f64; 2]> {
    let mut poly = p.to_vec();
    // Each half-plane as (axis, bound, keep below the bound).
    for (k, bound, below) in [
        (0, lo[0], false),
        (0, hi[0], true),
        (1, lo[1], false),
        (1, hi[1], true),
    ] {
        let inside = |x: &[f64; 2]| if below { x[k] <= bound } else { x[k] >= bound };
        let mut next = Vec::with_capacity(poly.len() + 2);
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            if inside(&a) {
                next.push(a);
            }
            if inside(&a) != inside(&b) {
                let t = (bound - a[k]) / (b[k] - a[k]);
                next.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
            }
        }
        poly = next;
        if poly.len() < 3 {
            return Vec::new();
        }
    }
    poly
}

/// The markers of a body minus those on faces pressed against the domain: along an
/// axis where the body, at its initial pose, spans the domain from face to face
/// (within δ/100 at both ends), markers on either domain face whose outward normal is
/// that face's outward normal see no fluid and are dropped. This is Joubert's
/// "infinitely long" cylinder (§3.2: its caps lie on the symmetry walls in z); the
/// remaining areas sum to the wetted surface. Such a body is held between the two faces
/// by the DEM's walls, so the dropped faces stay on them.
///
/// On a periodic axis the body must span the domain (else [`DemError::PeriodicSpan`]).
fn wetted(
    markers: Vec<LocalMarker>,
    body: &couplet_protocol::BodySpec,
    domain: &couplet_protocol::Domain,
    spacing: f64,
) -> Result<(Vec<LocalMarker>, Vec<usize>), DemError> {
    let q = quat_from_scaled_axis(body.rotation);
    let world = |m: &LocalMarker| {
        (
            add(rotate(q, m.position), body.position),
            rotate(q, m.normal),
        )
    };
    let tol = 0.01 * spacing;
    let mut spans = Vec::new();
    for k in 0..3 {
        let (lo, hi) = markers
            .iter()
            .map(|m| world(m).0[k])
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                (lo.min(x), hi.max(x))
            });
        if (lo - domain.min[k]).abs() < tol && (hi - domain.max[k]).abs() < tol {
            spans.push(k);
        } else if domain.periodic[k] {
            return Err(DemError::PeriodicSpan {
                axis: k,
                lo,
                hi,
                min: domain.min[k],
                max: domain.max[k],
            });
        }
    }
    let kept = markers
        .into_iter()
        .filter(|m| {
            let (x, n) = world(m);
            !spans.iter().any(|&k| {
                ((x[k] - domain.min[k]).abs() < tol && n[k] < -1.0 + 1e-9)
                    || ((x[k] - domain.max[k]).abs() < tol && n[k] > 1.0 - 1e-9)
            })
        })
        .collect();
    Ok((kept, spans))
}

/// How deep fill points reach: the largest support radius a fluid particle may have.
fn fill_reach(fluid: &FluidSpec, effects: &EffectsSpec) -> f64 {
    let ratio = if effects.variable_smoothing_length {
        fluid.max_smoothing_ratio()
    } else {
        1.0
    };
    fluid.support_radius() * ratio
}

/// The markers of every marker-coupled body of a scene (resolved, with a fluid, not a
/// fluid obstacle: [`Scene::is_marker_coupled`]), contiguous per body in body order.
#[derive(Debug, Clone, Default)]
pub struct MarkerSet {
    markers: Vec<LocalMarker>,
    ranges: Vec<(u32, Range<usize>)>,
}

impl MarkerSet {
    /// Markers of every marker-coupled body at the fluid spacing δ, followed, under
    /// Adami's wall model, by the body's fill points ([`fill_points`], area 0); a scene
    /// with no fluid has none.
    pub fn from_scene(scene: &Scene) -> Result<Self, DemError> {
        let mut set = Self::default();
        let Some(fluid) = &scene.fluid else {
            return Ok(set);
        };
        for (index, body) in scene.bodies.iter().enumerate() {
            if !scene.is_marker_coupled(body) {
                continue;
            }
            let geometry =
                BodyGeometry::from_shape(&body.shape).map_err(|e| e.in_body(index, &body.name))?;
            let own =
                markers_of(&geometry, fluid.spacing).map_err(|e| e.in_body(index, &body.name))?;
            let (mut own, spans) = wetted(own, body, &scene.domain, fluid.spacing)
                .map_err(|e| e.in_body(index, &body.name))?;
            if scene.domain.wall_model == WallModel::Adami {
                // The faces pressed against the domain (wetted's spans) are no surface.
                let q = quat_from_scaled_axis(body.rotation);
                let pressed = |n: [f64; 3]| {
                    let w = rotate(q, n);
                    spans.iter().any(|&k| w[k].abs() > 1.0 - 1e-9)
                };
                let reach = fill_reach(fluid, &scene.effects);
                own.extend(
                    fill_points(&geometry, fluid.spacing, reach, pressed)
                        .map_err(|e| e.in_body(index, &body.name))?,
                );
            }
            let start = set.markers.len();
            set.markers.extend(own);
            set.ranges.push((index as u32, start..set.markers.len()));
        }
        Ok(set)
    }

    /// Total number of markers.
    pub fn len(&self) -> usize {
        self.markers.len()
    }

    /// Whether there are no markers.
    pub fn is_empty(&self) -> bool {
        self.markers.is_empty()
    }

    /// Number of bodies with markers (the fluid sends one load for each).
    pub fn body_count(&self) -> usize {
        self.ranges.len()
    }

    /// `(scene body index, range of its markers)` for every marker-coupled body, in body order.
    pub fn body_ranges(&self) -> Vec<(u32, Range<usize>)> {
        self.ranges.clone()
    }

    /// The body-frame markers, contiguous per body.
    pub fn local(&self) -> &[LocalMarker] {
        &self.markers
    }

    /// World-frame coupling points at the given states (indexed by scene body, as
    /// [`crate::DemEngine::states`] gives them): position R·p + x, normal R·n, velocity
    /// v + ω × (R·p) (Joubert eq. 33), measure = area. Appends to `out`.
    ///
    /// Panics if `states` does not cover every marker-coupled body: states come from the
    /// engine built from the same scene, so that is a programming error.
    pub fn world_points(&self, states: &[BodyState], out: &mut Vec<CouplingPoint>) {
        out.reserve(self.markers.len());
        for (body, range) in &self.ranges {
            let s = &states[*body as usize];
            for m in &self.markers[range.clone()] {
                let arm = rotate(s.orientation, m.position);
                let position = add(s.position, arm);
                let normal = rotate(s.orientation, m.normal);
                // Joubert eq. (33): u_i = u_s + ω_s × (r_i − r_cg).
                let velocity = add(s.linear_velocity, cross(s.angular_velocity, arm));
                out.push(CouplingPoint {
                    position: position.map(|x| x as f32),
                    measure: m.area as f32,
                    velocity: velocity.map(|x| x as f32),
                    body: *body,
                    normal: normal.map(|x| x as f32),
                    _pad: 0,
                });
            }
        }
    }
}
