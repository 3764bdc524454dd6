//! An independent 2D reference for Joubert's settling cylinder (§3.2, §4.1, Table 2): the
//! terminal Reynolds number of a cylinder (a circle, or Joubert's 12-face prism) settling
//! along the centre line of a channel, from a lattice Boltzmann solver that shares no code
//! with couplet (std only):
//!
//!     cargo build --release -p couplet-tests --bin lbm-cylinder
//!     target/release/lbm-cylinder schafer-turek 20   # the solver's own check (below), D = 20 cells
//!     target/release/lbm-cylinder settle 40 prism12  # Joubert's cylinder, D = 40 cells across it
//!     target/release/lbm-cylinder settle 20 circle 12 36 0.02  # a circle, a longer channel, half the Mach
//!
//! `tests/tests/lbm_reference.rs` runs the check at D = 10 in CI.
//!
//! Method: D2Q9, two-relaxation-time collision (Ginzburg's Λ = 3/16, which puts a
//! bounce-back wall half way between nodes whatever the viscosity), Bouzidi, Firdaouss &
//! Lallemand (2001) linear interpolated bounce-back on the body (second order in its
//! shape), half-way bounce-back with a wall velocity (Ladd 1994) on the channel walls and
//! the inlet, Guo, Zheng & Shi (2002)'s non-equilibrium extrapolation at ρ = 1 on the
//! outlet, and the force by momentum exchange over the body's links.
//!
//! Terminal state: in the frame of a body settling at U the far fluid and both walls move
//! at U past the body at rest, and the flow is steady at these Re (no shedding). The
//! force balance F' = (ρs − ρf) g A per unit length, with F' = ½ ρf U² d C_D(Re) and
//! U = Re ν/d, is C_D(Re) Re² = K = 2 (ρs − ρf) g A d / (ρf ν²): a secant iteration on
//! ln Re solves it, one steady flow per iterate, each started from the last.
//!
//! Check (`schafer-turek D`): Schäfer & Turek (1996), benchmark 2D-1: channel 2.2 × 0.41,
//! cylinder d = 0.1 centred at (0.2, 0.2), parabolic inflow of mean 0.2 (U_max 0.3),
//! ν = 1e-3, Re = 20: C_D = 5.5795 and C_L = 0.01062 (the reference values of John &
//! Matthies 2001, 5.57953523384 and 0.010618948146).

use std::f64::consts::PI;

const C: [(i32, i32); 9] = [
    (0, 0),
    (1, 0),
    (0, 1),
    (-1, 0),
    (0, -1),
    (1, 1),
    (-1, 1),
    (-1, -1),
    (1, -1),
];
const OPP: [usize; 9] = [0, 3, 4, 1, 2, 7, 8, 5, 6];
const W: [f64; 9] = [
    4.0 / 9.0,
    1.0 / 9.0,
    1.0 / 9.0,
    1.0 / 9.0,
    1.0 / 9.0,
    1.0 / 36.0,
    1.0 / 36.0,
    1.0 / 36.0,
    1.0 / 36.0,
];

/// The body's cross-section in lattice units.
#[derive(Clone, Copy)]
enum Body {
    Circle {
        cx: f64,
        cy: f64,
        r: f64,
    },
    /// A regular polygon whose corners lie on the circle of `r`, with a face normal to ±x
    /// and to ±y (`sides` a multiple of 4), as couplet's `shape.prism` laid along z.
    Polygon {
        cx: f64,
        cy: f64,
        r: f64,
        sides: u32,
    },
}

impl Body {
    fn inside(&self, x: f64, y: f64) -> bool {
        match *self {
            Body::Circle { cx, cy, r } => (x - cx).powi(2) + (y - cy).powi(2) < r * r,
            Body::Polygon { cx, cy, r, sides } => {
                // Apothem r cos(π/n); face normals at 2πk/n.
                let a = r * (PI / sides as f64).cos();
                (0..sides).all(|k| {
                    let t = 2.0 * PI * k as f64 / sides as f64;
                    (x - cx) * t.cos() + (y - cy) * t.sin() < a
                })
            }
        }
    }

    /// Area, for the submerged weight.
    fn area(&self) -> f64 {
        match *self {
            Body::Circle { r, .. } => PI * r * r,
            Body::Polygon { r, sides, .. } => {
                0.5 * sides as f64 * r * r * (2.0 * PI / sides as f64).sin()
            }
        }
    }

