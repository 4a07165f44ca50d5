//! CPU reference benchmarks on the Cornell box: hierarchy construction and one bounce per
//! variant (after the direct pass and the first bounce's set-up). Run with
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

criterion_group!(benches, hierarchy, bounce);
criterion_main!(benches);
