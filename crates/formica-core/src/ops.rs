//! Portable maths: every transcendental function the simulator uses, through the `libm` crate.
//!
//! The platform's `sin`, `cos`, `exp`, `atan2`, ... (std's `f32::sin` and friends) call the
//! system maths library, whose last bits differ between operating systems and CPUs. `libm` is
//! plain Rust, so the same inputs give the same bits everywhere, and a result published with
//! its seed reproduces on any machine. `clippy.toml` forbids the std methods in this workspace
//! (`disallowed-methods`), as bevy does with its `ops` module. Square roots and the basic
//! arithmetic are exactly rounded by IEEE 754 and need no wrapper.
//!
//! Seeded Gaussian noise comes from here too ([`standard_normal`]), built on the same
//! functions, instead of `rand_distr::Normal`, whose tables and `exp`/`ln` calls are not
//! guaranteed to give the same bits on every platform.

use crate::geometry::Vec2;
use rand::Rng;

/// Sine (rad).
#[inline]
pub fn sin(x: f32) -> f32 {
    libm::sinf(x)
}

/// Cosine (rad).
#[inline]
pub fn cos(x: f32) -> f32 {
    libm::cosf(x)
}

/// Sine and cosine (rad).
#[inline]
pub fn sin_cos(x: f32) -> (f32, f32) {
    libm::sincosf(x)
}

/// Tangent (rad).
#[inline]
pub fn tan(x: f32) -> f32 {
    libm::tanf(x)
}

/// Arc sine (rad).
#[inline]
pub fn asin(x: f32) -> f32 {
    libm::asinf(x)
}

/// Arc cosine (rad).
#[inline]
pub fn acos(x: f32) -> f32 {
    libm::acosf(x)
}

/// Four-quadrant arc tangent of `y / x` (rad).
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    libm::atan2f(y, x)
}

/// e^x.
#[inline]
pub fn exp(x: f32) -> f32 {
    libm::expf(x)
}

/// Natural logarithm.
#[inline]
pub fn ln(x: f32) -> f32 {
    libm::logf(x)
}

/// x^y.
#[inline]
pub fn powf(x: f32, y: f32) -> f32 {
    libm::powf(x, y)
}

/// e^x, in double precision.
#[inline]
pub fn exp_f64(x: f64) -> f64 {
    libm::exp(x)
}

/// Natural logarithm, in double precision.
#[inline]
pub fn ln_f64(x: f64) -> f64 {
    libm::log(x)
}

/// The unit vector at angle `a` (rad) from +x.
#[inline]
pub fn unit(a: f32) -> Vec2 {
    let (s, c) = sin_cos(a);
    Vec2::new(c, s)
}

/// The angle of `v` from +x (rad, in (-pi, pi]).
#[inline]
pub fn angle_of(v: Vec2) -> f32 {
    atan2(v.y, v.x)
}

/// A standard normal sample (mean 0, standard deviation 1), by the Box–Muller transform on two
/// uniform draws. Portable: only exactly rounded arithmetic and the functions above.
pub fn standard_normal(rng: &mut impl Rng) -> f32 {
    // u1 in (0, 1], so that ln(u1) is finite.
    let u1 = 1.0 - rng.random::<f32>();
    let u2 = rng.random::<f32>();
    (-2.0 * ln(u1)).sqrt() * cos(std::f32::consts::TAU * u2)
}

/// `v` plus Gaussian noise of standard deviation `sd` (none when `sd` is not positive).
pub fn gaussian(v: f32, sd: f32, rng: &mut impl Rng) -> f32 {
    if sd > 0.0 {
        v + sd * standard_normal(rng)
    } else {
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn standard_normal_has_unit_spread() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
        let n = 100_000;
        let xs: Vec<f64> = (0..n)
            .map(|_| f64::from(standard_normal(&mut rng)))
            .collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var.sqrt() - 1.0).abs() < 0.01, "sd {}", var.sqrt());
        // Tails as a normal has them: about 4.55 % beyond 2 sd.
        let tail = xs.iter().filter(|x| x.abs() > 2.0).count() as f64 / n as f64;
        assert!((tail - 0.0455).abs() < 0.003, "tail {tail}");
    }

    #[test]
    fn known_bits() {
        // libm gives these bits on every platform (checked against the golden digests too).
        assert_eq!(sin(1.0).to_bits(), 0.841_470_96_f32.to_bits());
        assert_eq!(exp(-1.0).to_bits(), 0.367_879_44_f32.to_bits());
        assert_eq!(
            atan2(1.0, 1.0).to_bits(),
            std::f32::consts::FRAC_PI_4.to_bits()
        );
    }
}
