//! The stress run (`cargo xtask stress`): every method over the stress set
//! of hard poses, timed, against the board's cost table and the
//! barycenter's analytical bound; exits with the verdict (see
//! [`firmware::stress`]). No control loop, no watchdog: one long
//! measurement in `init`, interrupts off.

#![no_std]
#![no_main]

#[rtic::app(device = stm32f4::stm32f405, dispatchers = [SPI1])]
mod app {
    #[shared]
    struct Shared {}

    #[local]
    struct Local {}

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let (mut board, _rest) = firmware::Board::start(cx.device);
        firmware::stress::run(&mut board, POSES)
    }

    /// Poses in the run: `CDPR_STRESS_POSES` at build time (`cargo xtask
    /// stress --poses N`), 2 000 by default (the test command's short run).
    const POSES: u32 = match option_env!("CDPR_STRESS_POSES") {
        Some(s) => parse(s),
        None => 2_000,
    };

    const fn parse(s: &str) -> u32 {
        let b = s.as_bytes();
        let mut i = 0;
        let mut n = 0u32;
        while i < b.len() {
            assert!(b[i].is_ascii_digit(), "CDPR_STRESS_POSES must be a number");
            n = n * 10 + (b[i] - b'0') as u32;
            i += 1;
        }
        n
    }
}
