//! Vulkan instance, device, queue, allocator and the submission timeline.
//!
//! `Context` is a cheap clone (an `Arc`); resources keep one so the device outlives them. Dropped
//! resources go to a garbage list tagged with the latest submitted timeline value and are freed
//! only once the GPU has passed it, so nothing is destroyed while the GPU may still use it.

use super::debug::{DebugMessenger, MessageSink, ValidationMessage};
use super::select::{format_uuid, select_device, Candidate};
use crate::error::{Error, Result, VkContext};
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use std::collections::VecDeque;
use std::ffi::{c_char, CStr, CString};
use std::mem::ManuallyDrop;
use std::ops::Deref;
use std::sync::atomic::{AtomicU64, AtomicU8, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

mod garbage;
mod options;
mod timeline;
pub use garbage::RETIRED_SETS;
pub(crate) use garbage::{Garbage, Retired, TransientSet};
pub use options::{parse_gpu_timeout, ContextOptions, Validation, DEFAULT_GPU_TIMEOUT};
use timeline::{duration_ns, SubmissionNote, NOTES_KEPT};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// Facts about the selected device that the engine and its reports use.
#[derive(Clone, Debug)]
pub struct DeviceInfo {
    /// Device name, e.g. `llvmpipe (LLVM 15.0.6, 256 bits)`.
    pub name: String,
    /// Its index among the instance's physical devices (what `#N` selects).
    pub index: usize,
    /// Its `deviceUUID` as `8-4-4-4-12` hex (what `uuid:…` selects).
    pub uuid: String,
    /// Device type.
    pub kind: vk::PhysicalDeviceType,
    /// Driver name and version string.
    pub driver: String,
    /// Vulkan API version the device reports, as `major.minor.patch`.
    pub api_version: String,
    /// Nanoseconds per timestamp tick.
    pub timestamp_period_ns: f64,
    /// Device limits.
    pub limits: vk::PhysicalDeviceLimits,
    /// [`ContextOptions::max_allocation`]: the engine plans allocations no larger than this.
    pub max_allocation_cap: Option<u64>,
    /// [`ContextOptions::page_levels`].
    pub page_levels: Option<u32>,
    /// `VK_EXT_shader_atomic_float` buffer/image float32 atomic add is available and enabled.
    pub float_atomics: bool,
    /// Geometry shaders are available and enabled.
    pub geometry_shader: bool,
    /// Compute shaders may use subgroup ballots (`GL_KHR_shader_subgroup_ballot`).
    pub subgroup_ballot: bool,
    /// Compute shaders may also use subgroup votes and arithmetic (`GL_KHR_shader_subgroup_vote`,
    /// `_arithmetic`): bounded Monte Carlo's row-level cap needs them with the ballots.
    pub subgroup_arithmetic: bool,
    /// One indirect draw call may run several draws (`multiDrawIndirect`), enabled.
    pub multi_draw_indirect: bool,
    /// The least subgroup size (Vulkan 1.3 `minSubgroupSize`): a workgroup no larger is one
    /// subgroup.
    pub min_subgroup_size: u32,
    /// The validation layer (with synchronization validation) is active.
    pub validation: bool,
}

/// The device named `name` is llvmpipe (Mesa's CPU driver behind lavapipe), whose quirks some
/// passes work around: its loop limit, its per-dispatch uniform inlining.
pub fn is_llvmpipe(name: &str) -> bool {
    name.starts_with("llvmpipe")
}

impl DeviceInfo {
    /// This device is llvmpipe ([`is_llvmpipe`]).
    pub fn llvmpipe(&self) -> bool {
        is_llvmpipe(&self.name)
    }

    /// Bounded Monte Carlo work (`mc_bounded.comp`) can run: subgroup ballots, votes and
    /// arithmetic in compute shaders.
    pub fn bounded_mc(&self) -> bool {
        self.subgroup_ballot && self.subgroup_arithmetic
    }
}

/// Everything behind a [`Context`].
pub struct Shared {
    /// Loaded Vulkan entry points.
    pub entry: ash::Entry,
    /// The instance.
    pub instance: ash::Instance,
    /// The selected physical device.
    pub physical_device: vk::PhysicalDevice,
    /// The logical device.
    pub device: ash::Device,
    /// The one queue used for graphics, compute and transfer.
    pub queue: vk::Queue,
    /// Its family index.
    pub queue_family: u32,
    /// Facts about the device.
    pub info: DeviceInfo,
    /// `VK_KHR_push_descriptor` entry points.
    pub push_descriptor: ash::khr::push_descriptor::Device,
    /// Debug-utils device entry points (labels, object names), when the extension is present.
    pub debug_utils: Option<ash::ext::debug_utils::Device>,
    /// Pipeline cache shared by all pipelines.
    pub pipeline_cache: vk::PipelineCache,
    pipelines: super::pipeline::cache::PipelineCache,
    messenger: Mutex<Option<DebugMessenger>>,
    sink: Option<MessageSink>,
    allocator: ManuallyDrop<Mutex<Allocator>>,
    timeline: vk::Semaphore,
    submitted: AtomicU64,
    /// The GPU timeout in nanoseconds (settable while running, e.g. around one risky frame).
    gpu_timeout_ns: AtomicU64,
    /// [`HEALTHY`], [`TIMED_OUT`] or [`LOST`]: decides what teardown may still touch.
    health: AtomicU8,
    /// Frame index the caller is working on ([`NO_FRAME`] until one is set).
    frame: AtomicU64,
    /// Last pass recorded since the previous submission; the next submission takes it.
    pending_pass: Mutex<Option<String>>,
    /// What the most recent submissions carried, so a failed wait can name its work.
    notes: Mutex<VecDeque<SubmissionNote>>,
    pub(super) garbage: Mutex<Vec<(u64, Garbage)>>,
    /// Transient sets of finished graphs, kept for the next graph with the same signature.
    pub(super) retired: Mutex<Vec<Retired>>,
    queue_lock: Mutex<()>,
}

const HEALTHY: u8 = 0;
/// A wait timed out: the GPU may still be running that work.
const TIMED_OUT: u8 = 1;
/// `VK_ERROR_DEVICE_LOST`: nothing runs any more; objects may still be destroyed.
const LOST: u8 = 2;
const NO_FRAME: u64 = u64::MAX;

/// Handle to the Vulkan device and its shared services; clone freely.
#[derive(Clone)]
pub struct Context(Arc<Shared>);

impl Deref for Context {
    type Target = Shared;
    fn deref(&self) -> &Shared {
        &self.0
    }
}

fn api_string(v: u32) -> String {
    format!("{}.{}.{}", vk::api_version_major(v), vk::api_version_minor(v), vk::api_version_patch(v))
}

impl Context {
    /// Creates instance, device and allocator according to `opts`.
    pub fn new(opts: &ContextOptions) -> Result<Self> {
        // SAFETY: loading the system Vulkan loader; its entry points are trusted.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| Error::Loader(e.to_string()))?;
        // SAFETY: plain global query.
        let layers = unsafe { entry.enumerate_instance_layer_properties() }.vk("vkEnumerateInstanceLayerProperties")?;
        let has_layer = layers.iter().any(|l| l.layer_name_as_c_str() == Ok(VALIDATION_LAYER));
        let validation = match opts.validation {
            Validation::Off => false,
            Validation::IfAvailable if !has_layer => {
                eprintln!("warning: validation requested but VK_LAYER_KHRONOS_validation is not installed; running without it");
                false
            }
            Validation::Required if !has_layer => return Err(Error::MissingValidationLayer),
            _ => true,
        };

        // SAFETY: plain global query.
        let inst_exts = unsafe { entry.enumerate_instance_extension_properties(None) }
            .vk("vkEnumerateInstanceExtensionProperties")?;
        let has_ext = |name: &CStr| inst_exts.iter().any(|e| e.extension_name_as_c_str() == Ok(name));
        let mut extensions: Vec<*const c_char> = Vec::new();
        let debug_utils_available = has_ext(ash::ext::debug_utils::NAME);
        if debug_utils_available {
            extensions.push(ash::ext::debug_utils::NAME.as_ptr());
        }
        if let Some(display) = opts.display {
            let req = ash_window::enumerate_required_extensions(display).vk("enumerate_required_extensions")?;
            extensions.extend_from_slice(req);
        }
        let mut layer_names: Vec<*const c_char> = Vec::new();
        if validation {
            layer_names.push(VALIDATION_LAYER.as_ptr());
            // SAFETY: plain global query of the layer's own extensions.
            let layer_exts = unsafe { entry.enumerate_instance_extension_properties(Some(VALIDATION_LAYER)) }
                .vk("vkEnumerateInstanceExtensionProperties(layer)")?;
            if !layer_exts.iter().any(|e| e.extension_name_as_c_str() == Ok(ash::ext::validation_features::NAME)) {
                return Err(Error::NoDevice(
                    "validation layer lacks VK_EXT_validation_features; synchronization validation cannot be enabled"
                        .into(),
                ));
            }
            extensions.push(ash::ext::validation_features::NAME.as_ptr());
        }

        let app_name = CString::new("vkengine").expect("static name has no NUL");
        let app = vk::ApplicationInfo::default()
            .application_name(&app_name)
            .engine_name(&app_name)
            .api_version(vk::API_VERSION_1_3);
        let enabled_features = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut validation_features =
            vk::ValidationFeaturesEXT::default().enabled_validation_features(&enabled_features);
        let (sink, user_data) = if validation && debug_utils_available {
            let (s, p) = DebugMessenger::new_sink();
            (Some(s), p)
        } else {
            (None, std::ptr::null())
        };
        let mut messenger_info = DebugMessenger::create_info(user_data);
        let mut create_info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layer_names)
            .enabled_extension_names(&extensions);
        if validation {
            create_info = create_info.push_next(&mut validation_features);
            if sink.is_some() {
                create_info = create_info.push_next(&mut messenger_info);
            }
        }
        // SAFETY: all pointers in create_info live until this call returns.
        let instance = unsafe { entry.create_instance(&create_info, None) }.vk("vkCreateInstance")?;
        let messenger = match &sink {
            Some(_) => Some(DebugMessenger::create(&entry, &instance, user_data).vk("vkCreateDebugUtilsMessengerEXT")?),
            None => None,
        };
        // From here on, failures must tear down what exists; build a partially-filled guard.
        let guard = InstanceGuard { instance: Some(instance), messenger };
        let shared = Self::create_device(entry, guard, opts, validation, debug_utils_available, sink)?;
        Ok(Context(Arc::new(shared)))
    }

    fn create_device(
        entry: ash::Entry,
        mut guard: InstanceGuard,
        opts: &ContextOptions,
        validation: bool,
        debug_utils_available: bool,
        sink: Option<MessageSink>,
    ) -> Result<Shared> {
        let instance = guard.instance.as_ref().expect("guard holds instance").clone();
        // SAFETY: valid instance.
        let pdevs = unsafe { instance.enumerate_physical_devices() }.vk("vkEnumeratePhysicalDevices")?;
        let windowed = opts.display.is_some();
        let candidates: Vec<Candidate> = pdevs.iter().map(|&pd| probe(&instance, pd, windowed)).collect();
        // A choice that names no device is a bad argument (exit code 2), an unusable one is not.
        let idx = select_device(&candidates, opts.device.as_deref()).map_err(|r| match r.bad_choice {
            true => Error::Input(r.message),
            false => Error::NoDevice(r.message),
        })?;
        let pd = pdevs[idx];

        // SAFETY: pd is a valid physical device of this instance (all queries below).
        let props = unsafe { instance.get_physical_device_properties(pd) };
        let queue_family = unsafe { instance.get_physical_device_queue_family_properties(pd) }
            .iter()
            .position(|q| q.queue_flags.contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE))
            .ok_or_else(|| Error::NoDevice("selected device has no graphics+compute queue".into()))?
            as u32;
        let dev_exts =
            unsafe { instance.enumerate_device_extension_properties(pd) }.vk("vkEnumerateDeviceExtensionProperties")?;
        let has = |n: &CStr| dev_exts.iter().any(|e| e.extension_name_as_c_str() == Ok(n));

        let mut atomic_float_sup = vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT::default();
        let mut v12_sup = vk::PhysicalDeviceVulkan12Features::default();
        let mut v13_sup = vk::PhysicalDeviceVulkan13Features::default();
        let has_atomic_float = has(ash::ext::shader_atomic_float::NAME);
        let mut sup = vk::PhysicalDeviceFeatures2::default().push_next(&mut v12_sup).push_next(&mut v13_sup);
        if has_atomic_float {
            sup = sup.push_next(&mut atomic_float_sup);
        }
        unsafe { instance.get_physical_device_features2(pd, &mut sup) };
        let core = sup.features;

        let mut exts = vec![ash::khr::push_descriptor::NAME.as_ptr()];
        if windowed {
            exts.push(ash::khr::swapchain::NAME.as_ptr());
        }
        let float_atomics = has_atomic_float
            && atomic_float_sup.shader_buffer_float32_atomic_add == vk::TRUE
            && atomic_float_sup.shader_image_float32_atomic_add == vk::TRUE;
        if float_atomics {
            exts.push(ash::ext::shader_atomic_float::NAME.as_ptr());
        }
        let features = vk::PhysicalDeviceFeatures::default()
            .geometry_shader(core.geometry_shader == vk::TRUE)
            .fragment_stores_and_atomics(core.fragment_stores_and_atomics == vk::TRUE)
            .vertex_pipeline_stores_and_atomics(core.vertex_pipeline_stores_and_atomics == vk::TRUE)
            .shader_storage_image_write_without_format(core.shader_storage_image_write_without_format == vk::TRUE)
            .sampler_anisotropy(core.sampler_anisotropy == vk::TRUE)
            .shader_int64(core.shader_int64 == vk::TRUE)
            .multi_draw_indirect(core.multi_draw_indirect == vk::TRUE);
        let mut v12 = vk::PhysicalDeviceVulkan12Features::default()
            .timeline_semaphore(true)
            .scalar_block_layout(v12_sup.scalar_block_layout == vk::TRUE)
            .host_query_reset(v12_sup.host_query_reset == vk::TRUE);
        // maintenance4 relaxes vertex→fragment interface matching: optimised SPIR-V (release
        // builds) drops fragment inputs a shader ignores, which the layer would otherwise flag.
        let mut v13 = vk::PhysicalDeviceVulkan13Features::default()
            .synchronization2(true)
            .dynamic_rendering(true)
            .maintenance4(v13_sup.maintenance4 == vk::TRUE);
        let mut af = vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT::default()
            .shader_buffer_float32_atomic_add(float_atomics)
            .shader_image_float32_atomic_add(float_atomics);
        let prio = [1.0f32];
        let qinfo = [vk::DeviceQueueCreateInfo::default().queue_family_index(queue_family).queue_priorities(&prio)];
        let mut dinfo = vk::DeviceCreateInfo::default()
            .queue_create_infos(&qinfo)
            .enabled_extension_names(&exts)
            .enabled_features(&features)
            .push_next(&mut v12)
            .push_next(&mut v13);
        if float_atomics {
            dinfo = dinfo.push_next(&mut af);
        }
        // SAFETY: create info references only locals alive for the call.
        let device = unsafe { instance.create_device(pd, &dinfo, None) }.vk("vkCreateDevice")?;
        let device_guard = DeviceGuard(Some(device.clone()));
        // SAFETY: queue family/index requested above.
        let queue = unsafe { device.get_device_queue(queue_family, 0) };

        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: pd,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        })
        .map_err(|source| Error::Allocation { name: "allocator".into(), source })?;

        let mut tl_type =
            vk::SemaphoreTypeCreateInfo::default().semaphore_type(vk::SemaphoreType::TIMELINE).initial_value(0);
        // SAFETY: valid device; destroyed in Shared::drop.
        let timeline =
            unsafe { device.create_semaphore(&vk::SemaphoreCreateInfo::default().push_next(&mut tl_type), None) }
                .vk("vkCreateSemaphore(timeline)")?;
        // SAFETY: valid device; destroyed in Shared::drop.
        let pipeline_cache = unsafe { device.create_pipeline_cache(&vk::PipelineCacheCreateInfo::default(), None) }
            .vk("vkCreatePipelineCache")?;

        let mut driver_props = vk::PhysicalDeviceDriverProperties::default();
        let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
        let mut v13_props = vk::PhysicalDeviceVulkan13Properties::default();
        let mut props2 = vk::PhysicalDeviceProperties2::default()
            .push_next(&mut driver_props)
            .push_next(&mut subgroup)
            .push_next(&mut v13_props);
        // SAFETY: valid physical device.
        unsafe { instance.get_physical_device_properties2(pd, &mut props2) };
        let driver = format!(
            "{} {}",
            driver_props.driver_name_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(),
            driver_props.driver_info_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()
        );
        // The subgroup operations compute shaders may use (none where compute has no subgroups).
        let compute_subgroup_ops = if subgroup.supported_stages.contains(vk::ShaderStageFlags::COMPUTE) {
            subgroup.supported_operations
        } else {
            vk::SubgroupFeatureFlags::empty()
        };
        let info = DeviceInfo {
            name: candidates[idx].name.clone(),
            index: idx,
            uuid: format_uuid(&candidates[idx].uuid),
            kind: props.device_type,
            driver: driver.trim().to_string(),
            api_version: api_string(props.api_version),
            timestamp_period_ns: props.limits.timestamp_period as f64,
            limits: props.limits,
            max_allocation_cap: opts.max_allocation,
            page_levels: opts.page_levels,
            float_atomics,
            geometry_shader: core.geometry_shader == vk::TRUE,
            subgroup_ballot: compute_subgroup_ops.contains(vk::SubgroupFeatureFlags::BALLOT),
            subgroup_arithmetic: compute_subgroup_ops
                .contains(vk::SubgroupFeatureFlags::VOTE | vk::SubgroupFeatureFlags::ARITHMETIC),
            multi_draw_indirect: core.multi_draw_indirect == vk::TRUE,
            min_subgroup_size: v13_props.min_subgroup_size.max(1),
            validation,
        };
        let push_descriptor = ash::khr::push_descriptor::Device::new(&instance, &device);
        let debug_utils = debug_utils_available.then(|| ash::ext::debug_utils::Device::new(&instance, &device));
        std::mem::forget(device_guard);
        let messenger = guard.messenger.take();
        guard.instance = None;
        Ok(Shared {
            entry,
            instance,
            physical_device: pd,
            device,
            queue,
            queue_family,
            info,
            push_descriptor,
            debug_utils,
            pipeline_cache,
            pipelines: Default::default(),
            messenger: Mutex::new(messenger),
            sink,
            allocator: ManuallyDrop::new(Mutex::new(allocator)),
            timeline,
            submitted: AtomicU64::new(0),
            gpu_timeout_ns: AtomicU64::new(duration_ns(opts.gpu_timeout)),
            health: AtomicU8::new(HEALTHY),
            frame: AtomicU64::new(NO_FRAME),
            pending_pass: Mutex::new(None),
            notes: Mutex::new(VecDeque::with_capacity(NOTES_KEPT)),
            garbage: Mutex::new(Vec::new()),
            retired: Mutex::new(Vec::new()),
            queue_lock: Mutex::new(()),
        })
    }

    /// The validation-message sink, if validation is active; it outlives the context.
    pub fn message_sink(&self) -> Option<MessageSink> {
        self.sink.clone()
    }

    /// Validation messages recorded so far.
    pub fn validation_messages(&self) -> Vec<ValidationMessage> {
        self.sink.as_ref().map(|s| s.lock().map(|v| v.clone()).unwrap_or_default()).unwrap_or_default()
    }
}

