//! Shared by the timing examples: process CPU time and the median of repeated runs.

/// CPU time of the whole process so far (all threads; lavapipe's included), ms.
pub fn cpu_ms() -> f64 {
    cpu_time::ProcessTime::try_now()
        .map(|t| t.as_duration().as_secs_f64() * 1e3)
        .unwrap_or(f64::NAN)
}

/// The median of `v` (the upper one of an even count).
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}
