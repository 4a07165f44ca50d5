//! GPU backend benchmarks on the Cornell box: one bounce per variant (after the direct
//! pass), on the device the loader picks (`MESHRAD_BENCH_DEVICE` to choose). Run with
//! `cargo bench --bench gpu`. Per-kernel GPU times are in `meshrad solve --stats`.

use std::sync::Arc;

use criterion::{criterion_group, criterion_main, Criterion};
use meshrad::device::GpuBackend;
use meshrad::gpu::{Context, ContextOptions};
use meshrad::progress::Progress;
use meshrad::transport::{self, Backend};
use meshrad::{Hierarchy, Scene, Variant};

fn bounce(c: &mut Criterion) {
    let ctx = Arc::new(
        Context::new(&ContextOptions {
            validation: false,
            device: std::env::var("MESHRAD_BENCH_DEVICE").ok(),
        })
        .expect("a Vulkan device"),
    );
    let mut g = c.benchmark_group(format!("bounce_gpu ({})", ctx.info.name));
    g.sample_size(10);
    for v in Variant::ALL {
        let (scene, mut params) = Scene::embedded_cornell(&[]).expect("embedded scene");
        params.variant = v;
        let h = Hierarchy::build(&scene, &params, &Progress::hidden()).expect("build");
        let mut backend = GpuBackend::new(ctx.clone(), &scene, &h, &params).expect("upload");
        backend.direct().expect("direct");
        g.bench_function(format!("cornell/{}", v.name()), |b| {
            b.iter(|| {
                backend.init_unshot().expect("init");
                transport::bounce(&mut backend, &params, 1).expect("bounce")
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bounce);
criterion_main!(benches);
