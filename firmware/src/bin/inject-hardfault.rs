//! The demo, taking a HardFault at cycle [`cdpr_demo::INJECT_AT`] while the
//! drives command torques: the HardFault handler must stop them first and
//! exit with [`cdpr_demo::exit::HARDFAULT`] (`cargo xtask test`).

#![no_std]
#![no_main]

#[rtic::app(device = stm32f4::stm32f405, dispatchers = [SPI1])]
mod app {
    use firmware::demo::Inject;
    use firmware::Board;

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        board: Board,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let (board, rest) = Board::start(cx.device);
        Board::start_watchdog(&rest.iwdg);
        if control::spawn().is_err() {
            panic!("control task already spawned");
        }
        (Shared {}, Local { board })
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        firmware::idle()
    }

    /// The 1 kHz control loop on the scripted trajectory.
    #[task(priority = 2, local = [board])]
    async fn control(cx: control::Context) {
        firmware::demo::run(cx.local.board, Some(Inject::HardFault)).await
    }
}
