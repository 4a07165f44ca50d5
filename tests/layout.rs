//! The host structs of `src/layout.rs` and `src/gpu/globals.rs` against the `Offset`
//! decorations that the GLSL compiler gives their mirrors in `glsl/include/layout.glsl`:
//! every kernel is compiled again without optimisation (which keeps the names), the
//! SPIR-V is read, and each member's offset must equal Rust's `offset_of!`. A struct
//! that two kernels lay out differently fails too.

use std::collections::BTreeMap;
use std::mem::offset_of;
use std::path::{Path, PathBuf};
use std::process::Command;

use meshrad::device::globals::Globals;
use meshrad::device::kernels::{
    accumulate::AccumulatePush, batches::BatchesPush, clips::ClipsPush, compact::CompactPush, delta::DeltaPush,
    direct::DirectPush, energy::EnergyPush, gather::GatherPush, image::ImagePush, oracle::OraclePush,
    poisson::PoissonPush, pulldown::PulldownPush,
};
use meshrad::layout::*;

/// (struct, member) → offset, from one SPIR-V module.
fn member_offsets(spv: &[u8]) -> BTreeMap<(String, String), u32> {
    let w: Vec<u32> = spv
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    assert_eq!(w[0], 0x0723_0203, "SPIR-V magic");
    let string = |words: &[u32]| {
        let bytes: Vec<u8> = words
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .take_while(|&b| b != 0)
            .collect();
        String::from_utf8(bytes).unwrap()
    };
    let (mut names, mut members, mut offsets) = (BTreeMap::new(), BTreeMap::new(), Vec::new());
    let mut i = 5;
    while i < w.len() {
        let (count, op) = ((w[i] >> 16) as usize, w[i] & 0xffff);
        let args = &w[i + 1..i + count];
        match op {
            5 => {
                names.insert(args[0], string(&args[1..]));
            }
            6 => {
                members.insert((args[0], args[1]), string(&args[2..]));
            }
            // OpMemberDecorate … Offset
            72 if args[2] == 35 => offsets.push((args[0], args[1], args[3])),
            _ => {}
        }
        i += count.max(1);
    }
    offsets
        .into_iter()
        .filter_map(|(ty, m, off)| {
            let s = names.get(&ty)?;
            let n = members.get(&(ty, m))?;
            Some(((s.clone(), n.clone()), off))
        })
        .collect()
}

/// Every kernel, compiled without optimisation; the union of their layouts.
fn glsl_layouts() -> BTreeMap<(String, String), u32> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("constants.glsl"), meshrad::gpu::shaders::CONSTANTS_GLSL).unwrap();
    let glslc: PathBuf = std::env::var_os("GLSLC")
        .map(PathBuf::from)
        .unwrap_or_else(|| "glslc".into());
    let mut all: BTreeMap<(String, String), (u32, String)> = BTreeMap::new();
    let mut kernels: Vec<_> = std::fs::read_dir(root.join("glsl"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "comp"))
        .collect();
    kernels.sort();
    assert!(!kernels.is_empty());
    for k in &kernels {
        let out = tmp.path().join("k.spv");
        let st = Command::new(&glslc)
            .args(["--target-env=vulkan1.2", "-O0", "-g"])
            .arg(format!("-I{}", root.join("glsl/include").display()))
            .arg(format!("-I{}", tmp.path().display()))
            .arg("-o")
            .arg(&out)
            .arg(k)
            .status()
            .unwrap_or_else(|e| panic!("running {} (install glslc: bash .ci/setup): {e}", glslc.display()));
        assert!(st.success(), "compiling {}", k.display());
        let name = k.file_stem().unwrap().to_string_lossy().into_owned();
        for (key, off) in member_offsets(&std::fs::read(&out).unwrap()) {
            if let Some((o, first)) = all.get(&key) {
                assert_eq!(*o, off, "{key:?}: offset {o} in {first}, {off} in {name}");
            } else {
                all.insert(key, (off, name.clone()));
            }
        }
    }
    all.into_iter().map(|(k, (o, _))| (k, o)).collect()
}