    /// Fraction q in (0, 1] of the link from fluid point (x, y) along (dx, dy) at which
    /// the surface lies (bisection: the link crosses the surface once).
    fn q(&self, x: f64, y: f64, dx: f64, dy: f64) -> f64 {
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..60 {
            let m = 0.5 * (lo + hi);
            if self.inside(x + m * dx, y + m * dy) {
                hi = m;
            } else {
                lo = m;
            }
        }
        0.5 * (lo + hi)
    }
}

/// How the population arriving at a node along direction i is made.
#[derive(Clone, Copy)]
enum Link {
    /// Streamed from the neighbour at x − c_i.
    Stream,
    /// Half-way bounce-back from a wall or inlet moving at u (6 w_i c_i·u added).
    Wall { add: f64 },
    /// Bouzidi's bounce-back from the body, the wall at fraction q of the link from
    /// this node towards it (along −c_i); `far` whether the node beyond (x + c_i) is
    /// fluid, which q < ½ needs.
    Body { q: f64, far: bool },
    /// Set after streaming from the node before (outlet, in `step`).
    Outlet,
}

struct Lattice {
    nx: usize,
    ny: usize,
    solid: Vec<bool>,
    links: Vec<[Link; 9]>,
    f: Vec<f64>,
    g: Vec<f64>,
    rho: Vec<f64>,
}

impl Lattice {
    fn idx(&self, x: usize, y: usize) -> usize {
        x * self.ny + y
    }

    /// Walls at y = −½ and ny − ½ moving at (`wall_u`, 0), inlet at x = −½ with
    /// velocity `inflow(y)` along x, outlet at x = nx − ½, the body inside.
    fn new(nx: usize, ny: usize, body: Body, wall_u: f64, inflow: &dyn Fn(usize) -> f64) -> Self {
        let n = nx * ny;
        let mut solid = vec![false; n];
        for x in 0..nx {
            for y in 0..ny {
                solid[x * ny + y] = body.inside(x as f64, y as f64);
            }
        }
        let is_solid = |x: i64, y: i64| solid[x as usize * ny + y as usize];
        let mut links = vec![[Link::Stream; 9]; n];
        for x in 0..nx as i64 {
            for y in 0..ny as i64 {
                if is_solid(x, y) {
                    continue;
                }
                for i in 1..9 {
                    let (sx, sy) = (x - C[i].0 as i64, y - C[i].1 as i64);
                    let (cx, cy) = (C[i].0 as f64, C[i].1 as f64);
                    links[(x as usize) * ny + y as usize][i] = if sy < 0 || sy >= ny as i64 {
                        Link::Wall {
                            add: 6.0 * W[i] * cx * wall_u,
                        }
                    } else if sx < 0 {
                        Link::Wall {
                            add: 6.0 * W[i] * cx * inflow(y as usize),
                        }
                    } else if sx >= nx as i64 {
                        Link::Outlet
                    } else if is_solid(sx, sy) {
                        let (fx, fy) = (x as f64, y as f64);
                        let q = body.q(fx, fy, -cx, -cy);
                        let (bx, by) = (x + C[i].0 as i64, y + C[i].1 as i64);
                        let far = bx >= 0
                            && bx < nx as i64
                            && by >= 0
                            && by < ny as i64
                            && !is_solid(bx, by);
                        Link::Body { q, far }
                    } else {
                        Link::Stream
                    };
                }
            }
        }
        let mut f = vec![0.0; 9 * n];
        for x in 0..nx {
            for y in 0..ny {
                let u = inflow(y);
                for i in 0..9 {
                    f[i * n + x * ny + y] = feq(i, 1.0, u, 0.0);
                }
            }
        }
        Lattice {
            nx,
            ny,
            solid,
            links,
            g: f.clone(),
            f,
            rho: vec![1.0; n],
        }
    }

