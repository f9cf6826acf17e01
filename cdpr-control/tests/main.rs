//! The control loop's tests, one module per file (each file's header says
//! what it checks; `common`: the robot and the ideal drives they share),
//! built as one test binary. `cargo test -p cdpr-control --test control
//! safety::` runs one file's.

mod buffered_stream;
mod closed_loop;
mod common;
mod drive_fault;
mod drives;
mod encoder_reach;
mod feedback;
mod identify;
mod link;
mod point_buffer;
mod safety;
mod saturation;
mod setpoint_fields;
mod setpoint_range;
mod step_into;
mod winch_reach;
