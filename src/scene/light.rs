//! Lights and their direct irradiance (`ALGORITHM.md` §2; units as Mitsuba 3).
//! GLSL twin: `light_sample` in `glsl/include/surface.glsl`.

use std::path::Path;

use glam::Vec3;

use crate::error::{Error, Result};
use crate::layout::{GpuLight, LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT};

/// A light's unoccluded contribution at a point and the shadow ray that decides it:
/// the ray runs from the point along `to_light` for `t` in `(0, tmax)`.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    pub irradiance: Vec3,
    pub to_light: Vec3,
    pub tmax: f32,
}

/// `acos` by Abramowitz & Stegun 4.4.46 (|error| ≤ 2e-8 in exact arithmetic), written out
/// the same way in GLSL (`acos_as`): drivers' own `acos` differs by up to 1e-4 rad
/// (lavapipe), which the spot falloff turns into 0.1 % of direct light.
#[inline]
#[allow(clippy::excessive_precision)] // the published coefficients, as GLSL spells them too
pub fn acos_as(x: f32) -> f32 {
    let a = x.abs().min(1.0);
    let p = -0.001_262_491_1f32;
    let p = p * a + 0.006_670_090_1;
    let p = p * a - 0.017_088_125_6;
    let p = p * a + 0.030_891_881_0;
    let p = p * a - 0.050_174_304_6;
    let p = p * a + 0.088_978_987_4;
    let p = p * a - 0.214_598_801_6;
    let p = p * a + 1.570_796_305_0;
    let r = (1.0 - a).sqrt() * p;
    if x < 0.0 {
        std::f32::consts::PI - r
    } else {
        r
    }
}

/// Spot falloff: 1 inside the beam, linear in the angle to 0 at the cutoff.
#[inline]
pub fn spot_falloff(theta: f32, beam: f32, cutoff: f32) -> f32 {
    if theta <= beam {
        1.0
    } else if theta >= cutoff {
        0.0
    } else {
        (cutoff - theta) / (cutoff - beam)
    }
}

/// Direct irradiance from `l` at `(x, n)` before visibility, with the shadow ray to test.
/// `o` is the (offset) origin of that shadow ray.
#[inline]
pub fn light_sample(l: &GpuLight, x: Vec3, n: Vec3, o: Vec3) -> Option<LightSample> {
    let power = Vec3::from(l.power);
    if l.kind == LIGHT_DIRECTIONAL {
        let w = -Vec3::from(l.direction);
        let c = n.dot(w);
        if c <= 0.0 {
            return None;
        }
        return Some(LightSample {
            irradiance: power * c,
            to_light: w,
            tmax: f32::INFINITY,
        });
    }
    let q = Vec3::from(l.position);
    let v = q - x;
    let d2 = v.length_squared();
    if d2 <= 0.0 {
        return None;
    }
    let w = v / d2.sqrt();
    let c = n.dot(w);
    if c <= 0.0 {
        return None;
    }
    let mut e = power * (c / d2);
    if l.kind == LIGHT_SPOT {
        let cos_t = Vec3::from(l.direction).dot(-w).clamp(-1.0, 1.0);
        let f = spot_falloff(acos_as(cos_t), l.beam, l.cutoff);
        if f <= 0.0 {
            return None;
        }
        e *= f;
    }
    Some(LightSample {
        irradiance: e,
        to_light: q - o,
        tmax: crate::constants::SHADOW_TMAX,
    })
}

/// Total emitted power of a point or spot light (W, RGB): `4πI` or
/// `2πI ∫_0^cutoff f(θ) sinθ dθ` (`ALGORITHM.md` §7); `None` for directional lights.
pub fn power(l: &GpuLight) -> Option<Vec3> {
    let i = Vec3::from(l.power);
    match l.kind {
        LIGHT_POINT => Some(i * 4.0 * std::f32::consts::PI),
        LIGHT_SPOT => {
            let steps = 100_000;
            let h = l.cutoff as f64 / steps as f64;
            let s: f64 = (0..steps)
                .map(|k| {
                    let t = (k as f64 + 0.5) * h;
                    spot_falloff(t as f32, l.beam, l.cutoff) as f64 * t.sin() * h
                })
                .sum();
            Some(i * (2.0 * std::f64::consts::PI * s) as f32)
        }
        _ => None,
    }
}

/// A `[[light]]` table read key by key, so that every error names `light[i].key`.
struct Fields<'a> {
    t: &'a toml::Table,
    i: usize,
    path: &'a Path,
}

impl Fields<'_> {
    fn err(&self, key: &str, message: String) -> Error {
        Error::SceneValue {
            path: self.path.into(),
            key: format!("light[{}].{key}", self.i),
            message,
        }
    }

    fn number(&self, key: &str, v: &toml::Value) -> Result<f32> {
        match v {
            toml::Value::Float(f) => Ok(*f as f32),
            toml::Value::Integer(n) => Ok(*n as f32),
            other => Err(self.err(key, format!("expected a number, found {}", other.type_str()))),
        }
    }

    /// An optional three-vector of finite numbers (non-negative with `nonneg`).
    fn vec3(&self, key: &str, nonneg: bool) -> Result<Option<Vec3>> {
        let Some(v) = self.t.get(key) else { return Ok(None) };
        let toml::Value::Array(a) = v else {
            return Err(self.err(key, format!("expected an array of 3 numbers, found {}", v.type_str())));
        };
        if a.len() != 3 {
            return Err(self.err(key, format!("expected an array of 3 numbers, found {}", a.len())));
        }
        let mut out = [0.0f32; 3];
        for (o, x) in out.iter_mut().zip(a) {
            *o = self.number(key, x)?;
        }
        if out.iter().any(|c| !c.is_finite()) || (nonneg && out.iter().any(|&c| c < 0.0)) {
            return Err(self.err(
                key,
                format!(
                    "{out:?} must be finite{}",
                    if nonneg { " and non-negative" } else { "" }
                ),
            ));
        }
        Ok(Some(Vec3::from(out)))
    }

    fn required<T>(&self, key: &str, v: Result<Option<T>>) -> Result<T> {
        v?.ok_or_else(|| self.err(key, "is missing".into()))
    }

    fn scalar(&self, key: &str) -> Result<Option<f32>> {
        self.t.get(key).map(|v| self.number(key, v)).transpose()
    }

    /// A unit direction from `v` (the key it came from is `key`).
    fn unit(&self, key: &str, v: Vec3, what: &str) -> Result<Vec3> {
        crate::geom::unit_vector(v.as_dvec3()).ok_or_else(|| self.err(key, format!("{what} has zero length")))
    }
}