/// The Vulkan devices of this machine in selection order (`#N` is the N-th), with what keeps
/// any of them from running the engine headless: for listing them and spreading work over them.
pub fn list_devices() -> Result<Vec<Candidate>> {
    // SAFETY: loading the system Vulkan loader; its entry points are trusted.
    let entry = unsafe { ash::Entry::load() }.map_err(|e| Error::Loader(e.to_string()))?;
    let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_3);
    let info = vk::InstanceCreateInfo::default().application_info(&app);
    // SAFETY: the create info references only locals alive for the call.
    let instance = unsafe { entry.create_instance(&info, None) }.vk("vkCreateInstance")?;
    let guard = InstanceGuard { instance: Some(instance.clone()), messenger: None };
    // SAFETY: valid instance; it is destroyed (by the guard) only after the probes.
    let pdevs = unsafe { instance.enumerate_physical_devices() }.vk("vkEnumeratePhysicalDevices")?;
    let out = pdevs.iter().map(|&pd| probe(&instance, pd, false)).collect();
    drop(guard);
    Ok(out)
}

/// Tears down a half-built instance if device creation fails.
struct InstanceGuard {
    instance: Option<ash::Instance>,
    messenger: Option<DebugMessenger>,
}

impl Drop for InstanceGuard {
    fn drop(&mut self) {
        if let Some(m) = self.messenger.as_mut() {
            m.destroy();
        }
        if let Some(i) = self.instance.take() {
            // SAFETY: nothing else references the instance on this failure path.
            unsafe { i.destroy_instance(None) };
        }
        if let Some(m) = self.messenger.as_mut() {
            m.release_user_data();
        }
    }
}

