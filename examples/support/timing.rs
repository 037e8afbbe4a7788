//! Timing for the stage benches (`camera_bench`, `lens_bench`,
//! `rolling_bench`, `thermal_bench`, `weather_bench`): the median wall time
//! of repeated runs and their mean CPU time, all threads.

use std::time::Instant;

/// The process's CPU time so far, seconds (Linux's /proc/self/stat, in
/// 100 Hz ticks; NaN elsewhere).
pub fn cpu_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let field = |i: usize| after.split_whitespace().nth(i)?.parse::<f64>().ok();
    match (field(11), field(12)) {
        (Some(user), Some(system)) => (user + system) / 100.0,
        _ => f64::NAN,
    }
}

/// The median wall time of 30 runs after 3 warm-ups, and their mean CPU
/// time (all threads), ms.
pub fn median_ms(mut run: impl FnMut()) -> (f64, f64) {
    for _ in 0..3 {
        run();
    }
    let cpu = cpu_s();
    let times: Vec<f64> = (0..30)
        .map(|_| {
            let t = Instant::now();
            run();
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    let cpu_ms = (cpu_s() - cpu) * 1e3 / 30.0;
    (median(times), cpu_ms)
}

/// The median of `v` (the upper one of an even count; 0 when empty).
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}
