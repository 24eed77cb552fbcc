//! Recording a viewing: the gaze and the camera of every frame shown, as the CSV files
//! `fovea sequence`, `flicker` and `report` read back (`--gaze-csv`, `--camera-path`), so a
//! look-around becomes a reproducible measurement.
//!
//! `gaze.csv`: `t_s,x_norm,y_norm,depth_m,confidence` — the gaze as a fraction of the screen
//! (0 = left/top, 1 = right/bottom; so a viewing that switched headsets, or a replay at
//! another resolution, reads right), the tracker's vergence depth when it gave one,
//! confidence 1 for a valid gaze and 0 for a gap (the CSV reader holds the last valid gaze
//! there, as the viewer did). `camera.csv`:
//! `t,x,y,z,look_x,look_y,look_z,up_x,up_y,up_z` — the eye's position, a point one metre along
//! its view and its up vector. Times are seconds from the first frame, strictly increasing.
//! Both files are flushed after every frame, so a viewer that is killed leaves every frame
//! it showed.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use fovea_core::gaze::GazeSample;
use fovea_render::camera::EyeCamera;

use crate::error::{Result, ViewerError};

/// Writes `gaze.csv` and `camera.csv` into a folder.
pub struct Recorder {
    dir: PathBuf,
    gaze: BufWriter<File>,
    gaze_path: PathBuf,
    camera: BufWriter<File>,
    camera_path: PathBuf,
    last_t: Option<f64>,
    frames: u64,
}

fn io_error(path: &Path, e: std::io::Error) -> ViewerError {
    ViewerError::Io {
        path: path.to_path_buf(),
        reason: e,
    }
}

impl Recorder {
    /// Creates `dir` and the two files (replacing earlier ones).
    pub fn create(dir: &Path) -> Result<Self> {
        std::fs::create_dir_all(dir).map_err(|e| io_error(dir, e))?;
        let open = |name: &str, header: &str| -> Result<BufWriter<File>> {
            let p = dir.join(name);
            let mut w = BufWriter::new(File::create(&p).map_err(|e| io_error(&p, e))?);
            writeln!(w, "{header}").map_err(|e| io_error(&p, e))?;
            Ok(w)
        };
        Ok(Self {
            gaze: open("gaze.csv", "t_s,x_norm,y_norm,depth_m,confidence")?,
            gaze_path: dir.join("gaze.csv"),
            camera: open("camera.csv", "t,x,y,z,look_x,look_y,look_z,up_x,up_y,up_z")?,
            camera_path: dir.join("camera.csv"),
            dir: dir.to_path_buf(),
            last_t: None,
            frames: 0,
        })
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Frames recorded.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Records one frame shown at `t_s` (seconds from the first frame): its gaze (pixels of
    /// `camera`'s display) and its eye camera. A time not after the previous frame's is skipped (the
    /// readers need strictly increasing times).
    pub fn record(&mut self, t_s: f64, gaze: &GazeSample, camera: &EyeCamera) -> Result<()> {
        if !t_s.is_finite() || self.last_t.is_some_and(|t| t_s <= t) {
            return Ok(());
        }
        self.last_t = Some(t_s);
        let depth = gaze.depth_m.map_or(String::new(), |d| format!("{d:.6}"));
        let conf = if gaze.valid { 1 } else { 0 };
        let p = camera.position;
        let look = camera.position + camera.forward;
        let up = camera.up;
        let d = &camera.display;
        writeln!(
            self.gaze,
            "{t_s:.6},{:.9},{:.9},{depth},{conf}",
            gaze.x_px / f64::from(d.width_px),
            gaze.y_px / f64::from(d.height_px)
        )
        .and_then(|_| self.gaze.flush())
        .map_err(|e| io_error(&self.gaze_path, e))?;
        writeln!(
            self.camera,
            "{t_s:.6},{:.7},{:.7},{:.7},{:.7},{:.7},{:.7},{:.7},{:.7},{:.7}",
            p.x, p.y, p.z, look.x, look.y, look.z, up.x, up.y, up.z
        )
        .and_then(|_| self.camera.flush())
        .map_err(|e| io_error(&self.camera_path, e))?;
        self.frames += 1;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fovea_core::display::DisplayProfile;
    use fovea_core::gaze::csv::{parse_csv, CsvOptions};
    use fovea_render::camera_path::CameraPath;
    use glam::Vec3;

    /// What is written reads back through the readers `fovea sequence` uses, to the same
    /// gazes (a gap holds the last valid one) and camera poses.
    #[test]
    fn recordings_read_back_through_the_sequence_readers() {
        let dir = tempfile::tempdir().unwrap();
        let d = DisplayProfile::preset("vive-pro-eye").unwrap();
        let cam = |x: f32| {
            EyeCamera::new(
                Vec3::new(x, 1.0, 2.0),
                Vec3::new(0.0, -0.2, -1.0),
                Vec3::Y,
                &d,
            )
            .unwrap()
        };
        let mut r = Recorder::create(dir.path()).unwrap();
        let mut blink = GazeSample::new(0.2, 300.0, 200.0);
        blink.valid = false;
        let mut deep = GazeSample::new(0.1, 500.0, 600.0);
        deep.depth_m = Some(1.25);
        r.record(0.0, &GazeSample::new(0.0, 100.0, 200.0), &cam(0.0))
            .unwrap();
        r.record(0.1, &deep, &cam(0.5)).unwrap();
        r.record(0.1, &deep, &cam(0.7)).unwrap(); // same time: skipped
        r.record(0.2, &blink, &cam(1.0)).unwrap();
        assert_eq!(r.frames(), 3);
        let text = std::fs::read_to_string(dir.path().join("gaze.csv")).unwrap();
        let (t, report) = parse_csv(&text, 1440.0, 1600.0, &CsvOptions::default()).unwrap();
        assert_eq!(report.rows, 3);
        let s = t.samples();
        let near = |a: f64, b: f64| (a - b).abs() < 1e-5;
        assert!(near(s[0].x_px, 100.0) && near(s[0].y_px, 200.0) && s[0].valid);
        assert_eq!(s[1].depth_m, Some(1.25));
        assert!(near(s[2].x_px, 500.0) && near(s[2].y_px, 600.0) && !s[2].valid);
        // Normalised: the same gaze on a display of half the pixels.
        let (t, _) = parse_csv(&text, 720.0, 800.0, &CsvOptions::default()).unwrap();
        assert!(near(t.samples()[0].x_px, 50.0) && near(t.samples()[0].y_px, 100.0));
        let text = std::fs::read_to_string(dir.path().join("camera.csv")).unwrap();
        let path = CameraPath::parse(&text).unwrap();
        let (pos, look, up) = path.at(0.1);
        let c = cam(0.5);
        assert!((pos - c.position).length() < 1e-5);
        assert!((look - pos - c.forward).length() < 1e-5);
        assert!((up - c.up).length() < 1e-5);
    }
}
