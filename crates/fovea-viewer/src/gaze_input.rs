//! Where the viewer's gaze comes from: the mouse pointer over the frame, a replayed gaze CSV
//! (real time or stepped), or a live stream from an eye tracker over UDP.
//!
//! # The stream protocol
//!
//! UDP datagrams to `127.0.0.1:PORT` (`fovea view --gaze-udp PORT`), each holding one or more
//! JSON objects, one per line:
//!
//! ```text
//! {"x": 812.5, "y": 440.0}                                     pixels of the display, y down
//! {"x_norm": 0.42, "y_norm": 0.55, "depth_m": 0.8}             0–1 of the screen, y down
//! {"x": 812.5, "y": 440.0, "confidence": 0.3}                  a gap (below 0.6)
//! {"valid": false}                                             a blink
//! ```
//!
//! Fields: `x`/`y` (pixels) or `x_norm`/`y_norm` (0 = left/top, 1 = right/bottom); optional
//! `depth_m` (the tracker's vergence depth, metres, > 0: auto focus uses it), `confidence`
//! (0–1) and `valid` (boolean). The blink policy is the CSV reader's
//! ([`fovea_core::gaze::csv`]): a sample that is marked invalid, has a confidence below 0.6, or
//! lies off the screen by more than 5 % of its size is a gap and holds the last valid gaze; one
//! off by less is clamped onto the screen. A line that is not a JSON object, or whose fields
//! have the wrong type, is *malformed*: counted and skipped, never an error. The viewer uses
//! the newest sample each frame.

use std::net::UdpSocket;

use fovea_core::gaze::csv::OFFSCREEN_MARGIN_FRACTION;
use fovea_core::gaze::{GazeSample, GazeTrajectory};

use crate::error::{Result, ViewerError};

/// Confidence under which a sample is a gap (Pupil Labs' threshold, as the CSV reader).
pub const MIN_CONFIDENCE: f64 = 0.6;

/// Largest datagram read, bytes.
const MAX_DATAGRAM: usize = 64 * 1024;

/// What a stream line said.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Packet {
    /// A gaze on (or clamped onto) the screen, pixels, with the tracker's depth.
    Gaze {
        /// x, pixels.
        x_px: f64,
        /// y, pixels (down).
        y_px: f64,
        /// Vergence depth, metres.
        depth_m: Option<f64>,
        /// Whether it was clamped onto the screen.
        clamped: bool,
    },
    /// A blink or tracking gap.
    Gap,
}

/// Why a line was malformed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Malformed(pub String);

/// Parses one stream line for a `width_px` × `height_px` display.
pub fn parse_packet(
    line: &str,
    width_px: f64,
    height_px: f64,
) -> std::result::Result<Packet, Malformed> {
    let v: serde_json::Value =
        serde_json::from_str(line).map_err(|e| Malformed(format!("not JSON: {e}")))?;
    let obj = v
        .as_object()
        .ok_or_else(|| Malformed("not a JSON object".into()))?;
    let num = |k: &str| -> std::result::Result<Option<f64>, Malformed> {
        match obj.get(k) {
            None | Some(serde_json::Value::Null) => Ok(None),
            Some(serde_json::Value::Number(n)) => Ok(n.as_f64()),
            Some(other) => Err(Malformed(format!("`{k}` is {other}, not a number"))),
        }
    };
    let valid = match obj.get("valid") {
        None | Some(serde_json::Value::Null) => true,
        Some(serde_json::Value::Bool(b)) => *b,
        Some(other) => return Err(Malformed(format!("`valid` is {other}, not a boolean"))),
    };
    let confidence = num("confidence")?;
    let depth_m = num("depth_m")?.filter(|d| d.is_finite() && *d > 0.0);
    let (x, y) = match (num("x")?, num("y")?, num("x_norm")?, num("y_norm")?) {
        (Some(x), Some(y), _, _) => (x, y),
        (None, None, Some(xn), Some(yn)) => (xn * width_px, yn * height_px),
        (None, None, None, None) if !valid => return Ok(Packet::Gap),
        _ => {
            return Err(Malformed(
                "needs `x` and `y` (pixels) or `x_norm` and `y_norm` (0–1)".into(),
            ))
        }
    };
    if !valid || confidence.is_some_and(|c| c.is_nan() || c < MIN_CONFIDENCE) {
        return Ok(Packet::Gap);
    }
    let (mx, my) = (
        OFFSCREEN_MARGIN_FRACTION * width_px,
        OFFSCREEN_MARGIN_FRACTION * height_px,
    );
    let inside = |v: f64, size: f64, m: f64| v.is_finite() && v >= -m && v <= size + m;
    if !(inside(x, width_px, mx) && inside(y, height_px, my)) {
        return Ok(Packet::Gap);
    }
    let (cx, cy) = (x.clamp(0.0, width_px), y.clamp(0.0, height_px));
    Ok(Packet::Gaze {
        x_px: cx,
        y_px: cy,
        depth_m,
        clamped: (cx, cy) != (x, y),
    })
}