/// Long by design: one line per shared struct, listing its members.
#[test]
fn gpu_struct_offsets_match_the_host_structs() {
    let glsl = glsl_layouts();
    let mut checked = 0;
    let mut check = |s: &str, member: &str, rust: usize| {
        let key = (s.to_string(), member.to_string());
        let got = glsl
            .get(&key)
            .unwrap_or_else(|| panic!("{s}.{member} is in no kernel's SPIR-V (renamed or unused?)"));
        assert_eq!(*got as usize, rust, "{s}.{member}: GLSL offset {got}, Rust {rust}");
        checked += 1;
    };
    macro_rules! same {
        ($t:ty, $glsl:expr, $($f:ident),+) => {
            $( check($glsl, stringify!($f), offset_of!($t, $f)); )+
        };
    }
    same!(Tri, "Tri", v0, material, v1, pad0, v2, pad1);
    same!(TriUv, "TriUv", uv);
    same!(Node, "Node", pos, level, normal, object);
    same!(KdSplit, "KdSplit", value, dim);
    same!(Parent, "Parent", node, weight);
    same!(Material, "Material", kd, texture, alpha_texture, opacity, cutoff);
    same!(
        GpuEmitter,
        "GpuEmitter",
        tri,
        object,
        prob,
        cdf,
        radiance,
        lum,
        scale,
        texture
    );
    same!(TextureInfo, "TextureInfo", offset, width, height, wrap);
    same!(GpuLight, "GpuLight", position, kind, direction, cutoff, power, beam);
    same!(
        ObjectInfo,
        "ObjectInfo",
        to_object,
        to_world,
        scale,
        tri_offset,
        tri_count,
        bvh_offset,
        level_start,
        level_count,
        radius,
        cw_root
    );
    check("ObjectInfo", "pad0", offset_of!(ObjectInfo, pad));
    check("BvhNode", "lo", offset_of!(BvhNode, aabb));
    check("BvhNode", "hi", offset_of!(BvhNode, aabb) + 16);
    check("BvhNode", "prim_count", offset_of!(BvhNode, prim_count));
    check("BvhNode", "first_index", offset_of!(BvhNode, first_index));
    check("CwNode", "p", offset_of!(CwNode, p));
    check("CwNode", "e_imask", offset_of!(CwNode, e));
    check("CwNode", "child_base", offset_of!(CwNode, child_base_idx));
    check("CwNode", "prim_base", offset_of!(CwNode, primitive_base_idx));
    check("CwNode", "meta", offset_of!(CwNode, child_meta));
    check("CwNode", "lox", offset_of!(CwNode, child_min_x));
    check("CwNode", "hix", offset_of!(CwNode, child_max_x));
    check("CwNode", "loy", offset_of!(CwNode, child_min_y));
    check("CwNode", "hiy", offset_of!(CwNode, child_max_y));
    check("CwNode", "loz", offset_of!(CwNode, child_min_z));
    check("CwNode", "hiz", offset_of!(CwNode, child_max_z));
    same!(
        Globals,
        "GlobalsRef",
        tris,
        uvs,
        bvh,
        cw_nodes,
        cw_prims,
        materials,
        textures,
        texels,
        srgb,
        lights,
        objects,
        nodes,
        splits,
        clips,
        parent_offset,
        parents,
        child_offset,
        children,
        halton,
        direct,
        unshot,
        next,
        indirect,
        pred,
        gathered_mean,
        gathered_err,
        active_flag,
        child_flag,
        active_list,
        linked_list,
        counters,
        rays,
        hits,
        contrib,
        energy,
        dispatch_args,
        link_slot,
        links,
        link_counters,
        num_objects,
        num_lights,
        rays_per_integral,
        seed,
        scene_scale,
        kappa,
        alpha,
        approx_cos,
        eps_rel,
        eps_abs,
        noise_z,
        levels,
        sender_level,
        link_capacity
    );
    same!(
        ImageInfo,
        "ImageInfoRef",
        position,
        forward,
        right,
        up,
        normals,
        halton,
        width,
        height,
        spp,
        filter_kind,
        level,
        seed,
        mode,
        gather_rays,
        doubt_nodes,
        doubt_spread,
        chunks,
        chunk_rays,
        short_hops
    );
    assert_eq!(std::mem::size_of::<ImageInfo>(), 144);
    // Each kernel's push constants (one block per kernel; the four kernels of a gathering
    // batch share GatherPush).
    check("ImagePush", "g", offset_of!(ImagePush, globals));
    same!(
        ImagePush,
        "ImagePush",
        info,
        slots,
        pixels,
        first_pixel,
        count,
        pass,
        pad0
    );
    check("DirectPush", "g", offset_of!(DirectPush, globals));
    same!(DirectPush, "DirectPush", first, count);
    check("AccumulatePush", "g", offset_of!(AccumulatePush, globals));
    same!(AccumulatePush, "AccumulatePush", first, count);
    check("PulldownPush", "g", offset_of!(PulldownPush, globals));
    same!(PulldownPush, "PulldownPush", first, count, fill, pad0);
    check("DeltaPush", "g", offset_of!(DeltaPush, globals));
    same!(DeltaPush, "DeltaPush", first, count, level, init);
    check("OraclePush", "g", offset_of!(OraclePush, globals));
    same!(
        OraclePush,
        "OraclePush",
        first,
        count,
        level,
        activate,
        sparse_parents,
        pad
    );
    check("CompactPush", "g", offset_of!(CompactPush, globals));
    same!(CompactPush, "CompactPush", first, count, parent_level, split);
    check("EnergyPush", "g", offset_of!(EnergyPush, globals));
    same!(EnergyPush, "EnergyPush", first, count, mean_direct, pad0);
    check("BatchesPush", "g", offset_of!(BatchesPush, globals));
    same!(
        BatchesPush,
        "BatchesPush",
        batches,
        batch_size,
        count_slot,
        max_groups_x,
        first_batch,
        pad0
    );
    check("ClipsPush", "g", offset_of!(ClipsPush, globals));
    same!(
        ClipsPush,
        "ClipsPush",
        box_list,
        moved,
        out_nodes,
        out_clips,
        out_count,
        count,
        boxes,
        eps,
        pad0
    );
    check("PoissonPush", "g", offset_of!(PoissonPush, globals));
    same!(
        PoissonPush,
        "PoissonPush",
        cands,
        state,
        memo,
        table,
        fill,
        sorted,
        counters,
        count,
        mask,
        r,
        r2,
        inv_cell,
        d_min,
        diag,
        object,
        within,
        stage,
        round,
        pad0
    );
    check("GatherPush", "g", offset_of!(GatherPush, globals));
    same!(
        GatherPush,
        "GatherPush",
        first,
        count,
        batch_first,
        from_list,
        count_slot,
        exact_direct,
        rays,
        pad0
    );
    println!("LAYOUT {checked} members checked against the SPIR-V of every kernel");
}

/// Every kernel has its wrapper beside it: `glsl/<name>.comp` ↔ `src/device/kernels/<name>.rs`.
#[test]
fn every_kernel_has_its_wrapper() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut n = 0;
    for e in std::fs::read_dir(root.join("glsl")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|e| e == "comp") {
            let name = p.file_stem().unwrap().to_string_lossy().into_owned();
            let rs = root.join("src/device/kernels").join(format!("{name}.rs"));
            assert!(rs.is_file(), "{} has no wrapper {}", p.display(), rs.display());
            assert!(
                meshrad::device::kernels::NAMES.contains(&name.as_str()),
                "{name} is not in meshrad::device::kernels::NAMES"
            );
            n += 1;
        }
    }
    assert_eq!(n, meshrad::device::kernels::NAMES.len());
}
