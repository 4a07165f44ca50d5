//! The GPU backend against the CPU reference, kernel by kernel and whole solves, on the
//! device the loader finds (Mesa lavapipe in CI). A missing device is a failure, not a
//! skip. The validation layer is on in every test and must report zero errors.

mod common;

use std::sync::Arc;

use glam::{Vec3, Vec4, Vec4Swizzles};
use meshrad::device::backend::State;
use meshrad::device::GpuBackend;
use meshrad::geom::sampling::{cosine_direction, halton_table, integral_rotation, onb};
use meshrad::geom::Ray;
use meshrad::gpu::Context;
use meshrad::hierarchy::Hierarchy;
use meshrad::progress::Progress;
use meshrad::transport::cpu::{gather_integral, node_world, CpuBackend};
use meshrad::transport::{reconstruct::Sender, Backend};
use meshrad::{Scene, SolverParams, Variant};

fn context() -> Arc<Context> {
    common::gpu_context()
}

fn cornell(levels: u32, rays: u32, variant: Variant) -> (Scene, SolverParams) {
    let (s, mut p) = Scene::embedded_cornell(&[]).unwrap();
    p.levels = levels;
    p.sender_level = levels - 1;
    p.rays = rays;
    p.variant = variant;
    (s, p)
}

/// `|a − b| ≤ rel · max(|b|, floor)` per channel.
fn close(a: Vec3, b: Vec3, rel: f32, floor: f32) -> bool {
    ((a - b).abs() - b.abs().max(Vec3::splat(floor)) * rel).max_element() <= 0.0
}

#[test]
fn devices_are_listed() {
    let list = meshrad::gpu::list_devices().unwrap();
    assert!(!list.is_empty(), "no Vulkan device");
    assert!(list.iter().any(|d| d.unusable.is_none()), "{list:?}");
}

#[test]
fn kernel_direct_matches_cpu() {
    let (s, p) = cornell(4, 16, Variant::Modified);
    let h = Hierarchy::build(&s, &p, &Progress::hidden()).unwrap();
    let ctx = context();
    let mut g = GpuBackend::new(ctx.clone(), &s, &h, &p).unwrap();
    let mut c = CpuBackend::new(&s, &h, &p, &Progress::hidden());
    assert_eq!(g.direct().unwrap(), c.direct().unwrap(), "nodes lit per light");
    let gd = g.read_state(State::Direct).unwrap();
    let cd = c.state().0;
    // acos in the spot falloff differs by a few ulps between libm and the driver.
    for j in 0..h.nodes.len() {
        assert!(
            close(gd[j].xyz(), cd[j].xyz(), 2e-3, 1e-3),
            "node {j}: {} vs {}",
            gd[j],
            cd[j]
        );
    }
    assert_eq!(ctx.validation_errors(), 0);
}