/// Counts of a stream so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct StreamCounts {
    /// Lines read.
    pub lines: u64,
    /// Valid gazes (clamped ones included).
    pub valid: u64,
    /// Gaps (blinks, low confidence, off screen).
    pub gaps: u64,
    /// Gazes clamped onto the screen.
    pub clamped: u64,
    /// Malformed lines, skipped.
    pub malformed: u64,
}

/// The live gaze of a UDP stream with the blink policy: the newest valid sample, or the
/// last valid one held (marked invalid) through a gap.
pub struct GazeStream {
    socket: UdpSocket,
    width_px: f64,
    height_px: f64,
    last_valid: Option<(f64, f64, Option<f64>)>,
    latest_valid: bool,
    /// Counts so far.
    pub counts: StreamCounts,
    /// The last malformed line's reason.
    pub last_error: Option<String>,
    buf: Vec<u8>,
}

impl GazeStream {
    /// Listens on `127.0.0.1:port` (0: any free port, see [`GazeStream::port`]).
    pub fn bind(port: u16, width_px: f64, height_px: f64) -> Result<Self> {
        let socket = UdpSocket::bind(("127.0.0.1", port)).map_err(|e| {
            ViewerError::Input(format!(
                "cannot listen for gaze on UDP 127.0.0.1:{port}: {e} (is another program using the port? choose another with --gaze-udp)"
            ))
        })?;
        socket
            .set_nonblocking(true)
            .map_err(|e| ViewerError::Input(format!("UDP socket: {e}")))?;
        Ok(Self {
            socket,
            width_px,
            height_px,
            last_valid: None,
            latest_valid: false,
            counts: StreamCounts::default(),
            last_error: None,
            buf: vec![0; MAX_DATAGRAM],
        })
    }

    /// The port listened on.
    pub fn port(&self) -> u16 {
        self.socket.local_addr().map_or(0, |a| a.port())
    }

    /// The display size gazes are read for (a headset switch changes it).
    pub fn set_display(&mut self, width_px: f64, height_px: f64) {
        if let Some((x, y, d)) = self.last_valid {
            self.last_valid = Some((
                x * width_px / self.width_px,
                y * height_px / self.height_px,
                d,
            ));
        }
        self.width_px = width_px;
        self.height_px = height_px;
    }

    /// Reads every datagram waiting and returns the gaze now at time `t_s`: the newest valid
    /// sample, or the last valid one marked invalid after a gap; `None` before the first
    /// valid sample.
    pub fn poll(&mut self, t_s: f64) -> Option<GazeSample> {
        // Until WouldBlock (nothing more waiting); any other error (e.g. ICMP refused on some
        // systems) is not the tracker's data either.
        while let Ok(n) = self.socket.recv(&mut self.buf) {
            let text = String::from_utf8_lossy(&self.buf[..n]).into_owned();
            for line in text.lines().filter(|l| !l.trim().is_empty()) {
                self.feed(line);
            }
        }
        let (x, y, depth_m) = self.last_valid?;
        Some(GazeSample {
            t_s,
            x_px: x,
            y_px: y,
            depth_m,
            right: None,
            valid: self.latest_valid,
        })
    }

    /// Applies one line.
    pub fn feed(&mut self, line: &str) {
        self.counts.lines += 1;
        match parse_packet(line, self.width_px, self.height_px) {
            Ok(Packet::Gaze {
                x_px,
                y_px,
                depth_m,
                clamped,
            }) => {
                self.counts.valid += 1;
                self.counts.clamped += u64::from(clamped);
                self.last_valid = Some((x_px, y_px, depth_m));
                self.latest_valid = true;
            }
            Ok(Packet::Gap) => {
                self.counts.gaps += 1;
                self.latest_valid = false;
            }
            Err(Malformed(why)) => {
                self.counts.malformed += 1;
                self.last_error = Some(why);
            }
        }
    }
}

/// Maps the pointer over the frame's rectangle on screen to the display's pixels; outside the
/// frame the last valid gaze holds.
#[derive(Clone, Copy, Debug, Default)]
pub struct PointerGaze {
    last: Option<(f64, f64)>,
}

