//! Body geometry in `f64`, body frame with its origin at the centre of mass: the
//! scene's shapes as analytic primitives or convex polyhedra with planar faces,
//! their volumes and centroids. Engines (colliders, mass, buoyancy volume) and the
//! marker generator both start from it, so they agree on where the body is.

use crate::engine::DemError;
use couplet_protocol::Shape;
use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// Relative tolerance (of the shape's size) of the geometric predicates: coplanarity
/// of hull triangles, collinearity of face vertices, touching compound parts, a marker
/// lying on another part. Well above `f64` round-off of the input coordinates
/// (~1e-16·size) and well below any meaningful feature.
pub const GEOMETRY_REL_TOL: f64 = 1e-9;

/// Hull triangles whose unit normals differ by less than this (and whose planes are
/// within this fraction of the size) form one face. Looser than [`GEOMETRY_REL_TOL`]:
/// scene vertices are decimal text, so the corners of a face meant to be planar (a
/// rectangle of a rotated box) are coplanar only to the digits given.
const COPLANAR_TOL: f64 = 1e-6;

fn v3(p: [f64; 3]) -> V3 {
    V3::new(p[0], p[1], p[2])
}

/// One planar face of a convex polyhedron.
#[derive(Debug, Clone)]
pub struct Face {
    /// Indices into [`Polyhedron::vertices`], counter-clockwise seen from outside, no
    /// collinear (non-corner) vertices.
    pub vertices: Vec<usize>,
    /// Outward unit normal.
    pub normal: [f64; 3],
}

/// A convex polyhedron with planar (possibly non-triangular) faces.
#[derive(Debug, Clone)]
pub struct Polyhedron {
    /// Vertex coordinates, m.
    pub vertices: Vec<[f64; 3]>,
    /// Faces, each a convex polygon.
    pub faces: Vec<Face>,
}

impl Polyhedron {
    /// The box `[-h, h]` with its six rectangular faces.
    pub fn cuboid(half_extents: [f64; 3]) -> Self {
        let [hx, hy, hz] = half_extents;
        // Vertex i has x, y, z signs from bits 0, 1, 2 of i.
        let vertices = (0..8)
            .map(|i| {
                let s = |bit: usize, h: f64| if i >> bit & 1 == 1 { h } else { -h };
                [s(0, hx), s(1, hy), s(2, hz)]
            })
            .collect();
        // Counter-clockwise about the outward normal: +x, -x, +y, -y, +z, -z.
        let loops: [[usize; 4]; 6] = [
            [1, 3, 7, 5],
            [0, 4, 6, 2],
            [2, 6, 7, 3],
            [0, 1, 5, 4],
            [4, 5, 7, 6],
            [0, 2, 3, 1],
        ];
        let normals = [
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ];
        let faces = loops
            .iter()
            .zip(normals)
            .map(|(l, normal)| Face {
                vertices: l.to_vec(),
                normal,
            })
            .collect();
        Self { vertices, faces }
    }

