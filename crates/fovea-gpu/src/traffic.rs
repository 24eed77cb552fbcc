//! What crosses the bus and what the host waits for, counted where it happens (issue 37:
//! "counted, not estimated").
//!
//! Every buffer, bind group and upload of this crate goes through `GpuContext`'s
//! counting wrappers (`create_buffer`, `write_buffer`, `create_bind_group`), every readback
//! through `transfer::read_buffers`, and every blocking wait through `GpuContext::wait_idle`
//! (the device owns the counters: this module depends on no other of the crate); the
//! submissions are the device's gate's (`lockstep::SubmissionCounts`). A frame's traffic is
//! the difference of two snapshots, [`TrafficCounts::since`].

use std::sync::atomic::{AtomicU64, Ordering};

/// What a device has moved and waited for since it was opened (or, from
/// [`TrafficCounts::since`], between two snapshots).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TrafficCounts {
    /// Bytes written from the host into device buffers (`Queue::write_buffer`), bytes.
    pub bytes_uploaded: u64,
    /// Bytes of mapped buffers the host read back, bytes.
    pub bytes_read_back: u64,
    /// Buffers created.
    pub buffers_created: u64,
    /// Their sizes added up, bytes.
    pub buffer_bytes_created: u64,
    /// Bind groups created.
    pub bind_groups_created: u64,
    /// Buffers mapped for reading.
    pub buffer_maps: u64,
    /// Times the host thread blocked until the queue was idle.
    pub blocking_waits: u64,
    /// The host threads' time blocked in those waits, in the queue's submit calls and, in
    /// lockstep, waiting for the other eye's post, nanoseconds (summed over threads). A
    /// frame's wall time less this is the host's own work on it.
    pub blocked_ns: u64,
    /// `Queue::submit` calls.
    pub submissions: u64,
}

impl TrafficCounts {
    /// Every counter with its field's name, in declaration order (for JSON and reports).
    pub fn named(&self) -> [(&'static str, u64); 9] {
        [
            ("bytes_uploaded", self.bytes_uploaded),
            ("bytes_read_back", self.bytes_read_back),
            ("buffers_created", self.buffers_created),
            ("buffer_bytes_created", self.buffer_bytes_created),
            ("bind_groups_created", self.bind_groups_created),
            ("buffer_maps", self.buffer_maps),
            ("blocking_waits", self.blocking_waits),
            ("blocked_ns", self.blocked_ns),
            ("submissions", self.submissions),
        ]
    }

    /// The counts from `earlier` to `self`, two snapshots of one device (each field
    /// saturating at 0).
    pub fn since(&self, earlier: &Self) -> Self {
        Self {
            bytes_uploaded: self.bytes_uploaded.saturating_sub(earlier.bytes_uploaded),
            bytes_read_back: self.bytes_read_back.saturating_sub(earlier.bytes_read_back),
            buffers_created: self.buffers_created.saturating_sub(earlier.buffers_created),
            buffer_bytes_created: self
                .buffer_bytes_created
                .saturating_sub(earlier.buffer_bytes_created),
            bind_groups_created: self
                .bind_groups_created
                .saturating_sub(earlier.bind_groups_created),
            buffer_maps: self.buffer_maps.saturating_sub(earlier.buffer_maps),
            blocking_waits: self.blocking_waits.saturating_sub(earlier.blocking_waits),
            blocked_ns: self.blocked_ns.saturating_sub(earlier.blocked_ns),
            submissions: self.submissions.saturating_sub(earlier.submissions),
        }
    }
}

/// The device's counters (all but the submissions, which its gate counts).
#[derive(Default)]
pub(crate) struct Traffic {
    bytes_uploaded: AtomicU64,
    bytes_read_back: AtomicU64,
    buffers_created: AtomicU64,
    buffer_bytes_created: AtomicU64,
    bind_groups_created: AtomicU64,
    buffer_maps: AtomicU64,
    blocking_waits: AtomicU64,
    blocked_ns: AtomicU64,
}

impl Traffic {
    pub(crate) fn uploaded(&self, bytes: u64) {
        self.bytes_uploaded.fetch_add(bytes, Ordering::Relaxed);
    }

    pub(crate) fn read_back(&self, bytes: u64) {
        self.buffer_maps.fetch_add(1, Ordering::Relaxed);
        self.bytes_read_back.fetch_add(bytes, Ordering::Relaxed);
    }

    pub(crate) fn buffer(&self, bytes: u64) {
        self.buffers_created.fetch_add(1, Ordering::Relaxed);
        self.buffer_bytes_created
            .fetch_add(bytes, Ordering::Relaxed);
    }

    pub(crate) fn bind_group(&self) {
        self.bind_groups_created.fetch_add(1, Ordering::Relaxed);
    }

    /// A blocking wait for the queue that took `since.elapsed()`.
    pub(crate) fn waited(&self, since: std::time::Instant) {
        self.blocking_waits.fetch_add(1, Ordering::Relaxed);
        self.blocked(since);
    }

    /// Host time blocked (a submit, a wait for the other eye) from `since` until now.
    pub(crate) fn blocked(&self, since: std::time::Instant) {
        let ns = u64::try_from(since.elapsed().as_nanos()).unwrap_or(u64::MAX);
        self.blocked_ns.fetch_add(ns, Ordering::Relaxed);
    }

    pub(crate) fn snapshot(&self, submissions: u64) -> TrafficCounts {
        TrafficCounts {
            bytes_uploaded: self.bytes_uploaded.load(Ordering::Relaxed),
            bytes_read_back: self.bytes_read_back.load(Ordering::Relaxed),
            buffers_created: self.buffers_created.load(Ordering::Relaxed),
            buffer_bytes_created: self.buffer_bytes_created.load(Ordering::Relaxed),
            bind_groups_created: self.bind_groups_created.load(Ordering::Relaxed),
            buffer_maps: self.buffer_maps.load(Ordering::Relaxed),
            blocking_waits: self.blocking_waits.load(Ordering::Relaxed),
            blocked_ns: self.blocked_ns.load(Ordering::Relaxed),
            submissions,
        }
    }
}