/// hemisphere, trace, reconstruct and reduce on one whole level, ray by ray.
/// Long by design: the four kernels checked in the order they run, on one set-up.
#[test]
fn kernels_of_a_gather_match_cpu() {
    // The first bounce reads either the sender level (the paper's transport, every
    // variant) or the exact direct light at the hits (`exact_first_bounce`).
    // The area-lit box's exact first bounce samples its luminaire at each hit, with the
    // CPU's sample (the ray's seed).
    let cases = Variant::ALL.map(|v| (v, false, false)).into_iter().chain([
        (Variant::Approx, true, false),
        (Variant::Approx, true, true),
        (Variant::Original, true, true),
    ]);
    for (variant, exact, area) in cases {
        let rays = 32;
        let (s, mut p) = if area {
            let (s, mut p) = Scene::embedded_file("cornell_area.toml", &[]).unwrap();
            p.levels = 4;
            p.sender_level = 3;
            p.rays = rays;
            (s, p)
        } else {
            cornell(4, rays, variant)
        };
        p.exact_first_bounce = exact;
        let h = Hierarchy::build(&s, &p, &Progress::hidden()).unwrap();
        let ctx = context();
        let mut g = GpuBackend::new(ctx.clone(), &s, &h, &p).unwrap();
        let mut c = CpuBackend::new(&s, &h, &p, &Progress::hidden());
        for b in [&mut g as &mut dyn Backend, &mut c] {
            b.direct().unwrap();
            b.init_unshot().unwrap();
        }
        let unshot_gpu = g.read_state(State::Unshot).unwrap();
        let l0 = h.level_range(0);
        let direct_scale = c.state().0[l0.clone()].iter().map(|v| v.x).sum::<f32>() / l0.len() as f32;
        let unshot_cpu = c.state().1.to_vec();
        // The luminaire's samples: a shadow ray grazing an edge may go either way on the
        // two sides (one sample of 64 is 1.6 % of a node's value), at a few nodes only.
        let mut differ = 0;
        for j in 0..h.nodes.len() {
            let ok = close(unshot_gpu[j].xyz(), unshot_cpu[j].xyz(), 5e-3, 1e-2);
            assert!(
                ok || (area && close(unshot_gpu[j].xyz(), unshot_cpu[j].xyz(), 0.05, 1e-2)),
                "{variant:?} unshot (kernel delta / copy) at {j}: {} vs {}",
                unshot_gpu[j],
                unshot_cpu[j]
            );
            differ += !ok as usize;
        }
        assert!(differ as f64 <= 1e-3 * h.nodes.len() as f64, "{differ} nodes differ");
        let level = 0;
        let n = h.level_range(level).len();
        assert_eq!(g.gather(level as u32, exact).unwrap() as usize, n);
        let (gr, gh, gs) = g.read_batch(n * rays as usize).unwrap();
        let halton = halton_table(rays);
        let sender = Sender::of(&p);
        let (mut same_hit, mut total, mut shadow_differs) = (0, 0, 0);
        for (i, j) in h.level_range(level).enumerate() {
            let (x, nrm) = node_world(&s, &h, j);
            let o = s.offset(x, nrm);
            let (t, b) = onb(nrm);
            let phi = integral_rotation(p.seed, j as u32);
            for (r, &u) in halton.iter().enumerate() {
                let k = i * rays as usize + r;
                let d = cosine_direction(nrm, t, b, u, phi);
                assert!((gr[k][0].xyz() - o).length() <= 1e-4 * o.length(), "hemisphere origin");
                assert!(
                    (gr[k][1].xyz() - d).length() < 1e-5,
                    "hemisphere direction {} vs {d}",
                    gr[k][1]
                );
                let hit = s.intersect(&Ray { o, d }, f32::INFINITY);
                total += 1;
                let gpu_tri = (gh[k][0] != u32::MAX).then_some(gh[k][1]);
                if hit.map(|x| x.tri) == gpu_tri {
                    same_hit += 1;
                    if let Some(hh) = hit {
                        let sf = s.surface(&hh, d);
                        if exact {
                            // A shadow ray grazing an edge may go either way on the two sides.
                            let seed = meshrad::scene::emitter::hit_seed(j as u32, r as u32);
                            let want = sf.albedo * s.direct_one_seeded(sf.p, sf.n, seed);
                            shadow_differs += !close(gs[k].xyz(), want, 1e-2, 1e-4 * direct_scale) as usize;
                            continue;
                        }
                        let want = sf.albedo * sender.read_hit(&h, &sf, &unshot_cpu);
                        assert!(
                            // The delta hierarchy's sum cancels: its error scales with the
                            // direct light, not with the (possibly tiny) sum.
                            close(gs[k].xyz(), want, 1e-2, 1e-4 * direct_scale),
                            "{variant:?} reconstruct at ray {k}: {} vs {want}",
                            gs[k]
                        );
                    } else {
                        assert_eq!(gs[k].xyz(), Vec3::ZERO);
                    }
                }
            }
        }
        assert!(
            same_hit as f64 >= 0.999 * total as f64,
            "trace: {same_hit} of {total} rays agree"
        );
        assert!(
            shadow_differs as f64 <= 1e-3 * total as f64,
            "reconstruct with the exact direct light: {shadow_differs} of {total} rays differ"
        );
        // reduce: mean and standard error per integral.
        let gm = g.read_state(State::GatheredMean).unwrap();
        let ge = g.read_state(State::GatheredErr).unwrap();
        for j in h.level_range(level) {
            let want = gather_integral(&s, &h, &p, &halton, &unshot_cpu, j, exact);
            let scale = want.mean.max_element().max(1e-4);
            assert!(
                close(gm[j].xyz(), want.mean, 1e-2, scale),
                "{variant:?} mean at {j}: {} vs {:?}",
                gm[j],
                want
            );
            assert!(
                close(ge[j].xyz(), want.std_err, 2e-2, scale),
                "{variant:?} error at {j}: {} vs {:?}",
                ge[j],
                want
            );
        }
        assert_eq!(ctx.validation_errors(), 0);
    }
}