impl PointerGaze {
    /// The gaze at time `t_s` for a pointer at `pointer` (window points) over a frame drawn in
    /// `rect` (window points) showing a `width_px` × `height_px` display (one eye; with both
    /// eyes side by side, the half the pointer is over). `None` before the pointer first
    /// enters the frame.
    pub fn update(
        &mut self,
        t_s: f64,
        pointer: Option<egui::Pos2>,
        rect: egui::Rect,
        eyes: usize,
        width_px: f64,
        height_px: f64,
    ) -> Option<GazeSample> {
        let mut valid = false;
        if let Some(p) = pointer.filter(|p| rect.contains(*p) && rect.width() > 0.0) {
            let eye_w = rect.width() / eyes.max(1) as f32;
            let u = ((p.x - rect.min.x) % eye_w) / eye_w;
            let v = (p.y - rect.min.y) / rect.height();
            self.last = Some((
                (u as f64 * width_px).clamp(0.0, width_px),
                (v as f64 * height_px).clamp(0.0, height_px),
            ));
            valid = true;
        }
        let (x, y) = self.last?;
        Some(GazeSample {
            t_s,
            x_px: x,
            y_px: y,
            depth_m: None,
            right: None,
            valid,
        })
    }
}

/// How a replayed gaze CSV advances.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReplayMode {
    /// At the recorded times, from the viewer's clock (looping at the end).
    RealTime,
    /// One sample per step (key N; one per frame with `--frames`).
    Stepped,
}

/// A gaze CSV played back.
pub struct GazeReplay {
    trajectory: GazeTrajectory,
    mode: ReplayMode,
    index: usize,
}

impl GazeReplay {
    /// Replays `trajectory` (already parsed for the display's size).
    pub fn new(trajectory: GazeTrajectory, mode: ReplayMode) -> Self {
        Self {
            trajectory,
            mode,
            index: 0,
        }
    }

    /// The mode.
    pub fn mode(&self) -> ReplayMode {
        self.mode
    }

    /// The trajectory.
    pub fn trajectory(&self) -> &GazeTrajectory {
        &self.trajectory
    }

    /// Advances a stepped replay by one sample (holding the last).
    pub fn step(&mut self) {
        self.index = (self.index + 1).min(self.trajectory.len() - 1);
    }

    /// The gaze at viewer time `t_s` (real time: interpolated at `t_s` modulo the duration;
    /// stepped: the current sample, its time replaced by `t_s`).
    pub fn at(&self, t_s: f64) -> GazeSample {
        let mut g = match self.mode {
            ReplayMode::RealTime => {
                let d = self.trajectory.duration_s();
                let t = if d > 0.0 { t_s.rem_euclid(d) } else { 0.0 };
                self.trajectory.at(self.trajectory.start_s() + t)
            }
            ReplayMode::Stepped => self.trajectory.samples()[self.index],
        };
        g.t_s = t_s;
        g
    }

