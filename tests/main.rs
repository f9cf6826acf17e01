//! The cross-crate integration tests, one module per file (each file's
//! header says what it checks), built as one test binary: the solver's
//! generic code for every shape and precision is compiled once for all of
//! them. `cargo test --test integration barycenter::` runs one file's.

mod analytic_centre;
mod barycenter;
mod closed_form;
mod cold_search_border;
mod continuity;
mod forward_kinematics;
mod hostile_inputs;
mod kinematics;
mod more_methods;
mod scale_and_certificates;
mod shared_factorisation;
mod walk_hints;
