//! The node cloud as binary PLY: world position and normal, level, radius, `E_d`, `E_ind`.

use std::io::Write;
use std::path::Path;

use glam::{Vec3, Vec4Swizzles};

use crate::error::{Error, Result};
use crate::hierarchy::Hierarchy;
use crate::scene::Scene;
use crate::transport::{cpu::node_world, reconstruct, Solution};

/// The node cloud's columns, one row per node of every level, in world space.
#[derive(Clone, Debug, Default)]
pub struct NodeColumns {
    pub position: Vec<Vec3>,
    pub normal: Vec<Vec3>,
    pub level: Vec<i32>,
    /// The support radius, world units.
    pub radius: Vec<f32>,
    /// Direct irradiance at the node.
    pub e_d: Vec<Vec3>,
    /// Indirect irradiance: the absolute value the solution holds at the node (for the
    /// delta hierarchy, the sum of the levels up to the node's own).
    pub e_ind: Vec<Vec3>,
}

/// Every node's columns.
pub fn columns(scene: &Scene, h: &Hierarchy, sol: &Solution) -> NodeColumns {
    let mut c = NodeColumns::default();
    for (j, nd) in h.nodes.iter().enumerate() {
        let (x, n) = node_world(scene, h, j);
        let o = nd.object as usize;
        let l = nd.level as usize;
        let eind = if sol.variant.is_delta() {
            reconstruct::delta_sum(h, o, l, Vec3::from(nd.pos), Vec3::from(nd.normal), &sol.values.indirect)
        } else {
            sol.values.indirect[j].xyz()
        };
        c.position.push(x);
        c.normal.push(n);
        c.level.push(l as i32);
        c.radius.push(h.objects[o].radius[l] * scene.objects[o].transform.scale);
        c.e_d.push(sol.values.direct[j].xyz());
        c.e_ind.push(eind);
    }
    c
}

/// Writes every node of every level ([`columns`]).
pub fn encode(path: &Path, scene: &Scene, h: &Hierarchy, sol: &Solution) -> Result<Vec<u8>> {
    let mut out = Vec::with_capacity(64 + h.nodes.len() * 52);
    let props = ["x", "y", "z", "nx", "ny", "nz"];
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\ncomment meshrad node cloud\nelement vertex {}\n",
        h.nodes.len()
    )
    .and_then(|_| {
        for p in props {
            writeln!(out, "property float {p}")?;
        }
        writeln!(out, "property int level")?;
        for p in ["radius", "ed_r", "ed_g", "ed_b", "eind_r", "eind_g", "eind_b"] {
            writeln!(out, "property float {p}")?;
        }
        writeln!(out, "end_header")
    })
    .map_err(|e| Error::io(path, e))?;
    let c = columns(scene, h, sol);
    for j in 0..c.level.len() {
        let (x, n, ed, eind) = (c.position[j], c.normal[j], c.e_d[j], c.e_ind[j]);
        for v in [x.x, x.y, x.z, n.x, n.y, n.z] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&c.level[j].to_le_bytes());
        for v in [c.radius[j], ed.x, ed.y, ed.z, eind.x, eind.y, eind.z] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    Ok(out)
}
