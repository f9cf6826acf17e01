//! The demo and cycle-time run (`cargo xtask run`): the product's control
//! loop on the scripted trajectory of `cdpr-demo`, timed and judged; it
//! ends with an encoded report and exits with its verdict (see
//! [`firmware::demo`]).

#![no_std]
#![no_main]

// A robot with no demo trajectory: the build says why (`build.rs`).
#[cfg(no_demo)]
include!(concat!(env!("OUT_DIR"), "/no_demo.rs"));

#[cfg(not(no_demo))]
#[rtic::app(device = stm32f4::stm32f405, dispatchers = [SPI1])]
mod app {
    use canopen_drives::model::LoopbackRig;
    use firmware::Board;

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        /// In `init`'s static slot (not moved through `init`'s return).
        board: &'static mut Board,
        /// The CiA 402 layer and its drive models for the measured step
        /// (`CDPR_DEMO_CAN_LAYER` builds), also in a static slot.
        rig: Option<&'static mut LoopbackRig>,
    }

    #[init(local = [
        board_slot: Option<Board> = None,
        rig_slot: Option<LoopbackRig> = None,
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let (board, rest) = Board::start_in(cx.local.board_slot, cx.device);
        let rig = firmware::loopback::rig_for_the_step(cx.local.rig_slot);
        Board::start_watchdog(&rest.iwdg);
        if control::spawn().is_err() {
            panic!("control task already spawned");
        }
        (Shared {}, Local { board, rig })
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        firmware::idle()
    }

    /// The 1 kHz control loop on the scripted trajectory.
    #[task(priority = 2, local = [board, rig])]
    async fn control(cx: control::Context) {
        firmware::demo::run(cx.local.board, cx.local.rig.as_deref_mut(), None).await
    }
}
