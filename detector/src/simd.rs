//! Hot loops with the CPU's wider vector instructions, chosen at run time.
//!
//! The release build targets baseline x86-64 (SSE2), so that one binary runs on every x86-64 CPU.
//! [`avx2_dispatch!`] defines a function that calls an `#[inline(always)]` kernel through a copy
//! compiled with AVX2 enabled when the CPU has it (the compiler then vectorises the kernel's loops
//! four f64 wide instead of two), and the plain kernel otherwise. The results are bit-identical:
//! Rust never fuses a multiplication and an addition into an FMA, nor reorders floating-point
//! operations, whatever instructions are enabled (the kernels' tests compare them with naive
//! loops bit for bit).

/// Defines a function that runs its body compiled for AVX2 where the CPU has it (see the module
/// docs), in one of two forms:
/// - `avx2_dispatch! { /// docs
///   pub(crate) fn name(a: A, b: B) -> R { body } }`: the body becomes an `#[inline(always)]`
///   kernel (a parameter the body mutates is rebound inside it: `let mut b = b;`);
/// - `avx2_dispatch! { fn name(a: A, b: B) -> R => kernel }`: an existing `#[inline(always)]`
///   function or method (`Type::method`, `a` being the receiver) is the kernel.
///
/// Whatever the kernel calls that should use AVX2 must be `#[inline(always)]` too.
macro_rules! avx2_dispatch {
    ($(#[$meta:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $(#[$meta])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[inline(always)]
            fn kernel($($arg: $ty),*) $(-> $ret)? $body
            $crate::simd::avx2_dispatch!(@call kernel, ($($arg: $ty),*) $(-> $ret)?)
        }
    };
    ($(#[$meta:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? => $kernel:path) => {
        $(#[$meta])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            $crate::simd::avx2_dispatch!(@call $kernel, ($($arg: $ty),*) $(-> $ret)?)
        }
    };
    (@call $kernel:path, ($($arg:ident: $ty:ty),*) $(-> $ret:ty)?) => {{
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx2")]
            unsafe fn avx2($($arg: $ty),*) $(-> $ret)? {
                $kernel($($arg),*)
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2 (checked just above).
                return unsafe { avx2($($arg),*) };
            }
        }
        $kernel($($arg),*)
    }};
}
pub(crate) use avx2_dispatch;
