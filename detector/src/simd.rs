//! Hot loops with the CPU's wider vector instructions, chosen at run time.
//!
//! The release build targets baseline x86-64 (SSE2), so that one binary runs on every x86-64 CPU.
//! [`simd_dispatch!`] defines a function that calls an `#[inline(always)]` kernel through a copy
//! compiled with AVX-512 (F and VL) enabled when the CPU has it (the compiler then vectorises the
//! kernel's loops eight f64 wide instead of two), else through one with AVX2 (four wide), and the
//! plain kernel otherwise. The results are bit-identical:
//! Rust never fuses a multiplication and an addition into an FMA, nor reorders floating-point
//! operations, whatever instructions are enabled (the kernels' tests compare them with naive
//! loops bit for bit).

/// `simd_dispatch! { /// docs
/// pub(crate) fn name(a: A, b: B) -> R { body } }` defines `name`, which runs its body compiled
/// for AVX-512 or AVX2 where the CPU has it (see the module docs). The body becomes an `#[inline(always)]`
/// kernel; a parameter the body mutates is rebound inside it (`let mut b = b;`). Whatever the
/// body calls that should use the wider instructions must be `#[inline(always)]` too.
macro_rules! simd_dispatch {
    ($(#[$meta:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $(#[$meta])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[inline(always)]
            fn kernel($($arg: $ty),*) $(-> $ret)? $body
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f,avx512vl,avx2")]
                unsafe fn avx512($($arg: $ty),*) $(-> $ret)? {
                    kernel($($arg),*)
                }
                #[target_feature(enable = "avx2")]
                unsafe fn avx2($($arg: $ty),*) $(-> $ret)? {
                    kernel($($arg),*)
                }
                if $crate::simd::has_avx512() {
                    // SAFETY: the CPU supports AVX-512 F and VL (checked just above).
                    return unsafe { avx512($($arg),*) };
                }
                if std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU supports AVX2 (checked just above).
                    return unsafe { avx2($($arg),*) };
                }
            }
            kernel($($arg),*)
        }
    };
}
pub(crate) use simd_dispatch;

/// Whether the CPU has the AVX-512 subsets the wide kernels are compiled for (F and VL).
#[cfg(target_arch = "x86_64")]
pub(crate) fn has_avx512() -> bool {
    std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("avx512vl")
}