/// pulldown / delta (prediction), oracle, compact, accumulate and energy, stage by stage.
#[test]
fn kernels_of_the_refinement_match_cpu() {
    for variant in Variant::ALL {
        let (s, mut p) = cornell(4, 32, variant);
        // With the sparse children of lit nodes activated too (kernel oracle).
        p.sparse_parents = 3;
        let h = Hierarchy::build(&s, &p, &Progress::hidden()).unwrap();
        let ctx = context();
        let mut g = GpuBackend::new(ctx.clone(), &s, &h, &p).unwrap();
        let mut c = CpuBackend::new(&s, &h, &p, &Progress::hidden());
        for b in [&mut g as &mut dyn Backend, &mut c] {
            b.direct().unwrap();
            b.init_unshot().unwrap();
        }
        let mut activated = 0;
        for level in 0..3u32 {
            let (ng, nc) = (
                g.gather(level, p.exact_first_bounce).unwrap(),
                c.gather(level, p.exact_first_bounce).unwrap(),
            );
            assert_eq!(ng, nc, "{variant:?}: active set of level {level} (kernel compact)");
            let activate = level == 1; // level 2 is the last gathered level here
            let k = p.sparse_parents;
            let (rg, rc) = (
                g.refine(level, activate, k).unwrap(),
                c.refine(level, activate, k).unwrap(),
            );
            assert_eq!(
                rg, rc,
                "{variant:?}: refined and activated nodes of level {level} (oracle, compact)"
            );
            if activate {
                activated = rc.activated;
            }
            let next = g.read_state(State::Next).unwrap();
            for j in h.level_range(level as usize) {
                let want = c.state().2[j].xyz();
                assert!(
                    close(next[j].xyz(), want, 2e-3, 1e-3 * (1.0 + want.abs().max_element())),
                    "{variant:?} next at {j} (level {level}): {} vs {want}",
                    next[j]
                );
            }
        }
        for b in [&mut g as &mut dyn Backend, &mut c] {
            b.fill(3).unwrap();
        }
        let (eg, ec) = (g.end_bounce().unwrap(), c.end_bounce().unwrap());
        assert!(
            (eg.unshot - ec.unshot).abs() <= 1e-3 * ec.unshot,
            "energy {eg:?} vs {ec:?}"
        );
        assert!(
            (eg.direct - ec.direct).abs() <= 1e-3 * ec.direct,
            "energy {eg:?} vs {ec:?}"
        );
        let ind = g.read_state(State::Indirect).unwrap();
        let mut err2 = 0.0f64;
        let mut ref2 = 0.0f64;
        for (j, want) in c.state().3.iter().enumerate() {
            err2 += ((ind[j] - *want).xyz().length() as f64).powi(2);
            ref2 += (want.xyz().length() as f64).powi(2);
        }
        assert!(
            (err2 / ref2).sqrt() < 1e-3,
            "{variant:?} indirect after accumulate: rel rms {}",
            (err2 / ref2).sqrt()
        );
        assert_eq!(ctx.validation_errors(), 0);
        // The activations compared include sparse children of lit nodes (sparse_parents):
        // without them level 2 gets fewer integrals.
        if !variant.is_delta() {
            // Level 2's activations on the CPU, for a backend made with bound `own` and
            // refined with bound `k`.
            let activations = |own: u32, k: u32| {
                let mut q = p.clone();
                q.sparse_parents = own;
                let mut c = CpuBackend::new(&s, &h, &q, &Progress::hidden());
                c.direct().unwrap();
                c.init_unshot().unwrap();
                c.gather(0, q.exact_first_bounce).unwrap();
                c.refine(0, false, k).unwrap();
                c.gather(1, q.exact_first_bounce).unwrap();
                c.refine(1, true, k).unwrap().activated
            };
            let none = activations(0, 0);
            assert!(
                none < activated,
                "{variant:?}: sparse_parents activated nothing ({none} against {activated}): the test does not exercise it"
            );
            // A backend whose own bound differs from the one `refine` is given counts the
            // parents itself (its listed sparse children are for its own bound).
            assert_eq!(
                activations(1, p.sparse_parents),
                activated,
                "{variant:?}: activations with another backend bound"
            );
        }
    }
}

/// Whole solves agree with the CPU on the same seed: the same integrals, and per-node
/// indirect irradiance within 1e-3 relative RMS (float rounding, acos in the spot, rare
/// rays grazing an edge); no node off by more than 5 % of max(value, 1 % of the mean).
#[test]
fn whole_solves_match_cpu() {
    for variant in Variant::ALL {
        let (s, mut p) = cornell(5, 64, variant);
        p.bounces = 3;
        let ctx = context();
        let g = meshrad::solve(&s, &p, &mut meshrad::Engine::gpu(ctx.clone()), &Progress::hidden()).unwrap();
        let c = meshrad::solve(&s, &p, &mut meshrad::Engine::cpu(), &Progress::hidden()).unwrap();
        assert_eq!(g.solution.stats.integrals, c.solution.stats.integrals, "{variant:?}");
        for (bg, bc) in g.solution.stats.bounces.iter().zip(&c.solution.stats.bounces) {
            assert_eq!(bg.integrals_per_level, bc.integrals_per_level, "{variant:?}");
        }
        let (gi, ci) = (&g.solution.values.indirect, &c.solution.values.indirect);
        let mean = ci.iter().map(|v| v.xyz().max_element() as f64).sum::<f64>() / ci.len() as f64;
        let (mut e2, mut r2) = (0.0f64, 0.0f64);
        for j in 0..gi.len() {
            let d = (gi[j] - ci[j]).xyz();
            e2 += (d.length() as f64).powi(2);
            r2 += (ci[j].xyz().length() as f64).powi(2);
            let floor = ci[j].xyz().abs().max_element().max(0.01 * mean as f32);
            assert!(
                d.abs().max_element() <= 0.05 * floor,
                "{variant:?} node {j}: {} vs {}",
                gi[j],
                ci[j]
            );
        }
        let rms = (e2 / r2).sqrt();
        eprintln!("{variant:?}: relative RMS GPU vs CPU {rms:.2e}");
        assert!(rms < 1e-3, "{variant:?}: relative RMS {rms}");
        assert_eq!(ctx.validation_errors(), 0);
        let report = g.gpu.unwrap();
        assert!(
            report.kernels_never_dispatched.is_empty(),
            "{:?}",
            report.kernels_never_dispatched
        );
        assert!(report
            .skipped
            .iter()
            .any(|s| s.contains("texture sampling compiled out")));
    }
}

