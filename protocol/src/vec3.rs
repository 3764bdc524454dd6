//! Arithmetic on `[f64; 3]` vectors and unit quaternions `[x, y, z, w]`, for every
//! crate of the workspace (the servers' geometry and contacts, the CPU twins, the
//! recordings' VTK meshes), so that each does not keep its own copy.

#[inline]
pub fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[inline]
pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
pub fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    a.map(|c| c * s)
}

#[inline]
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[inline]
pub fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// `a += b`.
#[inline]
pub fn add_to(a: &mut [f64; 3], b: [f64; 3]) {
    for k in 0..3 {
        a[k] += b[k];
    }
}

/// The unit quaternion `[x, y, z, w]` of the rotation by |a| about a/|a| (a scaled
/// axis, the form of `bodies.rotation` in a scene).
pub fn quat_from_scaled_axis(a: [f64; 3]) -> [f64; 4] {
    let angle = norm(a);
    if angle == 0.0 {
        return [0.0, 0.0, 0.0, 1.0];
    }
    let s = (0.5 * angle).sin() / angle;
    [a[0] * s, a[1] * s, a[2] * s, (0.5 * angle).cos()]
}

/// Rotates `v` by the unit quaternion `q = [x, y, z, w]`: v + 2w (q⃗ × v) + 2 q⃗ × (q⃗ × v).
pub fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let u = [q[0], q[1], q[2]];
    let t = scale(cross(u, v), 2.0);
    add(v, add(scale(t, q[3]), cross(u, t)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact on small integers: the right-handed basis, a dot product and a norm.
    #[test]
    fn products_of_the_basis_and_a_3_4_12_vector() {
        let (x, y, z) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
        assert_eq!(cross(x, y), z);
        assert_eq!(cross(y, z), x);
        assert_eq!(cross(z, x), y);
        let v = [3.0, 4.0, 12.0];
        assert_eq!(norm(v), 13.0);
        assert_eq!(dot(v, [1.0, -1.0, 2.0]), 23.0);
        assert_eq!(sub(add(v, x), x), v);
        assert_eq!(scale(v, -2.0), [-6.0, -8.0, -24.0]);
        let mut w = v;
        add_to(&mut w, y);
        assert_eq!(w, [3.0, 5.0, 12.0]);
    }

    /// The quaternion of π/2 about z turns x into y, and a zero axis is the identity.
    #[test]
    fn scaled_axis_quaternion_rotates() {
        let q = quat_from_scaled_axis([0.0, 0.0, std::f64::consts::FRAC_PI_2]);
        let v = rotate(q, [1.0, 0.0, 0.0]);
        assert!(v[0].abs() < 1e-15 && (v[1] - 1.0).abs() < 1e-15 && v[2].abs() < 1e-15);
        assert_eq!(quat_from_scaled_axis([0.0; 3]), [0.0, 0.0, 0.0, 1.0]);
        assert_eq!(
            rotate([0.0, 0.0, 0.0, 1.0], [3.0, 4.0, 12.0]),
            [3.0, 4.0, 12.0]
        );
    }
}
