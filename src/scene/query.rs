//! Ray and box queries over the placed objects, and what a hit reads there: the surface,
//! its albedo and material.

use glam::{Vec2, Vec3};

use super::{texture, LocalSurface, Scene, SceneObject, Surface};
use crate::geom::bvh;
use crate::geom::ray::{offset_origin, tri_normal, tri_point, WatertightRay};
use crate::geom::transform::{xform_point, xform_vector};
use crate::geom::{Hit, Ray};
use crate::layout::{Tri, NONE};

/// The object-space cube `[lo, hi]` of object `o` that the world-space cube of half-width
/// `r` about `c` becomes for the box queries ([`Scene::any_triangle_near`],
/// [`Scene::triangles_near`]); `None` where the transform makes its extent not finite.
fn object_cube(o: &SceneObject, c: Vec3, r: f32) -> Option<(Vec3, Vec3)> {
    let co = xform_point(&o.to_object, c);
    let ro = xform_vector(&o.to_object, Vec3::new(r, 0.0, 0.0)).length();
    ro.is_finite().then(|| (co - ro, co + ro))
}

impl Scene {
    /// Closest hit of a world-space ray in `(0, tmax)` over all objects.
    pub fn intersect(&self, ray: &Ray, mut tmax: f32) -> Option<Hit> {
        let mut best = None;
        for (i, o) in self.objects.iter().enumerate() {
            let r = Ray {
                o: xform_point(&o.to_object, ray.o),
                d: xform_vector(&o.to_object, ray.d),
            };
            if let Some((tri, t, b1, b2)) = self.trace_object(i, &r, tmax, false) {
                tmax = t;
                best = Some(Hit {
                    object: i as u32,
                    tri,
                    t,
                    b1,
                    b2,
                });
            }
        }
        best
    }

    /// Whether anything blocks a world-space ray in `(0, tmax)`.
    pub fn occluded(&self, ray: &Ray, tmax: f32) -> bool {
        self.objects.iter().enumerate().any(|(i, o)| {
            let r = Ray {
                o: xform_point(&o.to_object, ray.o),
                d: xform_vector(&o.to_object, ray.d),
            };
            self.trace_object(i, &r, tmax, true).is_some()
        })
    }

    /// Whether some triangle whose bounds meet the world-space cube of half-width `r`
    /// about `c` satisfies `f(object, triangle)` (object-space triangle): which triangles
    /// rays from `c` no longer than `r` can reach, without tracing them.
    pub fn any_triangle_near(&self, c: Vec3, r: f32, mut f: impl FnMut(usize, &Tri) -> bool) -> bool {
        self.objects.iter().enumerate().any(|(i, o)| {
            let Some((lo, hi)) = object_cube(o, c, r) else {
                return true;
            };
            bvh::any_in_box(&self.bvh, &self.tris, o.bvh_root, lo, hi, |_, t| f(i, t))
        })
    }

    /// Every triangle whose bounds meet the world-space cube of half-width `r` about `c`
    /// (those [`Self::any_triangle_near`] tests), as (object, global triangle) in object
    /// order, into `out`, if there are at most `cap`; false, with `out` incomplete, if
    /// there are more or an object's transform makes the cube's extent not finite.
    pub fn triangles_near(&self, c: Vec3, r: f32, cap: usize, out: &mut Vec<(u32, u32)>) -> bool {
        out.clear();
        for (i, o) in self.objects.iter().enumerate() {
            let Some((lo, hi)) = object_cube(o, c, r) else {
                return false;
            };
            let over = bvh::any_in_box(&self.bvh, &self.tris, o.bvh_root, lo, hi, |t, _| {
                out.push((i as u32, t));
                out.len() > cap
            });
            if over {
                return false;
            }
        }
        true
    }

    /// Calls `f(object, triangle, t, b1, b2)` for each triangle of `near` (object order, as
    /// [`Self::triangles_near`] gives them) that the world-space `ray` hits in `(0, tmax)`,
    /// by the watertight test of [`bvh::trace`] in the object's space, until `f` returns
    /// true.
    fn hits_among(
        &self,
        near: &[(u32, u32)],
        ray: &Ray,
        tmax: f32,
        mut f: impl FnMut(u32, u32, f32, f32, f32) -> bool,
    ) {
        for run in near.chunk_by(|a, b| a.0 == b.0) {
            let o = &self.objects[run[0].0 as usize];
            let wt = WatertightRay::new(&Ray {
                o: xform_point(&o.to_object, ray.o),
                d: xform_vector(&o.to_object, ray.d),
            });
            for &(oi, tri) in run {
                if let Some((t, b1, b2)) = wt.intersect(&self.tris[tri as usize], tmax) {
                    if !self.stops(tri, b1, b2) {
                        continue;
                    }
                    if f(oi, tri, t, b1, b2) {
                        return;
                    }
                }
            }
        }
    }

