//! Both eyes' work in one submission: the device's meeting point for the threads that render
//! the eyes of a binocular frame at the same time (`fovea_render::pipeline::lockstep`).
//!
//! Every pass of this crate goes to the queue through `GpuContext::submit`. A thread that
//! is registered ([`Lockstep::enter`]) while another is too does not submit alone: its
//! command buffers wait until every registered thread has posted its own, and the last to
//! post submits all of them in one `Queue::submit`. A thread that leaves releases the
//! others: once every thread still registered has posted, they go without it. Threads that
//! are not registered submit as before.
//!
//! Each waiting thread holds no lock of the caller's: the executors take `&self`, so the
//! other eye always reaches its own submission (or leaves). Should it not within
//! [`POST_TIMEOUT`] (a stalled or starved thread), the waiting thread submits what is posted
//! itself — a submission that carries fewer eyes, never a frame that waits forever — and
//! [`SubmissionCounts::timed_out`] counts it.

use std::sync::{Condvar, Mutex, MutexGuard};
use std::thread::ThreadId;
use std::time::Duration;

/// How long a posted submission waits for the other registered threads before it goes
/// without them.
pub const POST_TIMEOUT: Duration = Duration::from_secs(5);

/// How a device's submissions went, since it was opened.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SubmissionCounts {
    /// `Queue::submit` calls.
    pub submissions: u64,
    /// Submissions that carried the work of more than one registered thread (both eyes).
    pub joint: u64,
    /// The passes' submissions as posted (each thread's `GpuContext::submit` calls): as many
    /// as `submissions` with no eyes in lockstep, up to twice as many with two.
    pub posted: u64,
    /// Submissions that went without every registered thread's post because one did not
    /// post within [`POST_TIMEOUT`].
    pub timed_out: u64,
}

/// The state behind [`SubmissionGate`]'s lock.
#[derive(Default)]
struct GateState {
    /// Registered threads.
    lanes: Vec<ThreadId>,
    /// Posted, not yet submitted: each registered thread's command buffers (one post each).
    pending: Vec<Vec<wgpu::CommandBuffer>>,
    /// Counts up at every joint submission, so a waiting thread knows its post went.
    flushed: u64,
    counts: SubmissionCounts,
}

/// The gate of one device (`GpuContext::submit`).
#[derive(Default)]
pub(crate) struct SubmissionGate {
    state: Mutex<GateState>,
    went: Condvar,
}

impl SubmissionGate {
    fn lock(&self) -> MutexGuard<'_, GateState> {
        // A thread that panicked while holding the lock left consistent state (every change
        // is a push, a drain or a count), so the lock is taken over.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Submits `buffers` alone, or with the other registered threads' (see the module docs).
    pub(crate) fn submit(&self, queue: &wgpu::Queue, buffers: Vec<wgpu::CommandBuffer>) {
        let me = std::thread::current().id();
        let mut st = self.lock();
        st.counts.posted += 1;
        if st.lanes.len() < 2 || !st.lanes.contains(&me) {
            st.counts.submissions += 1;
            drop(st);
            queue.submit(buffers);
            return;
        }
        st.pending.push(buffers);
        if st.pending.len() >= st.lanes.len() {
            Self::flush(&mut st, queue);
            drop(st);
            self.went.notify_all();
            return;
        }
        let ticket = st.flushed;
        let (mut st, waited) = self
            .went
            .wait_timeout_while(st, POST_TIMEOUT, |st| st.flushed == ticket)
            .unwrap_or_else(|e| e.into_inner());
        if waited.timed_out() && st.flushed == ticket {
            st.counts.timed_out += 1;
            Self::flush(&mut st, queue);
            drop(st);
            self.went.notify_all();
        }
    }

    /// Submits everything posted, in one submission.
    fn flush(st: &mut GateState, queue: &wgpu::Queue) {
        let posts: Vec<_> = st.pending.drain(..).collect();
        st.counts.submissions += 1;
        if posts.len() > 1 {
            st.counts.joint += 1;
        }
        st.flushed += 1;
        queue.submit(posts.into_iter().flatten());
    }

    pub(crate) fn enter(&self) {
        let me = std::thread::current().id();
        let mut st = self.lock();
        if !st.lanes.contains(&me) {
            st.lanes.push(me);
        }
    }

    pub(crate) fn leave(&self, queue: &wgpu::Queue) {
        let me = std::thread::current().id();
        let mut st = self.lock();
        st.lanes.retain(|&t| t != me);
        // The others may all have posted, waiting only for this thread.
        if !st.pending.is_empty() && st.pending.len() >= st.lanes.len() {
            Self::flush(&mut st, queue);
            drop(st);
            self.went.notify_all();
        }
    }

    pub(crate) fn counts(&self) -> SubmissionCounts {
        self.lock().counts
    }
}