    /// One collide-and-stream step with relaxation τ; returns the force on the body.
    fn step(&mut self, tau: f64) -> (f64, f64) {
        let n = self.nx * self.ny;
        let wp = 1.0 / tau;
        let wm = 1.0 / (3.0 / 16.0 / (tau - 0.5) + 0.5);
        // Collide in place (post-collision populations in f).
        let threads = std::thread::available_parallelism()
            .map_or(1, |t| t.get())
            .min(8);
        let chunk = n.div_ceil(threads);
        {
            let solid = &self.solid;
            let rho_out: Vec<&mut [f64]> = self.rho.chunks_mut(chunk).collect();
            let f = &mut self.f;
            let planes = per_thread(f, n, chunk, threads);
            std::thread::scope(|s| {
                for (t, (mut p, r)) in planes.into_iter().zip(rho_out).enumerate() {
                    s.spawn(move || {
                        let base = t * chunk;
                        for k in 0..r.len() {
                            if solid[base + k] {
                                continue;
                            }
                            let mut fi = [0.0; 9];
                            for i in 0..9 {
                                fi[i] = p[i][k];
                            }
                            let rho: f64 = fi.iter().sum();
                            let ux = (fi[1] - fi[3] + fi[5] - fi[6] - fi[7] + fi[8]) / rho;
                            let uy = (fi[2] - fi[4] + fi[5] + fi[6] - fi[7] - fi[8]) / rho;
                            r[k] = rho;
                            let mut eq = [0.0; 9];
                            for i in 0..9 {
                                eq[i] = feq(i, rho, ux, uy);
                            }
                            for i in 0..9 {
                                let o = OPP[i];
                                let sp = 0.5 * (fi[i] + fi[o]) - 0.5 * (eq[i] + eq[o]);
                                let sm = 0.5 * (fi[i] - fi[o]) - 0.5 * (eq[i] - eq[o]);
                                p[i][k] = fi[i] - wp * sp - wm * sm;
                            }
                        }
                    });
                }
            });
        }
        // Stream (pull) into g, with the boundary rules; force by momentum exchange.
        let (nx, ny) = (self.nx, self.ny);
        let (f, solid, links, rho) = (&self.f, &self.solid, &self.links, &self.rho);
        let planes = per_thread(&mut self.g, n, chunk, threads);
        let forces: Vec<(f64, f64)> = std::thread::scope(|s| {
            let handles: Vec<_> = (planes.into_iter().enumerate())
                .map(|(t, mut g)| {
                    s.spawn(move || {
                        let (mut fx, mut fy) = (0.0, 0.0);
                        let base = t * chunk;
                        for kk in 0..g[0].len() {
                            let k = base + kk;
                            if solid[k] {
                                continue;
                            }
                            let (x, y) = (k / ny, k % ny);
                            for i in 0..9 {
                                let o = OPP[i];
                                g[i][kk] = match links[k][i] {
                                    Link::Stream => {
                                        let sx = (x as i64 - C[i].0 as i64) as usize;
                                        let sy = (y as i64 - C[i].1 as i64) as usize;
                                        f[i * n + sx * ny + sy]
                                    }
                                    Link::Wall { add } => f[o * n + k] + rho[k] * add,
                                    Link::Body { q, far } => {
                                        let v = if q < 0.5 && far {
                                            let bx = (x as i64 + C[i].0 as i64) as usize;
                                            let by = (y as i64 + C[i].1 as i64) as usize;
                                            2.0 * q * f[o * n + k]
                                                + (1.0 - 2.0 * q) * f[o * n + bx * ny + by]
                                        } else if q >= 0.5 {
                                            f[o * n + k] / (2.0 * q)
                                                + (2.0 * q - 1.0) / (2.0 * q) * f[i * n + k]
                                        } else {
                                            f[o * n + k]
                                        };
                                        // The population left along c_o (into the body)
                                        // and came back along c_i: the body gained
                                        // (f_o + f_i) c_o.
                                        let m = f[o * n + k] + v;
                                        fx += m * C[o].0 as f64;
                                        fy += m * C[o].1 as f64;
                                        v
                                    }
                                    Link::Outlet => 0.0,
                                };
                            }
                        }
                        (fx, fy)
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        let (fx, fy) = forces
            .iter()
            .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
        // Outlet: Guo, Zheng & Shi (2002)'s non-equilibrium extrapolation at ρ = 1, the
        // last column taking the velocity and the non-equilibrium part of the one
        // before, which holds the pressure there (a copy alone let the mass grow).
        for y in 0..ny {
            let (k, kb) = (self.idx(nx - 1, y), self.idx(nx - 2, y));
            let fb: [f64; 9] = std::array::from_fn(|i| self.g[i * n + kb]);
            let rho: f64 = fb.iter().sum();
            let ux = (fb[1] - fb[3] + fb[5] - fb[6] - fb[7] + fb[8]) / rho;
            let uy = (fb[2] - fb[4] + fb[5] + fb[6] - fb[7] - fb[8]) / rho;
            for i in 0..9 {
                self.g[i * n + k] = feq(i, 1.0, ux, uy) + fb[i] - feq(i, rho, ux, uy);
            }
        }
        std::mem::swap(&mut self.f, &mut self.g);
        (fx, fy)
    }

    /// Steps until the force along x, averaged over windows of `window` steps, changes
    /// by less than `rtol` of itself between two windows twice running, after at least
    /// `min_steps`; returns the force and the steps taken. A window a whole number of
    /// periods of the channel's slowest sound averages out the sound that the start
    /// leaves ringing: the inlet fixes the velocity and the outlet the pressure, so the
    /// channel rings as a pipe closed at one end, with a period of four lengths over the
    /// speed of sound 1/√3 (a window of half that left the force at D = 40 alternating
    /// between windows by 4.5e-3 of itself after 50 000 steps, and still 1.4e-3 after
    /// 90 000, while the mean of two windows held to 1e-6).
    fn steady(&mut self, tau: f64, min_steps: usize, rtol: f64) -> ((f64, f64), usize) {
        let period = 4.0 * self.nx as f64 * 3f64.sqrt();
        let window = (period * (2000.0 / period).ceil()).round() as usize;
        let (mut last, mut passed, mut steps) = (f64::NAN, 0, 0);
        loop {
            let mut sum = (0.0, 0.0);
            for _ in 0..window {
                let f = self.step(tau);
                sum.0 += f.0;
                sum.1 += f.1;
            }
            steps += window;
            let mean = (sum.0 / window as f64, sum.1 / window as f64);
            if !mean.0.is_finite() {
                panic!("the lattice blew up after {steps} steps");
            }
            let change = ((mean.0 - last) / mean.0).abs();
            eprintln!(
                "  {steps} steps: F = ({:.6e}, {:.3e}), change {change:.2e}",
                mean.0, mean.1
            );
            passed = if change < rtol { passed + 1 } else { 0 };
            if steps >= min_steps && passed >= 2 {
                return (mean, steps);
            }
            last = mean.0;
        }
    }
}

/// The nine planes of `n` values in `buf`, each cut into pieces of `chunk`: for every
/// one of `threads` threads its nine pieces, for the collision and the streaming to
/// share out the same nodes.
fn per_thread(buf: &mut [f64], n: usize, chunk: usize, threads: usize) -> Vec<Vec<&mut [f64]>> {
    let mut planes: Vec<Vec<&mut [f64]>> = (0..threads).map(|_| Vec::new()).collect();
    for plane in buf.chunks_mut(n) {
        for (t, piece) in plane.chunks_mut(chunk).enumerate() {
            planes[t].push(piece);
        }
    }
    planes
}

fn feq(i: usize, rho: f64, ux: f64, uy: f64) -> f64 {
    let cu = C[i].0 as f64 * ux + C[i].1 as f64 * uy;
    W[i] * rho * (1.0 + 3.0 * cu + 4.5 * cu * cu - 1.5 * (ux * ux + uy * uy))
}

fn schafer_turek(d: usize) {
    assert!(
        d.is_multiple_of(10),
        "D must be a multiple of 10 (H = 4.1 D)"
    );
    let (nx, ny) = (22 * d, 41 * d / 10);
    let u_max = 0.06;
    let u_mean = 2.0 / 3.0 * u_max;
    let nu = u_mean * d as f64 / 20.0;
    let tau = 3.0 * nu + 0.5;
    let h = ny as f64;
    let inflow = |y: usize| {
        let s = y as f64 + 0.5;
        4.0 * u_max * s * (h - s) / (h * h)
    };
    // The walls at −½, so (0.2, 0.2) from them is 2D − ½ in node coordinates.
    let c = 2.0 * d as f64 - 0.5;
    let body = Body::Circle {
        cx: c,
        cy: c,
        r: 0.5 * d as f64,
    };
    let mut lat = Lattice::new(nx, ny, body, 0.0, &inflow);
    let t = std::time::Instant::now();
    let ((fx, fy), steps) = lat.steady(tau, 2 * (nx as f64 / u_mean) as usize, 1e-5);
    let scale = 0.5 * u_mean * u_mean * d as f64;
    println!(
        "Schäfer–Turek 2D-1, D = {d}: C_D = {:.4} (reference 5.5795, {:+.2} %), C_L = {:.4} \
         (reference 0.0106), {steps} steps, {:.0} s",
        fx / scale,
        100.0 * (fx / scale / 5.57953523384 - 1.0),
        fy / scale,
        t.elapsed().as_secs_f64()
    );
}

/// `up` and `down`: the channel before and after the body, in diameters; `u`: the
/// lattice velocity of the walls and the far fluid (the Mach number is u √3).
fn settle(d: usize, shape: &str, up: usize, down: usize, u: f64) {
    // Joubert §3.2: d = 2.5 mm, L = 20 mm (8 d), ρs = 1250, ρf = 1000, ν = 1e-5, g = 9.81.
    let (dia, width, rho_s, rho_f, nu, g) = (2.5e-3, 20e-3, 1250.0, 1000.0, 1e-5, 9.81);
    let ny = (width / dia * d as f64).round() as usize;
    let (up, down) = (up * d, down * d);
    let nx = up + down;
    let (cx, cy) = (up as f64, 0.5 * ny as f64 - 0.5);
    let r = 0.5 * d as f64;
    let body = match shape {
        "circle" => Body::Circle { cx, cy, r },
        // couplet's settling cylinder: shape.prism, 12 sides, corners on r = d/2, a face
        // normal to the fall (body rotated onto z).
        "prism12" => Body::Polygon {
            cx,
            cy,
            r,
            sides: 12,
        },
        _ => panic!("shape: circle or prism12"),
    };
    let area_phys = body.area() * (dia / d as f64).powi(2);
    let k = 2.0 * (rho_s - rho_f) * g * area_phys * dia / (rho_f * nu * nu);
    println!(
        "settling {shape} in a channel of 8 d, D = {d} cells ({nx} × {ny}), area {:.4} of the \
         circle's: C_D Re² = K = {k:.2}",
        body.area() / (PI * r * r)
    );
    let mut lat = Lattice::new(nx, ny, body, u, &|_| u);
    let t = std::time::Instant::now();
    let solve = |re: f64, lat: &mut Lattice, first: bool| {
        let nu_l = u * d as f64 / re;
        let tau = 3.0 * nu_l + 0.5;
        let min = if first {
            3 * (nx as f64 / u) as usize
        } else {
            (nx as f64 / u) as usize
        };
        let ((fx, _), steps) = lat.steady(tau, min, 1e-5);
        let cd = fx / (0.5 * u * u * d as f64);
        println!(
            "  Re {re:.4}: τ {tau:.3}, C_D {cd:.4}, C_D Re² {:.2}, {steps} steps, {:.0} s",
            cd * re * re,
            t.elapsed().as_secs_f64()
        );
        cd * re * re - k
    };
    // Secant on ln Re from Re = 14 and 15 (the D = 20 answer is 13.6).
    let (mut a, mut b) = (14.0f64.ln(), 15.0f64.ln());
    let mut fa = solve(a.exp(), &mut lat, true);
    let mut fb = solve(b.exp(), &mut lat, false);
    for _ in 0..8 {
        let c = b - fb * (b - a) / (fb - fa);
        let fc = solve(c.exp(), &mut lat, false);
        (a, fa, b, fb) = (b, fb, c, fc);
        if (b - a).abs() < 2e-4 {
            break;
        }
    }
    println!(
        "terminal Re of the {shape} at D = {d}: {:.3} (U = {:.2} mm/s), {:.0} s",
        b.exp(),
        b.exp() * nu / dia * 1e3,
        t.elapsed().as_secs_f64()
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let d = |k: usize| {
        args.get(k)
            .map_or(20, |s| s.parse().expect("D: cells across the body"))
    };
    match args.get(1).map(String::as_str) {
        Some("schafer-turek") => schafer_turek(d(2)),
        Some("settle") => {
            let num = |k: usize, default: f64| {
                args.get(k)
                    .map_or(default, |s| s.parse().expect("a number"))
            };
            settle(
                d(2),
                args.get(3).map_or("prism12", String::as_str),
                num(4, 6.0) as usize,
                num(5, 18.0) as usize,
                num(6, 0.04),
            )
        }
        _ => eprintln!(
            "usage: lbm-cylinder schafer-turek D | lbm-cylinder settle D [circle|prism12 [UP DOWN [U]]] \
             (defaults: prism12, 6 and 18 diameters before and after the body, U = 0.04)"
        ),
    }
}