#[test]
fn gpu_solves_are_deterministic() {
    let (s, p) = cornell(4, 32, Variant::Approx);
    let ctx = context();
    let a = meshrad::solve(&s, &p, &mut meshrad::Engine::gpu(ctx.clone()), &Progress::hidden()).unwrap();
    let b = meshrad::solve(&s, &p, &mut meshrad::Engine::gpu(ctx), &Progress::hidden()).unwrap();
    assert!(a.solution.values.indirect == b.solution.values.indirect);
    let _ = Vec4::ZERO;
}

/// A scene whose triangle buffer alone exceeds lavapipe's 128 MiB per storage-buffer
/// binding (5.2M triangles, 251 MB) solves, and gives the furnace's answer: buffers are
/// reached by device address, not through bindings.
#[test]
fn geometry_over_128_mib_solves() {
    let dir = common::tmpdir();
    let solver = "levels = 2\ncoarsest = 40\nrays = 32\nbounces = 1\nsender_level = 1\ngather_levels = 2\n\
                  variant = \"modified\"\nreach_paths = 4096\n";
    let path = meshrad::analytic::furnace(dir.path(), 1.0, 5, 0.5, [0.0; 3], 1.0, solver).unwrap();
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("mesh = \"sphere.obj\"", "mesh = \"sphere.obj\"\ntessellate = 4");
    std::fs::write(&path, text).unwrap();
    let (s, p) = common::load(&path, &[]);
    let bytes = s.tris.len() * std::mem::size_of::<meshrad::layout::Tri>();
    assert!(bytes > 128 << 20, "only {bytes} bytes of triangles");
    let ctx = context();
    let r = meshrad::solve(&s, &p, &mut meshrad::Engine::gpu(ctx.clone()), &Progress::hidden()).unwrap();
    let (_, eind, _) = meshrad::analytic::furnace_expected(1.0, 0.5, 1.0, 1);
    let h = &r.hierarchy;
    let l = h.level_range(1);
    let mean = l.clone().map(|j| r.solution.values.indirect[j].x as f64).sum::<f64>() / l.len() as f64;
    assert!(common::rel(mean, eind) < 0.01, "mean E_ind {mean} vs {eind}");
    assert_eq!(ctx.validation_errors(), 0);
}

/// The compressed wide BVH finds the same closest hits as the BVH2: whole GPU solves agree
/// to float rounding (ties on shared edges aside), on the Cornell box and on a mesh with
/// many small triangles.
#[test]
fn cwbvh_matches_bvh2() {
    let ctx = context();
    let dir = common::tmpdir();
    let furnace = meshrad::analytic::furnace(
        dir.path(),
        1.0,
        4,
        0.5,
        [0.3, 0.1, -0.2],
        1.0,
        "levels = 3\ncoarsest = 40\nrays = 32\nbounces = 2\nsender_level = 2\n",
    )
    .unwrap();
    let small = [("levels", "4"), ("sender_level", "3"), ("rays", "32")];
    let load = |which: usize, bvh: &str| -> (Scene, SolverParams) {
        let b = format!("\"{bvh}\"");
        if which == 0 {
            let mut o: Vec<(String, toml::Value)> = small
                .iter()
                .map(|(k, v)| (k.to_string(), toml::Value::Integer(v.parse().unwrap())))
                .collect();
            o.push(("bvh".into(), toml::Value::String(bvh.into())));
            Scene::embedded_cornell(&o).unwrap()
        } else {
            common::load(&furnace, &[("bvh", &b)])
        }
    };
    for which in 0..2 {
        let ((a, pa), (b, pb)) = (load(which, "bvh2"), load(which, "cwbvh"));
        let ra = meshrad::solve(&a, &pa, &mut meshrad::Engine::gpu(ctx.clone()), &Progress::hidden()).unwrap();
        let rb = meshrad::solve(&b, &pb, &mut meshrad::Engine::gpu(ctx.clone()), &Progress::hidden()).unwrap();
        let nodes = |r: &meshrad::Run| r.gpu.as_ref().unwrap().cwbvh_nodes;
        assert!(
            nodes(&ra) == 0 && nodes(&rb) > 0,
            "the CWBVH is built when asked, only then"
        );
        assert_eq!(ra.solution.stats.integrals, rb.solution.stats.integrals);
        let (x, y) = (&ra.solution.values.indirect, &rb.solution.values.indirect);
        let (mut e2, mut r2) = (0.0f64, 0.0f64);
        for j in 0..x.len() {
            e2 += ((x[j] - y[j]).xyz().length() as f64).powi(2);
            r2 += (x[j].xyz().length() as f64).powi(2);
        }
        assert!(
            (e2 / r2).sqrt() < 1e-5,
            "CWBVH vs BVH2: relative RMS {}",
            (e2 / r2).sqrt()
        );
    }
    assert_eq!(ctx.validation_errors(), 0);
}

