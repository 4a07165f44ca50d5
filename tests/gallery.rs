//! Sponza's gallery in miniature (issue #9): a colonnade with a roof over a sunlit floor,
//! a back wall that the sun lights above the roof, and a gallery floor half in the roof's
//! shadow. The light under the roof is almost all indirect, bounced off the lit floor
//! and the lit columns, with sharp changes at the shadow edge and at the column bases:
//! the case where Sponza lost a tenth of its indirect light. The solver at its defaults
//! is compared with the independent path tracer (the whole series) at points drawn
//! uniformly by area over every surface that can receive light; the test fails when
//! light is lost or gained (a median or energy estimate/reference outside 0.95–1.05, a
//! point off by 3×) or the error grows past 5 % (the basis read at the points, without
//! the final gather, gives 7.0 % here).

mod common;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::Vec3;
use meshrad::bench::area_probes;
use meshrad::metrics::indirect_error;
use meshrad::params::SolverParams;
use meshrad::progress::Progress;
use meshrad::reference::{self, ReferenceOptions};
use meshrad::transport::cpu::node_world;
use meshrad::transport::readout::Readout;

/// A closed box `[lo, hi]` with outward-facing triangles, appended to `obj`.
fn cuboid(obj: &mut String, verts: &mut usize, lo: [f64; 3], hi: [f64; 3], material: &str) {
    let c = |i: usize| {
        [
            if i & 1 == 0 { lo[0] } else { hi[0] },
            if i & 2 == 0 { lo[1] } else { hi[1] },
            if i & 4 == 0 { lo[2] } else { hi[2] },
        ]
    };
    for i in 0..8 {
        let p = c(i);
        let _ = writeln!(obj, "v {} {} {}", p[0], p[1], p[2]);
    }
    let _ = writeln!(obj, "usemtl {material}");
    // Faces as corner indices, counter-clockwise seen from outside.
    let quads = [
        [0, 2, 3, 1], // z = lo
        [4, 5, 7, 6], // z = hi
        [0, 1, 5, 4], // y = lo
        [2, 6, 7, 3], // y = hi
        [0, 4, 6, 2], // x = lo
        [1, 3, 7, 5], // x = hi
    ];
    for q in quads {
        let v = |k: usize| *verts + q[k] + 1;
        let _ = writeln!(obj, "f {} {} {}", v(0), v(1), v(2));
        let _ = writeln!(obj, "f {} {} {}", v(0), v(2), v(3));
    }
    *verts += 8;
}

/// Writes the gallery (metres) and its scene file; returns the scene file.
fn write_gallery(dir: &Path) -> PathBuf {
    let mut obj = String::from("mtllib gallery.mtl\n");
    let mut n = 0;
    // Ground slab, back wall (lit above the roof), the gallery roof and six columns.
    cuboid(&mut obj, &mut n, [0.0, -0.2, 0.0], [16.0, 0.0, 10.0], "floor");
    cuboid(&mut obj, &mut n, [0.0, 0.0, -0.3], [16.0, 7.0, 0.0], "wall");
    cuboid(&mut obj, &mut n, [0.0, 3.0, 0.0], [16.0, 3.3, 3.0], "wall");
    for k in 0..6 {
        let x = 1.5 + 2.6 * k as f64;
        cuboid(&mut obj, &mut n, [x, 0.0, 2.6], [x + 0.4, 3.0, 3.0], "column");
    }
    std::fs::write(dir.join("gallery.obj"), obj).unwrap();
    std::fs::write(
        dir.join("gallery.mtl"),
        "newmtl floor\nKd 0.6 0.55 0.5\nnewmtl wall\nKd 0.7 0.7 0.7\nnewmtl column\nKd 0.75 0.7 0.6\n",
    )
    .unwrap();
    // The sun travels towards the back wall (-z): the roof's shadow falls on the back half
    // of the gallery floor, the front half and the columns are lit.
    let toml = "[[object]]\nmesh = \"gallery.obj\"\n\n[[light]]\ntype = \"directional\"\n\
                direction = [0.3, -1.0, -0.55]\nirradiance = [5.0, 5.0, 5.0]\n\n[camera]\n\
                position = [8.0, 1.6, 9.0]\ntarget = [8.0, 1.8, 0.0]\nfov = 60.0\nwidth = 32\nheight = 24\n";
    let p = dir.join("gallery.toml");
    std::fs::write(&p, toml).unwrap();
    p
}