    /// The convex hull of `points` (parry's 3-D hull), with coplanar hull triangles
    /// merged into planar faces so that rectangles can be meshed bilinearly (Joubert §2.6).
    /// Coordinates stay the `f64` input; parry (`f32`) only decides the topology.
    pub fn convex_hull(points: &[[f64; 3]]) -> Result<Self, DemError> {
        let fail = |why: &str| DemError::Shape {
            what: "convex hull vertices".into(),
            value: format!(
                "{} points {:?}",
                points.len(),
                points.iter().take(8).collect::<Vec<_>>()
            ),
            why: why.into(),
        };
        if points.len() < 4 || points.iter().flatten().any(|c| !c.is_finite()) {
            return Err(fail("a hull needs at least 4 finite points"));
        }
        let size = bbox_diagonal(points);
        if !(size > 0.0) {
            return Err(fail("all points coincide"));
        }
        let pts32: Vec<parry3d::math::Vector> = points
            .iter()
            .map(|p| parry3d::math::Vector::new(p[0] as f32, p[1] as f32, p[2] as f32))
            .collect();
        let (hull_pts, tris) = parry3d::transformation::try_convex_hull(&pts32).map_err(|e| {
            fail(&format!(
                "parry cannot build the hull ({e:?}); the points must span a volume"
            ))
        })?;
        // Map parry's copies back to the input points (exact copies of the f32 casts).
        let to_input: Vec<usize> = hull_pts
            .iter()
            .map(|h| {
                let mut best = (f32::INFINITY, 0);
                for (i, p) in pts32.iter().enumerate() {
                    let d = (*p - *h).length_squared();
                    if d < best.0 {
                        best = (d, i);
                    }
                }
                best.1
            })
            .collect();
        let used: Vec<usize> = {
            let mut u: Vec<usize> = to_input.clone();
            u.sort_unstable();
            u.dedup();
            u
        };
        let interior = used.iter().map(|&i| v3(points[i])).sum::<V3>() / used.len() as f64;
        let tol = GEOMETRY_REL_TOL * size;

        // Planes of the hull triangles, outward; coplanar triangles share one plane.
        let mut planes: Vec<(V3, f64, Vec<usize>)> = Vec::new();
        for t in &tris {
            let [a, b, c] = t.map(|k| to_input.get(k as usize).copied().unwrap_or(0));
            let (pa, pb, pc) = (v3(points[a]), v3(points[b]), v3(points[c]));
            let mut n = (pb - pa).cross(&(pc - pa));
            let norm = n.norm();
            if !(norm > tol * size) {
                continue; // a sliver: its plane is undefined, and its neighbours cover it
            }
            n /= norm;
            if n.dot(&(pa - interior)) < 0.0 {
                n = -n;
            }
            let d = n.dot(&pa);
            match planes.iter_mut().find(|(m, e, _)| {
                (m - n).norm() < COPLANAR_TOL && (e - d).abs() < COPLANAR_TOL * size
            }) {
                Some((_, _, ids)) => ids.extend([a, b, c]),
                None => planes.push((n, d, vec![a, b, c])),
            }
        }
        if planes.len() < 4 {
            return Err(fail(
                "the points are (nearly) coplanar: the hull has no volume",
            ));
        }

        // Keep only vertices used by some face; renumber.
        let mut index_of = vec![usize::MAX; points.len()];
        let mut vertices = Vec::new();
        let mut faces = Vec::new();
        for (n, _, mut ids) in planes {
            ids.sort_unstable();
            ids.dedup();
            let ordered = order_polygon(points, &ids, &n, tol);
            if ordered.len() < 3 {
                continue;
            }
            let loop_ids = ordered
                .into_iter()
                .map(|i| {
                    if index_of[i] == usize::MAX {
                        index_of[i] = vertices.len();
                        vertices.push(points[i]);
                    }
                    index_of[i]
                })
                .collect();
            faces.push(Face {
                vertices: loop_ids,
                normal: [n.x, n.y, n.z],
            });
        }
        let hull = Self { vertices, faces };
        if !(hull.volume() > tol * size * size) {
            return Err(fail("the hull has no volume"));
        }
        Ok(hull)
    }

    /// Corner positions of face `f`, in loop order.
    pub fn face_points(&self, f: &Face) -> Vec<[f64; 3]> {
        f.vertices.iter().map(|&i| self.vertices[i]).collect()
    }

    /// Volume, m³ (divergence theorem over the fan-triangulated faces).
    pub fn volume(&self) -> f64 {
        self.volume_and_centroid().0
    }

    /// Centroid of the solid (its centre of mass at uniform density), m.
    pub fn centroid(&self) -> [f64; 3] {
        let c = self.volume_and_centroid().1;
        [c.x, c.y, c.z]
    }

