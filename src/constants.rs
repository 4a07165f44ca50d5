//! Constants shared with GLSL. `build.rs` parses this file (one `pub const NAME: u32 = V;`
//! or `pub const NAME: f32 = V;` per line) and writes `#define NAME Vu` (or the float
//! literal as written) into the generated `constants.glsl`, so that each value is typed
//! once.

/// The most hierarchy levels a scene may ask for.
pub const MAX_LEVELS: u32 = 8;
/// Sentinel for "none" in index fields.
pub const NONE: u32 = 0xffff_ffff;
/// Light kinds.
pub const LIGHT_POINT: u32 = 0;
pub const LIGHT_SPOT: u32 = 1;
pub const LIGHT_DIRECTIONAL: u32 = 2;
/// BVH traversal stack entries; a deeper BVH is rejected at build time.
pub const BVH_STACK: u32 = 64;
/// kd-tree traversal stack entries (enough for 2^31 nodes).
pub const KD_STACK: u32 = 32;
/// Threads per workgroup of the per-integral kernels.
pub const GATHER_GROUP: u32 = 128;
/// Threads per workgroup of the per-element kernels.
pub const LINEAR_GROUP: u32 = 64;
/// Variants as the GLSL specialization constant `VARIANT` sees them.
pub const VARIANT_ORIGINAL: u32 = 0;
pub const VARIANT_MODIFIED: u32 = 1;
pub const VARIANT_APPROX: u32 = 2;
/// BVH kinds as the GLSL specialization constant `BVH_KIND` sees them.
pub const BVH_BVH2: u32 = 0;
pub const BVH_CWBVH: u32 = 1;
/// Clip-plane distances are stored as `d / CLIP_SCALE · h` (see hierarchy::weight).
pub const CLIP_SCALE: u32 = 50000;
/// The `counters` buffer (u32 slots): per level l, `COUNTERS_PER_LEVEL` slots from
/// `COUNTERS_PER_LEVEL · l`: the nodes of level l the oracle refined
/// (`+ COUNTER_REFINED`) and the nodes of level l + 1 they activated, the next level's
/// active count (`+ COUNTER_ACTIVATED`), of which, where `compact` splits the active
/// set, those that hold links are counted apart (`+ COUNTER_LINKED`: the next level's
/// linked list; the active count is then the sum); then the nodes lit per light i at
/// `LIGHT_COUNTERS + i` (LIGHT_COUNTERS ≥ COUNTERS_PER_LEVEL · MAX_LEVELS).
pub const COUNTERS_PER_LEVEL: u32 = 3;
pub const COUNTER_REFINED: u32 = 0;
pub const COUNTER_ACTIVATED: u32 = 1;
pub const COUNTER_LINKED: u32 = 2;
pub const LIGHT_COUNTERS: u32 = 32;
/// The `energy` buffer (f32 slots): the level-0 sums of mean(un-shot) and mean(direct)
/// (the stop criterion), and from `ENERGY_MEAN_DIRECT` three slots of mean direct
/// irradiance per channel (the oracle's ε_abs scale); `ENERGY_SLOTS` in all.
pub const ENERGY_UNSHOT: u32 = 0;
pub const ENERGY_DIRECT: u32 = 1;
pub const ENERGY_MEAN_DIRECT: u32 = 4;
pub const ENERGY_SLOTS: u32 = 8;
/// The `dispatch_args` buffer (u32 slots): per batch b of a device-sized level,
/// `DISPATCH_PER_BATCH` words from `DISPATCH_PER_BATCH · b`: the ray kernels' grid at
/// `+ DISPATCH_RAYS` and the reduction's at `+ DISPATCH_REDUCE`, each a
/// VkDispatchIndirectCommand of `DISPATCH_WORDS` words (x, y, z).
pub const DISPATCH_WORDS: u32 = 3;
pub const DISPATCH_RAYS: u32 = 0;
pub const DISPATCH_REDUCE: u32 = 3;
pub const DISPATCH_PER_BATCH: u32 = 6;
/// The links on the device (`ALGORITHM.md` §5.6): a node's `link_slot` is `NONE`, or
/// its slot with `LINK_RECORDING` set while its first traced gather records the links
/// (cleared by `reduce`: from then on its gathers read them). The `link_counters` buffer
/// (u32 slots): slots handed out, integrals read from links, integrals traced that read
/// the sender level, and of those the ones that found no slot free; nodes given slots,
/// and the slots the linked integrals read. A slot holds `rays_per_integral` links; a
/// level-1 node takes `level1_rays` consecutive slots.
pub const LINK_RECORDING: u32 = 0x8000_0000;
pub const LINK_TAKEN: u32 = 0;
pub const LINK_LINKED: u32 = 1;
pub const LINK_TRACED: u32 = 2;
pub const LINK_TRACED_FULL: u32 = 3;
pub const LINK_NODES: u32 = 4;
pub const LINK_LINKED_SLOTS: u32 = 5;
pub const LINK_COUNTERS: u32 = 6;
/// Threads of the one workgroup of the `energy` kernel (a power of two).
pub const ENERGY_GROUP: u32 = 256;
/// Stack entries of the GPU's CWBVH traversal; the CWBVH builder keeps within it.
pub const CWBVH_STACK: u32 = 32;
/// Specialization constant ids: the variant, whether textures are sampled, the BVH kind.
/// `Globals::sky_kind`: no sky, a constant one, an environment map.
pub const SKY_NONE: u32 = 0;
pub const SKY_CONSTANT: u32 = 1;
pub const SKY_MAP: u32 = 2;
/// Up to this many emitting triangles, each receiving point weighs them by the solid
/// angle they subtend there (`scene::emitter`).
pub const LOCAL_WEIGHTS: u32 = 64;
/// Emitting triangles subtending less than this solid angle (sr) are sampled by area.
pub const SPHERICAL_MIN: f32 = 0.001;
pub const SPEC_VARIANT: u32 = 0;
pub const SPEC_TEXTURED: u32 = 1;
pub const SPEC_BVH_KIND: u32 = 2;
/// The slab test's far distance is scaled by this (conservative traversal, Ize 2013).
pub const SLAB_FAR: f32 = 1.000_000_4;
/// Shadow rays towards a point or spot light stop at this fraction of the distance.
pub const SHADOW_TMAX: f32 = 0.9999;
/// Clip-plane directions are stored as i16 components of a unit vector times this.
pub const CLIP_DIR: f32 = 32767.0;
/// Ray offsets: 32 ulps along the normal, or `scale / OFFSET_FINE_DIV` (2^-21 of the
/// scene's size) where a coordinate is within `scale / OFFSET_NEAR_DIV` of zero.
pub const OFFSET_ULPS: f32 = 32.0;
pub const OFFSET_NEAR_DIV: f32 = 32.0;
pub const OFFSET_FINE_DIV: f32 = 2_097_152.0;