    /// Scales the gaze to another display size.
    pub fn rescale(&mut self, width_px: f64, height_px: f64) -> Result<()> {
        let (sx, sy) = (
            width_px / self.trajectory.width_px(),
            height_px / self.trajectory.height_px(),
        );
        let samples = self
            .trajectory
            .samples()
            .iter()
            .map(|g| GazeSample {
                x_px: g.x_px * sx,
                y_px: g.y_px * sy,
                right: g.right.map(|(x, y)| (x * sx, y * sy)),
                ..*g
            })
            .collect();
        self.trajectory = GazeTrajectory::new(samples, width_px, height_px)
            .map_err(|e| ViewerError::Input(e.to_string()))?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packets_in_pixels_and_normalised() {
        assert_eq!(
            parse_packet(r#"{"x": 10, "y": 20.5}"#, 100.0, 50.0),
            Ok(Packet::Gaze {
                x_px: 10.0,
                y_px: 20.5,
                depth_m: None,
                clamped: false
            })
        );
        assert_eq!(
            parse_packet(
                r#"{"x_norm": 0.25, "y_norm": 1.0, "depth_m": 0.8}"#,
                100.0,
                50.0
            ),
            Ok(Packet::Gaze {
                x_px: 25.0,
                y_px: 50.0,
                depth_m: Some(0.8),
                clamped: false
            })
        );
    }

    #[test]
    fn the_blink_policy_is_the_csv_readers() {
        let gap = Ok(Packet::Gap);
        assert_eq!(parse_packet(r#"{"valid": false}"#, 100.0, 50.0), gap);
        assert_eq!(
            parse_packet(r#"{"x": 1, "y": 1, "confidence": 0.59}"#, 100.0, 50.0),
            gap
        );
        // 5 % of 100 px: 104 is clamped, 106 a gap.
        assert_eq!(parse_packet(r#"{"x": 106, "y": 1}"#, 100.0, 50.0), gap);
        assert_eq!(
            parse_packet(r#"{"x": 104, "y": -2}"#, 100.0, 50.0),
            Ok(Packet::Gaze {
                x_px: 100.0,
                y_px: 0.0,
                depth_m: None,
                clamped: true
            })
        );
        assert!(matches!(
            parse_packet(
                r#"{"x": 1, "y": 1, "confidence": 0.6, "depth_m": -1}"#,
                100.0,
                50.0
            ),
            Ok(Packet::Gaze { depth_m: None, .. })
        ));
    }

    #[test]
    fn malformed_lines_are_reasons_not_panics() {
        for line in [
            "",
            "{",
            "[1, 2]",
            "42",
            r#"{"x": "10", "y": 2}"#,
            r#"{"x": 10}"#,
            r#"{"valid": "no", "x": 1, "y": 1}"#,
            r#"{"x": 1e999, "y": 1}"#,
            "\u{0}\u{1}",
        ] {
            assert!(parse_packet(line, 100.0, 50.0).is_err(), "{line:?}");
        }
    }

    #[test]
    fn a_stream_holds_the_last_valid_gaze_through_gaps_and_counts_junk() {
        let mut s = GazeStream::bind(0, 100.0, 50.0).unwrap();
        assert_eq!(s.poll(0.0), None);
        let sender = UdpSocket::bind("127.0.0.1:0").unwrap();
        let to = ("127.0.0.1", s.port());
        sender
            .send_to(b"{\"x\": 30, \"y\": 40}\nnot json\n", to)
            .unwrap();
        sender.send_to(&[0xff, 0xfe, 0x00], to).unwrap();
        // Datagrams on the loopback arrive in order; wait until both are read.
        let mut g = None;
        for _ in 0..200 {
            g = s.poll(1.0);
            if s.counts.lines >= 3 {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        let first = g.unwrap();
        assert_eq!((first.x_px, first.y_px, first.valid), (30.0, 40.0, true));
        assert_eq!(s.counts.malformed, 2);
        sender.send_to(b"{\"valid\": false}", to).unwrap();
        for _ in 0..200 {
            g = s.poll(2.0);
            if s.counts.gaps == 1 {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        let g = g.unwrap();
        assert_eq!((g.x_px, g.y_px, g.valid), (30.0, 40.0, false));
        assert_eq!(s.counts.valid, 1);
    }

    #[test]
    fn the_pointer_outside_the_frame_holds_the_last_gaze() {
        let rect = egui::Rect::from_min_size(egui::pos2(100.0, 50.0), egui::vec2(200.0, 100.0));
        let mut p = PointerGaze::default();
        assert!(p
            .update(0.0, Some(egui::pos2(10.0, 10.0)), rect, 1, 400.0, 200.0)
            .is_none());
        let g = p
            .update(0.1, Some(egui::pos2(150.0, 75.0)), rect, 1, 400.0, 200.0)
            .unwrap();
        assert_eq!((g.x_px, g.y_px, g.valid), (100.0, 50.0, true));
        let g = p.update(0.2, None, rect, 1, 400.0, 200.0).unwrap();
        assert_eq!((g.x_px, g.y_px, g.valid), (100.0, 50.0, false));
        // Both eyes: the right half maps onto the same display.
        let g = p
            .update(0.3, Some(egui::pos2(250.0, 75.0)), rect, 2, 400.0, 200.0)
            .unwrap();
        assert_eq!((g.x_px, g.y_px), (200.0, 50.0));
    }

    #[test]
    fn a_stepped_replay_steps_and_holds_the_last_sample() {
        let t = GazeTrajectory::new(
            vec![
                GazeSample::new(0.0, 1.0, 2.0),
                GazeSample::new(0.5, 3.0, 4.0),
            ],
            10.0,
            10.0,
        )
        .unwrap();
        let mut r = GazeReplay::new(t.clone(), ReplayMode::Stepped);
        assert_eq!(r.at(7.0).x_px, 1.0);
        r.step();
        r.step();
        let g = r.at(8.0);
        assert_eq!((g.t_s, g.x_px), (8.0, 3.0));
        let r = GazeReplay::new(t, ReplayMode::RealTime);
        assert_eq!(r.at(0.25).x_px, 2.0);
        assert_eq!(r.at(0.75).x_px, 2.0, "loops");
    }
}