/// The gallery with one more box `[lo, hi]` of `material`; returns the scene file.
fn write_gallery_with(dir: &Path, lo: [f64; 3], hi: [f64; 3], material: &str) -> PathBuf {
    let path = write_gallery(dir);
    let mut obj = std::fs::read_to_string(dir.join("gallery.obj")).unwrap();
    let mut n = obj.lines().filter(|l| l.starts_with("v ")).count();
    cuboid(&mut obj, &mut n, lo, hi, material);
    std::fs::write(dir.join("gallery.obj"), obj).unwrap();
    path
}

/// The converged reference (the whole series, 4096 paths) at `probes`.
fn converged(scene: &meshrad::scene::Scene, probes: &[meshrad::output::probe::Probe]) -> Vec<reference::Estimate> {
    let pts: Vec<_> = probes.iter().map(|q| (q.p, q.n)).collect();
    let opts = ReferenceOptions {
        samples: 4096,
        max_bounces: 0,
        ..Default::default()
    };
    reference::indirect_many(scene, &pts, &opts)
}

/// The errors of one solve at its defaults against the converged reference, read with
/// each of `final_gathers` (rays; 0: the basis at the point).
fn errors(final_gathers: &[u32]) -> (SolverParams, Vec<meshrad::metrics::ErrorStats>) {
    let dir = common::tmpdir();
    let path = write_gallery(dir.path());
    let (scene, p) = common::load(&path, &[]);
    let probes = area_probes(&scene, 96, 7);
    let refs = converged(&scene, &probes);
    let (h, sol) = common::solve_cpu(&scene, &p);
    let stats = final_gathers
        .iter()
        .map(|&fg| {
            let read = Readout::with_rays(&scene, &h, &sol, &p, fg);
            let est: Vec<_> = probes.iter().map(|q| read.at(q.p, q.n).mean).collect();
            indirect_error(&est, &refs)
        })
        .collect();
    (p, stats)
}

#[test]
fn gallery_keeps_its_indirect_light() {
    let (p, stats) = errors(&[SolverParams::default().final_gather, 0, 1024]);
    for (e, what) in stats.iter().zip(["defaults", "basis read", "final gather 1024"]) {
        println!(
            "GALLERY {what}: rel-RMS {:.2} %, median e/r {:.3}, mean e/r {:.3}, energy {:.3}, off 3x {} of {}, \
             leak {:.4}, reference noise {:.2} %",
            100.0 * e.rel_rms,
            e.median_ratio,
            e.mean_ratio,
            e.energy_ratio,
            e.off_3x,
            e.points,
            e.leak,
            100.0 * e.reference_noise
        );
    }
    let e = &stats[0];
    assert_eq!(p.final_gather, SolverParams::default().final_gather);
    assert!(e.points >= 48, "too few points above the floor: {}", e.points);
    assert!(
        (0.95..=1.05).contains(&e.median_ratio),
        "median estimate/reference {:.3} outside [0.95, 1.05]: indirect light lost (or gained)",
        e.median_ratio
    );
    assert!(
        (0.95..=1.05).contains(&e.energy_ratio),
        "energy estimate/reference {:.3}",
        e.energy_ratio
    );
    assert_eq!(e.off_3x, 0, "points off by more than 3x");
    // Measured: 2.3 % at the defaults (a final gather of 1024 rays), 7.0 % with the basis
    // read at the points; the reference's own noise is about 2 %.
    assert!(e.rel_rms < 0.05, "rel-RMS {:.2} %", 100.0 * e.rel_rms);
}

