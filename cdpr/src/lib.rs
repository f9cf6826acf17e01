//! # cdpr
//!
//! The host command-line tool of the project (`cdpr`), as a library so that
//! its logic is testable: robot files and pose tables read with errors that
//! name the file, line and column; tensions along pose tables (`solve`) and
//! smooth trajectories (`trajectory`, `compare`); the wrench-feasible
//! workspace (`workspace`); poses from cable lengths (`forward`); a board
//! operated over its serial link (`stream`). Everything follows `docs/conventions.md` (poses, robot
//! files, CSV tables, method names) and uses `tension-core` in `f64`.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod error;
pub mod forward;
pub mod output;
pub mod profiles;
pub mod robot;
pub mod solve;
pub mod stream;
pub mod table;
pub mod trajectory;
pub mod workspace;

pub use error::{one_line, CliError};
