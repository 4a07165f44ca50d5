//! The Monte Carlo estimate of one gathering integral: running sums of RGB samples in
//! double precision ([`Estimator`]) and the mean with its standard error ([`Gathered`]).
//! The CPU backend, its links and the outputs' final gather all reduce through it (the
//! GPU's twin is kernel `reduce`).

use glam::Vec3;

/// One gathering integral's Monte Carlo result: mean and standard error per channel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Gathered {
    pub mean: Vec3,
    pub std_err: Vec3,
}

/// Running sums of a Monte Carlo mean of RGB samples, in double precision; samples not
/// added (misses) count as zero.
#[derive(Clone, Copy, Debug, Default)]
pub struct Estimator {
    sum: glam::DVec3,
    sum2: glam::DVec3,
}

impl Estimator {
    #[inline]
    pub fn add(&mut self, c: Vec3) {
        let c = c.as_dvec3();
        self.sum += c;
        self.sum2 += c * c;
    }

    /// The mean over `n` samples and its standard error (unbiased sample variance).
    pub fn finish(&self, n: usize) -> Gathered {
        let nf = n.max(1) as f64;
        let mean = self.sum / nf;
        let var = if n > 1 {
            ((self.sum2 / nf - mean * mean) * (nf / (nf - 1.0))).max(glam::DVec3::ZERO)
        } else {
            glam::DVec3::ZERO
        };
        Gathered {
            mean: mean.as_vec3(),
            std_err: (var / nf).as_vec3().map(f32::sqrt),
        }
    }
}
