//! The submission timeline: submits signal one timeline semaphore, waits are bounded by the GPU
//! timeout, and a wait that fails names the frame and the last pass of the submission the GPU
//! is stuck in (or lost on).

use super::{Shared, LOST, NO_FRAME, TIMED_OUT};
use crate::error::{Error, Result, VkContext};
use ash::vk;
use std::sync::atomic::Ordering;
use std::sync::MutexGuard;
use std::time::Duration;

/// A duration as Vulkan's nanosecond timeout (saturating: `u64::MAX` ns is 584 years).
pub(super) fn duration_ns(d: Duration) -> u64 {
    u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)
}
/// Submissions remembered for error messages (waits lag submissions by a few frames at most).
pub(super) const NOTES_KEPT: usize = 16;

/// What one submission carried: its timeline value, the frame and the last graph pass in it.
#[derive(Clone, Debug)]
pub(super) struct SubmissionNote {
    value: u64,
    frame: u64,
    last_pass: Option<String>,
}

impl SubmissionNote {
    fn describe(&self) -> String {
        let what = match self.frame {
            NO_FRAME => format!("submission {}", self.value),
            f => format!("frame {f}"),
        };
        match &self.last_pass {
            Some(p) => format!("{what} (last pass submitted: `{p}`)"),
            None => format!("{what} (no frame-graph pass: an upload, readback or clear)"),
        }
    }
}

impl Shared {
    /// Timeline value of the most recent submission.
    pub fn last_submitted(&self) -> u64 {
        self.submitted.load(Ordering::Acquire)
    }

    /// Timeline value the GPU has completed.
    pub fn completed(&self) -> Result<u64> {
        // SAFETY: timeline semaphore owned by this device.
        unsafe { self.device.get_semaphore_counter_value(self.timeline) }.vk("vkGetSemaphoreCounterValue")
    }

    /// Blocks until the GPU has completed timeline value `value`, at most the GPU timeout:
    /// past it the error names the frame and pass that did not finish ([`Error::GpuTimeout`]).
    pub fn wait_for(&self, value: u64) -> Result<()> {
        self.wait_within(value, self.gpu_timeout())
    }

    pub(super) fn wait_within(&self, value: u64, timeout: Duration) -> Result<()> {
        if self.health.load(Ordering::Acquire) == LOST {
            return Err(Error::DeviceLost { work: self.stuck_work(value) });
        }
        let sems = [self.timeline];
        let vals = [value];
        let info = vk::SemaphoreWaitInfo::default().semaphores(&sems).values(&vals);
        // SAFETY: waits on our own timeline semaphore.
        match unsafe { self.device.wait_semaphores(&info, duration_ns(timeout)) } {
            Ok(()) => Ok(()),
            Err(vk::Result::TIMEOUT) => {
                self.health.fetch_max(TIMED_OUT, Ordering::AcqRel);
                Err(Error::GpuTimeout { work: self.stuck_work(value), timeout_s: timeout.as_secs_f64() })
            }
            Err(result) => Err(self.device_error("vkWaitSemaphores", result, value)),
        }
    }

    /// Maps `VK_ERROR_DEVICE_LOST` to [`Error::DeviceLost`] (and remembers it); other results
    /// stay plain Vulkan errors.
    pub(super) fn device_error(&self, call: &'static str, result: vk::Result, value: u64) -> Error {
        if result == vk::Result::ERROR_DEVICE_LOST {
            self.health.store(LOST, Ordering::Release);
            Error::DeviceLost { work: self.stuck_work(value) }
        } else {
            Error::Vulkan { call, result }
        }
    }

    /// Describes the oldest submission up to `value` that has not completed: the one the GPU is
    /// stuck in (falls back to the newest remembered one).
    pub(super) fn stuck_work(&self, value: u64) -> String {
        // A lost device may not answer; then the newest remembered submission is the best guess.
        let done = self.completed().unwrap_or(0);
        let notes = self.notes.lock().unwrap_or_else(|p| p.into_inner());
        notes
            .iter()
            .find(|n| n.value > done && n.value <= value)
            .or_else(|| notes.iter().rev().find(|n| n.value <= value))
            .or(notes.back())
            .map_or_else(|| format!("submission {value}"), SubmissionNote::describe)
    }

