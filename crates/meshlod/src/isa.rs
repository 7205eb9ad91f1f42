//! Runtime instruction-set dispatch for the hot `f64` kernels (the quadric
//! minimiser, the fold-over check, the closest-point query).
//!
//! [`dispatch`] runs a closure compiled a second time with AVX2 (and the BMI, LZCNT
//! and POPCNT extensions of the same CPU generation) when the CPU has them, else the
//! baseline x86-64 build. The VEX encodings mostly save register copies and the false
//! dependencies of the legacy `f32 → f64` conversions and square roots.
//!
//! Results are **bit for bit** those of the baseline build: FMA is deliberately *not*
//! enabled, and Rust never fuses a multiply and an add on its own, so every
//! operation rounds exactly as before (the simplifier's outputs were compared
//! byte for byte). `MESHLOD_NO_AVX2=1` in the environment forces the baseline path.
//!
//! This is the crate's only `unsafe`: calling a `#[target_feature]` function is
//! unsafe because running it on a CPU without the features is undefined behaviour;
//! [`dispatch`] calls it only after `is_x86_feature_detected!` confirmed each one.
#![allow(unsafe_code)]

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::sync::atomic::{AtomicU8, Ordering};

    /// 0: not yet known, 1: baseline, 2: AVX2 and friends.
    static LEVEL: AtomicU8 = AtomicU8::new(0);

    #[cold]
    fn detect() -> bool {
        let forced_off = std::env::var_os("MESHLOD_NO_AVX2").is_some_and(|v| v != "0");
        let ok = !forced_off
            && std::is_x86_feature_detected!("avx")
            && std::is_x86_feature_detected!("avx2")
            && std::is_x86_feature_detected!("bmi1")
            && std::is_x86_feature_detected!("bmi2")
            && std::is_x86_feature_detected!("lzcnt")
            && std::is_x86_feature_detected!("popcnt");
        LEVEL.store(if ok { 2 } else { 1 }, Ordering::Relaxed);
        ok
    }

    /// Whether the AVX2 path may run on this CPU.
    #[inline]
    pub(super) fn avx2() -> bool {
        match LEVEL.load(Ordering::Relaxed) {
            0 => detect(),
            l => l == 2,
        }
    }

    /// `f()` compiled with the AVX2 generation's features (the closure and what it
    /// inlines).
    ///
    /// # Safety
    /// The CPU must support every feature enabled here ([`avx2`] says so).
    #[target_feature(enable = "avx,avx2,bmi1,bmi2,lzcnt,popcnt")]
    #[inline]
    pub(super) unsafe fn run<R>(f: impl FnOnce() -> R) -> R {
        f()
    }
}

/// Runs `f`, as its AVX2 build when the CPU has the features (see the module docs;
/// the result is the same either way). Kernels passed here should mark what they
/// call `#[inline]`/`#[inline(always)]`, so it is compiled into the AVX2 copy.
#[inline(always)]
pub(crate) fn dispatch<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    if x86::avx2() {
        // SAFETY: `avx2()` checked every feature `run` enables.
        return unsafe { x86::run(f) };
    }
    f()
}

/// `f` run as the baseline build and, when the CPU has the features, as the AVX2
/// build: for tests that the two give the same bits.
#[cfg(test)]
pub(crate) fn both<R>(f: impl Fn() -> R) -> (R, Option<R>) {
    let base = f();
    #[cfg(target_arch = "x86_64")]
    if x86::avx2() {
        // SAFETY: `avx2()` checked every feature `run` enables.
        return (base, Some(unsafe { x86::run(f) }));
    }
    (base, None)
}

#[cfg(test)]
mod tests {
    /// Both paths run the closure once and return its value.
    #[test]
    fn dispatch_returns_the_closure_value() {
        let mut calls = 0;
        let v = super::dispatch(|| {
            calls += 1;
            0.1f64 + 0.2
        });
        assert_eq!((v, calls), (0.1f64 + 0.2, 1));
    }
}
