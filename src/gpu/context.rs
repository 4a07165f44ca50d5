//! The headless compute context: instance (with the validation layer and a debug
//! messenger that counts errors, when asked), physical-device choice, one compute queue,
//! the allocator and a command pool. Every handle is released in `Drop`, in order.

use std::ffi::{c_void, CStr, CString};
use std::mem::ManuallyDrop;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Mutex;

use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};

use super::VkCheck;
use crate::error::{Error, Result};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// How to create a context.
#[derive(Clone, Debug, Default)]
pub struct ContextOptions {
    /// Enable the Khronos validation layer and count its errors (fails if it is missing).
    pub validation: bool,
    /// Pick a device by index (as `meshrad devices` lists them) or by name substring.
    pub device: Option<String>,
}

impl ContextOptions {
    /// Validation on when `MESHRAD_VALIDATION=1` is set.
    pub fn from_env(device: Option<String>) -> Self {
        ContextOptions {
            validation: std::env::var("MESHRAD_VALIDATION").is_ok_and(|v| v == "1"),
            device,
        }
    }
}

/// What a device is and what it allows.
#[derive(Clone, Debug, serde::Serialize)]
pub struct DeviceInfo {
    pub index: usize,
    pub name: String,
    pub device_type: String,
    pub driver_name: String,
    pub driver_info: String,
    pub driver_version: u32,
    pub api_version: String,
    pub subgroup_size: u32,
    pub timestamp_period_ns: f32,
    pub max_workgroup_count_x: u32,
    pub max_allocation_bytes: u64,
    pub device_local_bytes: u64,
    /// Why the device cannot be used, if it cannot.
    pub unusable: Option<String>,
}

/// Errors and warnings seen by the debug messenger.
#[derive(Default)]
pub struct ValidationLog {
    pub errors: AtomicU32,
    pub messages: Mutex<Vec<String>>,
}

/// A Vulkan device ready for compute.
pub struct Context {
    pub info: DeviceInfo,
    pub device: ash::Device,
    pub queue: vk::Queue,
    pub queue_family: u32,
    pub pool: vk::CommandPool,
    pub timestamps: bool,
    pub allocator: ManuallyDrop<Mutex<Allocator>>,
    pub log: Box<ValidationLog>,
    physical: vk::PhysicalDevice,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    instance: ash::Instance,
    _entry: ash::Entry,
}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    // SAFETY: `user` is the `ValidationLog` boxed in the context, which outlives the
    // messenger; `data` is valid for the duration of the callback per the spec.
    unsafe {
        let log = &*(user as *const ValidationLog);
        let msg = if data.is_null() || (*data).p_message.is_null() {
            String::from("(no message)")
        } else {
            CStr::from_ptr((*data).p_message).to_string_lossy().into_owned()
        };
        if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
            log.errors.fetch_add(1, Ordering::Relaxed);
            eprintln!("vulkan validation error: {msg}");
        }
        if let Ok(mut m) = log.messages.lock() {
            if m.len() < 64 {
                m.push(msg);
            }
        }
    }
    vk::FALSE
}

fn load_entry() -> Result<ash::Entry> {
    // SAFETY: loading the system Vulkan loader; ash checks the symbols it resolves.
    unsafe { ash::Entry::load() }.map_err(|e| {
        Error::Gpu(format!(
            "the Vulkan loader (libvulkan.so.1) could not be loaded: {e}; install it \
             (Debian: apt-get install libvulkan1 mesa-vulkan-drivers)"
        ))
    })
}

fn create_instance(entry: &ash::Entry, validation: bool) -> Result<ash::Instance> {
    let app = CString::new("meshrad").expect("static name");
    let app_info = vk::ApplicationInfo::default()
        .application_name(&app)
        .engine_name(&app)
        .api_version(vk::API_VERSION_1_2);
    let mut layers = Vec::new();
    let mut extensions = Vec::new();
    if validation {
        // SAFETY: plain enumeration call on a loaded entry.
        let available =
            unsafe { entry.enumerate_instance_layer_properties() }.vk("vkEnumerateInstanceLayerProperties")?;
        let has = available
            .iter()
            .any(|l| l.layer_name_as_c_str().is_ok_and(|n| n == VALIDATION_LAYER));
        if !has {
            return Err(Error::Gpu(
                "validation was requested but VK_LAYER_KHRONOS_validation is not installed \
                 (Debian: apt-get install vulkan-validationlayers)"
                    .into(),
            ));
        }
        layers.push(VALIDATION_LAYER.as_ptr());
        extensions.push(ash::ext::debug_utils::NAME.as_ptr());
    }
    let info = vk::InstanceCreateInfo::default()
        .application_info(&app_info)
        .enabled_layer_names(&layers)
        .enabled_extension_names(&extensions);
    // SAFETY: every pointer in `info` outlives the call.
    unsafe { entry.create_instance(&info, None) }.vk("vkCreateInstance")
}