/// A cornice lit from straight above on an otherwise unlit wall: the wall just above it
/// gets its first bounce from the cornice's top, a sunlit strip narrower than the coarse
/// levels' supports, with a shadowed step right below it that faces the same way. The
/// nodes there must get the light the top sends them (the reference's one-bounce term
/// at the node centres). Gathers next to the thin strip are noisy (σ/g 10–15 % at 512
/// rays), and with the oracle's noise allowance at 2 standard errors (the value Table 2
/// was reproduced with) the nodes there are not refined and take their parents'
/// flattened prediction: 0.83 of the light. A noise allowance of 1 (the default) closes
/// most of it, and so would gathering the cornice's sparse nodes (`sparse_parents`). The
/// test fails when that returns at the defaults, and checks that the paper's oracle
/// still shows it.
#[test]
fn cornice_light_reaches_the_wall_above() {
    let dir = common::tmpdir();
    let mut obj = String::from("mtllib c.mtl\n");
    let mut n = 0;
    cuboid(&mut obj, &mut n, [0.0, 0.0, -0.3], [60.0, 20.0, 0.0], "wall");
    cuboid(&mut obj, &mut n, [0.0, 10.0, 0.0], [60.0, 10.04, 0.08], "wall");
    cuboid(&mut obj, &mut n, [0.0, 9.9, 0.0], [60.0, 9.94, 0.05], "wall");
    std::fs::write(dir.path().join("c.obj"), obj).unwrap();
    std::fs::write(dir.path().join("c.mtl"), "newmtl wall\nKd 0.7 0.7 0.7\n").unwrap();
    let toml = "[[object]]\nmesh = \"c.obj\"\n\n[[light]]\ntype = \"directional\"\n\
                direction = [0.0, -1.0, 0.0]\nirradiance = [5.0, 5.0, 5.0]\n";
    let path = dir.path().join("c.toml");
    std::fs::write(&path, toml).unwrap();
    let mut ratios = Vec::new();
    let d = SolverParams::default();
    // The defaults, then the paper's oracle (noise allowance 2, no sparse-node gathering,
    // and the floor of 1 % of the mean direct light the defaults had before issue #32).
    for (noise_z, sparse, eps_abs) in [(d.noise_z, d.sparse_parents, d.eps_abs), (2.0, 0, 0.01)] {
        // At the paper's fixed density: the mean free path (`free_path`) would add nodes
        // enough to hide the peak from both oracles.
        let (scene, mut p) = common::load(
            &path,
            &[("bounces", "1"), ("stop_threshold", "0.0"), ("free_path", "0")],
        );
        p.noise_z = noise_z;
        p.sparse_parents = sparse;
        p.eps_abs = eps_abs;
        let (h, sol) = common::solve_cpu(&scene, &p);
        // Nodes of every level on the wall's face within 0.3 above the cornice's top.
        let picked: Vec<(Vec3, Vec3, f64)> = (0..h.nodes.len())
            .map(|j| {
                let (x, nn) = node_world(&scene, &h, j);
                (x, nn, sol.values.indirect[j].x as f64)
            })
            .filter(|&(x, nn, _)| {
                nn.z > 0.99 && x.z.abs() < 1e-3 && x.y > 10.05 && x.y < 10.35 && x.x > 5.0 && x.x < 55.0
            })
            .collect();
        assert!(picked.len() >= 100, "only {} nodes above the cornice", picked.len());
        let pts: Vec<_> = picked.iter().map(|&(x, nn, _)| (x, nn)).collect();
        let opts = ReferenceOptions {
            samples: 4096,
            max_bounces: 1,
            ..Default::default()
        };
        let refs = reference::indirect_many(&scene, &pts, &opts);
        let est: f64 = picked.iter().map(|q| q.2).sum();
        let want: f64 = refs.iter().map(|r| r.mean.x).sum();
        println!(
            "CORNICE noise_z {noise_z}, sparse_parents {sparse}: {} nodes, {} integrals, estimate/reference {:.3}",
            picked.len(),
            sol.stats.integrals,
            est / want
        );
        ratios.push(est / want);
    }
    // Measured: 0.959 at the defaults (noise_z 1), 0.83 at the paper's; 0.983 with
    // sparse_parents 3 as well, 0.952 with sparse_parents 3 at noise_z 2; 0.997 with
    // eps_abs 0.002 (issue #32), 0.850 for the paper's oracle at 0.01 (0.952 at 0.002).
    assert!(
        (0.93..=1.07).contains(&ratios[0]),
        "the first bounce on the wall above the cornice: estimate/reference {:.3}",
        ratios[0]
    );
    assert!(
        ratios[1] < ratios[0] - 0.05,
        "the paper's oracle no longer flattens the peak ({:.3} against {:.3}): the test lost its case",
        ratios[1],
        ratios[0]
    );
}

