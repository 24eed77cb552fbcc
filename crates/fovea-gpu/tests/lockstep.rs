//! Both eyes' work in one submission (`fovea_gpu::lockstep`): two threads rendering the eyes
//! of a pair (`fovea_render::pipeline::in_lockstep`) share every submission while both
//! are registered, each pass is submitted exactly once, and an eye that finishes early,
//! fails or panics never leaves the other waiting. Counted with
//! `GpuContext::submission_counts` on real (empty) command buffers.
//!
//! Needs a GPU adapter (lavapipe will do); without one each test says SKIPPED on stderr, and
//! fails under FOVEA_REQUIRE_GPU=1.

mod common;

use std::sync::atomic::{AtomicUsize, Ordering};

use fovea_gpu::{GpuContext, SubmissionCounts};
use fovea_render::pipeline::in_lockstep;
use fovea_render::RenderError;

/// Submits `n` empty command buffers, one per submission, as a pass would.
fn submit(ctx: &GpuContext, n: usize) {
    for _ in 0..n {
        let encoder = ctx
            .device()
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("test"),
            });
        ctx.submit([encoder.finish()]);
    }
    ctx.wait_idle("the test's submissions").unwrap();
}

fn counts(submissions: u64, joint: u64, posted: u64) -> SubmissionCounts {
    SubmissionCounts {
        submissions,
        joint,
        posted,
        timed_out: 0,
    }
}

#[test]
fn one_thread_submits_alone() {
    let Some(ctx) = common::gpu_or_skip("one_thread_submits_alone") else {
        return;
    };
    submit(&ctx, 4);
    assert_eq!(ctx.submission_counts(), counts(4, 0, 4));
}

#[test]
fn eyes_in_lockstep_share_every_submission_the_shorter_eye_has() {
    let Some(ctx) = common::gpu_or_skip("eyes_in_lockstep_share_every_submission") else {
        return;
    };
    for (left, right) in [(5, 3), (2, 6), (4, 4), (0, 3)] {
        let before = ctx.submission_counts();
        in_lockstep(
            &ctx,
            || {
                submit(&ctx, left);
                Ok(())
            },
            || {
                submit(&ctx, right);
                Ok(())
            },
        )
        .unwrap();
        let after = ctx.submission_counts();
        let got = counts(
            after.submissions - before.submissions,
            after.joint - before.joint,
            after.posted - before.posted,
        );
        let (n, m) = (left.max(right) as u64, left.min(right) as u64);
        assert_eq!(got, counts(n, m, n + m), "left {left}, right {right}");
    }
    // Afterwards nobody is registered: a lone thread submits alone again.
    let before = ctx.submission_counts();
    submit(&ctx, 2);
    let after = ctx.submission_counts();
    assert_eq!(after.submissions - before.submissions, 2);
    assert_eq!(after.joint, before.joint);
}

#[test]
fn an_eye_that_fails_or_panics_releases_the_other() {
    let Some(ctx) = common::gpu_or_skip("an_eye_that_fails_or_panics_releases_the_other") else {
        return;
    };
    // An error after one submission: the other eye's remaining three go alone.
    let left_done = AtomicUsize::new(0);
    let out: Result<((), ())> = in_lockstep(
        &ctx,
        || {
            submit(&ctx, 4);
            left_done.fetch_add(4, Ordering::SeqCst);
            Ok(())
        },
        || {
            submit(&ctx, 1);
            Err(RenderError::Unsupported("the right eye failed".into()))
        },
    );
    assert!(matches!(out, Err(RenderError::Unsupported(_))), "{out:?}");
    assert_eq!(left_done.load(Ordering::SeqCst), 4);
    assert_eq!(ctx.submission_counts(), counts(4, 1, 5));

    // A panic after one submission: the left eye finishes, then the panic is resumed here.
    let panicked = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        in_lockstep(
            &ctx,
            || {
                submit(&ctx, 3);
                left_done.fetch_add(3, Ordering::SeqCst);
                Ok(())
            },
            || -> Result<()> {
                submit(&ctx, 1);
                panic!("the right eye panicked");
            },
        )
    }));
    assert!(panicked.is_err());
    assert_eq!(left_done.load(Ordering::SeqCst), 7);
    assert_eq!(ctx.submission_counts(), counts(7, 2, 9));
}

#[test]
fn a_post_the_other_eye_never_joins_goes_alone_after_the_timeout() {
    let Some(ctx) =
        common::gpu_or_skip("a_post_the_other_eye_never_joins_goes_alone_after_the_timeout")
    else {
        return;
    };
    // The right eye is registered but busy past the gate's timeout before it posts: the
    // left eye's post goes alone (timed out), then the right eye's.
    let started = std::time::Instant::now();
    let out: Result<((), ())> = in_lockstep(
        &ctx,
        || {
            submit(&ctx, 1);
            Ok(())
        },
        || {
            std::thread::sleep(
                fovea_gpu::lockstep::POST_TIMEOUT + std::time::Duration::from_millis(500),
            );
            submit(&ctx, 1);
            Ok(())
        },
    );
    assert!(out.is_ok(), "{out:?}");
    assert!(started.elapsed() >= fovea_gpu::lockstep::POST_TIMEOUT);
    let c = ctx.submission_counts();
    assert_eq!(
        (c.submissions, c.joint, c.posted, c.timed_out),
        (2, 0, 2, 1),
        "{c:?}"
    );
}

type Result<T> = std::result::Result<T, RenderError>;
