//! Angle wrapping for the hot paths (motions sampled by the collision checks, the
//! Reeds-Shepp solver): bit for bit [`aisle_geometry::wrap_angle`], without its
//! remainder call when the angle is already within one turn, as the search's angles
//! nearly always are (`fmod` is a library call and was a few per cent of a request).

use std::f64::consts::{PI, TAU};

/// [`aisle_geometry::wrap_angle`]: `a` wrapped to (-pi, pi], the same bits.
#[inline]
pub(crate) fn wrap(a: f64) -> f64 {
    // The remainder is exact, and for |a| < 2 pi it is `a` itself (sign of zero
    // included); NaN and infinities take the remainder as before.
    let r = if a.abs() < TAU { a } else { a % TAU };
    if r > PI {
        r - TAU
    } else if r <= -PI {
        r + TAU
    } else {
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::wrap_angle;

    #[test]
    fn same_bits_as_the_geometry_crate() {
        let mut edges = vec![
            0.0,
            -0.0,
            PI,
            -PI,
            TAU,
            -TAU,
            3.0 * PI,
            -3.0 * PI,
            1e300,
            -1e300,
            f64::MIN_POSITIVE,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for e in [PI, TAU, 3.0 * PI] {
            for k in 1..4 {
                let mut up = e;
                let mut down = e;
                for _ in 0..k {
                    up = f64::from_bits(up.to_bits() + 1);
                    down = f64::from_bits(down.to_bits() - 1);
                }
                edges.extend([up, down, -up, -down]);
            }
        }
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        for _ in 0..200_000 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let u = (seed >> 11) as f64 / (1u64 << 53) as f64;
            edges.push((u - 0.5) * 40.0);
        }
        for a in edges {
            assert_eq!(wrap(a).to_bits(), wrap_angle(a).to_bits(), "{a:e}");
        }
    }
}