/// Kernel `scan` (the relations' CSR offsets on the device) against a prefix sum on the
/// host: sizes around its block (256 words) and past one workgroup's walk of the block
/// totals (256 blocks), including a million words.
#[test]
fn scan_matches_a_prefix_sum() {
    use meshrad::device::kernels::scan::Scan;
    use meshrad::device::kernels::Recorder;
    use meshrad::gpu::buffer::Buffer;
    use meshrad::gpu::pipeline::Specialization;
    use meshrad::gpu::profiler::Profiler;

    let ctx = context();
    let spec = Specialization {
        variant: meshrad::constants::VARIANT_APPROX,
        textured: false,
        bvh: meshrad::constants::BVH_BVH2,
    };
    let scan = Scan::new(&ctx, spec).unwrap();
    let mut prof = Profiler::new(&ctx).unwrap();
    for n in [1usize, 255, 256, 257, 65_537, 1_000_003] {
        let data: Vec<u32> = (0..n as u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 28) % 9)
            .collect();
        let buf = Buffer::upload(&ctx, "data", &data[..]).unwrap();
        let sums = Buffer::zeroed(&ctx, "sums", 4 * Scan::blocks(n as u64)).unwrap();
        ctx.run(|cmd| {
            prof.begin_frame(cmd);
            let mut rec = Recorder {
                ctx: &ctx,
                prof: &mut prof,
                cmd,
                globals: 0,
            };
            scan.record(&mut rec, buf.address, sums.address, n as u32);
            Ok(())
        })
        .unwrap();
        prof.end_frame().unwrap();
        let got: Vec<u32> = buf.download(0, n).unwrap();
        let mut acc = 0u32;
        for (i, (&g, &d)) in got.iter().zip(&data).enumerate() {
            assert_eq!(g, acc, "n = {n}: offset {i}");
            acc += d;
        }
    }
    assert_eq!(ctx.validation_errors(), 0);
}

/// Links on the device (`ALGORITHM.md` §5.6): a node's first traced gather keeps each
/// ray's sender node and albedo, and its later gathers read them instead of tracing. The
/// solution must be the traced one bit for bit, with room for every node, with room for a
/// few (the rest traced every bounce) and with none; the counts show the links used and
/// the full case out of room; a warm solve on the same backend records its own. With and
/// without the exact first bounce (without it, the first bounce reads no link although
/// its gathers record them: the schedule must not take levels 0 and 1 for linked there).
#[test]
fn gpu_links_give_the_traced_answer() {
    for exact in [true, false] {
        links_give_the_traced_answer_with(exact);
    }
}

fn links_give_the_traced_answer_with(exact_first_bounce: bool) {
    let ctx = context();
    let run = |link_memory: u32, warmups: u32| {
        let (s, mut p) = cornell(4, 64, Variant::Approx);
        p.link_memory = link_memory;
        p.exact_first_bounce = exact_first_bounce;
        p.stop_threshold = 1e-3;
        let h = Hierarchy::build(&s, &p, &Progress::hidden()).unwrap();
        let mut g = GpuBackend::new(ctx.clone(), &s, &h, &p).unwrap();
        for _ in 0..warmups {
            meshrad::transport::solve(&p, &mut g, &Progress::hidden()).unwrap();
        }
        let sol = meshrad::transport::solve(&p, &mut g, &Progress::hidden()).unwrap();
        (sol.values, sol.stats)
    };
    let (traced, st) = run(0, 0);
    assert!(st.links.is_none(), "link_memory = 0 keeps no links");
    assert!(
        st.bounces.len() >= 4,
        "the test needs several bounces: {}",
        st.bounces.len()
    );
    // 64 rays × 16 bytes = 1 KiB a node: 1 MiB holds 1024 nodes, fewer than the nodes
    // levels 0–2 gather.
    for (mib, full, warmups) in [(2048, false, 0), (1, true, 0), (2048, false, 1)] {
        let (linked, st) = run(mib, warmups);
        let l = st.links.expect("links kept");
        let same = |a: &[Vec4], b: &[Vec4]| bytemuck::cast_slice::<Vec4, u8>(a) == bytemuck::cast_slice::<Vec4, u8>(b);
        assert!(
            same(&linked.direct, &traced.direct) && same(&linked.indirect, &traced.indirect),
            "link_memory {mib} (warm-ups {warmups}, exact first bounce {exact_first_bounce}): the solution differs \
             from the traced one"
        );
        common::check_link_counts(&l, mib, full, 64, (16, 16));
        assert_eq!(
            st.rays_traced,
            st.rays_gathered - l.rays_linked,
            "rays traced: the linked integrals cast none"
        );
    }
    assert_eq!(ctx.validation_errors(), 0);
}

/// A textured glTF (a checker floor with uv beyond [0, 1], u clamped and v mirrored)
/// solves on the GPU as on the CPU: the kernels' albedo lookup (`sample_texture`) is the
/// twin of `texture::sample`, wrap modes included.
#[test]
fn textured_gltf_solves_match_cpu() {
    let dir = common::tmpdir();
    let path = common::gltf::textured_corner(
        dir.path(),
        "levels = 4\ncoarsest = 40\nrays = 64\nbounces = 2\nsender_level = 3\n",
    );
    let (s, p) = common::load(&path, &[]);
    assert!(s.textured());
    let ctx = context();
    let g = meshrad::solve(&s, &p, &mut meshrad::Engine::gpu(ctx.clone()), &Progress::hidden()).unwrap();
    let c = meshrad::solve(&s, &p, &mut meshrad::Engine::cpu(), &Progress::hidden()).unwrap();
    assert_eq!(g.solution.stats.integrals, c.solution.stats.integrals);
    let (gi, ci) = (&g.solution.values.indirect, &c.solution.values.indirect);
    let (mut e2, mut r2) = (0.0f64, 0.0f64);
    for j in 0..gi.len() {
        e2 += ((gi[j] - ci[j]).xyz().length() as f64).powi(2);
        r2 += (ci[j].xyz().length() as f64).powi(2);
    }
    let rms = (e2 / r2).sqrt();
    eprintln!("textured glTF: relative RMS GPU vs CPU {rms:.2e}");
    assert!(r2 > 0.0 && rms < 1e-3, "relative RMS {rms}");
    // The floor's colour reaches the wall: red and blue differ from the grey they would be.
    let colour = ci.iter().map(|v| (v.x - v.z).abs() as f64).sum::<f64>();
    assert!(colour > 0.0);
    assert_eq!(ctx.validation_errors(), 0);
    assert!(!g
        .gpu
        .unwrap()
        .skipped
        .iter()
        .any(|s| s.contains("texture sampling compiled out")));
}

