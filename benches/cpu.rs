//! CPU reference benchmarks on the Cornell box: hierarchy construction, one bounce per
//! variant (after the direct pass and the first bounce's set-up), and the traversal of
//! 100 000 rays from surface points through the BVH2 and the CWBVH (also on Cornell +
//! Buddha where `$MESHRAD_SCENES`, default `../shared/scenes`, holds it). Run with
//! `cargo bench --bench cpu`.

use criterion::{criterion_group, criterion_main, Criterion};
use meshrad::progress::Progress;
use meshrad::transport::{self, cpu::CpuBackend, Backend};
use meshrad::{Hierarchy, Scene, Variant};

fn hierarchy(c: &mut Criterion) {
    let (scene, params) = Scene::embedded_cornell(&[]).expect("embedded scene");
    let mut g = c.benchmark_group("hierarchy");
    g.sample_size(10);
    g.bench_function("cornell", |b| {
        b.iter(|| Hierarchy::build(&scene, &params, &Progress::hidden()).expect("build"))
    });
    g.finish();
}

fn bounce(c: &mut Criterion) {
    let mut g = c.benchmark_group("bounce_cpu");
    g.sample_size(10);
    for v in Variant::ALL {
        let (scene, mut params) = Scene::embedded_cornell(&[]).expect("embedded scene");
        params.variant = v;
        let h = Hierarchy::build(&scene, &params, &Progress::hidden()).expect("build");
        let mut backend = CpuBackend::new(&scene, &h, &params, &Progress::hidden());
        backend.direct().expect("direct");
        backend.init_unshot().expect("init");
        g.bench_function(format!("cornell/{}", v.name()), |b| {
            b.iter(|| {
                // Re-seed the un-shot energy so every iteration is the first bounce.
                backend.init_unshot().expect("init");
                transport::bounce(&mut backend, &params, 1).expect("bounce")
            })
        });
    }
    g.finish();
}

/// 100 000 cosine-distributed rays from uniform points of the first object's triangles
/// (offset origins, as the solver casts them).
fn surface_rays(scene: &Scene) -> Vec<meshrad::geom::Ray> {
    use glam::Vec2;
    use meshrad::geom::ray::{tri_normal, tri_point};
    use meshrad::geom::sampling::{cosine_direction, onb, uniform_triangle};
    let o = &scene.objects[0];
    let tris = &scene.tris[o.tri_offset as usize..][..o.tri_count as usize];
    let mut rng = meshrad::geom::rng::Rng::new(1, 0);
    (0..100_000)
        .map(|_| {
            let tri = &tris[(rng.next_f32() * tris.len() as f32) as usize % tris.len()];
            let (b1, b2) = uniform_triangle(Vec2::new(rng.next_f32(), rng.next_f32()));
            let n = tri_normal(tri);
            let (t, b) = onb(n);
            let d = cosine_direction(n, t, b, Vec2::new(rng.next_f32(), rng.next_f32()), 0.0);
            meshrad::geom::Ray {
                o: scene.offset(tri_point(tri, b1, b2), n),
                d,
            }
        })
        .collect()
}

fn trace(c: &mut Criterion) {
    use meshrad::geom::bvh;
    let mut scenes = vec![("cornell", Scene::embedded_cornell(&[]).expect("embedded scene").0)];
    let dir = std::env::var("MESHRAD_SCENES").unwrap_or_else(|_| "../shared/scenes".into());
    let buddha = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/shared/cornell_buddha.toml");
    if std::path::Path::new(&dir).join("cornell_buddha").exists() {
        scenes.push(("cornell_buddha", Scene::load(&buddha, &[]).expect("Cornell + Buddha").0));
    } else {
        eprintln!("trace: no {dir}/cornell_buddha, Cornell + Buddha left out");
    }
    let mut g = c.benchmark_group("trace");
    g.sample_size(10);
    for (name, scene) in &scenes {
        let rays = surface_rays(scene);
        let (root2, rootw) = (scene.objects[0].bvh_root, scene.cw.roots[0]);
        g.bench_function(format!("{name}/bvh2"), |b| {
            b.iter(|| {
                rays.iter()
                    .filter(|r| bvh::trace(&scene.bvh, &scene.tris, root2, r, f32::INFINITY, false).is_some())
                    .count()
            })
        });
        g.bench_function(format!("{name}/cwbvh"), |b| {
            b.iter(|| {
                rays.iter()
                    .filter(|r| {
                        bvh::trace_cw(&scene.cw, &scene.tris, rootw, r, f32::INFINITY, false, |_, _, _| true).is_some()
                    })
                    .count()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, hierarchy, bounce, trace);
criterion_main!(benches);
