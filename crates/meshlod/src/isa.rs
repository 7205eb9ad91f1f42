//! Runtime instruction-set dispatch for the hot `f64` code: the edge-collapse
//! driver's whole queue loop (quadric minimiser, fold-over check, re-queueing),
//! the closest-point query and the Morton tree build of the orientation repair.
//!
//! `dispatch!` runs an expression compiled a second time with AVX2 (and the BMI,
//! LZCNT and POPCNT extensions of the same CPU generation) when the CPU has them,
//! else the baseline x86-64 build. The VEX encodings mostly save register copies and
//! the false dependencies of the legacy `f32 → f64` conversions and square roots.
//!
//! The AVX2 copy only contains what is inlined into it: the expression is wrapped
//! in an `#[inline(always)]` closure with a single call site, inside the
//! `#[target_feature]` function, and what it calls should be `#[inline(always)]`
//! (a plain `#[inline]` function, or a closure that is also called on the baseline
//! path, stays one out-of-line baseline function, and the "AVX2 copy" is then just
//! a jump to it — which is how this was until 2026-12-02).
//!
//! Results are **bit for bit** those of the baseline build: FMA is deliberately *not*
//! enabled, and Rust never fuses a multiply and an add on its own, so every
//! operation rounds exactly as before (the simplifier's outputs were compared
//! byte for byte, with and without `MESHLOD_NO_AVX2=1`, which forces the baseline
//! path).
//!
//! This module holds the crate's only `unsafe` code, two audited calls:
//! - calling a `#[target_feature]` function is unsafe because running it on a CPU
//!   without the features is undefined behaviour; `run_avx2` calls it only after
//!   `is_x86_feature_detected!` confirmed each one;
//! - [`prefetch`] issues the SSE `PREFETCHT0` hint, which never faults and has no
//!   architectural effect, on the address of a live reference.
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

/// `f()` as its AVX2 build when the CPU has the features, else `None` (the caller
/// then evaluates the same expression itself: see [`dispatch!`]).
///
/// `f` is called in exactly one place, inside the `#[target_feature]` function, so
/// the compiler inlines the closure there (a closure with two call sites, one of
/// them the baseline call, stays an out-of-line baseline function and the
/// "AVX2 copy" would only be a jump to it).
#[inline(always)]
pub(crate) fn run_avx2<R>(f: impl FnOnce() -> R) -> Option<R> {
    #[cfg(target_arch = "x86_64")]
    if x86::avx2() {
        // SAFETY: `avx2()` checked every feature `run` enables.
        return Some(unsafe { x86::run(f) });
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = f;
    None
}

/// Asks the CPU to start loading the cache line holding `*r` (a hint: no
/// architectural effect, nothing waits for it). A no-op off x86-64.
#[inline(always)]
pub(crate) fn prefetch<T>(r: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch never faults and reads nothing architecturally (Intel SDM
    // and AMD APM, PREFETCHh); `r` is a valid reference anyway. SSE, which the
    // intrinsic requires, is part of the x86-64 baseline.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
            std::ptr::from_ref(r).cast::<i8>(),
        );
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = r;
}

/// Evaluates the expression as its AVX2 build when the CPU has the features, else
/// as the baseline build (see the module docs; the result is the same either way).
/// The expression is written out twice, so each build has its own copy: kernels
/// it calls should be `#[inline]`/`#[inline(always)]`, so they are compiled into
/// the AVX2 copy. The AVX2 copy sits inside a closure, so the expression must not
/// `return` or use `?` (those would leave the closure in one copy and the caller in
/// the other): wrap such code in a function and dispatch the call.
macro_rules! dispatch {
    ($e:expr) => {
        match $crate::isa::run_avx2(
            #[inline(always)]
            || $e,
        ) {
            Some(r) => r,
            None => $e,
        }
    };
}
pub(crate) use dispatch;

/// The expression run as the baseline build and, when the CPU has the features, as
/// the AVX2 build: for tests that the two give the same bits.
#[cfg(test)]
macro_rules! both {
    ($e:expr) => {
        (
            $e,
            $crate::isa::run_avx2(
                #[inline(always)]
                || $e,
            ),
        )
    };
}
#[cfg(test)]
pub(crate) use both;

#[cfg(test)]
mod tests {
    /// Both paths run the closure once and return its value.
    #[test]
    fn dispatch_returns_the_closure_value() {
        let mut calls = 0;
        let v = super::dispatch!({
            calls += 1;
            0.1f64 + 0.2
        });
        assert_eq!((v, calls), (0.1f64 + 0.2, 1));
    }
}