    /// [`Self::intersect`] for a ray that stays within a cube whose triangles `near` holds
    /// ([`Self::triangles_near`]): the closest hit among them, found without a BVH walk.
    /// Where another hit lies within a relative 1e-5 of it, or it lies that close to
    /// `tmax`, the traversal's rounding could pick otherwise, and the ray is traced.
    pub fn intersect_among(&self, near: &[(u32, u32)], ray: &Ray, tmax: f32) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut second = f32::INFINITY;
        self.hits_among(near, ray, tmax, |object, tri, t, b1, b2| {
            match best {
                Some(b) if t >= b.t => second = second.min(t),
                _ => {
                    if let Some(b) = best {
                        second = second.min(b.t);
                    }
                    best = Some(Hit { object, tri, t, b1, b2 });
                }
            }
            false
        });
        match best {
            Some(b) if second - b.t <= 1e-5 * b.t || tmax - b.t <= 1e-5 * tmax => self.intersect(ray, tmax),
            _ => best,
        }
    }

    /// [`Self::occluded`] for a ray that stays within a cube whose triangles `near` holds:
    /// whether one of them is hit in `(0, tmax)`. Where every hit lies within a relative
    /// 1e-5 of `tmax` (the traversal's rounding could cull it), the ray is traced.
    pub fn occluded_among(&self, near: &[(u32, u32)], ray: &Ray, tmax: f32) -> bool {
        let (mut clear, mut marginal) = (false, false);
        self.hits_among(near, ray, tmax, |_, _, t, _, _| {
            if tmax - t > 1e-5 * tmax {
                clear = true;
            } else {
                marginal = true;
            }
            clear
        });
        clear || (marginal && self.occluded(ray, tmax))
    }

    /// The surface at a hit, its normal turned towards the ray's origin: the shading
    /// normal where the triangle has vertex normals ([`Scene::shading_normal`]), else the
    /// geometric one. (`local.n_obj` stays geometric: the gathering rays' sender reads
    /// use it, on both backends alike.)
    pub fn surface(&self, hit: &Hit, ray_d: Vec3) -> Surface {
        let local = self.local_surface(hit, ray_d);
        let (p, mut n) = self.world_of(&local);
        if let Some(ns) = self.shading_normal(hit.tri, hit.b1, hit.b2, local.back) {
            let o = &self.objects[hit.object as usize];
            if let Some(w) = xform_vector(&o.to_world, ns).try_normalize() {
                n = w;
            }
        }
        Surface { local, p, n }
    }

    /// The shading normal at barycentrics `(b1, b2)` of global triangle `tri`, object
    /// space, on the side the ray met (`back`): its corner normals interpolated and made
    /// unit. `None` where it has none, or where the interpolated normal is zero or does
    /// not lie on the triangle's front (then the geometric normal serves).
    #[inline]
    pub fn shading_normal(&self, tri: u32, b1: f32, b2: f32, back: bool) -> Option<Vec3> {
        let n = interpolate_normal(
            self.normals.get(tri as usize)?,
            tri_normal(&self.tris[tri as usize]),
            b1,
            b2,
        )?;
        Some(if back { -n } else { n })
    }

    /// The world-space point and unit normal of a [`LocalSurface`] (those of
    /// [`Scene::surface`]).
    #[inline]
    pub fn world_of(&self, l: &LocalSurface) -> (Vec3, Vec3) {
        let o = &self.objects[l.object as usize];
        (
            xform_point(&o.to_world, l.p_obj),
            xform_vector(&o.to_world, l.n_obj).normalize(),
        )
    }

    /// [`Scene::surface`] in the object's space alone (the gathering rays' sender reads:
    /// no world-space point and normal to transform and normalise).
    #[inline]
    pub fn local_surface(&self, hit: &Hit, ray_d: Vec3) -> LocalSurface {
        let o = &self.objects[hit.object as usize];
        let tri = &self.tris[hit.tri as usize];
        let p_obj = tri_point(tri, hit.b1, hit.b2);
        let mut n_obj = tri_normal(tri);
        let back = n_obj.dot(xform_vector(&o.to_object, ray_d)) > 0.0;
        if back {
            n_obj = -n_obj;
        }
        LocalSurface {
            object: hit.object,
            tri: hit.tri,
            p_obj,
            n_obj,
            back,
            albedo: self.albedo(hit.tri, hit.b1, hit.b2),
        }
    }

    /// Material `m`'s `kd`: the albedo everywhere on an untextured triangle of it.
    #[inline]
    pub fn kd(&self, m: u32) -> Vec3 {
        Vec3::from(self.materials[m as usize].kd)
    }

    /// The material of global triangle `tri` if its albedo is that material's `kd`
    /// everywhere on it (no texture): what [`Scene::albedo`] returns there.
    #[inline]
    pub fn plain_material(&self, tri: u32) -> Option<u32> {
        let m = self.tris[tri as usize].material;
        (self.materials[m as usize].texture == NONE).then_some(m)
    }

    /// Albedo `ρ` at barycentrics `(b1, b2)` of global triangle `tri`.
    pub fn albedo(&self, tri: u32, b1: f32, b2: f32) -> Vec3 {
        let mi = self.tris[tri as usize].material;
        let (m, kd) = (&self.materials[mi as usize], self.kd(mi));
        if m.texture == NONE {
            return kd;
        }
        kd * texture::sample(
            &self.texels,
            &self.textures[m.texture as usize],
            self.uv_at(tri, b1, b2),
            &self.srgb,
        )
    }

    /// The texture coordinates at barycentrics `(b1, b2)` of global triangle `tri` (a
    /// scene with a texture).
    pub fn uv_at(&self, tri: u32, b1: f32, b2: f32) -> Vec2 {
        let uv = &self.uvs[tri as usize].uv;
        let b0 = 1.0 - b1 - b2;
        Vec2::new(
            uv[0] * b0 + uv[2] * b1 + uv[4] * b2,
            uv[1] * b0 + uv[3] * b1 + uv[5] * b2,
        )
    }

    /// Closest (or, with `any`, first) hit in `(0, tmax)` of an object-space ray in object
    /// `o`'s CWBVH, every hit asked [`Scene::stops`] first: the global triangle, t and
    /// barycentrics. Every traversal of the scene goes through here.
    #[inline]
    pub fn trace_object(&self, o: usize, ray: &Ray, tmax: f32, any: bool) -> Option<(u32, f32, f32, f32)> {
        bvh::trace_cw(&self.cw, &self.tris, self.cw.roots[o], ray, tmax, any, |t, b1, b2| {
            self.stops(t, b1, b2)
        })
    }

    /// Whether a ray that meets global triangle `tri` at barycentrics `(b1, b2)` stops
    /// there: false where the triangle's material is a cutout whose alpha there (its
    /// `opacity` times its alpha texture) is below its cutoff. Every traversal's any-hit
    /// test (camera, shadow, gathering, reach and crevice rays; kernels `opaque_at`).
    #[inline]
    pub fn stops(&self, tri: u32, b1: f32, b2: f32) -> bool {
        if !self.cutouts {
            return true;
        }
        let m = &self.materials[self.tris[tri as usize].material as usize];
        if m.alpha_texture == NONE {
            return true;
        }
        let a = texture::sample_alpha(
            &self.texels,
            &self.textures[m.alpha_texture as usize],
            self.uv_at(tri, b1, b2),
        );
        m.opacity * a >= m.cutoff
    }

    /// The shadow-ray origin for a world-space surface point.
    pub fn offset(&self, p: Vec3, n: Vec3) -> Vec3 {
        offset_origin(p, n, self.scale)
    }

    /// Whether any material is textured (texture sampling can be compiled out otherwise).
    pub fn textured(&self) -> bool {
        !self.textures.is_empty()
    }

    /// Total triangle count.
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }
}

/// Corner normals `c` (zero: none) interpolated at barycentrics `(b1, b2)` and made unit,
/// if that lies on the side of `front` (the triangle's winding normal); `None` otherwise.
#[inline]
pub fn interpolate_normal(c: &[f32; 9], front: Vec3, b1: f32, b2: f32) -> Option<Vec3> {
    if c[0] == 0.0 && c[1] == 0.0 && c[2] == 0.0 {
        return None;
    }
    let b0 = 1.0 - b1 - b2;
    let n = Vec3::new(c[0], c[1], c[2]) * b0 + Vec3::new(c[3], c[4], c[5]) * b1 + Vec3::new(c[6], c[7], c[8]) * b2;
    n.try_normalize().filter(|n| n.dot(front) > 0.0)
}
