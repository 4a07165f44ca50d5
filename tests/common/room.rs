//! A closed room (unit cube, walls facing in) with variants of its floor mesh, for the
//! stress tests: slivers, T-junctions, coincident duplicates, and a splitting wall.
#![allow(dead_code)]

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// How the floor (y = 0) is meshed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Floor {
    /// Two triangles.
    Plain,
    /// 1000 strips of two needle triangles each (aspect 1000:1).
    Slivers,
    /// Left half two triangles, right half a 6×6 grid: T-junctions along x = 0.5.
    TJunctions,
    /// The plain floor twice, plus an overlapping coplanar square.
    Coincident,
}

/// The room's OBJ text: scaled by `scale`, translated by `offset`; with `wall`, a
/// double-sided wall at x = 0.5 splits the room (with a door at z > 1 − `door`).
pub fn obj(floor: Floor, scale: f64, offset: [f64; 3], wall: Option<f64>) -> String {
    let mut v: Vec<[f64; 3]> = Vec::new();
    let mut f: Vec<([usize; 3], &str)> = Vec::new();
    let quad = |v: &mut Vec<[f64; 3]>, f: &mut Vec<([usize; 3], &'static str)>, p: [[f64; 3]; 4], m: &'static str| {
        let b = v.len();
        v.extend(p);
        f.push(([b, b + 1, b + 2], m));
        f.push(([b, b + 2, b + 3], m));
    };
    // Walls facing into the unit cube (counter-clockwise seen from inside).
    quad(
        &mut v,
        &mut f,
        [[0., 1., 0.], [0., 1., 1.], [1., 1., 1.], [1., 1., 0.]],
        "white",
    ); // ceiling
    quad(
        &mut v,
        &mut f,
        [[0., 0., 1.], [0., 1., 1.], [0., 1., 0.], [0., 0., 0.]],
        "red",
    ); // x = 0
    quad(
        &mut v,
        &mut f,
        [[1., 0., 0.], [1., 1., 0.], [1., 1., 1.], [1., 0., 1.]],
        "green",
    ); // x = 1
    quad(
        &mut v,
        &mut f,
        [[0., 0., 0.], [0., 1., 0.], [1., 1., 0.], [1., 0., 0.]],
        "white",
    ); // z = 0
    quad(
        &mut v,
        &mut f,
        [[1., 0., 1.], [1., 1., 1.], [0., 1., 1.], [0., 0., 1.]],
        "white",
    ); // z = 1
    let floor_quad =
        |v: &mut Vec<[f64; 3]>, f: &mut Vec<([usize; 3], &'static str)>, x0: f64, x1: f64, z0: f64, z1: f64| {
            let b = v.len();
            v.extend([[x0, 0., z0], [x1, 0., z0], [x1, 0., z1], [x0, 0., z1]]);
            f.push(([b, b + 2, b + 1], "white"));
            f.push(([b, b + 3, b + 2], "white"));
        };
    match floor {
        Floor::Plain => floor_quad(&mut v, &mut f, 0., 1., 0., 1.),
        Floor::Slivers => {
            for k in 0..1000 {
                let (z0, z1) = (k as f64 / 1000.0, (k + 1) as f64 / 1000.0);
                floor_quad(&mut v, &mut f, 0., 1., z0, z1);
            }
        }
        Floor::TJunctions => {
            floor_quad(&mut v, &mut f, 0., 0.5, 0., 1.);
            for i in 0..6 {
                for j in 0..6 {
                    let (x0, z0) = (0.5 + i as f64 / 12.0, j as f64 / 6.0);
                    floor_quad(&mut v, &mut f, x0, x0 + 1.0 / 12.0, z0, z0 + 1.0 / 6.0);
                }
            }
        }
        Floor::Coincident => {
            floor_quad(&mut v, &mut f, 0., 1., 0., 1.);
            floor_quad(&mut v, &mut f, 0., 1., 0., 1.);
            floor_quad(&mut v, &mut f, 0.2, 0.7, 0.3, 0.8);
        }
    }
    if let Some(door) = wall {
        // One sheet, both sides lit (or dark): x = 0.5, from z = 0 to 1 − door.
        let b = v.len();
        let z1 = 1.0 - door;
        v.extend([[0.5, 0., 0.], [0.5, 1., 0.], [0.5, 1., z1], [0.5, 0., z1]]);
        f.push(([b, b + 1, b + 2], "white"));
        f.push(([b, b + 2, b + 3], "white"));
    }
    let mut s = String::from("mtllib room.mtl\n");
    for p in &v {
        let q: Vec<f64> = (0..3).map(|i| p[i] * scale + offset[i]).collect();
        let _ = writeln!(s, "v {} {} {}", q[0], q[1], q[2]);
    }
    let mut cur = "";
    for (t, m) in &f {
        if *m != cur {
            let _ = writeln!(s, "usemtl {m}");
            cur = m;
        }
        let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s
}

/// Writes the room with a point light at `light` (room units), intensity scaled so that
/// irradiance is the same at every `scale`; returns the scene file.
#[allow(clippy::too_many_arguments)]
pub fn write(
    dir: &Path,
    floor: Floor,
    scale: f64,
    offset: [f64; 3],
    wall: Option<f64>,
    light: [f64; 3],
    solver: &str,
) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("room.obj"), obj(floor, scale, offset, wall)).unwrap();
    std::fs::write(
        dir.join("room.mtl"),
        "newmtl white\nKd 0.7 0.7 0.7\nnewmtl red\nKd 0.7 0.2 0.2\nnewmtl green\nKd 0.2 0.7 0.2\n",
    )
    .unwrap();
    let l: Vec<f64> = (0..3).map(|i| light[i] * scale + offset[i]).collect();
    let i = scale * scale;
    let c: Vec<f64> = (0..3).map(|k| 0.5 * scale + offset[k]).collect();
    let toml = format!(
        "[[object]]\nmesh = \"room.obj\"\n\n[[light]]\ntype = \"point\"\nposition = [{}, {}, {}]\n\
         intensity = [{i}, {i}, {i}]\n\n[camera]\nposition = [{}, {}, {}]\ntarget = [{}, {}, {}]\n\
         fov = 90.0\nwidth = 16\nheight = 16\n\n[solver]\n{solver}\n",
        l[0],
        l[1],
        l[2],
        c[0],
        c[1],
        c[2] + 0.01 * scale,
        c[0],
        c[1],
        c[2]
    );
    let p = dir.join("room.toml");
    std::fs::write(&p, toml).unwrap();
    p
}

/// Probe points in room units: floor, ceiling and walls, facing in.
pub fn probes() -> Vec<([f64; 3], [f64; 3])> {
    let mut out = Vec::new();
    for &a in &[0.15, 0.35, 0.65, 0.85] {
        for &b in &[0.2, 0.5, 0.8] {
            out.push(([a, 0.0, b], [0., 1., 0.]));
            out.push(([a, 1.0, b], [0., -1., 0.]));
            out.push(([0.0, b, a], [1., 0., 0.]));
            out.push(([a, b, 0.0], [0., 0., 1.]));
        }
    }
    out
}
