//! What the closed-loop tests share: a scenario by name and a run's
//! state changes.

use cdpr_control::protocol::{Reason, State};
use hal_sim::{Outcome, Scenario};

/// The scenario `name` (panics if there is none).
pub fn scenario(name: &str) -> Scenario {
    Scenario::named(name).unwrap_or_else(|| panic!("no scenario {name}"))
}

/// The state machine's changes, without times.
pub fn states(o: &Outcome) -> Vec<(State, Reason, Reason)> {
    o.transitions.iter().map(|&(_, s, r, h)| (s, r, h)).collect()
}