struct DeviceGuard(Option<ash::Device>);

impl Drop for DeviceGuard {
    fn drop(&mut self) {
        if let Some(d) = self.0.take() {
            // SAFETY: failure path: the device has no children yet that outlive this guard.
            unsafe { d.destroy_device(None) };
        }
    }
}

fn probe(instance: &ash::Instance, pd: vk::PhysicalDevice, windowed: bool) -> Candidate {
    // SAFETY: pd enumerated from this instance.
    let props = unsafe { instance.get_physical_device_properties(pd) };
    let name = props.device_name_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let mut v12 = vk::PhysicalDeviceVulkan12Features::default();
    let mut v13 = vk::PhysicalDeviceVulkan13Features::default();
    let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut v12).push_next(&mut v13);
    // SAFETY: valid physical device.
    unsafe { instance.get_physical_device_features2(pd, &mut f2) };
    // SAFETY: valid physical device.
    let exts = unsafe { instance.enumerate_device_extension_properties(pd) }.unwrap_or_default();
    let has = |n: &CStr| exts.iter().any(|e| e.extension_name_as_c_str() == Ok(n));
    let mut missing = Vec::new();
    if props.api_version < vk::API_VERSION_1_3 {
        missing.push(format!("Vulkan 1.3 (device has {})", api_string(props.api_version)));
    }
    if v13.synchronization2 != vk::TRUE {
        missing.push("synchronization2".into());
    }
    if v13.dynamic_rendering != vk::TRUE {
        missing.push("dynamic rendering".into());
    }
    if v12.timeline_semaphore != vk::TRUE {
        missing.push("timeline semaphores".into());
    }
    if !has(ash::khr::push_descriptor::NAME) {
        missing.push("VK_KHR_push_descriptor".into());
    }
    if windowed && !has(ash::khr::swapchain::NAME) {
        missing.push("VK_KHR_swapchain".into());
    }
    let mut id = vk::PhysicalDeviceIDProperties::default();
    if props.api_version >= vk::API_VERSION_1_1 {
        let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut id);
        // SAFETY: valid physical device of a Vulkan 1.1+ device.
        unsafe { instance.get_physical_device_properties2(pd, &mut p2) };
    }
    Candidate {
        name,
        kind: props.device_type,
        uuid: id.device_uuid,
        unsupported: (!missing.is_empty()).then(|| format!("missing {}", missing.join(", "))),
    }
}

