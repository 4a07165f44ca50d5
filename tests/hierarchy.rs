//! Invariants of the meshless hierarchy on the Cornell box: Poisson distance on every
//! level, coverage without holes, partition of unity, parent weights summing to one,
//! Shepard reproducing constants, and determinism.

mod common;

use glam::{Vec3, Vec4};
use meshrad::hierarchy::{self, poisson, Hierarchy};
use meshrad::progress::Progress;
use meshrad::scene::reach;
use meshrad::transport::reconstruct;
use meshrad::{Scene, SolverParams, Variant};

fn cornell(levels: u32) -> (Scene, SolverParams) {
    let (s, mut p) = Scene::embedded_cornell(&[]).unwrap();
    p.levels = levels;
    p.sender_level = levels - 1;
    p.gather_levels = Some(levels.min(3));
    (s, p)
}

/// Random points on the sides light reaches, out of crevices (the definitions the build
/// uses).
fn surface_points(scene: &Scene, p: &SolverParams, h: &Hierarchy, n: usize) -> Vec<(Vec3, Vec3)> {
    let sides = reach::reachable_sides(scene, p.reach_paths, p.reach_bounces, p.seed);
    let d_min = p.crevice_distance * h.stats.radius_per_level.last().unwrap();
    poisson::candidates(&scene.tris, &[], &sides, n, 12345, &|_, _, _| true)
        .into_iter()
        .enumerate()
        .filter(|(i, c)| !hierarchy::in_crevice(scene, 0, c, d_min, *i as u32))
        .map(|(_, c)| (c.pos, c.normal))
        .collect()
}

#[test]
fn poisson_distance_on_every_level() {
    let (scene, params) = cornell(5);
    let h = Hierarchy::build(&scene, &params, &Progress::hidden()).unwrap();
    for l in 0..5 {
        let (nodes, _, _) = h.level(0, l);
        let r = h.objects[0].radius[l];
        let mut g = poisson::Grid::new(r);
        for nd in nodes {
            let c = poisson::Candidate {
                pos: Vec3::from(nd.pos),
                normal: Vec3::from(nd.normal),
            };
            assert!(!g.conflicts(&c), "level {l}: two same-side nodes closer than r = {r}");
            g.insert(c);
        }
        println!("level {l}: {} nodes, r = {r}", nodes.len());
    }
    // Roughly 4× per level (radius halves).
    let n = &h.stats.nodes_per_level;
    for l in 1..5 {
        let ratio = n[l] as f64 / n[l - 1] as f64;
        assert!((3.0..4.6).contains(&ratio), "{n:?}");
    }
    assert!((150..320).contains(&n[0]), "coarsest {n:?} for a target of 226");
}

#[test]
fn dart_throwing_is_maximal() {
    let (scene, _) = cornell(3);
    let sides = vec![true; scene.tris.len() * 2];
    let pool = poisson::candidates(&scene.tris, &[], &sides, 20_000, 5, &|_, _, _| true);
    let r = 20.0;
    let set = poisson::dart_throw(&pool, r, |_| true);
    let mut g = poisson::Grid::new(r);
    for c in &set {
        g.insert(*c);
    }
    for c in &pool {
        assert!(g.conflicts(c) || set.contains(c), "candidate not covered: not maximal");
    }
}