/// The faces narrower than the coarser levels resolve (the roof's front edge, the
/// columns' sides, the slab's rim): their nodes have at most a few parents, and where the
/// oracle trusts the pull-down they take the parents' weighted mean, which comes from the
/// wider faces around them rather than from the light the strip itself catches: here
/// too much (1.08 of the reference), on Sponza's ceiling edges too little (0.88). With
/// `sparse_parents` (3 here; off by default, for its cost) they are gathered wherever a
/// parent is lit. The nodes compared are
/// the lit sparse nodes that the paper's oracle (`sparse_parents = 0`) leaves to the
/// pull-down; their first bounce against the reference's one-bounce term at the node
/// centres. The test fails when a sparse node with a lit parent is not gathered or their
/// light is off again, and checks that with the mechanism off it is off (the case is
/// still a case).
#[test]
fn narrow_faces_get_their_light() {
    use meshrad::transport::cpu::CpuBackend;
    let dir = common::tmpdir();
    let path = write_gallery(dir.path());
    let (scene, mut p) = common::load(&path, &[("bounces", "1"), ("stop_threshold", "0.0")]);
    let k = 3;
    let h = meshrad::Hierarchy::build(&scene, &p, &Progress::hidden()).unwrap();
    let mut values = Vec::new();
    let mut picked: Vec<usize> = Vec::new();
    for sparse in [0, k] {
        p.sparse_parents = sparse;
        let mut b = CpuBackend::new(&scene, &h, &p, &Progress::hidden());
        let sol = meshrad::transport::solve(&p, &mut b, &Progress::hidden()).unwrap();
        let l0 = h.level_range(0);
        let mean_direct = sol.values.direct[l0.clone()].iter().map(|v| v.x as f64).sum::<f64>() / l0.len() as f64;
        let floor = mean_direct * p.eps_abs as f64;
        let lit_parent = |c: usize| {
            h.parents_of(c)
                .iter()
                .any(|q| sol.values.indirect[q.node as usize].x as f64 > floor)
        };
        if sparse == 0 {
            picked = (h.level_range(1).end..h.nodes.len())
                .filter(|&c| h.parents_of(c).len() <= k as usize && b.gathered(c).is_none() && lit_parent(c))
                .collect();
        } else {
            // The mechanism: every sparse node with a lit parent is gathered.
            for c in h.level_range(1).end..h.nodes.len() {
                if h.parents_of(c).len() <= k as usize && lit_parent(c) {
                    assert!(
                        b.gathered(c).is_some(),
                        "sparse node {c} with a lit parent was not gathered"
                    );
                }
            }
        }
        values.push(
            picked
                .iter()
                .map(|&j| sol.values.indirect[j].x as f64)
                .collect::<Vec<_>>(),
        );
    }
    assert!(
        picked.len() >= 100,
        "only {} sparse lit nodes left to the pull-down",
        picked.len()
    );
    let step = picked.len().div_ceil(300);
    let idx: Vec<usize> = (0..picked.len()).step_by(step).collect();
    let pts: Vec<_> = idx.iter().map(|&i| node_world(&scene, &h, picked[i])).collect();
    let opts = ReferenceOptions {
        samples: 2048,
        max_bounces: 1,
        ..Default::default()
    };
    let refs = reference::indirect_many(&scene, &pts, &opts);
    let want: f64 = refs.iter().map(|r| r.mean.x).sum();
    let ratio = |v: &[f64]| idx.iter().map(|&i| v[i]).sum::<f64>() / want;
    let (off, on) = (ratio(&values[0]), ratio(&values[1]));
    println!(
        "NARROW {} sparse lit nodes ({} compared): estimate/reference {off:.3} with sparse_parents 0, {on:.3} with {k}",
        picked.len(),
        idx.len()
    );
    // Measured: 1.000 with the mechanism, 1.083 without (2392 nodes, 299 compared).
    assert!(
        (0.95..=1.05).contains(&on),
        "the first bounce at the narrow faces: estimate/reference {on:.3}"
    );
    assert!(
        (off - 1.0).abs() > (on - 1.0).abs() + 0.03,
        "the pull-down is no longer off at these nodes ({off:.3} against {on:.3}): the test lost its case"
    );
}