    fn volume_and_centroid(&self) -> (f64, V3) {
        // Tetrahedra from a reference vertex keep the round-off relative to the size.
        let r = self.vertices.first().map_or(V3::zeros(), |p| v3(*p));
        let (mut vol, mut moment) = (0.0, V3::zeros());
        for f in &self.faces {
            let p = self.face_points(f);
            for k in 1..p.len().saturating_sub(1) {
                let (a, b, c) = (v3(p[0]) - r, v3(p[k]) - r, v3(p[k + 1]) - r);
                let v = a.dot(&b.cross(&c)) / 6.0;
                vol += v;
                moment += v * (a + b + c) / 4.0;
            }
        }
        let c = if vol != 0.0 { r + moment / vol } else { r };
        (vol, c)
    }

    /// Second moment ∫ x xᵀ dV about the frame origin, m⁵: a tetrahedron p₀…p₃ of signed
    /// volume V contributes V/20 (Σ pᵢ pᵢᵀ + (Σ pᵢ)(Σ pᵢ)ᵀ) (Tonon 2004, J. Math. Stat.
    /// 1(1)), over the same fan of tetrahedra as the volume.
    pub fn second_moment(&self) -> nalgebra::Matrix3<f64> {
        let r = self.vertices.first().map_or(V3::zeros(), |p| v3(*p));
        let mut m = nalgebra::Matrix3::zeros();
        for f in &self.faces {
            let p = self.face_points(f);
            for k in 1..p.len().saturating_sub(1) {
                let t = [r, v3(p[0]), v3(p[k]), v3(p[k + 1])];
                let v = (t[1] - r).dot(&(t[2] - r).cross(&(t[3] - r))) / 6.0;
                let sum: V3 = t.iter().sum();
                let own = t
                    .iter()
                    .fold(nalgebra::Matrix3::zeros(), |acc, q| acc + q * q.transpose());
                m += v / 20.0 * (own + sum * sum.transpose());
            }
        }
        m
    }

    /// Surface area, m².
    pub fn area(&self) -> f64 {
        self.faces
            .iter()
            .map(|f| polygon_area(&self.face_points(f)))
            .sum()
    }

    /// Largest signed distance of `p` beyond the face planes: ≤ 0 inside or on the
    /// surface, > 0 outside (then it is a lower bound of the distance).
    pub fn outside_distance(&self, p: [f64; 3]) -> f64 {
        let p = v3(p);
        self.faces
            .iter()
            .map(|f| {
                let n = v3(f.normal);
                n.dot(&(p - v3(self.vertices[f.vertices[0]])))
            })
            .fold(f64::NEG_INFINITY, f64::max)
    }

    /// Diagonal of the bounding box, m.
    pub fn size(&self) -> f64 {
        bbox_diagonal(&self.vertices)
    }

    fn translate(&mut self, d: V3) {
        for p in &mut self.vertices {
            *p = [p[0] + d.x, p[1] + d.y, p[2] + d.z];
        }
    }

    fn edges(&self) -> Vec<V3> {
        let mut out: Vec<V3> = Vec::new();
        for f in &self.faces {
            let p = self.face_points(f);
            for k in 0..p.len() {
                let e = v3(p[(k + 1) % p.len()]) - v3(p[k]);
                let n = e.norm();
                if n > 0.0 {
                    out.push(e / n);
                }
            }
        }
        out
    }

    fn project(&self, axis: &V3) -> (f64, f64) {
        self.vertices
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                let s = axis.dot(&v3(*p));
                (lo.min(s), hi.max(s))
            })
    }
}

/// Penetration depth of two convex polyhedra by the separating-axis test (face
/// normals and edge × edge axes): ≤ 0 when they are apart or only touch.
pub fn overlap_depth(a: &Polyhedron, b: &Polyhedron) -> f64 {
    let mut axes: Vec<V3> = a
        .faces
        .iter()
        .chain(&b.faces)
        .map(|f| v3(f.normal))
        .collect();
    let (ea, eb) = (a.edges(), b.edges());
    for u in &ea {
        for w in &eb {
            let c = u.cross(w);
            let n = c.norm();
            if n > 1e-6 {
                axes.push(c / n);
            }
        }
    }
    axes.iter()
        .map(|ax| {
            let ((a0, a1), (b0, b1)) = (a.project(ax), b.project(ax));
            a1.min(b1) - a0.max(b0)
        })
        .fold(f64::INFINITY, f64::min)
}

