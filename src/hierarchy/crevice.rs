//! The crevice test of dart throwing (`ALGORITHM.md` §3.3): whether a candidate lies in a
//! gap light does not enter ([`in_crevice`], or within its object alone,
//! [`in_crevice_within`]), and the test as dart throwing asks it ([`CreviceTest`]).

use glam::{Vec2, Vec3};

use super::poisson::Candidate;
use super::{ray_cube, NEAR_CAP};
use crate::geom::sampling::{cosine_direction, integral_rotation, onb};
use crate::geom::transform::{xform_point, xform_vector};
use crate::geom::Ray;
use crate::scene::Scene;

/// Whether a candidate lies in a crevice: 7 of 8 stratified cosine-distributed rays from it
/// hit something within `d_min` (world units). Such a point sits in a gap light does not
/// enter (under an object resting on the floor, behind a luminaire a hair below the
/// ceiling); a node there would blend its darkness into the lit surface facing it.
///
/// The rays are traced only where they can hit something: they leave `origin` into the
/// upper half-space of the candidate's tangent plane through it, so a triangle lying at
/// least half the ray offset below that plane cannot stop one. Where every triangle within
/// `d_min` of the origin does (a candidate on open floor: its own surface alone), the
/// answer is "no crevice" without a ray.
pub fn in_crevice(scene: &Scene, o: usize, c: &Candidate, d_min: f32, index: u32) -> bool {
    let obj = &scene.objects[o];
    let x = xform_point(&obj.to_world, c.pos);
    let n = xform_vector(&obj.to_world, c.normal).normalize();
    let origin = scene.offset(x, n);
    let below = 0.5 * (origin - x).dot(n);
    let reach = ray_cube(origin, d_min);
    let above = |oi: usize, tri: &crate::layout::Tri| {
        let m = &scene.objects[oi].to_world;
        [tri.v0, tri.v1, tri.v2]
            .iter()
            .any(|&v| above_plane(xform_point(m, Vec3::from(v)), origin, n, below))
    };
    if below > 0.0 && !scene.any_triangle_near(origin, reach, above) {
        return false;
    }
    // Few triangles within reach: the rays tested against them, without a walk each.
    let mut near = Vec::with_capacity(NEAR_CAP + 1);
    if scene.triangles_near(origin, reach, NEAR_CAP, &mut near) {
        return crevice_rays(scene, o, c, index, |ray| scene.occluded_among(&near, ray, d_min));
    }
    in_crevice_traced(scene, o, c, d_min, index)
}

/// Whether `v` lies less than `below` under the plane through `origin` with normal `n`
/// (in double precision: the shortcuts' margin is the ray offset, a few ulps).
#[inline]
fn above_plane(v: Vec3, origin: Vec3, n: Vec3, below: f32) -> bool {
    (v.as_dvec3() - origin.as_dvec3()).dot(n.as_dvec3()) > -(below as f64)
}

/// [`in_crevice`] with every ray traced (what the shortcut must reproduce; tests).
pub fn in_crevice_traced(scene: &Scene, o: usize, c: &Candidate, d_min: f32, index: u32) -> bool {
    crevice_rays(scene, o, c, index, |ray| scene.occluded(ray, d_min))
}

/// Whether at least 7 of the crevice test's 8 world-space rays from candidate `c` are
/// `blocked` ([`Scene::occluded`] within `d_min`, or what gives the same).
fn crevice_rays(scene: &Scene, o: usize, c: &Candidate, index: u32, blocked: impl Fn(&Ray) -> bool) -> bool {
    let obj = &scene.objects[o];
    let x = xform_point(&obj.to_world, c.pos);
    let n = xform_vector(&obj.to_world, c.normal).normalize();
    let origin = scene.offset(x, n);
    let (t, b) = onb(n);
    let phi0 = integral_rotation(0x0c0e_u32, index);
    let mut near = 0;
    for k in 0..8 {
        let u = Vec2::new((k as f32 + 0.5) / 8.0, (k as f32 * 0.618_034).fract());
        let d = cosine_direction(n, t, b, u, phi0);
        if blocked(&Ray { o: origin, d }) {
            near += 1;
        }
    }
    near >= 7
}

/// [`in_crevice`] against object `o` alone, in object space (`reach = "object"`): the
/// gap must lie within the object (`d_min_obj` in object units), so the answer does not
/// depend on where the object is or on the other objects.
/// Rays are traced only where they can hit something, as in [`in_crevice`].
pub fn in_crevice_within(scene: &Scene, o: usize, c: &Candidate, d_min_obj: f32, index: u32, diag: f32) -> bool {
    let obj = &scene.objects[o];
    let origin = crate::geom::ray::offset_origin(c.pos, c.normal, diag);
    let below = 0.5 * (origin - c.pos).dot(c.normal);
    if below > 0.0 {
        let reach = ray_cube(origin, d_min_obj);
        let may_hit = crate::geom::bvh::any_in_box(
            &scene.bvh,
            &scene.tris,
            obj.bvh_root,
            origin - reach,
            origin + reach,
            |_, tri| {
                [tri.v0, tri.v1, tri.v2]
                    .iter()
                    .any(|&v| above_plane(Vec3::from(v), origin, c.normal, below))
            },
        );
        if !may_hit {
            return false;
        }
    }
    in_crevice_within_traced(scene, o, c, d_min_obj, index, diag)
}

/// [`in_crevice_within`] with every ray traced (tests).
pub fn in_crevice_within_traced(scene: &Scene, o: usize, c: &Candidate, d_min_obj: f32, index: u32, diag: f32) -> bool {
    let origin = crate::geom::ray::offset_origin(c.pos, c.normal, diag);
    let (t, b) = onb(c.normal);
    let phi0 = integral_rotation(0x0c0e_u32, index);
    let mut near = 0;
    for k in 0..8 {
        let u = Vec2::new((k as f32 + 0.5) / 8.0, (k as f32 * 0.618_034).fract());
        let d = cosine_direction(c.normal, t, b, u, phi0);
        let ray = Ray { o: origin, d };
        if scene.trace_object(o, &ray, d_min_obj, true).is_some() {
            near += 1;
        }
    }
    near >= 7
}

/// Object-space diagonal of object `o`'s bounds (the offset scale of object-space rays).
pub fn object_diagonal(scene: &Scene, o: usize) -> f32 {
    let obj = &scene.objects[o];
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for t in &scene.tris[obj.tri_offset as usize..(obj.tri_offset + obj.tri_count) as usize] {
        for v in [t.v0, t.v1, t.v2] {
            lo = lo.min(Vec3::from(v));
            hi = hi.max(Vec3::from(v));
        }
    }
    (hi - lo).length()
}

/// The crevice test as dart throwing asks it of object `o`'s candidates
/// ([`in_crevice`], or [`in_crevice_within`] with `within`).
#[derive(Clone, Debug)]
pub struct CreviceTest {
    /// The gap width, world units (0: no test).
    pub d_min: f32,
    /// `reach = "object"`: the test within each object, in object space.
    pub within: bool,
    /// Per object, with `within`: its diagonal (the ray offset's scale).
    pub diags: Vec<f32>,
}

impl CreviceTest {
    /// The gap width in object `o`'s units with `within` (world units without).
    pub fn d_min_in(&self, scene: &Scene, o: usize) -> f32 {
        if self.within {
            self.d_min / scene.objects[o].transform.scale
        } else {
            self.d_min
        }
    }
}
