//! The first connection to the X server: made before anything else talks to it, retried
//! briefly, and held open until the window's event loop has its own.
//!
//! Why (measured under `xvfb-run -a`, whose Xvfb runs without `-noreset`): an X server resets
//! when its last client disconnects, and a client that connects while it resets is refused
//! ("Failed to open connection to X server"); the reset re-initialises the server, which
//! takes long enough on a busy machine to be hit. Before the window opens, `fovea view`
//! probes the GPU, and Mesa's Vulkan device-selection layer (`VK_LAYER_MESA_device_select`,
//! an implicit layer) connects to the X server and disconnects again to find the display's
//! GPU (Xvfb's `-audit 4` log shows "client 1 connected … disconnected" for a bare
//! `vkCreateInstance` + `vkEnumeratePhysicalDevices` with the X11 surface extensions, as
//! wgpu asks for them; nothing with `NODEVICE_SELECT=1`). As the only client, its disconnect
//! resets the server just before winit connects. On the 2-core machine with builds running
//! (load 9–10), a C loop of "Vulkan probe, then connect" under `xvfb-run -a` failed the
//! connect 128 times in 260; with one connection held open from before the first probe,
//! 0 in 260. (winit cannot retry by itself: an event loop whose creation failed cannot be
//! created again in the same process.)
//!
//! So [`connect_display_server`] connects first (retrying for up to [`RETRY_FOR`] with
//! backoff, and saying so when it had to), and the [`DisplayHold`] it returns keeps the
//! server from resetting until the event loop is connected.

use std::time::{Duration, Instant};

use crate::error::{Result, ViewerError};

/// How long the first connection is retried before giving up.
pub const RETRY_FOR: Duration = Duration::from_secs(5);

/// A connection to the X server held open (nothing is read from or sent on it); dropping it
/// closes it. Empty where the window will not use X11 (Wayland, other platforms).
pub struct DisplayHold {
    #[cfg(all(
        unix,
        not(any(target_os = "macos", target_os = "ios", target_os = "android"))
    ))]
    _x11: Option<x11rb::rust_connection::RustConnection>,
}

impl DisplayHold {
    /// A hold of nothing.
    pub fn none() -> Self {
        Self {
            #[cfg(all(
                unix,
                not(any(target_os = "macos", target_os = "ios", target_os = "android"))
            ))]
            _x11: None,
        }
    }
}

/// Connects to the X server of `DISPLAY` (when the window will use X11: `DISPLAY` is set and
/// neither `WAYLAND_DISPLAY` nor `WAYLAND_SOCKET` is) and holds the connection. A refused
/// connection is retried after 20, 40, 80 … ms (at most 500 ms apart) for up to
/// [`RETRY_FOR`]; when a retry succeeds a one-line note on stderr says how many attempts it
/// took (unless `quiet`). When none does, the error names the display, the attempts and the
/// last reason.
pub fn connect_display_server(quiet: bool) -> Result<DisplayHold> {
    #[cfg(all(
        unix,
        not(any(target_os = "macos", target_os = "ios", target_os = "android"))
    ))]
    {
        let set = |k: &str| std::env::var_os(k).is_some_and(|v| !v.is_empty());
        if !set("DISPLAY") || set("WAYLAND_DISPLAY") || set("WAYLAND_SOCKET") {
            return Ok(DisplayHold::none());
        }
        let display = std::env::var("DISPLAY").unwrap_or_default();
        let connect = || {
            x11rb::rust_connection::RustConnection::connect(None)
                .map(|(c, _screen)| c)
                .map_err(|e| e.to_string())
        };
        let (conn, attempts, waited) =
            retry(connect, RETRY_FOR, std::thread::sleep).map_err(|(attempts, e)| {
                ViewerError::NoDisplay(format!(
                    "cannot connect to the X server DISPLAY={display} ({attempts} attempts over \
                     {:.0} s; last: {e}); check DISPLAY (X11) or WAYLAND_DISPLAY (Wayland)",
                    RETRY_FOR.as_secs_f64()
                ))
            })?;
        if attempts > 1 && !quiet {
            eprintln!(
                "note: the X server DISPLAY={display} refused the first connection; connected \
                 at attempt {attempts}, after {:.2} s",
                waited.as_secs_f64()
            );
        }
        Ok(DisplayHold { _x11: Some(conn) })
    }
    #[cfg(not(all(
        unix,
        not(any(target_os = "macos", target_os = "ios", target_os = "android"))
    )))]
    {
        let _ = quiet;
        Ok(DisplayHold::none())
    }
}

/// Calls `attempt` until it succeeds or `budget` has passed, sleeping (with `sleep`) 20 ms,
/// then twice as long each time up to 500 ms, in between. `Ok((value, attempts, time
/// spent))`, or `Err((attempts, last error))`.
pub fn retry<T, E>(
    mut attempt: impl FnMut() -> std::result::Result<T, E>,
    budget: Duration,
    mut sleep: impl FnMut(Duration),
) -> std::result::Result<(T, u32, Duration), (u32, E)> {
    let start = Instant::now();
    let mut slept = Duration::ZERO;
    let mut pause = Duration::from_millis(20);
    let mut attempts = 0u32;
    loop {
        attempts += 1;
        match attempt() {
            Ok(v) => return Ok((v, attempts, start.elapsed().max(slept))),
            Err(e) => {
                let spent = start.elapsed().max(slept);
                if spent >= budget {
                    return Err((attempts, e));
                }
                let p = pause.min(budget - spent);
                sleep(p);
                slept += p;
                pause = (pause * 2).min(Duration::from_millis(500));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn retries_with_backoff_until_success() {
        let mut pauses = Vec::new();
        let mut left = 3;
        let (v, attempts, _) = retry(
            || {
                left -= 1;
                if left == 0 {
                    Ok(7)
                } else {
                    Err("refused")
                }
            },
            RETRY_FOR,
            |d| pauses.push(d),
        )
        .unwrap();
        assert_eq!((v, attempts), (7, 3));
        assert_eq!(
            pauses,
            vec![Duration::from_millis(20), Duration::from_millis(40)]
        );
    }

    #[test]
    fn gives_up_after_the_budget_with_the_last_error() {
        let mut pauses = Vec::new();
        let mut n = 0;
        let (attempts, e) = retry(
            || -> std::result::Result<(), String> {
                n += 1;
                Err(format!("refused {n}"))
            },
            RETRY_FOR,
            |d| pauses.push(d),
        )
        .unwrap_err();
        // 20 + 40 + 80 + 160 + 320 + 500 × 8 + 380 ms = 5 s, then the last attempt.
        let total: Duration = pauses.iter().sum();
        assert_eq!(total, RETRY_FOR);
        assert_eq!(attempts as usize, pauses.len() + 1);
        assert!(pauses.iter().all(|&p| p <= Duration::from_millis(500)));
        assert_eq!(e, format!("refused {attempts}"));
    }
}
