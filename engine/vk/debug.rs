//! Validation-layer messenger: records every warning and error so tests can fail on them.

use ash::vk;
use std::ffi::CStr;
use std::sync::{Arc, Mutex};

/// One message from the validation layer (or the loader/driver via debug utils).
#[derive(Clone, Debug)]
pub struct ValidationMessage {
    /// Severity as reported by the layer.
    pub severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    /// VUID or message id name, e.g. `SYNC-HAZARD-WRITE-AFTER-WRITE`.
    pub id: String,
    /// Full text.
    pub text: String,
}

impl std::fmt::Display for ValidationMessage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "[{:?}] {}: {}", self.severity, self.id, self.text)
    }
}

/// Shared sink the messenger writes into; clone it to read messages after the context is gone.
pub type MessageSink = Arc<Mutex<Vec<ValidationMessage>>>;

pub(crate) struct DebugMessenger {
    pub(crate) loader: ash::ext::debug_utils::Instance,
    pub(crate) messenger: vk::DebugUtilsMessengerEXT,
    user_data: *const Mutex<Vec<ValidationMessage>>,
}

// SAFETY: the raw pointer is an Arc we own; the callback only locks the Mutex behind it.
unsafe impl Send for DebugMessenger {}
// SAFETY: as above, all access through the pointer is synchronized by the Mutex.
unsafe impl Sync for DebugMessenger {}

impl DebugMessenger {
    pub(crate) fn create_info<'a>(
        user_data: *const Mutex<Vec<ValidationMessage>>,
    ) -> vk::DebugUtilsMessengerCreateInfoEXT<'a> {
        vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(
                vk::DebugUtilsMessageSeverityFlagsEXT::WARNING | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
            )
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                    | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                    | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
            )
            .pfn_user_callback(Some(callback))
            .user_data(user_data as *mut std::ffi::c_void)
    }

    /// Creates the sink and the raw pointer handed to the layer (one strong count owned by it).
    pub(crate) fn new_sink() -> (MessageSink, *const Mutex<Vec<ValidationMessage>>) {
        let sink: MessageSink = Arc::new(Mutex::new(Vec::new()));
        let raw = Arc::into_raw(sink.clone());
        (sink, raw)
    }

    pub(crate) fn create(
        entry: &ash::Entry,
        instance: &ash::Instance,
        user_data: *const Mutex<Vec<ValidationMessage>>,
    ) -> Result<Self, vk::Result> {
        let loader = ash::ext::debug_utils::Instance::new(entry, instance);
        let info = Self::create_info(user_data);
        // SAFETY: valid instance with VK_EXT_debug_utils enabled; user_data outlives the messenger (freed in drop).
        let messenger = unsafe { loader.create_debug_utils_messenger(&info, None)? };
        Ok(Self { loader, messenger, user_data })
    }

    /// Destroys the messenger and releases the layer's reference to the sink.
    pub(crate) fn destroy(&mut self) {
        // SAFETY: messenger was created from this loader and is destroyed exactly once.
        unsafe { self.loader.destroy_debug_utils_messenger(self.messenger, None) };
        self.messenger = vk::DebugUtilsMessengerEXT::null();
    }

    /// Releases the Arc handed to the layer; call after the instance (and its chained messenger) is gone.
    pub(crate) fn release_user_data(&mut self) {
        if !self.user_data.is_null() {
            // SAFETY: pointer came from Arc::into_raw in new_sink and is released exactly once.
            unsafe { drop(Arc::from_raw(self.user_data)) };
            self.user_data = std::ptr::null();
        }
    }
}

unsafe extern "system" fn callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut std::ffi::c_void,
) -> vk::Bool32 {
    if data.is_null() || user.is_null() {
        return vk::FALSE;
    }
    // SAFETY: the layer passes valid callback data for the duration of the call.
    let data = unsafe { &*data };
    let cstr = |p: *const std::ffi::c_char| {
        if p.is_null() {
            String::new()
        } else {
            // SAFETY: non-null strings from the layer are NUL-terminated.
            unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
        }
    };
    let msg = ValidationMessage { severity, id: cstr(data.p_message_id_name), text: cstr(data.p_message) };
    eprintln!("vulkan validation: {msg}");
    // SAFETY: user points at the Mutex inside the Arc kept alive by DebugMessenger.
    let sink = unsafe { &*(user as *const Mutex<Vec<ValidationMessage>>) };
    if let Ok(mut v) = sink.lock() {
        v.push(msg);
    }
    vk::FALSE
}
