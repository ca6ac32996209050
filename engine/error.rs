//! Engine error type: every failure names what went wrong and, for input, which file.

use ash::vk;

/// Errors surfaced by the engine.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A Vulkan call failed.
    #[error("{call} failed: {result}")]
    Vulkan {
        /// The Vulkan entry point (or engine operation) that failed.
        call: &'static str,
        /// The VkResult it returned.
        result: vk::Result,
    },
    /// The Vulkan loader could not be found or loaded.
    #[error("could not load the Vulkan loader (libvulkan.so.1): {0}; run tools/setup.sh")]
    Loader(String),
    /// No device can run the engine, or the requested one does not exist.
    #[error("{0}")]
    NoDevice(String),
    /// The Khronos validation layer was required but is not installed.
    #[error("validation layer VK_LAYER_KHRONOS_validation is not installed (Debian: apt-get install vulkan-validationlayers)")]
    MissingValidationLayer,
    /// GPU memory allocation failed.
    #[error("memory allocation for `{name}` failed: {source}")]
    Allocation {
        /// Resource name.
        name: String,
        /// Allocator error.
        source: gpu_allocator::AllocationError,
    },
    /// Bad user input: the message names the file or flag and the problem.
    #[error("{0}")]
    Input(String),
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// The validation layer reported this many messages during a run.
    #[error("the validation layer reported {0} message(s) (printed above)")]
    Validation(usize),
    /// An internal frame-graph or engine invariant failed (a bug, not bad input).
    #[error("frame graph: {0}")]
    Graph(String),
    /// The GPU did not finish in time (`--gpu-timeout`, `VKENGINE_GPU_TIMEOUT`).
    #[error("GPU timeout: {work} did not finish within {timeout_s} s (raise --gpu-timeout or VKENGINE_GPU_TIMEOUT if the work is legitimately this long)")]
    GpuTimeout {
        /// The frame and last pass of the submission that did not finish.
        work: String,
        /// The timeout that ran out, in seconds.
        timeout_s: f64,
    },
    /// The device was lost (`VK_ERROR_DEVICE_LOST`: a driver reset, hang recovery or crash).
    #[error("the Vulkan device was lost during {work}")]
    DeviceLost {
        /// The frame and last pass of the submission that was running.
        work: String,
    },
    /// Window or surface failure.
    #[error("window: {0}")]
    Window(String),
}

/// Result alias for engine operations.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Attaches the failing entry point's name to a raw `VkResult`.
pub(crate) trait VkContext<T> {
    /// Wraps the error with the call name.
    fn vk(self, call: &'static str) -> Result<T>;
}

impl<T> VkContext<T> for std::result::Result<T, vk::Result> {
    fn vk(self, call: &'static str) -> Result<T> {
        self.map_err(|result| Error::Vulkan { call, result })
    }
}