/// A low table in the gallery's shade: a plate whose top is 0.12 m above the floor, less
/// than the finest support (`h` = 0.31 m with 4 levels), so the floor under it and its
/// top are two sheets facing the same way within one support. The floor under the plate
/// gets what comes in from its sides; the top sees the roof and the lit floor. A read at
/// one must not take the other's nodes (`plane_offset`, `ALGORITHM.md` §5.3). The basis
/// read at area-uniform points on both sheets is compared with the converged reference:
/// the test fails when the sheets are mixed at the defaults, and checks that without the
/// plane test they still are (the case is still there).
#[test]
fn stacked_sheets_keep_their_own_light() {
    let dir = common::tmpdir();
    let path = write_gallery_with(dir.path(), [5.0, 0.1, 0.6], [9.0, 0.12, 2.2], "wall");
    let under = |q: &meshrad::output::probe::Probe| {
        (5.0..=9.0).contains(&q.p.x) && (0.6..=2.2).contains(&q.p.z) && q.p.y < 0.13 && q.n.y > 0.9
    };
    let mut ratios = Vec::new();
    for plane in ["0.25", "0"] {
        let (scene, p) = common::load(
            &path,
            &[
                ("levels", "4"),
                ("sender_level", "3"),
                ("final_gather", "0"),
                ("plane_offset", plane),
            ],
        );
        let probes: Vec<_> = area_probes(&scene, 4000, 11)
            .into_iter()
            .filter(under)
            .take(48)
            .collect();
        assert!(probes.len() >= 40, "only {} points on the two sheets", probes.len());
        let refs = converged(&scene, &probes);
        let (h, sol) = common::solve_cpu(&scene, &p);
        // The plane test alone: without the probes' own tests of the point (issue #32),
        // whose visibility test also keeps the plate's top from the floor under it.
        let mut alone = p.clone();
        (alone.basis_crevice, alone.basis_visibility) = (false, false);
        for (q, what) in [(&alone, "alone"), (&p, "with the probes' tests")] {
            let read = Readout::with_rays(&scene, &h, &sol, q, 0);
            let est: Vec<_> = probes.iter().map(|q| read.at(q.p, q.n).mean).collect();
            let e = indirect_error(&est, &refs);
            println!(
                "SHEETS plane_offset {plane} {what}: rel-RMS {:.2} %, median e/r {:.3}, energy {:.3}, off 3x {} of {}",
                100.0 * e.rel_rms,
                e.median_ratio,
                e.energy_ratio,
                e.off_3x,
                e.points
            );
            ratios.push(e);
        }
    }
    let (on, off) = (&ratios[0], &ratios[2]);
    // Measured with the probes' tests (the defaults): 10.7 %, median 0.986; without the
    // plane test they alone give 11.0 %, median 0.970.
    assert!(
        ratios[1].rel_rms < 0.15 && (0.95..=1.05).contains(&ratios[1].median_ratio),
        "rel-RMS {:.2} %, median {:.3} on the two sheets at the defaults",
        100.0 * ratios[1].rel_rms,
        ratios[1].median_ratio
    );
    // Measured (the probes' tests off): 10.7 %, median 0.986 with the plane test (the
    // basis read of 4 levels at the plate's shadow edges); 34.2 %, median 0.722 without
    // (20.0 % and 40.1 % before issue #32's lower oracle floor).
    assert!(
        on.rel_rms < 0.25,
        "rel-RMS {:.2} % on the two sheets",
        100.0 * on.rel_rms
    );
    assert!(
        (0.9..=1.1).contains(&on.median_ratio),
        "median estimate/reference {:.3} on the two sheets",
        on.median_ratio
    );
    assert!(
        off.rel_rms > on.rel_rms + 0.1 && off.median_ratio < 0.8,
        "without the plane test the sheets are no longer mixed ({:.3}, median {:.3}): the test lost its case",
        off.rel_rms,
        off.median_ratio
    );
}

