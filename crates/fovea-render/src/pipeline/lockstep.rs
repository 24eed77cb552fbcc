//! Both eyes of a binocular frame at the same time, their device work submitted together
//! (VaFR Sec. 6: both eyes are ray-cast in one pass; issue 18, "both eyes in one
//! submission").
//!
//! Each eye runs the whole frame script ([`super::render_planned`]) on a thread of its own,
//! in its own [`super::FrameContext`], on executors that share one device. The device's
//! [`Lockstep`] holds each eye's submission until the other eye's is ready and sends both in
//! one: every stage the eyes have in common (each chunk's rays, the shadow rays, AA,
//! reconstruction, DOF) goes to the device once for the pair, and one eye's CPU work (its
//! plan, its surfaces, its shading arithmetic) overlaps the other's device work. The eye
//! with more submissions sends its last ones alone once the other has finished.
//!
//! The frames are those of the eyes rendered one after the other: each eye's work is the
//! same, only its submission is shared. Stage times are the process's (wall and CPU): in
//! lockstep each eye's include the other's concurrent work, so the pair's wall time is the
//! figure to compare.

use crate::error::{RenderError, Result};

/// A device's meeting point for the submissions of the threads rendering the eyes of a
/// pair (e.g. `fovea_gpu::GpuContext`).
pub trait Lockstep: Sync {
    /// Registers the calling thread as one eye of the pair: while more than one thread is
    /// registered, each registered thread's submission waits until every registered
    /// thread has one ready, and all go to the device as one.
    fn enter(&self);
    /// Unregisters the calling thread (its eye is done, or failed): the others' waiting
    /// submissions no longer wait for it.
    fn leave(&self);
}

/// Registered with a [`Lockstep`] until dropped — also when the eye's thread unwinds, so the
/// other eye never waits for a thread that is gone.
struct Entered<'a>(&'a dyn Lockstep);

impl<'a> Entered<'a> {
    fn new(lockstep: &'a dyn Lockstep) -> Self {
        lockstep.enter();
        Self(lockstep)
    }
}

impl Drop for Entered<'_> {
    fn drop(&mut self) {
        self.0.leave();
    }
}

/// Runs `left` and `right` (each one eye's whole frame) at the same time, each on a thread
/// registered with `lockstep`, both registered before either starts, and returns both
/// results — the first error (left's first) if either failed. A panic in either is resumed
/// on the calling thread after the other has finished.
pub fn in_lockstep<T, L, R>(lockstep: &dyn Lockstep, left: L, right: R) -> Result<(T, T)>
where
    T: Send,
    L: FnOnce() -> Result<T> + Send,
    R: FnOnce() -> Result<T> + Send,
{
    let ready = std::sync::Barrier::new(2);
    let (l, r) = std::thread::scope(|s| {
        let ready = &ready;
        let right = std::thread::Builder::new()
            .name("fovea-right-eye".into())
            .spawn_scoped(s, move || {
                let _entered = Entered::new(lockstep);
                ready.wait();
                right()
            })
            .map_err(|e| RenderError::Executor {
                stage: "lockstep",
                backend: "cpu".into(),
                message: format!("cannot start the second eye's thread: {e}"),
            })?;
        let l = {
            let _entered = Entered::new(lockstep);
            ready.wait();
            left()
        };
        Ok::<_, RenderError>((l, right.join()))
    })?;
    let r = match r {
        Ok(r) => r,
        Err(panic) => std::panic::resume_unwind(panic),
    };
    Ok((l?, r?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    /// Records who is registered.
    #[derive(Default)]
    struct Registry {
        lanes: Mutex<Vec<std::thread::ThreadId>>,
    }

    impl Lockstep for Registry {
        fn enter(&self) {
            self.lanes.lock().unwrap().push(std::thread::current().id());
        }
        fn leave(&self) {
            let me = std::thread::current().id();
            self.lanes.lock().unwrap().retain(|&t| t != me);
        }
    }

    impl Registry {
        fn registered(&self) -> usize {
            self.lanes.lock().unwrap().len()
        }
        fn holds_me(&self) -> bool {
            let me = std::thread::current().id();
            self.lanes.lock().unwrap().contains(&me)
        }
    }

    #[test]
    fn both_eyes_are_registered_on_their_own_threads_before_either_starts() {
        let reg = Registry::default();
        // Neither eye finishes (and leaves) before both have looked.
        let looked = std::sync::Barrier::new(2);
        let eye = || -> Result<(usize, bool, std::thread::ThreadId)> {
            let seen = (
                reg.registered(),
                reg.holds_me(),
                std::thread::current().id(),
            );
            looked.wait();
            Ok(seen)
        };
        let ((l_seen, l_mine, l_thread), (r_seen, r_mine, r_thread)) =
            in_lockstep(&reg, eye, eye).unwrap();
        assert_eq!((l_seen, r_seen), (2, 2));
        assert!(l_mine && r_mine);
        assert_ne!(l_thread, r_thread);
        assert_eq!(reg.registered(), 0, "both left");
    }

    #[test]
    fn an_error_of_either_eye_is_returned_after_both_finished() {
        let reg = Registry::default();
        let fail = || -> Result<u32> { Err(RenderError::Unsupported("right".into())) };
        let out = in_lockstep(&reg, || Ok(1), fail);
        assert!(matches!(out, Err(RenderError::Unsupported(m)) if m == "right"));
        let out = in_lockstep(&reg, || Err(RenderError::Unsupported("left".into())), fail);
        assert!(matches!(out, Err(RenderError::Unsupported(m)) if m == "left"));
        assert_eq!(in_lockstep(&reg, || Ok(1), || Ok(2)).unwrap(), (1, 2));
        assert_eq!(reg.registered(), 0);
    }

    #[test]
    fn a_panicking_eye_leaves_before_its_panic_is_resumed() {
        let reg = Registry::default();
        let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            in_lockstep(&reg, || Ok(1), || -> Result<u32> { panic!("right eye") })
        }));
        assert!(out.is_err());
        assert_eq!(reg.registered(), 0);
    }
}
