//! Stack painting: the unused stack is filled with a pattern at start-up,
//! and the deepest word that lost it is the stack's high-water mark.

/// The stack's extent from the linker script: it grows down from
/// `_stack_start` (end of RAM) towards `_stack_end` (end of `.bss`/`.uninit`).
fn stack_bounds() -> (usize, usize) {
    extern "C" {
        static _stack_start: u32;
        static _stack_end: u32;
    }
    // Only the symbols' addresses are taken (safe since Rust 1.82).
    (core::ptr::addr_of!(_stack_end) as usize, core::ptr::addr_of!(_stack_start) as usize)
}

const PAINT: u32 = 0x5A5A_A5A5;

/// Fills the unused stack (from its limit up to 256 bytes below the current
/// stack pointer) with a pattern, for [`stack_high_water`]. Call once, early.
pub fn paint_stack() {
    let (bottom, _) = stack_bounds();
    let limit = cortex_m::register::msp::read() as usize - 256;
    let mut addr = bottom;
    while addr < limit {
        // SAFETY: the words between the stack's limit and well below the
        // live stack pointer belong to no one yet.
        unsafe { core::ptr::write_volatile(addr as *mut u32, PAINT) };
        addr += 4;
    }
}

/// `(used, size)` of the stack in bytes: the deepest word that no longer
/// holds the pattern of [`paint_stack`].
pub fn stack_high_water() -> (u32, u32) {
    let (bottom, top) = stack_bounds();
    let mut addr = bottom;
    // SAFETY: reads of RAM inside the stack region.
    while addr < top && unsafe { core::ptr::read_volatile(addr as *const u32) } == PAINT {
        addr += 4;
    }
    ((top - addr) as u32, (top - bottom) as u32)
}