/// A panel 30 cm tall hung 3 cm in front of the gallery's back wall, under the roof (Bitterli's
/// staircase has its stair stringer so, 3–4 cm off the wall): the wall behind it gets a
/// fraction of the light the open wall beside it gets, through a gap far narrower than
/// the finest level's support. The crevice test leaves the gap without nodes, so every
/// node that answers there stands on the open wall. A probe's final gather from the gap
/// lands on the panel's back and the wall at once; reading the basis at those hits
/// takes the open wall's light into the gap. With `short_hops` the path takes one more
/// hop where a hop is shorter than the support (`ALGORITHM.md` §6) and leaves the gap as
/// the light entered it. The probes behind the panel against the converged reference;
/// the test fails when the gap is lit at the defaults, and checks that without the hops
/// it still is (the case is still there).
#[test]
fn the_gap_behind_a_panel_stays_dark() {
    let dir = common::tmpdir();
    let path = write_gallery_with(dir.path(), [5.0, 1.0, 0.03], [9.0, 1.3, 0.07], "column");
    let probes: Vec<_> = (0..8)
        .flat_map(|i| (0..2).map(move |j| (i, j)))
        .map(|(i, j)| meshrad::output::probe::Probe {
            p: Vec3::new(5.4 + 0.45 * i as f32, 1.06 + 0.06 * j as f32, 0.0),
            n: Vec3::Z,
        })
        .collect();
    let mut stats = Vec::new();
    for hops in ["8", "0"] {
        let (scene, p) = common::load(&path, &[("short_hops", hops)]);
        let refs = stats.is_empty().then(|| {
            let pts: Vec<_> = probes.iter().map(|q| (q.p, q.n)).collect();
            let opts = ReferenceOptions {
                samples: 32768,
                max_bounces: 0,
                ..Default::default()
            };
            reference::indirect_many(&scene, &pts, &opts)
        });
        let (h, sol) = common::solve_cpu(&scene, &p);
        let read = Readout::new(&scene, &h, &sol, &p);
        let est: Vec<_> = probes.iter().map(|q| read.at(q.p, q.n).mean).collect();
        stats.push((est, refs));
    }
    let refs = stats[0].1.clone().unwrap();
    let errs: Vec<_> = stats.iter().map(|(est, _)| indirect_error(est, &refs)).collect();
    for k in 0..probes.len() {
        println!(
            "GAP {:?}: reference {:.4} ± {:.4}, short hops {:.4}, none {:.4}",
            probes[k].p, refs[k].mean.x, refs[k].std_err.x, stats[0].0[k].x, stats[1].0[k].x
        );
    }
    for (e, hops) in errs.iter().zip(["8", "0"]) {
        println!(
            "GAP short_hops {hops}: rel-RMS {:.2} %, median e/r {:.3}, energy {:.3}, off 3x {} of {}, reference noise {:.2} %",
            100.0 * e.rel_rms,
            e.median_ratio,
            e.energy_ratio,
            e.off_3x,
            e.points,
            100.0 * e.reference_noise
        );
    }
    let (on, off) = (&errs[0], &errs[1]);
    assert!(on.points >= 14, "only {} of the gap's points are measurable", on.points);
    assert!(
        on.rel_rms < 0.1 && (0.9..=1.1).contains(&on.median_ratio),
        "the gap behind the panel: rel-RMS {:.2} %, median estimate/reference {:.3}",
        100.0 * on.rel_rms,
        on.median_ratio
    );
    assert!(
        off.rel_rms > on.rel_rms + 0.15,
        "without the short hops the gap is no longer lit ({:.2} % against {:.2} %): the test lost its case",
        100.0 * off.rel_rms,
        100.0 * on.rel_rms
    );
}

