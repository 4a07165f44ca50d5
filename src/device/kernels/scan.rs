//! Kernel `scan` (`glsl/scan.comp`): the exclusive prefix sum of a word array, in place
//! (blocks, block totals, add), for the relations' CSR offsets.

use bytemuck::{Pod, Zeroable};

use super::{kernel, Recorder};
use crate::constants::LINEAR_GROUP;

/// Words per block of the first and last dispatch (GLSL `SCAN_BLOCK`).
pub const SCAN_BLOCK: u64 = LINEAR_GROUP as u64 * 4;

/// The push constants of `scan` (GLSL `ScanPush`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct ScanPush {
    pub globals: u64,
    /// Address of the words scanned in place.
    pub data: u64,
    /// Address of one word per block of [`SCAN_BLOCK`].
    pub sums: u64,
    /// Words of `data`.
    pub count: u32,
    /// 0: blocks, 1: block totals, 2: add.
    pub mode: u32,
}

kernel!(Scan, "scan", SCAN, ScanPush);

impl Scan {
    /// Blocks of `count` words: the size of the `sums` buffer [`Scan::record`] needs.
    pub fn blocks(count: u64) -> u64 {
        count.div_ceil(SCAN_BLOCK)
    }

    /// Records the exclusive scan of `count` words at `data`, with `sums` holding
    /// [`Scan::blocks`] words; barriers between its three dispatches and after.
    pub fn record(&self, rec: &mut Recorder, data: u64, sums: u64, count: u32) {
        let blocks = Scan::blocks(count as u64);
        for (mode, groups) in [(0, blocks), (1, 1), (2, blocks)] {
            let push = ScanPush {
                globals: rec.globals,
                data,
                sums,
                count,
                mode,
            };
            rec.dispatch(&self.0, &push, groups);
            rec.barrier();
        }
    }
}
