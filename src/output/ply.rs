//! The node cloud as binary PLY: world position and normal, level, radius, `E_d`, `E_ind`.

use std::io::Write;
use std::path::Path;

use glam::{Vec3, Vec4Swizzles};

use crate::error::{Error, Result};
use crate::hierarchy::Hierarchy;
use crate::scene::Scene;
use crate::transport::{cpu::node_world, reconstruct, Solution};

/// Writes every node of every level. `E_ind` is the absolute value the solution holds at
/// the node (for the delta hierarchy, the sum of the levels up to the node's own).
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
    for (j, nd) in h.nodes.iter().enumerate() {
        let (x, n) = node_world(scene, h, j);
        let o = nd.object as usize;
        let l = nd.level as usize;
        let eind = if sol.variant.is_delta() {
            reconstruct::delta_sum(h, o, l, Vec3::from(nd.pos), Vec3::from(nd.normal), &sol.values.indirect)
        } else {
            sol.values.indirect[j].xyz()
        };
        let ed = sol.values.direct[j].xyz();
        let r = h.objects[o].radius[l] * scene.objects[o].transform.scale;
        for v in [x.x, x.y, x.z, n.x, n.y, n.z] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&(l as i32).to_le_bytes());
        for v in [r, ed.x, ed.y, ed.z, eind.x, eind.y, eind.z] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    Ok(out)
}