fn type_name(t: vk::PhysicalDeviceType) -> &'static str {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => "discrete GPU",
        vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated GPU",
        vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual GPU",
        vk::PhysicalDeviceType::CPU => "CPU",
        _ => "other",
    }
}

fn describe(instance: &ash::Instance, pd: vk::PhysicalDevice, index: usize) -> DeviceInfo {
    let mut driver = vk::PhysicalDeviceDriverProperties::default();
    let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
    let mut props2 = vk::PhysicalDeviceProperties2::default()
        .push_next(&mut driver)
        .push_next(&mut subgroup);
    let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
    let mut feats2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut f12);
    // SAFETY: queries on a valid physical device with correctly chained structs.
    let (mem, queues) = unsafe {
        instance.get_physical_device_properties2(pd, &mut props2);
        instance.get_physical_device_features2(pd, &mut feats2);
        (
            instance.get_physical_device_memory_properties(pd),
            instance.get_physical_device_queue_family_properties(pd),
        )
    };
    let int64 = feats2.features.shader_int64;
    let p = props2.properties;
    let api = p.api_version;
    let local: u64 = mem.memory_heaps[..mem.memory_heap_count as usize]
        .iter()
        .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
        .map(|h| h.size)
        .max()
        .unwrap_or(0);
    let mut unusable = None;
    if vk::api_version_major(api) == 1 && vk::api_version_minor(api) < 2 {
        unusable = Some("Vulkan 1.2 is required".to_string());
    } else if f12.buffer_device_address == vk::FALSE {
        unusable = Some("bufferDeviceAddress is not supported".to_string());
    } else if int64 == vk::FALSE {
        // The emitters' and sky's per-point sample shifts are 64-bit hashes (emitters.glsl).
        unusable = Some("shaderInt64 is not supported".to_string());
    } else if !queues.iter().any(|q| q.queue_flags.contains(vk::QueueFlags::COMPUTE)) {
        unusable = Some("no compute queue".to_string());
    }
    DeviceInfo {
        index,
        name: p
            .device_name_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        device_type: type_name(p.device_type).into(),
        driver_name: driver
            .driver_name_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        driver_info: driver
            .driver_info_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        driver_version: p.driver_version,
        api_version: format!(
            "{}.{}.{}",
            vk::api_version_major(api),
            vk::api_version_minor(api),
            vk::api_version_patch(api)
        ),
        subgroup_size: subgroup.subgroup_size,
        timestamp_period_ns: p.limits.timestamp_period,
        max_workgroup_count_x: p.limits.max_compute_work_group_count[0],
        max_allocation_bytes: 0,
        device_local_bytes: local,
        unusable,
    }
}

fn rank(t: &str) -> u32 {
    match t {
        "discrete GPU" => 0,
        "integrated GPU" => 1,
        "virtual GPU" => 2,
        "CPU" => 3,
        _ => 4,
    }
}

/// Every Vulkan device the loader sees, with why any is unusable.
pub fn list_devices() -> Result<Vec<DeviceInfo>> {
    let entry = load_entry()?;
    let instance = create_instance(&entry, false)?;
    // SAFETY: the instance is valid and destroyed right after.
    let list = unsafe {
        let pds = instance.enumerate_physical_devices().vk("vkEnumeratePhysicalDevices");
        let out = pds.map(|pds| {
            pds.iter()
                .enumerate()
                .map(|(i, &pd)| describe(&instance, pd, i))
                .collect()
        });
        instance.destroy_instance(None);
        out
    };
    list
}