/// Relative RMS of `a` against `b` over the nodes (xyz), and the largest node difference
/// relative to max(|b|, 1 % of the mean).
fn compare(a: &[Vec4], b: &[Vec4]) -> (f64, f64) {
    let mean = b.iter().map(|v| v.xyz().max_element() as f64).sum::<f64>() / b.len().max(1) as f64;
    let (mut e2, mut r2, mut worst) = (0.0f64, 0.0f64, 0.0f64);
    for (x, y) in a.iter().zip(b) {
        let d = (*x - *y).xyz();
        e2 += (d.length() as f64).powi(2);
        r2 += (y.xyz().length() as f64).powi(2);
        let floor = (y.xyz().abs().max_element() as f64).max(0.01 * mean);
        worst = worst.max(d.abs().max_element() as f64 / floor);
    }
    ((e2 / r2.max(1e-300)).sqrt(), worst)
}

/// Small solver settings for the generated scenes below.
const SMALL_SOLVER: &str = "levels = 4\ncoarsest = 60\nsender_level = 3\nrays = 64\nbounces = 2\n";

/// A plane under a constant sky, the same under an environment map (a bright strip), and
/// a lamp masked by an emission texture (`map_Ke`: the kernels read it per texel), written
/// into `dir`.
fn sky_and_emission_scenes(dir: &std::path::Path) -> Vec<(String, Scene, SolverParams)> {
    let sky = meshrad::analytic::sky_plane(dir, 4.0, true, 1.0, SMALL_SOLVER).unwrap();
    let text = std::fs::read_to_string(&sky).unwrap();
    let map = dir.join("map.toml");
    std::fs::write(
        &map,
        text.replace("radiance = [1, 1, 1]", "envmap = \"sky.exr\"\nrotate = 25.0"),
    )
    .unwrap();
    exr::prelude::write_rgb_file(dir.join("sky.exr"), 16, 8, |x, y| {
        let b = if (5..8).contains(&x) && y == 2 { 30.0f32 } else { 1.0 };
        (0.3 * b, 0.4 * b + 0.01 * x as f32, 0.2 * b + 0.02 * y as f32)
    })
    .unwrap();
    let masked = meshrad::analytic::masked_emitter(&dir.join("masked"), 4.0, 1.0, 1.0, 2.0, SMALL_SOLVER).unwrap();
    let out: Vec<(String, Scene, SolverParams)> = [
        ("constant sky", sky),
        ("environment map", map),
        ("emission texture", masked),
    ]
    .into_iter()
    .map(|(name, path)| {
        let (s, p) = common::load(&path, &[]);
        (name.to_string(), s, p)
    })
    .collect();
    assert!(out[2].1.textured());
    out
}

