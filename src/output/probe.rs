//! Probe points: `px py pz nx ny nz` per line (`#` starts a comment) in, CSV out.

use std::fmt::Write as _;
use std::path::Path;

use glam::Vec3;
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::hierarchy::Hierarchy;
use crate::params::SolverParams;
use crate::scene::Scene;
use crate::transport::readout::{Read, Readout};
use crate::transport::Solution;

/// The CSV header of `probe`: the point, direct, indirect and total irradiance, the
/// standard error of the indirect value (the final gather's Monte Carlo noise, 0 when the
/// basis is read at the point) and of the direct one (the emitting surfaces' sampling, 0
/// for lights alone: they are exact).
pub const HEADER: &str = "px,py,pz,nx,ny,nz,direct_r,direct_g,direct_b,indirect_r,indirect_g,indirect_b,\
total_r,total_g,total_b,indirect_se_r,indirect_se_g,indirect_se_b,direct_se_r,direct_se_g,direct_se_b";

/// A query point with a unit normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Probe {
    pub p: Vec3,
    pub n: Vec3,
}

/// A probe from `px py pz nx ny nz`: finite, the normal made unit (in double precision);
/// else what is wrong. Every way points come in (a file, the Python module) goes through
/// here, so the same numbers give the same probe.
pub fn point(v: [f32; 6]) -> std::result::Result<Probe, &'static str> {
    if v.iter().any(|x| !x.is_finite()) {
        return Err("values must be finite");
    }
    let n = glam::DVec3::new(v[3] as f64, v[4] as f64, v[5] as f64);
    let n = crate::geom::unit_vector(n).ok_or("the normal has zero length")?;
    Ok(Probe {
        p: Vec3::new(v[0], v[1], v[2]),
        n,
    })
}

/// Parses a points file; errors name the line.
pub fn parse(path: &Path, text: &str) -> Result<Vec<Probe>> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let l = raw.split('#').next().unwrap_or("").trim();
        if l.is_empty() {
            continue;
        }
        let bad = |m: String| Error::Points {
            path: path.into(),
            line,
            message: m,
        };
        let vals = l
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|s| !s.is_empty())
            .map(|s| s.parse::<f32>().map_err(|_| bad(format!("`{s}` is not a number"))))
            .collect::<Result<Vec<f32>>>()?;
        let vals: [f32; 6] = vals
            .try_into()
            .map_err(|v: Vec<f32>| bad(format!("expected 6 numbers (px py pz nx ny nz), found {}", v.len())))?;
        out.push(point(vals).map_err(|m| bad(m.into()))?);
    }
    if out.is_empty() {
        return Err(Error::Points {
            path: path.into(),
            line: 0,
            message: "no points".into(),
        });
    }
    Ok(out)
}

/// Reads and parses a points file.
pub fn read(path: &Path) -> Result<Vec<Probe>> {
    read_within(path, &crate::limits::Limits::default())
}

/// Bytes a probe point takes while a command runs: the point and normal, its values and
/// standard errors, and its CSV line (21 numbers).
pub const BYTES_PER_PROBE: u64 = 400;

/// [`read`] within `limits`: the file at most a quarter of the memory limit (and
/// `MAX_TEXT_BYTES`), and its points, with their values and CSV, within the limit; else
/// an error naming the file with the estimate.
pub fn read_within(path: &Path, limits: &crate::limits::Limits) -> Result<Vec<Probe>> {
    let cap = crate::limits::MAX_TEXT_BYTES.min(limits.max_memory / 4).max(1 << 16);
    let text = crate::limits::read_text(path, cap)?;
    let points = parse(path, &text)?;
    drop(text);
    limits.check(
        path,
        "--points",
        &[crate::limits::Part {
            what: format!("{} probe points, their values and CSV", points.len()),
            bytes: (points.len() as u64 * BYTES_PER_PROBE) as f64,
        }],
    )?;
    Ok(points)
}

/// A probe's values.
#[derive(Clone, Copy, Debug)]
pub struct ProbeValue {
    pub direct: Vec3,
    /// The direct value's standard error (the emitters' sampling).
    pub direct_se: Vec3,
    pub indirect: Read,
}