    /// The GPU timeout this context waits with.
    pub fn gpu_timeout(&self) -> Duration {
        Duration::from_nanos(self.gpu_timeout_ns.load(Ordering::Acquire))
    }

    /// Changes the GPU timeout for the waits that follow.
    pub fn set_gpu_timeout(&self, timeout: Duration) {
        self.gpu_timeout_ns.store(duration_ns(timeout), Ordering::Release);
    }

    /// Tells the context which frame the following submissions belong to (for error messages).
    pub fn set_frame(&self, frame: u64) {
        self.frame.store(frame, Ordering::Release);
    }

    /// Remembers the last pass recorded into the next submission (the frame-graph executor
    /// calls this), so a wait that fails can name it.
    pub fn note_pass(&self, name: &str) {
        *self.pending_pass.lock().unwrap_or_else(|p| p.into_inner()) = Some(name.to_string());
    }

    /// Submits command buffers; waits/signals binary semaphores (for presentation) and signals the
    /// timeline. Returns the timeline value that marks this submission complete.
    pub fn submit(
        &self,
        cmds: &[vk::CommandBuffer],
        wait_binary: &[(vk::Semaphore, vk::PipelineStageFlags2)],
        signal_binary: &[vk::Semaphore],
    ) -> Result<u64> {
        let _q = self.queue_lock.lock().unwrap_or_else(|p| p.into_inner());
        let value = self.submitted.load(Ordering::Acquire) + 1;
        let cmd_infos: Vec<_> =
            cmds.iter().map(|&c| vk::CommandBufferSubmitInfo::default().command_buffer(c)).collect();
        let waits: Vec<_> =
            wait_binary.iter().map(|&(s, st)| vk::SemaphoreSubmitInfo::default().semaphore(s).stage_mask(st)).collect();
        let mut signals: Vec<_> = signal_binary
            .iter()
            .map(|&s| vk::SemaphoreSubmitInfo::default().semaphore(s).stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS))
            .collect();
        signals.push(
            vk::SemaphoreSubmitInfo::default()
                .semaphore(self.timeline)
                .value(value)
                .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS),
        );
        let submit = vk::SubmitInfo2::default()
            .command_buffer_infos(&cmd_infos)
            .wait_semaphore_infos(&waits)
            .signal_semaphore_infos(&signals);
        let note = SubmissionNote {
            value,
            frame: self.frame.load(Ordering::Acquire),
            last_pass: self.pending_pass.lock().unwrap_or_else(|p| p.into_inner()).take(),
        };
        if self.health.load(Ordering::Acquire) == LOST {
            return Err(Error::DeviceLost { work: note.describe() });
        }
        // SAFETY: queue access is serialized by queue_lock; all handles belong to this device.
        unsafe { self.device.queue_submit2(self.queue, &[submit], vk::Fence::null()) }.map_err(|r| {
            if r == vk::Result::ERROR_DEVICE_LOST {
                self.health.store(LOST, Ordering::Release);
                Error::DeviceLost { work: note.describe() }
            } else {
                Error::Vulkan { call: "vkQueueSubmit2", result: r }
            }
        })?;
        {
            let mut notes = self.notes.lock().unwrap_or_else(|p| p.into_inner());
            if notes.len() == NOTES_KEPT {
                notes.pop_front();
            }
            notes.push_back(note);
        }
        self.submitted.store(value, Ordering::Release);
        Ok(value)
    }

    /// Serializes presentation with submissions (one queue).
    pub(crate) fn lock_queue(&self) -> MutexGuard<'_, ()> {
        self.queue_lock.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Waits until the device is idle (and then frees all garbage), at most the GPU timeout.
    pub fn wait_idle(&self) -> Result<()> {
        // Every submission signals the timeline, so waiting for the newest one bounds the wait;
        // vkDeviceWaitIdle itself has no timeout and then only covers presentation.
        self.wait_for(self.last_submitted())?;
        let _q = self.lock_queue();
        // SAFETY: serialized with submissions by the queue lock.
        unsafe { self.device.device_wait_idle() }.map_err(|r| self.device_error("vkDeviceWaitIdle", r, 0))?;
        drop(_q);
        self.collect_garbage()
    }
}
