//! Which SIMD build of every vectorised kernel this process runs, and the
//! camera sweep's dispatch to it. This is the one place that answers "which
//! SIMD level may I use": the camera's row sweep ([`crate::sensor`]'s `sweep`) and its
//! registered per-pixel stages ([`widest`]), the lens, rolling-shutter,
//! thermal and weather kernels, the renderer's upsampling and the optical
//! flow's background rows all ask [`simd_level`]. Each build performs the
//! same f32 operations in the same order on wider registers (Rust never
//! fuses a multiply and an add on its own), so every build gives the same
//! bytes; `SWARMSHOT_SIMD` caps the level so that the whole binary can be run
//! as a narrower CPU runs it (`tests/suite/determinism_audit.rs` compares).

pub(crate) mod math;

/// The variable that caps [`simd_level`]: `base`, `avx2` or `avx512`.
pub const SIMD_ENV: &str = "SWARMSHOT_SIMD";

/// The cap's older name, read when [`SIMD_ENV`] is not set.
const SIMD_ENV_OLD: &str = "SWARMSHOT_CAMERA_SIMD";

/// The level a cap's value names (2 AVX-512, 1 AVX2, 0 the baseline), any
/// case; `None` for no cap or a value it does not know.
fn cap_of(value: &str) -> Option<u8> {
    match value.trim().to_ascii_lowercase().as_str() {
        "base" | "scalar" | "none" => Some(0),
        "avx2" => Some(1),
        "avx512" => Some(2),
        _ => None,
    }
}

/// The cap the environment sets (no cap: 2), warning once of a value it
/// does not know rather than running uncapped in silence.
fn env_cap() -> u8 {
    let value = std::env::var(SIMD_ENV).or_else(|_| std::env::var(SIMD_ENV_OLD));
    let Ok(value) = value else { return 2 };
    cap_of(&value).unwrap_or_else(|| {
        eprintln!("warning: {SIMD_ENV}={value:?}: not base, avx2 or avx512; SIMD is not capped");
        2
    })
}

/// The widest build this process runs: 2 AVX-512 (F, BW, DQ, VL), 1 AVX2, 0
/// the baseline; the CPU's widest ([`cpu_simd_level`]) capped by
/// `SWARMSHOT_SIMD=base|avx2|avx512` (for running as a narrower CPU does;
/// the bytes are the same). Every SIMD dispatch in the crate asks this.
#[cfg(target_arch = "x86_64")]
pub(crate) fn simd_level() -> u8 {
    static LEVEL: std::sync::OnceLock<u8> = std::sync::OnceLock::new();
    *LEVEL.get_or_init(|| cpu_simd_level().min(env_cap()))
}

/// No SIMD builds off x86-64: the baseline.
#[cfg(not(target_arch = "x86_64"))]
pub(crate) fn simd_level() -> u8 {
    0
}

/// Whether AVX2 kernels may run ([`simd_level`] at least 1).
pub(crate) fn avx2() -> bool {
    simd_level() >= 1
}

/// Whether AVX-512 kernels that also use Ice Lake's extensions may run:
/// [`simd_level`] 2 and the CPU has VBMI (byte permutes) and VNNI (byte dot
/// products), as Intel's AVX-512 CPUs since Ice Lake and AMD's since Zen 4.
#[cfg(target_arch = "x86_64")]
pub(crate) fn avx512_icl() -> bool {
    static ICL: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    simd_level() >= 2
        && *ICL.get_or_init(|| {
            std::arch::is_x86_feature_detected!("avx512vbmi")
                && std::arch::is_x86_feature_detected!("avx512vnni")
        })
}

/// Whether AVX2 kernels that also convert half floats with F16C may run
/// ([`avx2`] and the CPU has F16C, which every AVX2 CPU has in practice).
#[cfg(target_arch = "x86_64")]
pub(crate) fn f16c() -> bool {
    static F16C: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    avx2() && *F16C.get_or_init(|| std::arch::is_x86_feature_detected!("f16c"))
}

/// The widest build the CPU itself can run (2 AVX-512, 1 AVX2, 0 the
/// baseline), whatever `SWARMSHOT_SIMD` says.
#[cfg(target_arch = "x86_64")]
pub(crate) fn cpu_simd_level() -> u8 {
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
pub(crate) fn widest<R>(f: impl FnOnce() -> R) -> R {
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
pub(crate) fn on_avx512<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// `f()` compiled for AVX2 (never inlined).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
pub(crate) fn on_avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// `f()` in the build of SIMD `level` (0 the baseline, 1 AVX2, 2 AVX-512;
/// at most the CPU's widest): for tests that compare a kernel's builds.
#[cfg(test)]
pub(crate) fn in_build<R>(level: u8, f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    {
        assert!(
            level <= cpu_simd_level(),
            "this CPU has no SIMD level {level}"
        );
        // SAFETY: the CPU runs builds up to `cpu_simd_level` (asserted above).
        #[allow(unsafe_code)]
        match level {
            1 => return unsafe { on_avx2(f) },
            2 => return unsafe { on_avx512(f) },
            _ => {}
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    assert_eq!(level, 0, "no SIMD builds off x86-64");
    f()
}

#[cfg(test)]
mod tests {
    use super::cap_of;

    #[test]
    fn each_cap_names_its_level_in_any_case() {
        assert_eq!(cap_of("base"), Some(0));
        assert_eq!(cap_of("AVX2"), Some(1));
        assert_eq!(cap_of(" avx512 "), Some(2));
        assert_eq!(cap_of("sse4.1"), None);
        assert_eq!(cap_of(""), None);
    }
}