/// Orders the coplanar points `ids` counter-clockwise about `n` and drops those that
/// are not corners (on an edge between two corners).
fn order_polygon(points: &[[f64; 3]], ids: &[usize], n: &V3, tol: f64) -> Vec<usize> {
    let c = ids.iter().map(|&i| v3(points[i])).sum::<V3>() / ids.len() as f64;
    let u = {
        let t = if n.x.abs() < 0.9 { V3::x() } else { V3::y() };
        n.cross(&t).normalize()
    };
    let w = n.cross(&u);
    let mut by_angle: Vec<(f64, usize)> = ids
        .iter()
        .map(|&i| {
            let d = v3(points[i]) - c;
            (d.dot(&w).atan2(d.dot(&u)), i)
        })
        .collect();
    by_angle.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut ring: Vec<usize> = by_angle.into_iter().map(|(_, i)| i).collect();
    loop {
        let m = ring.len();
        if m < 3 {
            return ring;
        }
        let drop = (0..m).find(|&k| {
            let (p, q, r) = (
                v3(points[ring[(k + m - 1) % m]]),
                v3(points[ring[k]]),
                v3(points[ring[(k + 1) % m]]),
            );
            // Twice the triangle area against the base length: the corner's distance off the line.
            let base = (r - p).norm();
            base > 0.0 && (q - p).cross(&(r - p)).norm() / base <= tol || (q - p).norm() <= tol
        });
        match drop {
            Some(k) => {
                ring.remove(k);
            }
            None => return ring,
        }
    }
}

/// Area of a planar polygon given in loop order, m².
pub fn polygon_area(p: &[[f64; 3]]) -> f64 {
    let mut s = V3::zeros();
    for k in 1..p.len().saturating_sub(1) {
        s += (v3(p[k]) - v3(p[0])).cross(&(v3(p[k + 1]) - v3(p[0])));
    }
    0.5 * s.norm()
}

fn bbox_diagonal(points: &[[f64; 3]]) -> f64 {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt()
}

/// A body's shape in its body frame, origin at the centre of mass (uniform density).
#[derive(Debug, Clone)]
pub enum BodyGeometry {
    /// Sphere of `radius`, m.
    Sphere { radius: f64 },
    /// Box `[-h, h]`, m.
    Box { half_extents: [f64; 3] },
    /// Cylinder along the body y axis, m.
    Cylinder { radius: f64, half_height: f64 },
    /// One convex polyhedron, or the non-overlapping convex parts of a compound, all
    /// shifted together so that their common centroid is the origin.
    Polyhedra(Vec<Polyhedron>),
}