/// Emitting surfaces and the sky on the GPU: the area-lit Cornell box (every variant, the
/// exact first bounce's direct light at the hits included), a floor and wall under a
/// constant sky and under an environment map, and a lamp masked by an emission texture
/// solve as on the CPU, with the same samples
/// (seeds from node and ray indices) in single precision.
#[test]
fn emitters_and_sky_solve_as_on_the_cpu() {
    let ctx = context();
    let dir = common::tmpdir();
    let mut cases: Vec<(String, Scene, SolverParams)> = Vec::new();
    for variant in Variant::ALL {
        let (s, mut p) = Scene::embedded_file("cornell_area.toml", &[]).unwrap();
        p.levels = 4;
        p.sender_level = 3;
        p.rays = 32;
        p.bounces = 2;
        p.variant = variant;
        // The delta hierarchy's coefficients turn a refinement decision that flips into
        // large node differences: its exact first bounce is checked ray by ray in
        // `kernels_of_a_gather_match_cpu` instead.
        p.exact_first_bounce = variant != Variant::Original;
        cases.push((format!("area-lit box, {variant:?}"), s, p));
    }
    cases.extend(sky_and_emission_scenes(dir.path()));
    for (name, s, p) in &cases {
        let g = meshrad::solve(s, p, &mut meshrad::Engine::gpu(ctx.clone()), &Progress::hidden()).unwrap();
        let c = meshrad::solve(s, p, &mut meshrad::Engine::cpu(), &Progress::hidden()).unwrap();
        let (gd, cd) = (&g.solution.values.direct, &c.solution.values.direct);
        let (rms_d, worst_d) = compare(gd, cd);
        let (rms_i, worst_i) = compare(&g.solution.values.indirect, &c.solution.values.indirect);
        let (ge, ce) = (
            g.solution.stats.direct_error.clone().unwrap(),
            c.solution.stats.direct_error.clone().unwrap(),
        );
        eprintln!(
            "{name}: direct RMS {rms_d:.2e} (worst node {worst_d:.2e}), indirect RMS {rms_i:.2e} (worst {worst_i:.2e}); \
             direct error GPU {:.3e} CPU {:.3e}",
            ge.mean_rel_std_err, ce.mean_rel_std_err
        );
        assert_eq!(
            g.solution.stats.nodes_lit_per_light, c.solution.stats.nodes_lit_per_light,
            "{name}"
        );
        assert_eq!(
            (ge.samples, ge.shadow_rays, ge.lit_nodes),
            (ce.samples, ce.shadow_rays, ce.lit_nodes),
            "{name}"
        );
        assert!(
            (ge.mean_rel_std_err - ce.mean_rel_std_err).abs() < 1e-3 * ce.mean_rel_std_err,
            "{name}"
        );
        // The same samples: the direct light within float rounding, but for a shadow ray
        // that grazes an edge (one sample of 64 is 1.6 % of a node).
        assert!(rms_d < 1e-3 && worst_d < 0.05, "{name}: direct {rms_d} {worst_d}");
        // A handful of refinement decisions may flip on such a sample (the oracle is a
        // threshold): the integrals per level within 1 %, the indirect light within
        // 0.5 % RMS.
        for (bg, bc) in g.solution.stats.bounces.iter().zip(&c.solution.stats.bounces) {
            for (a, b) in bg.integrals_per_level.iter().zip(&bc.integrals_per_level) {
                assert!(
                    a.abs_diff(*b) as f64 <= 0.01 * *b as f64,
                    "{name}: integrals {a} vs {b}"
                );
            }
        }
        assert!(rms_i < 5e-3, "{name}: indirect {rms_i} (worst node {worst_i})");
    }
    assert_eq!(ctx.validation_errors(), 0);
}

/// Dart throwing on the device (kernel `poisson`) gives the host's nodes, bit for bit:
/// the embedded box (`reach = "lights"`: crevice rays through the whole scene, and the
/// blocks on the floor make crevices) and its parts as objects of their own, the tall
/// block turned, scaled and moved (`reach = "object"`: crevice rays within each object,
/// in object space). Both have crevices.
#[test]
fn device_dart_throwing_gives_the_host_nodes() {
    let ctx = context();
    let dir = common::tmpdir();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mesh = root.join("cornell_original_mm.obj");
    let parts = std::fs::read_to_string(root.join("cornell_parts.toml"))
        .unwrap()
        .replace(
            "\"cornell_original_mm.obj\"",
            &format!("{:?}", mesh.display().to_string()),
        )
        .replace(
            "group = \"cbox_largebox\"",
            "group = \"cbox_largebox\"\nrotate = [0.0, 20.0, 0.0]\nscale = 0.8\ntranslate = [40.0, 0.0, 30.0]",
        );
    let parts_path = dir.path().join("parts.toml");
    std::fs::write(&parts_path, parts).unwrap();
    let small = [("levels", "5"), ("sender_level", "4")];
    let scenes = [
        ("box", cornell(5, 64, Variant::Approx)),
        ("parts", common::load(&parts_path, &small)),
    ];
    let hidden = Progress::hidden();
    for (name, (scene, p)) in scenes {
        let host = Hierarchy::build_unarranged(&scene, &p, &hidden).unwrap();
        let mut pd = p.clone();
        pd.dart_throwing = Some(meshrad::params::DartThrowing::Device);
        let dev = meshrad::Engine::gpu(ctx.clone()).build(&scene, &pd, &hidden).unwrap();
        assert_eq!(host.stats.poisson_on, "host");
        assert_eq!(dev.stats.poisson_on, "device", "{name}");
        assert!(dev.stats.poisson_rounds > 0 && host.stats.poisson_rounds == 0);
        assert_eq!(dev.stats.nodes_per_level, host.stats.nodes_per_level, "{name}");
        let differ = host
            .nodes
            .iter()
            .zip(&dev.nodes)
            .filter(|(a, b)| bytemuck::bytes_of(*a) != bytemuck::bytes_of(*b))
            .count();
        assert_eq!(differ, 0, "{name}: nodes differ");
        assert!(
            dev.stats.crevice_candidates_dropped > 0,
            "{name}: the crevices are found on the device"
        );
        eprintln!(
            "{name}: {:?} nodes, crevice drops host {} device {}, {} rounds",
            dev.stats.nodes_per_level,
            host.stats.crevice_candidates_dropped,
            dev.stats.crevice_candidates_dropped,
            dev.stats.poisson_rounds
        );
    }
    assert_eq!(ctx.validation_errors(), 0);
}

/// Relative RMS of `a` against `b` over all pixels (`sqrt(Σ|a−b|² / Σ|b|²)`).
fn image_rel_rms(a: &[Vec3], b: &[Vec3]) -> f64 {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for (x, y) in a.iter().zip(b) {
        num += (*x - *y).as_dvec3().length_squared();
        den += y.as_dvec3().length_squared();
    }
    (num / den.max(1e-300)).sqrt()
}

