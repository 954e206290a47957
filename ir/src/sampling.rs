//! Reproducible random inputs: unit vectors, triangles of vertex normals
//! meeting a convexity threshold, barycentric coordinates.

use glam::DVec3;

/// SplitMix64: small, fast, well-known; the same seed gives the same stream
/// on every machine.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in `[0, 1)` (53 random bits).
    #[allow(clippy::cast_precision_loss, reason = "53 bits: exact in f64")]
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    /// Uniform in `0..n`.
    pub fn below(&mut self, n: u64) -> u64 {
        ((u128::from(self.next_u64()) * u128::from(n)) >> 64) as u64
    }
    /// A uniformly distributed unit vector.
    pub fn direction(&mut self) -> DVec3 {
        let z = self.uniform(-1.0, 1.0);
        let a = self.uniform(0.0, std::f64::consts::TAU);
        let r = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(r * a.cos(), r * a.sin(), z)
    }
    /// A unit vector uniformly distributed within angle `alpha` of `axis`.
    pub fn in_cone(&mut self, axis: DVec3, alpha: f64) -> DVec3 {
        let cos_t = self.uniform(alpha.cos(), 1.0);
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let a = self.uniform(0.0, std::f64::consts::TAU);
        let (u, v) = axis.any_orthonormal_pair();
        (axis * cos_t + (u * a.cos() + v * a.sin()) * sin_t).normalize()
    }
    /// Barycentric coordinates uniform over a triangle.
    pub fn barycentric(&mut self) -> [f64; 3] {
        let (mut u, mut v) = (self.unit(), self.unit());
        if u + v > 1.0 {
            u = 1.0 - u;
            v = 1.0 - v;
        }
        [1.0 - u - v, u, v]
    }
}

/// `c1·N1 + c2·N2 + c3·N3`.
pub fn lerp3(n: &[DVec3; 3], c: [f64; 3]) -> DVec3 {
    n[0] * c[0] + n[1] * c[1] + n[2] * c[2]
}

/// The cosine of the largest angle between the vertex normals:
/// `min(N1·N2, N2·N3, N3·N1)`.
pub fn cos_phi(n: &[DVec3; 3]) -> f64 {
    n[0].dot(n[1]).min(n[1].dot(n[2])).min(n[2].dot(n[0]))
}

/// Three unit normals whose pairwise dot products are all exactly `theta`,
/// randomly oriented: `N_i = (r cos 2πi/3, r sin 2πi/3, h)` rotated, with
/// `h² = (1 + 2Θ)/3` — the triangle whose centroid has the smallest `d`.
pub fn equiangular(theta: f64, rng: &mut Rng) -> [DVec3; 3] {
    let h = ((1.0 + 2.0 * theta) / 3.0).sqrt();
    let r = (1.0 - h * h).max(0.0).sqrt();
    let axis = rng.direction();
    let (u, v) = axis.any_orthonormal_pair();
    let spin = rng.uniform(0.0, std::f64::consts::TAU);
    std::array::from_fn(|i| {
        let a = spin + [0.0, 1.0, 2.0][i] * std::f64::consts::TAU / 3.0;
        (axis * h + (u * a.cos() + v * a.sin()) * r).normalize()
    })
}

/// A random triangle of unit vertex normals meeting `theta`
/// (`cos φ ≥ Θ`): half the time all three within `φ/2` of a random axis
/// (always meets Θ), half the time within `φ` of it, rejected until it
/// meets Θ (reaching the wide, thin configurations too).
pub fn triangle_meeting(theta: f64, rng: &mut Rng) -> [DVec3; 3] {
    let phi = theta.clamp(-1.0, 1.0).acos();
    let axis = rng.direction();
    if rng.next_u64() & 1 == 0 {
        return std::array::from_fn(|_| rng.in_cone(axis, phi / 2.0));
    }
    loop {
        let t: [DVec3; 3] = std::array::from_fn(|_| rng.in_cone(axis, phi));
        if cos_phi(&t) >= theta {
            return t;
        }
    }
}