// The slot layouts fit together (checked at compile time; build.rs reads only the
// `pub const` lines above).
const _: () = {
    assert!(LIGHT_COUNTERS >= COUNTERS_PER_LEVEL * MAX_LEVELS);
    assert!(COUNTER_REFINED < COUNTERS_PER_LEVEL && COUNTER_ACTIVATED < COUNTERS_PER_LEVEL);
    assert!(COUNTER_LINKED < COUNTERS_PER_LEVEL);
    assert!(ENERGY_UNSHOT == 0 && ENERGY_DIRECT == 1); // read back as the first two slots
    assert!(ENERGY_MEAN_DIRECT >= 2 && ENERGY_MEAN_DIRECT + 3 <= ENERGY_SLOTS);
    assert!(DISPATCH_RAYS + DISPATCH_WORDS <= DISPATCH_REDUCE);
    assert!(DISPATCH_REDUCE + DISPATCH_WORDS <= DISPATCH_PER_BATCH);
};
/// `ImageInfo::filter_kind`: the pixel filter (`scene::camera::Filter`).
pub const FILTER_BOX: u32 = 0;
pub const FILTER_GAUSSIAN: u32 = 1;
/// `ImageInfo::mode`: how the `image` kernel reads the indirect light at a sample's hit
/// (`transport::readout`): the basis, a gather where the basis read is doubted
/// (`doubt_gather`), a gather everywhere (`final_gather_pixels`).
pub const IMAGE_BASIS: u32 = 0;
pub const IMAGE_DOUBT: u32 = 1;
pub const IMAGE_GATHER: u32 = 2;
/// The `image` kernel's passes (`ImagePush::pass`): one thread per sample and chunk of
/// its gather, then one per pixel summing them.
pub const IMAGE_PASS_SAMPLES: u32 = 0;
pub const IMAGE_PASS_PIXELS: u32 = 1;
/// Most gather rays one `image` thread traces (a sample's gather is split into chunks of
/// at most this many, one thread each): llvmpipe ends a loop nest silently past 65535
/// iterations, and a ray in a large scene takes hundreds (BVH, shadow ray, kd-tree).
pub const IMAGE_CHUNK_RAYS: u32 = 32;
/// Most sample slots of one `image` band (2^20: 32 MiB), so that no submission runs long
/// and the band's buffer stays small.
pub const IMAGE_BAND_SLOTS: u32 = 1048576;
/// Most slots one pixel sums (samples × chunks), within llvmpipe's loop limit.
pub const IMAGE_PIXEL_SLOTS: u32 = 60000;
