//! No silent black (issue #34): warnings for a run whose light reaches no node, or no
//! pixel the camera sees, naming the object whose outside alone catches the light when
//! it encloses the rest (a skybox mesh around a city keeps the sun and the sky out).

use glam::Vec3;

use super::image::Images;
use crate::hierarchy::Hierarchy;
use crate::scene::{object_box, Scene};
use crate::transport::Solution;

/// An image whose mean is below this fraction of the lit nodes' mean direct irradiance is
/// dark (Khronos' VC, a city inside a skybox that leaks a little light through its
/// seams, comes to 1.4e-6).
const DARK_IMAGE: f64 = 1e-4;

/// The warnings for `sol` (and its image, when one was drawn); empty when light arrives.
pub fn warnings(scene: &Scene, h: &Hierarchy, sol: &Solution, img: Option<&Images>) -> Vec<String> {
    let mut out = Vec::new();
    // Nodes with direct light, per object.
    let lit: Vec<usize> = h
        .objects
        .iter()
        .map(|ol| {
            (0..ol.start.len())
                .flat_map(|l| ol.start[l] as usize..(ol.start[l] + ol.count[l]) as usize)
                .filter(|&j| sol.values.direct[j].truncate().max_element() > 0.0)
                .count()
        })
        .collect();
    let total: usize = lit.iter().sum();
    // The image is dark when its mean is below `DARK_IMAGE` of the lit nodes' mean direct
    // irradiance: a few leaks through a skybox's seams leave it all but black.
    let lit_mean = {
        let d = sol
            .values
            .direct
            .iter()
            .map(|v| v.truncate().max_element())
            .filter(|&e| e > 0.0);
        let (n, s) = d.fold((0usize, 0f64), |(n, s), e| (n + 1, s + e as f64));
        s / n.max(1) as f64
    };
    let image_mean = img.map(|i| {
        let t = i.total();
        t.iter().map(|p| p.max_element().max(0.0) as f64).sum::<f64>() / t.len().max(1) as f64
    });
    let dark_image = image_mean.is_some_and(|m| m <= DARK_IMAGE * lit_mean);
    if total == 0 {
        out.push(
            "no light reaches any node: the lights, emitters and sky light nothing the solve can see (every \
             image and probe holds at most the emitters' own radiance)"
                .into(),
        );
    } else if dark_image {
        out.push(match image_mean {
            Some(m) if m > 0.0 => format!(
                "almost no light reaches what the camera sees: the image's mean is {:.1e} of the lit nodes' mean \
                 direct irradiance (below {DARK_IMAGE:.0e})",
                m / lit_mean
            ),
            _ => "no light reaches what the camera sees: every pixel is black".into(),
        });
    }
    if total == 0 || dark_image {
        if let Some(e) = (scene.objects.len() > 1).then(|| enclosing(scene, &lit)).flatten() {
            let o = &scene.objects[e];
            out.push(format!(
                "object {e} (`{}`) encloses the others, and the light reaches only its outside: a box or skybox \
                 around the scene keeps the lights and the sky out; leave it out (its [[object]], or `group = \"!name\"` \
                 for a glTF node or OBJ group inside it) or give it no faces toward the light",
                o.name
            ));
        } else if let Some((e, part)) = enclosing_part(scene, &lit) {
            out.push(format!(
                "`{part}`, a glTF node or OBJ group of object {e} (`{}`), encloses the rest of the scene, and the light \
                 reaches only its outside: a box or skybox around the scene keeps the lights and the sky out; leave it \
                 out (`group = \"!{part}\"` in that [[object]]) or give it no faces toward the light",
                scene.objects[e].name
            ));
        }
    }
    out
}

/// How far (a fraction of the enclosing box's extent per axis) another box may reach out
/// of the one that encloses it: VC's ground plane overhangs its skybox by 1.7 %.
const ENCLOSE_MARGIN: f32 = 0.05;

/// Whether the box `lo..hi` holds `a..b`, up to [`ENCLOSE_MARGIN`].
fn holds(lo: Vec3, hi: Vec3, a: Vec3, b: Vec3) -> bool {
    let m = (hi - lo) * ENCLOSE_MARGIN;
    a.cmpge(lo - m).all() && b.cmple(hi + m).all()
}

/// A named part (OBJ group, glTF node) of an object, the only object with lit nodes if
/// any is lit, whose world box holds every other part's and every other object's (up to
/// [`ENCLOSE_MARGIN`]): the object and the part's name.
fn enclosing_part(scene: &Scene, lit: &[usize]) -> Option<(usize, String)> {
    let lit_objects: Vec<usize> = (0..lit.len()).filter(|&o| lit[o] > 0).collect();
    if lit_objects.len() > 1 {
        return None;
    }
    // Every part's world box, with its object; objects without parts count whole.
    let mut boxes: Vec<(usize, Option<&str>, Vec3, Vec3)> = Vec::new();
    for (o, obj) in scene.objects.iter().enumerate() {
        if obj.parts.is_empty() {
            let (lo, hi) = object_box(obj, &scene.tris);
            boxes.push((o, None, lo, hi));
        }
        for p in &obj.parts {
            let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
            for k in 0..8 {
                let c = Vec3::new(
                    if k & 1 == 0 { p.lo.x } else { p.hi.x },
                    if k & 2 == 0 { p.lo.y } else { p.hi.y },
                    if k & 4 == 0 { p.lo.z } else { p.hi.z },
                );
                let w = crate::geom::transform::xform_point(&obj.to_world, c);
                lo = lo.min(w);
                hi = hi.max(w);
            }
            boxes.push((o, Some(&p.name), lo, hi));
        }
    }
    if boxes.len() < 2 {
        return None;
    }
    boxes.iter().enumerate().find_map(|(i, &(o, name, lo, hi))| {
        let name = name?;
        if lit_objects.first().is_some_and(|&l| l != o) {
            return None;
        }
        let holds = boxes
            .iter()
            .enumerate()
            .all(|(j, &(_, _, a, b))| j == i || holds(lo, hi, a, b));
        holds.then(|| (o, name.to_string()))
    })
}

/// The one object whose nodes alone are lit and whose box holds every other object's.
fn enclosing(scene: &Scene, lit: &[usize]) -> Option<usize> {
    let mut lit_objects = lit.iter().enumerate().filter(|(_, &n)| n > 0).map(|(o, _)| o);
    let e = lit_objects.next()?;
    if lit_objects.next().is_some() {
        return None;
    }
    let (lo, hi) = object_box(&scene.objects[e], &scene.tris);
    (0..scene.objects.len())
        .filter(|&o| o != e)
        .all(|o| {
            let (a, b) = object_box(&scene.objects[o], &scene.tris);
            holds(lo, hi, a, b)
        })
        .then_some(e)
}
