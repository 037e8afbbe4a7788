//! Timing for the stage benches (`lens_bench`, `rolling_bench`,
//! `thermal_bench`): the median
//! wall time of repeated runs and their mean CPU time, all threads.

use std::time::Instant;

/// The process's CPU time so far, seconds (Linux's /proc/self/stat, in
/// 100 Hz ticks; NaN elsewhere).
fn cpu_s() -> f64 {
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
    let mut times: Vec<f64> = (0..30)
        .map(|_| {
            let t = Instant::now();
            run();
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    let cpu_ms = (cpu_s() - cpu) * 1e3 / 30.0;
    times.sort_by(f64::total_cmp);
    (times[times.len() / 2], cpu_ms)
}