/// The chunked, parallel dart throwing accepts exactly what the sequential loop accepts,
/// in the same order, whatever `usable` rejects, over many chunks.
#[test]
fn parallel_dart_throwing_equals_sequential() {
    let (scene, _) = cornell(3);
    let sides = vec![true; scene.tris.len() * 2];
    let pool = poisson::candidates(&scene.tris, &[], &sides, 60_000, 9, &|_, _, _| true);
    let usable = |i: usize| (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 61 != 0; // drops 1 in 8
    for r in [60.0, 15.0, 4.0] {
        let par = poisson::dart_throw(&pool, r, usable);
        let seq = poisson::dart_throw_sequential(&pool, r, usable);
        println!("r = {r}: {} nodes", seq.len());
        assert!(seq.len() > 100);
        assert_eq!(par, seq, "r = {r}");
    }
}

#[test]
fn partition_of_unity_and_constants() {
    let (scene, params) = cornell(5);
    let h = Hierarchy::build(&scene, &params, &Progress::hidden()).unwrap();
    let constant = vec![Vec4::new(2.5, 2.5, 2.5, 0.0); h.nodes.len()];
    let pts = surface_points(&scene, &params, &h, 2000);
    assert!(pts.len() > 1800, "most points are out of crevices");
    for l in 0..5 {
        let mut holes = 0;
        for &(p, n) in &pts {
            let mut sum_b = 0.0f64;
            let mut ws = Vec::new();
            h.for_each_weight(0, l, p, n, |_, w| ws.push(w));
            let total: f32 = ws.iter().sum();
            if total == 0.0 {
                holes += 1;
                continue;
            }
            for w in ws {
                sum_b += (w / total) as f64;
            }
            assert!((sum_b - 1.0).abs() < 1e-5, "ΣB = {sum_b}");
            let v = reconstruct::exact(&h, 0, l, p, n, &constant).unwrap();
            assert!((v.x - 2.5).abs() < 1e-5, "constant reproduced as {v}");
        }
        assert_eq!(holes, 0, "level {l} has holes on the lit walls");
    }
}

#[test]
fn parent_weights_sum_to_one() {
    let (scene, params) = cornell(5);
    let h = Hierarchy::build(&scene, &params, &Progress::hidden()).unwrap();
    let mut checked = 0;
    let mut holes = 0;
    for c in h.level_start[1] as usize..h.nodes.len() {
        let ps = h.parents_of(c);
        assert!(!ps.is_empty(), "node {c} has no parent");
        let s: f32 = ps.iter().map(|p| p.weight).sum();
        assert!((s - 1.0).abs() < 1e-5, "node {c}: parent weights sum to {s}");
        // The lists come from one kd walk per group of children: each must hold exactly
        // the nodes the child's own descent finds, ascending, with their weights.
        let nd = &h.nodes[c];
        let mut own = Vec::new();
        h.for_each_weight(
            nd.object as usize,
            nd.level as usize - 1,
            Vec3::from(nd.pos),
            Vec3::from(nd.normal),
            |j, w| own.push((j as u32, w)),
        );
        own.sort_by_key(|&(j, _)| j);
        if own.is_empty() {
            holes += 1;
            assert_eq!((ps.len(), ps[0].weight), (1, 1.0), "node {c}: a hole takes one parent");
        } else {
            let sum: f32 = own.iter().map(|&(_, w)| w).sum();
            assert_eq!(ps.len(), own.len(), "node {c}: parents");
            for (p, &(j, w)) in ps.iter().zip(&own) {
                assert_eq!(p.node, j, "node {c}: parents");
                assert!((p.weight - w / sum).abs() <= 1e-6, "node {c}: weight of parent {j}");
            }
        }
        for p in ps {
            assert_eq!(h.nodes[p.node as usize].level + 1, h.nodes[c].level);
            assert!(h.children_of(p.node as usize).contains(&(c as u32)));
        }
        checked += 1;
    }
    assert!(checked > 10_000);
    assert_eq!(h.stats.orphans_per_level.iter().sum::<u32>(), 0);
    assert_eq!(h.stats.parent_holes_per_level.iter().sum::<u32>(), holes);
}

#[test]
fn same_seed_same_everything() {
    let a = {
        let (s, p) = cornell(4);
        let (h, sol) = common::solve_cpu(&s, &p);
        (h.nodes, sol.values.direct, sol.values.indirect)
    };
    let b = {
        let (s, p) = cornell(4);
        let (h, sol) = common::solve_cpu(&s, &p);
        (h.nodes, sol.values.direct, sol.values.indirect)
    };
    assert!(a.0 == b.0, "nodes differ between two runs with the same seed");
    assert!(
        a.1 == b.1 && a.2 == b.2,
        "values differ between two runs with the same seed"
    );
    let c = {
        let (s, mut p) = cornell(4);
        p.seed = 1;
        Hierarchy::build(&s, &p, &Progress::hidden()).unwrap().nodes
    };
    assert!(a.0 != c, "another seed gives other nodes");
}

/// Every gathering ray that hits a surface light can reach gets a value: of the first
/// bounce's light that the level-0 integrals see, almost none falls on points the sender
/// level does not cover (`transport::coverage`). Fails when holes come back: surfaces
/// without nodes, or a normal test or clip plane that rejects every basis function there.
/// The same measure must see the loss when the sender reads a level that is too sparse
/// for the approximate reconstruction's normal test.
#[test]
fn gathered_light_finds_a_value_at_every_hit() {
    for variant in [Variant::Approx, Variant::Modified, Variant::Original] {
        let (s, mut p) = Scene::embedded_cornell(&[]).unwrap();
        p.variant = variant;
        p.rays = 128;
        let h = Hierarchy::build(&s, &p, &Progress::hidden()).unwrap();
        let c = meshrad::transport::coverage::first_bounce(&s, &h, &p);
        println!("COVERAGE {variant:?}: {c:?}");
        assert!(c.rays > 20_000, "{c:?}");
        assert!(c.no_value_receiving * 1000 <= c.rays, "{variant:?}: {c:?}");
        assert!(
            c.light_lost < 1e-3,
            "{variant:?}: {:.3} % of the first bounce's light lost",
            100.0 * c.light_lost
        );
    }
    // The measure sees a loss: clip planes that cut every support on both sides of the
    // node (u = ±x in its tangent frame, at distance 0, in all 8 directions) leave every
    // hit without a value.
    let (s, mut p) = Scene::embedded_cornell(&[]).unwrap();
    p.rays = 128;
    let mut h = Hierarchy::build(&s, &p, &Progress::hidden()).unwrap();
    let mut clip = [0u8; 16];
    clip[0..2].copy_from_slice(&i16::MAX.to_le_bytes());
    clip[8..10].copy_from_slice(&(-i16::MAX).to_le_bytes());
    clip[6] = 0xff;
    clip[14] = 0xff;
    h.clips.iter_mut().for_each(|c| *c = clip);
    let c = meshrad::transport::coverage::first_bounce(&s, &h, &p);
    println!("COVERAGE every support clipped away: {c:?}");
    assert!(c.light_lost > 0.99 && c.no_value_receiving > 10_000, "{c:?}");
}

/// Links (`transport::links`): later bounces gather over the rays' recorded sender nodes
/// and albedos instead of tracing, and must give the traced answer bit for bit, with room
/// for every node, with room for a few (the rest traced every bounce) and with none. The
/// counts show that the links were used and that the full case ran out of room.
#[test]
fn links_give_the_traced_answer() {
    let run = |link_memory: u32, rays: u32| {
        let (s, mut p) = cornell(4);
        p.rays = rays;
        p.link_memory = link_memory;
        p.stop_threshold = 1e-3;
        let (_, sol) = common::solve_cpu(&s, &p);
        (sol.values.indirect, sol.stats)
    };
    // 64 rays × 16 bytes = 1 KiB a node: 1 MiB holds 1024 nodes, fewer than the 1000+
    // nodes levels 0–2 gather.
    let (traced, st) = run(0, 64);
    assert!(st.links.is_none(), "link_memory = 0 keeps no links");
    assert!(
        st.bounces.len() >= 4,
        "the test needs several bounces: {}",
        st.bounces.len()
    );
    for (mib, full) in [(2048, false), (1, true)] {
        let (linked, st) = run(mib, 64);
        let l = st.links.expect("links kept");
        assert!(
            linked == traced,
            "link_memory {mib}: indirect differs from the traced solve"
        );
        // The box has no texture: every node keeps its links without albedos.
        common::check_link_counts(&l, mib, full, 64, (8, 8));
    }
    // A textured floor: the wall's nodes see it and keep their albedos (16 bytes a link),
    // the floor's see only the wall (8): the same answer as tracing either way. (One ray
    // count on every level, so that the bytes bound the kinds.)
    let dir = common::tmpdir();
    let corner = common::gltf::textured_corner(
        dir.path(),
        "levels = 4\nsender_level = 3\ncoarsest = 40\nrays = 64\nlevel1_rays = 1\nstop_threshold = 1e-3\n",
    );
    let solve_corner = |link_memory: u32| {
        let (s, p) = common::load(&corner, &[("link_memory", &link_memory.to_string())]);
        let (_, sol) = common::solve_cpu(&s, &p);
        (sol.values.indirect, sol.stats)
    };
    let (traced, _) = solve_corner(0);
    let (linked, st) = solve_corner(2048);
    assert!(
        linked == traced,
        "textured corner: indirect differs from the traced solve"
    );
    let l = st.links.expect("links kept");
    assert!(
        l.integrals_linked > 0,
        "textured corner: links served no integral: {l:?}"
    );
    assert!(
        l.nodes * 64 * 8 < l.bytes && l.bytes < l.nodes * 64 * 16,
        "both kinds of links kept: {l:?}"
    );
    // A second solve on the same backend (a benchmark's warm run) records its own links
    // and counts: the same values and the same statistics as a cold one.
    let (s, mut p) = cornell(4);
    p.rays = 64;
    let h = Hierarchy::build(&s, &p, &Progress::hidden()).unwrap();
    let (cold, _) = meshrad::Engine::cpu()
        .transport(&s, &p, &h, 0, &Progress::hidden())
        .unwrap();
    let (warm, _) = meshrad::Engine::cpu()
        .transport(&s, &p, &h, 1, &Progress::hidden())
        .unwrap();
    assert!(cold.values.indirect == warm.values.indirect, "a warm solve differs");
    assert_eq!(cold.stats.links, warm.stats.links);
    assert_eq!(cold.stats.rays_traced, warm.stats.rays_traced);
    // The other variants read more than one node at a hit: they keep no links.
    let (s, mut p) = cornell(3);
    p.variant = Variant::Modified;
    p.rays = 16;
    assert!(common::solve_cpu(&s, &p).1.stats.links.is_none());
}

/// The clip and crevice tests skip their rays where no ray can hit what they look for
/// (`may_meet_wall`, the half-space test of `in_crevice`) and test them against the few
/// triangles near where there are few (`Scene::intersect_among`, `occluded_among`): their
/// answers are those of the
/// traced tests at every node and every candidate, on the embedded box (one object, world
/// space) and on the box in parts with a turned and scaled block (object transforms,
/// `reach = "object"`).
#[test]
fn clip_and_crevice_shortcuts_give_the_traced_answers() {
    let dir = common::tmpdir();
    let mesh = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_original_mm.obj");
    let parts =
        std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_parts.toml"))
            .unwrap()
            .replace("\"cornell_original_mm.obj\"", &format!("{:?}", mesh.to_str().unwrap()))
            .replace(
                "group = \"cbox_largebox\"",
                "group = \"cbox_largebox\"\nrotate = [0.0, 17.0, 0.0]\nscale = 0.9\ntranslate = [20.0, 0.0, -15.0]",
            );
    let path = dir.path().join("parts.toml");
    std::fs::write(&path, parts).unwrap();
    let scenes = [Scene::embedded_cornell(&[]).unwrap(), Scene::load(&path, &[]).unwrap()];
    for (k, (scene, mut p)) in scenes.into_iter().enumerate() {
        p.levels = 5;
        p.sender_level = 4;
        p.gather_levels = Some(3);
        let h = Hierarchy::build(&scene, &p, &Progress::hidden()).unwrap();
        let (mut skipped, mut walls) = (0, 0);
        for i in 0..h.nodes.len() {
            let nd = &h.nodes[i];
            let traced = hierarchy::node_clip_traced(&scene, &h, i);
            assert_eq!(hierarchy::node_clip(&scene, &h, i), traced, "scene {k}, node {i}");
            let may = hierarchy::may_meet_wall(&scene, nd, h.support(nd.object as usize, nd.level as usize));
            skipped += !may as usize;
            walls += (traced != meshrad::hierarchy::weight::NO_CLIP) as usize;
        }
        println!(
            "scene {k}: {} nodes, {skipped} clips without rays, {walls} clipped",
            h.nodes.len()
        );
        assert!(
            walls > 100 && skipped > h.nodes.len() / 2,
            "the scene has walls and open floor"
        );
        let d_min = p.crevice_distance * h.stats.radius_per_level.last().unwrap();
        let (mut crevices, mut tested) = (0, 0);
        for o in 0..scene.objects.len() {
            let obj = &scene.objects[o];
            let r = obj.tri_offset as usize..(obj.tri_offset + obj.tri_count) as usize;
            let pool = poisson::candidates(
                &scene.tris[r],
                &[],
                &vec![true; obj.tri_count as usize * 2],
                6000,
                77,
                &|_, _, _| true,
            );
            let diag = hierarchy::object_diagonal(&scene, o);
            for (i, c) in pool.iter().enumerate() {
                let i = i as u32;
                let world = hierarchy::in_crevice(&scene, o, c, d_min, i);
                assert_eq!(
                    world,
                    hierarchy::in_crevice_traced(&scene, o, c, d_min, i),
                    "scene {k}, {c:?}"
                );
                let d_obj = d_min / obj.transform.scale;
                let within = hierarchy::in_crevice_within(&scene, o, c, d_obj, i, diag);
                let traced = hierarchy::in_crevice_within_traced(&scene, o, c, d_obj, i, diag);
                assert_eq!(within, traced, "scene {k}, object {o}, {c:?}");
                crevices += world as usize;
                tested += 1;
            }
        }
        println!("scene {k}: {crevices} of {tested} candidates in crevices");
        assert!(
            crevices > 10,
            "the blocks stand on the floor: some candidates lie in crevices"
        );
    }
}

/// The hierarchy does not depend on the number of threads that build it: nodes, clips,
/// parents and weights are identical bit for bit with 1, 2 and 3 threads (issue #13).
#[test]
fn same_hierarchy_on_any_number_of_threads() {
    let build = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let (s, p) = cornell(5);
            let h = Hierarchy::build(&s, &p, &Progress::hidden()).unwrap();
            let parents: Vec<(u32, u32)> = h.parents.iter().map(|q| (q.node, q.weight.to_bits())).collect();
            (h.nodes, h.clips, h.parent_offset, parents)
        })
    };
    let one = build(1);
    assert!(one.0.len() > 40_000);
    for threads in [2, 3] {
        let other = build(threads);
        assert!(one.0 == other.0, "nodes differ with {threads} threads");
        assert!(one.1 == other.1, "clips differ with {threads} threads");
        assert!(
            one.2 == other.2 && one.3 == other.3,
            "parents differ with {threads} threads"
        );
    }
}