impl Shared {
    /// Locks the GPU memory allocator.
    pub(crate) fn allocator(&self) -> MutexGuard<'_, Allocator> {
        self.allocator.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Bytes of device memory the engine's allocator holds (its blocks, used or not): what
    /// freeing this context returns to the device.
    pub fn reserved_bytes(&self) -> u64 {
        self.allocator().generate_report().total_reserved_bytes
    }

    /// Names a Vulkan object for debuggers and validation messages (no-op without debug utils).
    pub fn set_name<H: vk::Handle + Copy>(&self, handle: H, name: &str) {
        if handle.as_raw() == 0 {
            return;
        }
        if let (Some(du), Ok(cname)) = (&self.debug_utils, CString::new(name)) {
            let info = vk::DebugUtilsObjectNameInfoEXT::default().object_handle(handle).object_name(&cname);
            // SAFETY: handle belongs to this device; the name lives for the call.
            let _ = unsafe { du.set_debug_utils_object_name(&info) };
        }
    }

    /// The lazy pipeline and sampler cache that shader passes draw from.
    pub fn pipelines(&self) -> &super::pipeline::cache::PipelineCache {
        &self.pipelines
    }
}

impl Drop for Shared {
    fn drop(&mut self) {
        if self.health.load(Ordering::Acquire) == TIMED_OUT {
            // The timed-out work may still be running and using every resource below; destroying
            // them under it is undefined. Give it one more timeout (at least 2 s) to finish, else
            // leak the device: the process is ending with an error anyway, and the layer reports
            // leaks only when the device is destroyed.
            let grace = self.gpu_timeout().max(Duration::from_secs(2));
            if self.wait_within(self.last_submitted(), grace).is_err() {
                eprintln!("warning: the GPU is still busy after the timeout; leaving the Vulkan device undestroyed");
                return;
            }
        }
        // SAFETY: last owner: wait for the GPU (returns at once on a lost device, whose objects
        // may still be destroyed), then destroy children before the device and instance.
        unsafe {
            let _ = self.device.device_wait_idle();
            let all: Vec<Garbage> =
                self.garbage.get_mut().unwrap_or_else(|p| p.into_inner()).drain(..).map(|(_, g)| g).collect();
            let retired = std::mem::take(self.retired.get_mut().unwrap_or_else(|p| p.into_inner()));
            for g in all.into_iter().chain(retired.into_iter().flat_map(Retired::into_garbage)) {
                self.destroy_now(g);
            }
            self.pipelines.destroy(&self.device);
            ManuallyDrop::drop(&mut self.allocator);
            self.device.destroy_pipeline_cache(self.pipeline_cache, None);
            self.device.destroy_semaphore(self.timeline, None);
            self.device.destroy_device(None);
            let mut messenger = self.messenger.get_mut().unwrap_or_else(|p| p.into_inner()).take();
            if let Some(m) = messenger.as_mut() {
                m.destroy();
            }
            self.instance.destroy_instance(None);
            if let Some(m) = messenger.as_mut() {
                m.release_user_data();
            }
        }
    }
}