impl ProbeValue {
    /// Every vector it holds: direct, its standard error, indirect, its standard error.
    pub fn vectors(&self) -> [Vec3; 4] {
        [self.direct, self.direct_se, self.indirect.mean, self.indirect.std_err]
    }
}

/// Direct (exact for lights, sampled for emitting surfaces, with its standard error) and
/// indirect (read as `params` ask: the basis on the output level, clamped at zero, or a
/// final gather with its standard error) irradiance at each probe.
pub fn evaluate(
    scene: &Scene,
    h: &Hierarchy,
    sol: &Solution,
    probes: &[Probe],
    params: &SolverParams,
) -> Vec<ProbeValue> {
    let read = Readout::new(scene, h, sol, params);
    let samples = params.final_gather.max(params.emitter_samples) as usize;
    evaluate_with(scene, probes, samples, |q| read.at(q.p, q.n))
}

/// [`evaluate`] with the indirect light read as the image reads it
/// ([`Readout::image_at`]: the basis, and where it is doubted a gather of a pixel's worth of
/// rays), for `probe --read image`: what the image pipeline computes at the points.
pub fn evaluate_as_image(
    scene: &Scene,
    h: &Hierarchy,
    sol: &Solution,
    probes: &[Probe],
    params: &SolverParams,
) -> Vec<ProbeValue> {
    let read = Readout::for_image_points(scene, h, sol, params);
    evaluate_with(scene, probes, scene.emitters.samples(), |q| Read {
        mean: read.image_at(q.p, q.n),
        std_err: Vec3::ZERO,
    })
}

/// Each probe's direct light from `samples` emitter and sky samples, and its indirect
/// light as `indirect` reads it.
fn evaluate_with(
    scene: &Scene,
    probes: &[Probe],
    samples: usize,
    indirect: impl Fn(&Probe) -> Read + Sync,
) -> Vec<ProbeValue> {
    probes
        .par_iter()
        .map(|q| {
            let (direct, direct_se) = scene.direct_with_samples(q.p, q.n, samples);
            ProbeValue {
                direct,
                direct_se,
                indirect: indirect(q),
            }
        })
        .collect()
}

/// The reference CSV header: the probe columns plus the standard errors of the indirect
/// (and total: direct is exact) irradiance.
pub const REFERENCE_HEADER: &str = "px,py,pz,nx,ny,nz,direct_r,direct_g,direct_b,indirect_r,indirect_g,indirect_b,\
total_r,total_g,total_b,indirect_se_r,indirect_se_g,indirect_se_b";

/// The reference CSV text.
pub fn reference_csv(probes: &[Probe], direct: &[Vec3], est: &[crate::reference::Estimate]) -> String {
    let mut s = String::from(REFERENCE_HEADER);
    s.push('\n');
    for ((q, d), e) in probes.iter().zip(direct).zip(est) {
        let (i, se) = (e.mean, e.std_err);
        let t = d.as_dvec3() + i;
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            q.p.x, q.p.y, q.p.z, q.n.x, q.n.y, q.n.z, d.x, d.y, d.z, i.x, i.y, i.z, t.x, t.y, t.z, se.x, se.y, se.z
        );
    }
    s
}

/// The CSV text for probes and their values.
pub fn csv(probes: &[Probe], values: &[ProbeValue]) -> String {
    let mut s = String::from(HEADER);
    s.push('\n');
    for (q, v) in probes.iter().zip(values) {
        let (d, ds, i, se) = (v.direct, v.direct_se, v.indirect.mean, v.indirect.std_err);
        let t = d + i;
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            q.p.x,
            q.p.y,
            q.p.z,
            q.n.x,
            q.n.y,
            q.n.z,
            d.x,
            d.y,
            d.z,
            i.x,
            i.y,
            i.z,
            t.x,
            t.y,
            t.z,
            se.x,
            se.y,
            se.z,
            ds.x,
            ds.y,
            ds.z
        );
    }
    s
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_readme_lists_every_probe_column() {
        let readme = include_str!("../../README.md");
        assert!(
            readme.contains(&format!("`{}`", super::HEADER)),
            "README.md lacks the probe header"
        );
        let n = super::HEADER.split(',').count();
        assert!(
            readme.contains(&format!("({n} columns)")),
            "README.md does not count {n} columns"
        );
    }
}
