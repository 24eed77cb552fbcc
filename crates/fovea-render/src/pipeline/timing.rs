//! Per-stage wall and processor time of a frame, the way the papers' tables report them
//! (VaFR Sec. 6, Weier Table 1). Stages are an enum, so a misspelt stage is a compile error.

use serde::ser::{Serialize, SerializeMap, Serializer};
use std::time::Instant;

/// The stages of a frame, in the order they run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stage {
    /// Building the frame plan (mapping, footprint tables, culling limits).
    Plan,
    /// Primary rays to the G-buffer.
    Trace,
    /// Direct lighting with shadow rays, or path tracing.
    Shade,
    /// Colour of samples culled by the DOF roulette, from their shaded neighbours.
    CullFill,
    /// Temporal accumulation (history folded in, and kept for the next frame).
    Temporal,
    /// Sample-space denoising (and recording its guides at the trace).
    Denoise,
    /// Sample-space anti-aliasing.
    Aa,
    /// Sample buffers to screen pixels.
    Reconstruct,
    /// Peripheral contrast enhancement.
    Contrast,
    /// Depth of field.
    Dof,
}

impl Stage {
    /// Every stage, in order.
    pub const ALL: [Stage; 10] = [
        Stage::Plan,
        Stage::Trace,
        Stage::Shade,
        Stage::CullFill,
        Stage::Temporal,
        Stage::Denoise,
        Stage::Aa,
        Stage::Reconstruct,
        Stage::Contrast,
        Stage::Dof,
    ];

    /// The name in JSON and tables.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Plan => "plan",
            Stage::Trace => "trace",
            Stage::Shade => "shade",
            Stage::CullFill => "cull-fill",
            Stage::Temporal => "temporal",
            Stage::Denoise => "denoise",
            Stage::Aa => "aa",
            Stage::Reconstruct => "reconstruct",
            Stage::Contrast => "contrast",
            Stage::Dof => "dof",
        }
    }
}

impl std::fmt::Display for Stage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Milliseconds per stage, for the stages that ran; serialised as a map from stage name to
/// milliseconds (in name order, as the JSON has always been written).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageMs([Option<f64>; Stage::ALL.len()]);

impl StageMs {
    /// Milliseconds of `stage` (0 when it did not run).
    pub fn get(&self, stage: Stage) -> f64 {
        self.0[stage as usize].unwrap_or(0.0)
    }

    /// Whether `stage` ran.
    pub fn ran(&self, stage: Stage) -> bool {
        self.0[stage as usize].is_some()
    }

    /// Adds `ms` to `stage`.
    pub fn add(&mut self, stage: Stage, ms: f64) {
        *self.0[stage as usize].get_or_insert(0.0) += ms;
    }

    /// The stages that ran with their milliseconds, in frame order.
    pub fn iter(&self) -> impl Iterator<Item = (Stage, f64)> + '_ {
        Stage::ALL
            .iter()
            .filter_map(|&s| self.0[s as usize].map(|v| (s, v)))
    }

    /// Sum over `stages`.
    pub fn sum(&self, stages: &[Stage]) -> f64 {
        stages.iter().map(|&s| self.get(s)).sum()
    }
}

impl Serialize for StageMs {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut entries: Vec<(&str, f64)> = self.iter().map(|(s, v)| (s.name(), v)).collect();
        entries.sort_by(|a, b| a.0.cmp(b.0));
        let mut map = serializer.serialize_map(Some(entries.len()))?;
        for (k, v) in entries {
            map.serialize_entry(k, &v)?;
        }
        map.end()
    }
}

/// Wall and process CPU time since a start.
pub struct Stopwatch {
    wall: Instant,
    cpu: Option<cpu_time::ProcessTime>,
}

impl Stopwatch {
    /// Starts now.
    pub fn start() -> Self {
        Self {
            wall: Instant::now(),
            cpu: cpu_time::ProcessTime::try_now().ok(),
        }
    }

    /// (wall, CPU) milliseconds elapsed; CPU is NaN where the clock is unavailable.
    pub fn elapsed_ms(&self) -> (f64, f64) {
        let wall = self.wall.elapsed().as_secs_f64() * 1e3;
        let cpu = self
            .cpu
            .and_then(|c| c.try_elapsed().ok())
            .map_or(f64::NAN, |d| d.as_secs_f64() * 1e3);
        (wall, cpu)
    }
}

/// Wall and CPU milliseconds per stage, summed over the times a stage runs (trace and shade
/// run once per chunk).
#[derive(Clone, Copy, Debug, Default)]
pub struct StageTimes {
    /// Wall time.
    pub wall: StageMs,
    /// Processor time summed over threads.
    pub cpu: StageMs,
}

impl StageTimes {
    /// Adds the time since `since` to `stage`.
    pub fn add(&mut self, stage: Stage, since: &Stopwatch) {
        let (w, c) = since.elapsed_ms();
        self.wall.add(stage, w);
        self.cpu.add(stage, c);
    }

    /// Runs `f` as `stage`.
    pub fn time<T>(&mut self, stage: Stage, f: impl FnOnce() -> T) -> T {
        let t = Stopwatch::start();
        let out = f();
        self.add(stage, &t);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stage_ms_serialises_as_the_old_name_map() {
        let mut s = StageMs::default();
        s.add(Stage::Trace, 2.0);
        s.add(Stage::Aa, 1.0);
        s.add(Stage::Trace, 0.5);
        assert_eq!(s.get(Stage::Trace), 2.5);
        assert_eq!(s.get(Stage::Dof), 0.0);
        assert!(!s.ran(Stage::Dof));
        assert_eq!(
            serde_json::to_string(&s).unwrap(),
            r#"{"aa":1.0,"trace":2.5}"#
        );
        let names: Vec<_> = Stage::ALL.iter().map(|s| s.name()).collect();
        let mut unique = names.clone();
        unique.dedup();
        assert_eq!(names, unique);
    }
}
