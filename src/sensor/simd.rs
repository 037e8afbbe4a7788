//! Which SIMD build of the camera's row sweep this CPU runs, and the
//! dispatch to it: the sweep's band ([`super::sweep`]) and every registered
//! per-pixel stage ([`widest`]) are compiled for AVX-512 and AVX2 as well as
//! for the baseline and run the widest way the CPU has. Each build performs
//! the same f32 operations in the same order on wider registers (Rust never
//! fuses a multiply and an add on its own), so every build gives the same
//! bytes.

/// The widest build this CPU runs: 2 AVX-512 (F, BW, DQ, VL), 1 AVX2, 0
/// the baseline. `SWARMSHOT_CAMERA_SIMD=avx2` or `=base` caps it (for
/// comparing the builds; the bytes are the same).
#[cfg(target_arch = "x86_64")]
pub(crate) fn simd_level() -> u8 {
    static LEVEL: std::sync::OnceLock<u8> = std::sync::OnceLock::new();
    *LEVEL.get_or_init(|| {
        let cap = match std::env::var("SWARMSHOT_CAMERA_SIMD").as_deref() {
            Ok("base") => 0,
            Ok("avx2") => 1,
            _ => 2,
        };
        cpu_simd_level().min(cap)
    })
}

/// The widest build the CPU itself can run (2 AVX-512, 1 AVX2, 0 the
/// baseline), whatever `SWARMSHOT_CAMERA_SIMD` says.
#[cfg(target_arch = "x86_64")]
pub(super) fn cpu_simd_level() -> u8 {
    let avx512 = std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512bw")
        && std::arch::is_x86_feature_detected!("avx512dq")
        && std::arch::is_x86_feature_detected!("avx512vl");
    let avx2 = std::arch::is_x86_feature_detected!("avx2");
    if avx512 { 2 } else { u8::from(avx2) }
}

/// `f()` compiled the widest way this CPU runs ([`simd_level`]): a stage's
/// row loop written once, its `#[inline(always)]` kernels vectorised for
/// AVX-512 or AVX2 where the CPU has them. The closure must be marked
/// `#[inline(always)]`: otherwise it may stay a baseline function that the
/// wider builds merely call (measured: the band twice as slow).
#[inline(always)]
pub(super) fn widest<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    {
        if simd_level() >= 2 {
            // SAFETY: the CPU has these features (checked by `simd_level`).
            #[allow(unsafe_code)]
            unsafe {
                return on_avx512(f);
            }
        }
        if simd_level() >= 1 {
            // SAFETY: the CPU has AVX2 (checked by `simd_level`).
            #[allow(unsafe_code)]
            unsafe {
                return on_avx2(f);
            }
        }
    }
    f()
}

/// `f()` compiled for AVX-512 (never inlined into a narrower caller, nor a
/// narrower build into it: each build stays what it says). A closure's
/// captured slices lose their no-alias marks: a loop that needs them (the
/// decode and encode rows) gets its own `#[target_feature]` function.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512dq,avx512vl")]
#[inline(never)]
pub(super) fn on_avx512<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// `f()` compiled for AVX2 (never inlined).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
pub(super) fn on_avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}