/// Validates `[[light]]` table number `i` (from 0) and converts it.
/// Long by design: one block per key of the table, each checked and named in its error.
pub fn from_table(t: &toml::Table, i: usize, path: &Path) -> Result<GpuLight> {
    let f = Fields { t, i, path };
    let kind = match t.get("type") {
        None => return Err(f.err("type", "is missing (point, spot or directional)".into())),
        Some(toml::Value::String(s)) => s.as_str(),
        Some(v) => return Err(f.err("type", format!("expected a string, found {}", v.type_str()))),
    };
    let allowed: &[&str] = match kind {
        "point" => &["type", "position", "intensity"],
        "directional" => &["type", "direction", "irradiance"],
        "spot" => &[
            "type",
            "position",
            "target",
            "direction",
            "intensity",
            "cutoff_angle",
            "beam_width",
        ],
        other => {
            return Err(f.err(
                "type",
                format!("`{other}` is not a light type (point, spot or directional)"),
            ))
        }
    };
    if let Some(k) = t.keys().find(|k| !allowed.contains(&k.as_str())) {
        return Err(f.err(
            k,
            format!(
                "unknown key for a {kind} light (expected one of {})",
                allowed[1..].join(", ")
            ),
        ));
    }
    Ok(match kind {
        "point" => GpuLight {
            position: f.required("position", f.vec3("position", false))?.into(),
            kind: LIGHT_POINT,
            power: f.required("intensity", f.vec3("intensity", true))?.into(),
            ..Default::default()
        },
        "directional" => {
            let d = f.required("direction", f.vec3("direction", false))?;
            GpuLight {
                kind: LIGHT_DIRECTIONAL,
                direction: f.unit("direction", d, "direction")?.into(),
                power: f.required("irradiance", f.vec3("irradiance", true))?.into(),
                ..Default::default()
            }
        }
        _ => {
            let pos = f.required("position", f.vec3("position", false))?;
            let dir = match (f.vec3("target", false)?, f.vec3("direction", false)?) {
                (Some(target), None) => {
                    let d = target.as_dvec3() - pos.as_dvec3();
                    crate::geom::unit_vector(d)
                        .ok_or_else(|| f.err("target", "equals `position`: the spot points nowhere".into()))?
                }
                (None, Some(d)) => f.unit("direction", d, "direction")?,
                _ => {
                    return Err(f.err(
                        "target",
                        "a spot light needs exactly one of `target` and `direction`".into(),
                    ))
                }
            };
            let cutoff = f.required("cutoff_angle", f.scalar("cutoff_angle"))?;
            if !(cutoff > 0.0 && cutoff <= 180.0) {
                return Err(f.err("cutoff_angle", format!("{cutoff} must be in (0, 180] degrees")));
            }
            let beam = f.required("beam_width", f.scalar("beam_width"))?;
            if !(beam >= 0.0 && beam <= cutoff) {
                return Err(f.err("beam_width", format!("{beam} must be in [0, cutoff_angle]")));
            }
            GpuLight {
                position: pos.into(),
                kind: LIGHT_SPOT,
                direction: dir.into(),
                cutoff: cutoff.to_radians(),
                power: f.required("intensity", f.vec3("intensity", true))?.into(),
                beam: beam.to_radians(),
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn point_light_over_plane() {
        let l = GpuLight {
            position: [0.0, 2.0, 0.0],
            kind: LIGHT_POINT,
            power: [3.0, 3.0, 3.0],
            ..Default::default()
        };
        let x = Vec3::new(1.5, 0.0, 0.0);
        let s = light_sample(&l, x, Vec3::Y, x).unwrap();
        let h = 2.0f32;
        let expected = 3.0 * h / (h * h + 1.5 * 1.5f32).powf(1.5);
        assert!((s.irradiance.x - expected).abs() < 1e-6);
        assert!(light_sample(&l, x, -Vec3::Y, x).is_none());
    }

    #[test]
    fn acos_polynomial_is_accurate() {
        for i in 0..=2000 {
            let x = -1.0 + i as f64 / 1000.0;
            let err = (acos_as(x as f32) as f64 - x.acos()).abs();
            assert!(err < 5e-7, "acos({x}): {err}");
        }
    }

    #[test]
    fn spot_power_matches_closed_form() {
        // With beam = cutoff, f = 1 in the cone: Φ = 2πI(1 − cos cutoff).
        let c = 60f32.to_radians();
        let l = GpuLight {
            kind: LIGHT_SPOT,
            power: [1.0; 3],
            cutoff: c,
            beam: c,
            direction: [0.0, -1.0, 0.0],
            ..Default::default()
        };
        let p = power(&l).unwrap().x;
        let expected = 2.0 * std::f32::consts::PI * (1.0 - c.cos());
        assert!((p - expected).abs() < 1e-4 * expected);
    }
}