/// The probes' basis read (`final_gather = 0`) under a board lying on spacers over the
/// gallery floor (`ALGORITHM.md` §6; issue #32, where Bitterli's staircase lost its
/// basis read to points behind its stringer and inside its mouldings). The floor under
/// the board gets a few hundredths of the open floor's light through the gap, or none,
/// but the nodes within a support of it stand on the board's lit top, a sheet facing the
/// same way within the read's plane tolerance. Two tests of the point's surroundings
/// keep their light out: the crevice test of the build (where it holds the build put no
/// node, so none is read) and the visibility of each node from the point (the board
/// hides its top's nodes from the floor under it). Two boards: 6 cm up, with 4 levels,
/// where either test alone darkens the floor under it, and 3 mm up, where the crevice
/// test must (the segments, lifted a tenth of the support, pass over the board). The
/// test fails when the floor under a board reads more than twice its reference, and
/// checks that without the tests it reads more than ten times that (the case is there).
#[test]
fn the_basis_read_keeps_out_from_under_a_board() {
    // (what, the board's height, overrides, the (crevice, visibility) settings that
    // must darken the floor under it)
    type Case<'a> = (&'a str, f64, &'a [(&'a str, &'a str)], &'a [(bool, bool)]);
    let cases: [Case; 2] = [
        (
            "6 cm, 4 levels",
            0.06,
            &[("levels", "4"), ("sender_level", "3")],
            &[(true, true), (true, false), (false, true)],
        ),
        ("3 mm", 0.003, &[], &[(true, true), (true, false)]),
    ];
    for (what, y, over, settings) in cases {
        let dir = common::tmpdir();
        let path = write_gallery_with(dir.path(), [5.0, y, 0.6], [9.0, y + 0.01, 2.2], "wall");
        let mut over = over.to_vec();
        over.push(("final_gather", "0"));
        let (scene, p) = common::load(&path, &over);
        let probes: Vec<_> = (0..8)
            .flat_map(|i| (0..2).map(move |j| (i, j)))
            .map(|(i, j)| meshrad::output::probe::Probe {
                p: Vec3::new(5.4 + 0.45 * i as f32, 0.0, 1.2 + 0.4 * j as f32),
                n: Vec3::Y,
            })
            .collect();
        let refs = converged(&scene, &probes);
        let reference = refs.iter().map(|r| r.mean.x).sum::<f64>() / refs.len() as f64;
        let (h, sol) = common::solve_cpu(&scene, &p);
        let mean_read = |&(crevice, visibility): &(bool, bool)| {
            let mut q = p.clone();
            q.basis_crevice = crevice;
            q.basis_visibility = visibility;
            let read = Readout::new(&scene, &h, &sol, &q);
            probes.iter().map(|q| read.at(q.p, q.n).mean.x as f64).sum::<f64>() / probes.len() as f64
        };
        let none = mean_read(&(false, false));
        println!("BOARD {what}: mean reference {reference:.4}, basis read without the tests {none:.4}");
        for s in settings {
            let read = mean_read(s);
            println!("BOARD {what}: crevice {}, visibility {}: {read:.4}", s.0, s.1);
            assert!(
                read <= 2.0 * reference,
                "{what}: the floor under the board reads {read:.4} against {reference:.4} (crevice {}, visibility {})",
                s.0,
                s.1
            );
        }
        assert!(
            none > 10.0 * reference + 0.1,
            "{what}: without the tests the floor under the board reads {none:.4} against {reference:.4}: the case is gone"
        );
    }
}
