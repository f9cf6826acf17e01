//! `vsqrt.f32`, the FPU's correctly rounded single-precision square root, as
//! a safe function for bare-metal ARM hard-float targets (the board's
//! Cortex-M4F: FPv4-SP), where neither `core` nor libm reach it on stable
//! Rust: `f32::sqrt` needs `std`, libm's `sqrtf` is a software loop, and
//! `asm!`'s `sreg` class needs the `vfp2` target feature (double precision),
//! which `thumbv7em-none-eabihf` does not enable.
//!
//! The instruction lives in a three-instruction function written in
//! `global_asm!` under the AAPCS-VFP calling convention (argument and result
//! in `s0`, which the caller saves). Every hard-float ARM core has it (VFPv2
//! and later, FPv4-SP, FPv5), so the function is compiled for
//! `target_arch = "arm"` with `target_abi = "eabihf"` and is absent
//! elsewhere: [`AVAILABLE`] says which.
//!
//! IEEE 754 `squareRoot`: NaN for a negative or NaN argument, `-0` for `-0`,
//! infinity for infinity; nothing traps (the FPU's exception flags are only
//! set, never enabled on the board).
#![no_std]

/// `true` when [`sqrt`] exists for this target.
pub const AVAILABLE: bool = cfg!(all(target_arch = "arm", target_abi = "eabihf"));

#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
core::arch::global_asm!(
    ".fpu fpv4-sp-d16",
    ".section .text.vfp_sqrt_f32,\"ax\",%progbits",
    ".global vfp_sqrt_f32",
    ".type vfp_sqrt_f32,%function",
    ".thumb_func",
    "vfp_sqrt_f32:",
    "    vsqrt.f32 s0, s0",
    "    bx lr",
    ".size vfp_sqrt_f32, . - vfp_sqrt_f32",
);

#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
extern "C" {
    /// `s0 <- sqrt(s0)`; touches nothing else.
    fn vfp_sqrt_f32(x: f32) -> f32;
}

/// The correctly rounded square root of `x` by the FPU's `vsqrt.f32`.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline]
pub fn sqrt(x: f32) -> f32 {
    // SAFETY: `vfp_sqrt_f32` above reads and writes `s0` only, as the
    // hard-float calling convention of `extern "C"` on this target passes
    // and returns an `f32` there; it has no memory effects and cannot fault
    // (FPU exceptions do not trap on Cortex-M unless enabled).
    unsafe { vfp_sqrt_f32(x) }
}
