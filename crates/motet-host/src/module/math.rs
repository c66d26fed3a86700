//! Homogeneous transforms (4×4, row-major, `f64`): what a module's
//! placement is and what composing a chain multiplies. Sixteen numbers
//! and a product need no library.

/// A homogeneous transform: rotation in the upper-left 3×3, translation
/// (mm) in the last column, bottom row `0 0 0 1`.
pub type Htm = [[f64; 4]; 4];

/// The transform that changes nothing.
pub const IDENTITY: Htm = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// The wire's row-major `f32` placement as a transform.
pub fn from_wire(m: &[f32; 16]) -> Htm {
    let mut out = [[0.0; 4]; 4];
    for (r, row) in out.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = f64::from(m[r * 4 + c]);
        }
    }
    out
}

/// `a · b`: first `b`, then `a`.
pub fn mul(a: &Htm, b: &Htm) -> Htm {
    let mut out = [[0.0; 4]; 4];
    for (r, row) in out.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = (0..4).map(|k| a[r][k] * b[k][c]).sum();
        }
    }
    out
}

/// The rotation part applied to a direction.
pub fn rotate(m: &Htm, v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|r| (0..3).map(|k| m[r][k] * v[k]).sum())
}

/// Where the transform takes a point.
pub fn apply(m: &Htm, p: [f64; 3]) -> [f64; 3] {
    let r = rotate(m, p);
    [r[0] + m[0][3], r[1] + m[1][3], r[2] + m[2][3]]
}

/// How far the upper-left 3×3 is from a rotation: the largest entry of
/// `RᵀR − I`, or `|det R − 1|` if larger (a mirror has `det −1`).
pub fn rigidity_error(m: &Htm) -> f64 {
    let mut worst = 0.0f64;
    for i in 0..3 {
        for j in 0..3 {
            let dot: f64 = (0..3).map(|k| m[k][i] * m[k][j]).sum();
            let want = if i == j { 1.0 } else { 0.0 };
            worst = worst.max((dot - want).abs());
        }
    }
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    worst.max((det - 1.0).abs())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rot_z(deg: f64) -> Htm {
        let (s, c) = deg.to_radians().sin_cos();
        [
            [c, -s, 0.0, 1.0],
            [s, c, 0.0, 2.0],
            [0.0, 0.0, 1.0, 3.0],
            [0.0, 0.0, 0.0, 1.0],
        ]
    }

    #[test]
    fn products_and_rigidity() {
        let m = mul(&rot_z(90.0), &rot_z(-90.0));
        let p = apply(&m, [1.0, 0.0, 0.0]);
        // Turned back, and translated by both: p + R₉₀·t + t.
        for (got, want) in p.iter().zip([1.0 - 2.0 + 1.0, 1.0 + 2.0, 3.0 + 3.0]) {
            assert!((got - want).abs() < 1e-12, "{p:?}");
        }
        assert!(rigidity_error(&rot_z(33.0)) < 1e-12);
        assert_eq!(rigidity_error(&IDENTITY), 0.0);
        let mut scaled = IDENTITY;
        scaled[0][0] = 2.0;
        assert!((rigidity_error(&scaled) - 3.0).abs() < 1e-12);
        let mut mirror = IDENTITY;
        mirror[1][1] = -1.0;
        assert_eq!(rigidity_error(&mirror), 2.0);
        let mut shear = IDENTITY;
        shear[0][1] = 0.5;
        assert!(rigidity_error(&shear) >= 0.5);
    }
}