/// Issue #33: the image drawn on the device that solved (kernel `image`) equals the CPU's
/// image of the same solution to float tolerance, for every way the indirect light is
/// read (the basis, a gather where it is doubted, a gather everywhere), both pixel
/// filters, every variant, lights, emitting surfaces (an emission texture too), a
/// constant sky and an environment map, textures and shading normals.
#[test]
fn images_drawn_on_the_device_equal_the_cpu_images() {
    let ctx = context();
    let dir = common::tmpdir();
    let small = |s: &mut Scene, spp: u32| {
        s.camera.width = 48;
        s.camera.height = 40;
        s.camera.spp = spp;
    };
    let mut cases: Vec<(String, Scene, SolverParams)> = Vec::new();
    for variant in Variant::ALL {
        let (mut s, mut p) = cornell(4, 64, variant);
        small(&mut s, 4);
        p.bounces = 2;
        match variant {
            // A gather at every sample (`final_gather_pixels`).
            Variant::Original => p.final_gather_pixels = 4,
            // The basis alone, through the Gaussian filter.
            Variant::Approx => {
                p.doubt_gather = 0;
                s.camera.filter = meshrad::scene::camera::Filter::Gaussian;
            }
            // A gather where the basis is doubted (the default), made frequent.
            Variant::Modified => p.doubt_nodes = 6,
        }
        cases.push((format!("Cornell box, {variant:?}"), s, p));
    }
    // Much work a pixel: 16 samples, each gathering 64 rays (two chunks of 32 threads'
    // worth). One thread a pixel ran past llvmpipe's loop limit here and lost samples.
    let (mut s, mut p) = cornell(4, 64, Variant::Modified);
    (s.camera.width, s.camera.height, s.camera.spp) = (16, 12, 16);
    (p.bounces, p.doubt_nodes, p.doubt_gather) = (2, 1024, 64);
    cases.push(("Cornell box, every sample gathers 64 rays".into(), s, p));
    let (mut s, mut p) = Scene::embedded_file("cornell_area.toml", &[]).unwrap();
    small(&mut s, 2);
    (p.levels, p.sender_level, p.rays, p.bounces) = (4, 3, 32, 2);
    cases.push(("area-lit box".into(), s, p));
    for (name, mut s, p) in sky_and_emission_scenes(dir.path()) {
        small(&mut s, 2);
        cases.push((name, s, p));
    }
    let sphere = meshrad::analytic::lit_sphere(&dir.path().join("sphere"), 1.0, 1, true, SMALL_SOLVER).unwrap();
    let (mut s, p) = common::load(&sphere, &[]);
    assert!(!s.normals.is_empty());
    small(&mut s, 2);
    cases.push(("shading normals".into(), s, p));
    let boxed = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/BoxTextured/scene.toml");
    let (mut s, p) = common::load(&boxed, &[]);
    small(&mut s, 2);
    cases.push(("BoxTextured (glTF, textured)".into(), s, p));
    let hidden = Progress::hidden();
    for (name, s, p) in &cases {
        let mut engine = meshrad::Engine::gpu(ctx.clone());
        let run = meshrad::solve(s, p, &mut engine, &hidden).unwrap();
        let cpu = meshrad::output::image::render(s, &run.hierarchy, &run.solution, p, &hidden);
        let gpu = meshrad::output::image::render_on(&mut engine, s, &run.hierarchy, &run.solution, p, &hidden).unwrap();
        assert!(gpu.device.is_some(), "{name}: drawn on the CPU");
        let (d, i) = (
            image_rel_rms(&gpu.direct, &cpu.direct),
            image_rel_rms(&gpu.indirect, &cpu.indirect),
        );
        let t = image_rel_rms(&gpu.total(), &cpu.total());
        eprintln!(
            "{name}: direct {d:.2e}, indirect {i:.2e}, total {t:.2e}; doubted samples GPU {} CPU {}, basis {} / {}",
            gpu.doubted_samples, cpu.doubted_samples, gpu.basis_samples, cpu.basis_samples
        );
        let lit = cpu.total().iter().filter(|v| v.max_element() > 0.0).count();
        assert!(
            lit > cpu.direct.len() / 4,
            "{name}: {lit} lit pixels: the case tests nothing"
        );
        assert!(d <= 0.005 && i <= 0.005 && t <= 0.005, "{name}");
        if name.ends_with("Modified") {
            assert!(cpu.doubted_samples > 0, "{name}: no sample was doubted");
        }
        if name.ends_with("64 rays") {
            let hits = cpu.doubted_samples + cpu.basis_samples;
            assert!(hits > 2000 && cpu.doubted_samples == hits, "{name}: {hits} hits");
        }
        assert_eq!(
            gpu.doubted_samples + gpu.basis_samples,
            cpu.doubted_samples + cpu.basis_samples,
            "{name}"
        );
        assert!(
            gpu.doubted_samples.abs_diff(cpu.doubted_samples) <= 1 + cpu.doubted_samples / 100,
            "{name}"
        );
        assert_eq!(ctx.validation_errors(), 0, "{name}");
    }
}