impl BodyGeometry {
    /// Builds the body-frame geometry of a scene shape. Hull vertices are recentred on
    /// the volume centroid (the centre of mass, which the scene's body position names);
    /// compound parts that overlap are refused ([`DemError::OverlappingParts`]): the
    /// volume would be counted twice in the mass and the buoyancy of Joubert eq. (28).
    pub fn from_shape(shape: &Shape) -> Result<Self, DemError> {
        let positive = |what: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(DemError::Shape {
                    what: what.into(),
                    value: v.to_string(),
                    why: "must be a positive finite length".into(),
                })
            }
        };
        Ok(match shape {
            Shape::Sphere { radius } => {
                positive("sphere.radius", *radius)?;
                Self::Sphere { radius: *radius }
            }
            Shape::Box { half_extents } => {
                for h in half_extents {
                    positive("box.half_extents", *h)?;
                }
                Self::Box {
                    half_extents: *half_extents,
                }
            }
            Shape::Cylinder {
                radius,
                half_height,
            } => {
                positive("cylinder.radius", *radius)?;
                positive("cylinder.half_height", *half_height)?;
                Self::Cylinder {
                    radius: *radius,
                    half_height: *half_height,
                }
            }
            Shape::Convex { vertices } => {
                Self::Polyhedra(recentre(vec![Polyhedron::convex_hull(vertices)?]))
            }
            Shape::Prism {
                sides,
                radius,
                half_height,
            } => {
                positive("prism.radius", *radius)?;
                positive("prism.half_height", *half_height)?;
                if *sides < 3 {
                    return Err(DemError::Shape {
                        what: "prism.sides".into(),
                        value: sides.to_string(),
                        why: "a prism needs at least 3 sides".into(),
                    });
                }
                Self::Polyhedra(recentre(vec![Polyhedron::convex_hull(&prism_vertices(
                    *sides,
                    *radius,
                    *half_height,
                ))?]))
            }
            Shape::Ring {
                sides,
                inner_radius,
                outer_radius,
                half_height,
            } => {
                positive("ring.inner_radius", *inner_radius)?;
                positive("ring.half_height", *half_height)?;
                if !(outer_radius > inner_radius && outer_radius.is_finite()) {
                    return Err(DemError::Shape {
                        what: "ring.outer_radius".into(),
                        value: outer_radius.to_string(),
                        why: format!("must be finite and exceed the inner radius {inner_radius}"),
                    });
                }
                if *sides < 3 {
                    return Err(DemError::Shape {
                        what: "ring.sides".into(),
                        value: sides.to_string(),
                        why: "a ring needs at least 3 sides".into(),
                    });
                }
                Self::compound(
                    &ring_parts(*sides, *inner_radius, *outer_radius, *half_height),
                    "ring",
                )?
            }
            Shape::Cross {
                base,
                width,
                height,
            } => {
                positive("cross.base", *base)?;
                positive("cross.width", *width)?;
                positive("cross.height", *height)?;
                Self::compound(&cross_parts(*base, *width, *height), "cross")?
            }
            Shape::Compound { parts } => Self::compound(parts, "compound")?,
        })
    }

    /// The compound of the convex hulls of `parts`, recentred on their common centroid;
    /// parts that overlap are refused (`what` names the shape in errors).
    fn compound(parts: &[Vec<[f64; 3]>], what: &str) -> Result<Self, DemError> {
        let hulls = parts
            .iter()
            .enumerate()
            .map(|(i, p)| {
                Polyhedron::convex_hull(p).map_err(|e| match e {
                    DemError::Shape { value, why, .. } => DemError::Shape {
                        what: format!("{what}.parts[{i}]"),
                        value,
                        why,
                    },
                    other => other,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let size = hulls.iter().map(Polyhedron::size).fold(0.0, f64::max);
        for i in 0..hulls.len() {
            for j in i + 1..hulls.len() {
                let depth = overlap_depth(&hulls[i], &hulls[j]);
                if depth > GEOMETRY_REL_TOL * size {
                    return Err(DemError::OverlappingParts {
                        first: i,
                        second: j,
                        depth,
                    });
                }
            }
        }
        Ok(Self::Polyhedra(recentre(hulls)))
    }

    /// Solid volume, m³: exact for the primitives and hulls; a compound's is the sum of
    /// its parts (exact since overlapping parts are refused).
    pub fn volume(&self) -> f64 {
        use std::f64::consts::PI;
        match self {
            Self::Sphere { radius } => 4.0 / 3.0 * PI * radius.powi(3),
            Self::Box {
                half_extents: [a, b, c],
            } => 8.0 * a * b * c,
            Self::Cylinder {
                radius,
                half_height,
            } => PI * radius * radius * 2.0 * half_height,
            Self::Polyhedra(parts) => parts.iter().map(Polyhedron::volume).sum(),
        }
    }

    /// Inertia tensor about the centre of mass (the body-frame origin) at uniform
    /// `density`, kg·m², in `f64`: the textbook formulas for the primitives, and
    /// ρ (tr C 𝟙 − C) from the second moment C of the polyhedra. The DEM engines take it
    /// from here rather than from parry, whose `f32` principal-axis decomposition loses
    /// the axes of bodies of millimetre size (see `rapier_engine.rs`).
    pub fn inertia(&self, density: f64) -> nalgebra::Matrix3<f64> {
        let m = density * self.volume();
        let diag = |a: f64, b: f64, c: f64| nalgebra::Matrix3::from_diagonal(&V3::new(a, b, c));
        match self {
            Self::Sphere { radius } => {
                let i = 0.4 * m * radius * radius;
                diag(i, i, i)
            }
            Self::Box {
                half_extents: [a, b, c],
            } => {
                let (a2, b2, c2) = ((2.0 * a).powi(2), (2.0 * b).powi(2), (2.0 * c).powi(2));
                diag(
                    m * (b2 + c2) / 12.0,
                    m * (a2 + c2) / 12.0,
                    m * (a2 + b2) / 12.0,
                )
            }
            Self::Cylinder {
                radius,
                half_height,
            } => {
                let side = m * (3.0 * radius * radius + 4.0 * half_height * half_height) / 12.0;
                diag(side, 0.5 * m * radius * radius, side)
            }
            Self::Polyhedra(parts) => {
                let c: nalgebra::Matrix3<f64> = parts.iter().map(Polyhedron::second_moment).sum();
                density * (nalgebra::Matrix3::identity() * c.trace() - c)
            }
        }
    }

    /// Diagonal of the bounding box, m: the length scale of the tolerances.
    pub fn size(&self) -> f64 {
        match self {
            Self::Sphere { radius } => 2.0 * 3f64.sqrt() * radius,
            Self::Box {
                half_extents: [a, b, c],
            } => 2.0 * (a * a + b * b + c * c).sqrt(),
            Self::Cylinder {
                radius,
                half_height,
            } => 2.0 * (2.0 * radius * radius + half_height * half_height).sqrt(),
            Self::Polyhedra(parts) => {
                let all: Vec<[f64; 3]> = parts
                    .iter()
                    .flat_map(|p| p.vertices.iter().copied())
                    .collect();
                bbox_diagonal(&all)
            }
        }
    }
}

/// Vertices of a right regular prism along y with its edges on a circle of `radius`;
/// vertices at angles 2π(k + ½)/sides from +x in the x–z plane, so that face normals
/// sit at 2πk/sides.
pub fn prism_vertices(sides: u32, radius: f64, half_height: f64) -> Vec<[f64; 3]> {
    (0..sides)
        .map(|k| polygon_corner(k, sides, radius))
        .flat_map(|(x, z)| [[x, -half_height, z], [x, half_height, z]])
        .collect()
}

/// Corner (x, z) of a regular polygon of `sides` on a circle of `radius`, at angle
/// 2π(k + ½)/sides from +x (the corners of [`prism_vertices`]). `k` is taken modulo
/// `sides` so that neighbouring parts get bit-identical shared corners.
fn polygon_corner(k: u32, sides: u32, radius: f64) -> (f64, f64) {
    let a = 2.0 * std::f64::consts::PI * (f64::from(k % sides) + 0.5) / f64::from(sides);
    (radius * a.cos(), radius * a.sin())
}

/// The `sides` trapezoidal prisms of Joubert's ring (§4.2, Fig. 17c): part k spans the
/// polygon corners k and k + 1 on the inner and outer circles, from y = −h to h.
/// Neighbouring parts share a radial face exactly, so the marker generator drops both
/// copies and only the outer surface is meshed.
pub fn ring_parts(sides: u32, inner: f64, outer: f64, half_height: f64) -> Vec<Vec<[f64; 3]>> {
    (0..sides)
        .map(|k| {
            [k, k + 1]
                .into_iter()
                .flat_map(|c| [inner, outer].map(|r| polygon_corner(c, sides, r)))
                .flat_map(|(x, z)| [[x, -half_height, z], [x, half_height, z]])
                .collect()
        })
        .collect()
}

/// The five cuboids of Joubert's cross (§4.2, Fig. 17d; the layout is argued at
/// `Shape::Cross`): `base` along x, `height` along y, `width` along z, centred at the
/// origin, ±width along z and ±height along y.
pub fn cross_parts(base: f64, width: f64, height: f64) -> Vec<Vec<[f64; 3]>> {
    let half = [0.5 * base, 0.5 * height, 0.5 * width];
    [
        [0.0, 0.0, 0.0],
        [0.0, 0.0, width],
        [0.0, 0.0, -width],
        [0.0, height, 0.0],
        [0.0, -height, 0.0],
    ]
    .iter()
    .map(|c| {
        Polyhedron::cuboid(half)
            .vertices
            .iter()
            .map(|v| [c[0] + v[0], c[1] + v[1], c[2] + v[2]])
            .collect()
    })
    .collect()
}

/// Shifts the parts so that their common volume centroid is the origin.
fn recentre(mut parts: Vec<Polyhedron>) -> Vec<Polyhedron> {
    let (mut vol, mut moment) = (0.0, V3::zeros());
    for p in &parts {
        let (v, c) = p.volume_and_centroid();
        vol += v;
        moment += v * c;
    }
    if vol > 0.0 {
        let shift = -moment / vol;
        for p in &mut parts {
            p.translate(shift);
        }
    }
    parts
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Box volume 8abc and area 8(ab + bc + ca): checks the face loops are outward.
    #[test]
    fn cuboid_volume_and_area() {
        let b = Polyhedron::cuboid([0.5, 1.0, 1.5]);
        assert!((b.volume() - 6.0).abs() < 1e-12);
        assert!((b.area() - 2.0 * (2.0 + 3.0 + 6.0)).abs() < 1e-12);
        for f in &b.faces {
            let p = b.face_points(f);
            let n = (v3(p[1]) - v3(p[0])).cross(&(v3(p[2]) - v3(p[1])));
            assert!(n.dot(&v3(f.normal)) > 0.0);
        }
    }

    /// The hull of a cube's corners plus interior and edge-midpoint points is the cube:
    /// six 4-corner faces, volume a³.
    #[test]
    fn hull_merges_coplanar_triangles_into_rectangles() {
        let mut pts: Vec<[f64; 3]> = Polyhedron::cuboid([1.0; 3]).vertices;
        pts.push([0.1, 0.2, 0.3]);
        pts.push([1.0, 0.0, 1.0]);
        let h = Polyhedron::convex_hull(&pts).unwrap();
        assert_eq!(h.faces.len(), 6);
        assert!(h.faces.iter().all(|f| f.vertices.len() == 4));
        assert!((h.volume() - 8.0).abs() < 1e-12);
    }

    /// Touching cubes pass the overlap test, overlapping ones are refused with the depth.
    #[test]
    fn compound_overlap_is_detected() {
        let cube = |x0: f64| {
            vec![
                [x0, 0.0, 0.0],
                [x0 + 1.0, 0.0, 0.0],
                [x0, 1.0, 0.0],
                [x0 + 1.0, 1.0, 0.0],
                [x0, 0.0, 1.0],
                [x0 + 1.0, 0.0, 1.0],
                [x0, 1.0, 1.0],
                [x0 + 1.0, 1.0, 1.0],
            ]
        };
        let ok = BodyGeometry::from_shape(&Shape::Compound {
            parts: vec![cube(0.0), cube(1.0)],
        })
        .unwrap();
        assert!((ok.volume() - 2.0).abs() < 1e-12);
        match BodyGeometry::from_shape(&Shape::Compound {
            parts: vec![cube(0.0), cube(0.75)],
        }) {
            Err(DemError::OverlappingParts { depth, .. }) => assert!((depth - 0.25).abs() < 1e-12),
            other => panic!("{other:?}"),
        }
    }
}