fn pick(infos: &[DeviceInfo], want: Option<&str>) -> Result<usize> {
    match want {
        Some(w) => {
            let found = match w.parse::<usize>() {
                Ok(i) => infos.iter().position(|d| d.index == i),
                Err(_) => infos
                    .iter()
                    .position(|d| d.name.to_lowercase().contains(&w.to_lowercase())),
            };
            let i = found.ok_or_else(|| {
                Error::Gpu(format!(
                    "no Vulkan device matches `--device {w}`; `meshrad devices` lists {}",
                    infos
                        .iter()
                        .map(|d| format!("{}: {}", d.index, d.name))
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            })?;
            if let Some(why) = &infos[i].unusable {
                return Err(Error::Gpu(format!(
                    "device {} ({}) is unusable: {why}",
                    i, infos[i].name
                )));
            }
            Ok(i)
        }
        None => infos
            .iter()
            .filter(|d| d.unusable.is_none())
            .min_by_key(|d| (rank(&d.device_type), d.index))
            .map(|d| d.index)
            .ok_or_else(|| {
                Error::Gpu(if infos.is_empty() {
                    "no Vulkan device found (Debian: apt-get install mesa-vulkan-drivers for lavapipe)".into()
                } else {
                    format!(
                        "no usable Vulkan device: {}",
                        infos
                            .iter()
                            .map(|d| format!("{} ({})", d.name, d.unusable.clone().unwrap_or_default()))
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                })
            }),
    }
}

impl Context {
    /// Creates the instance, picks a device and creates the logical device, queue,
    /// allocator and command pool.
    pub fn new(opts: &ContextOptions) -> Result<Context> {
        let entry = load_entry()?;
        let instance = create_instance(&entry, opts.validation)?;
        let log = Box::<ValidationLog>::default();
        // From here on, a failure must destroy what exists: build in a closure.
        let debug = if opts.validation {
            let du = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(
                    vk::DebugUtilsMessageSeverityFlagsEXT::ERROR | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
                )
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                        | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                        | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
                )
                .pfn_user_callback(Some(debug_callback))
                .user_data(&*log as *const ValidationLog as *mut c_void);
            // SAFETY: the callback and the boxed log outlive the messenger (destroyed in Drop).
            match unsafe { du.create_debug_utils_messenger(&info, None) } {
                Ok(m) => Some((du, m)),
                Err(r) => {
                    // SAFETY: nothing else was created from this instance.
                    unsafe { instance.destroy_instance(None) };
                    return Err(super::vk_err("vkCreateDebugUtilsMessengerEXT", r));
                }
            }
        } else {
            None
        };
        let partial = Partial {
            instance: Some(instance),
            debug,
            entry: Some(entry),
        };
        partial.finish(log, opts)
    }

    /// Allocates a primary command buffer, records `f` into it, submits it and waits.
    pub fn run<T>(&self, f: impl FnOnce(vk::CommandBuffer) -> Result<T>) -> Result<T> {
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(self.pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: pool and device are valid; the buffer is freed before returning.
        unsafe {
            let cmd = self
                .device
                .allocate_command_buffers(&alloc)
                .vk("vkAllocateCommandBuffers")?[0];
            let result = (|| {
                self.device
                    .begin_command_buffer(
                        cmd,
                        &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                    )
                    .vk("vkBeginCommandBuffer")?;
                let out = f(cmd)?;
                self.device.end_command_buffer(cmd).vk("vkEndCommandBuffer")?;
                let fence = self
                    .device
                    .create_fence(&vk::FenceCreateInfo::default(), None)
                    .vk("vkCreateFence")?;
                let cmds = [cmd];
                let submit = vk::SubmitInfo::default().command_buffers(&cmds);
                let r = self
                    .device
                    .queue_submit(self.queue, &[submit], fence)
                    .vk("vkQueueSubmit")
                    .and_then(|_| {
                        self.device
                            .wait_for_fences(&[fence], true, u64::MAX)
                            .vk("vkWaitForFences")
                    });
                self.device.destroy_fence(fence, None);
                r.map(|_| out)
            })();
            self.device.free_command_buffers(self.pool, &[cmd]);
            result
        }
    }

    /// Validation errors reported so far.
    pub fn validation_errors(&self) -> u32 {
        self.log.errors.load(Ordering::Relaxed)
    }

    /// The physical device (for the allocator and limits).
    pub fn physical(&self) -> vk::PhysicalDevice {
        self.physical
    }

    /// The instance.
    pub fn instance(&self) -> &ash::Instance {
        &self.instance
    }
}

/// An instance (and messenger) not yet owned by a `Context`: destroyed on failure, before
/// the loader (`entry`) is unloaded.
struct Partial {
    instance: Option<ash::Instance>,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    entry: Option<ash::Entry>,
}

impl Drop for Partial {
    fn drop(&mut self) {
        // SAFETY: only reached when `finish` failed before creating the device.
        unsafe {
            if let Some((du, m)) = self.debug.take() {
                du.destroy_debug_utils_messenger(m, None);
            }
            if let Some(i) = self.instance.take() {
                i.destroy_instance(None);
            }
        }
    }
}

impl Partial {
    fn finish(mut self, log: Box<ValidationLog>, opts: &ContextOptions) -> Result<Context> {
        let instance = self.instance.as_ref().expect("instance present").clone();
        let chosen = choose_device(&instance, opts)?;
        let (device, queue, pool, allocator) = open_device(&instance, chosen.physical, chosen.queue_family)?;
        let instance = self.instance.take().expect("instance present");
        let debug = self.debug.take();
        let entry = self.entry.take().expect("entry present");
        Ok(Context {
            info: chosen.info,
            device,
            queue,
            queue_family: chosen.queue_family,
            pool,
            timestamps: chosen.timestamps,
            allocator: ManuallyDrop::new(Mutex::new(allocator)),
            log,
            physical: chosen.physical,
            debug,
            instance,
            _entry: entry,
        })
    }
}

/// The physical device a context runs on and what it offers.
struct Chosen {
    physical: vk::PhysicalDevice,
    info: DeviceInfo,
    queue_family: u32,
    timestamps: bool,
}

/// The device `opts` names (or the best usable one), its compute queue family (one
/// without graphics if there is one), whether it times kernels, and its largest
/// allocation.
fn choose_device(instance: &ash::Instance, opts: &ContextOptions) -> Result<Chosen> {
    // SAFETY: enumeration on a valid instance.
    let pds = unsafe { instance.enumerate_physical_devices() }.vk("vkEnumeratePhysicalDevices")?;
    let infos: Vec<DeviceInfo> = pds
        .iter()
        .enumerate()
        .map(|(i, &pd)| describe(instance, pd, i))
        .collect();
    let index = pick(&infos, opts.device.as_deref())?;
    let physical = pds[index];
    let mut info = infos[index].clone();
    // SAFETY: queries on a valid physical device.
    let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
    let queue_family = families
        .iter()
        .enumerate()
        .filter(|(_, q)| q.queue_flags.contains(vk::QueueFlags::COMPUTE))
        .min_by_key(|(_, q)| q.queue_flags.contains(vk::QueueFlags::GRAPHICS))
        .map(|(i, _)| i as u32)
        .ok_or_else(|| Error::Gpu("no compute queue".into()))?;
    let timestamps = families[queue_family as usize].timestamp_valid_bits > 0 && info.timestamp_period_ns > 0.0;
    let mut m11 = vk::PhysicalDeviceMaintenance3Properties::default();
    let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut m11);
    // SAFETY: as above.
    unsafe { instance.get_physical_device_properties2(physical, &mut p2) };
    info.max_allocation_bytes = m11.max_memory_allocation_size;
    Ok(Chosen {
        physical,
        info,
        queue_family,
        timestamps,
    })
}

/// The logical device with buffer device addresses, its queue, a command pool and the
/// allocator; on failure, what was created is destroyed again.
fn open_device(
    instance: &ash::Instance,
    physical: vk::PhysicalDevice,
    queue_family: u32,
) -> Result<(ash::Device, vk::Queue, vk::CommandPool, Allocator)> {
    let priorities = [1.0f32];
    let queue_info = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(queue_family)
        .queue_priorities(&priorities)];
    let mut f12 = vk::PhysicalDeviceVulkan12Features::default().buffer_device_address(true);
    let features = vk::PhysicalDeviceFeatures::default().shader_int64(true);
    let mut f2 = vk::PhysicalDeviceFeatures2::default()
        .features(features)
        .push_next(&mut f12);
    let device_info = vk::DeviceCreateInfo::default()
        .queue_create_infos(&queue_info)
        .push_next(&mut f2);
    // SAFETY: the physical device supports every enabled feature (checked in `describe`).
    let device = unsafe { instance.create_device(physical, &device_info, None) }.vk("vkCreateDevice")?;
    // SAFETY: the family exists and has one queue.
    let queue = unsafe { device.get_device_queue(queue_family, 0) };
    let pool_info = vk::CommandPoolCreateInfo::default()
        .queue_family_index(queue_family)
        .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
    // SAFETY: valid device.
    let pool = match unsafe { device.create_command_pool(&pool_info, None) } {
        Ok(p) => p,
        Err(r) => {
            // SAFETY: nothing was created from the device yet.
            unsafe { device.destroy_device(None) };
            return Err(super::vk_err("vkCreateCommandPool", r));
        }
    };
    let allocator = match Allocator::new(&AllocatorCreateDesc {
        instance: instance.clone(),
        device: device.clone(),
        physical_device: physical,
        debug_settings: Default::default(),
        buffer_device_address: true,
        allocation_sizes: Default::default(),
    }) {
        Ok(a) => a,
        Err(e) => {
            // SAFETY: the pool and device were created above and are unused.
            unsafe {
                device.destroy_command_pool(pool, None);
                device.destroy_device(None);
            }
            return Err(Error::Gpu(format!("gpu-allocator: {e}")));
        }
    };
    Ok((device, queue, pool, allocator))
}

impl Drop for Context {
    fn drop(&mut self) {
        // SAFETY: all resources created from this context (buffers, pipelines, pools) hold
        // an `Arc<Context>` and are gone; the allocator goes before the device, the device
        // before the messenger and the instance.
        unsafe {
            let _ = self.device.device_wait_idle();
            ManuallyDrop::drop(&mut self.allocator);
            self.device.destroy_command_pool(self.pool, None);
            self.device.destroy_device(None);
            if let Some((du, m)) = self.debug.take() {
                du.destroy_debug_utils_messenger(m, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}
