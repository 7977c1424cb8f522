//! Exit codes of the `cellsar` binary, and failures that carry theirs: the codes every cellsar
//! binary shares ([`cellsar_error::exit`]).
//!
//! | code | `cellsar` |
//! |---:|---|
//! | 0 | done (`run`: the mission completed) |
//! | 1 | failure at run time (a child that keeps failing, no plan in time, I/O, Zenoh, a planner that failed) |
//! | 2 | bad input: an option, the mission or the scene file (the message names it); nothing started (or the planner refused the request as `bad_request`) |
//! | 3 | the mission cannot be flown (the message names the first slot and the reason), found before anything starts or by the planner (an `infeasible` refusal) |
//! | 4 | `run --strict`: completed, but a landmark in view was not detected |
//! | 130 | interrupted (SIGINT/SIGTERM); every child stopped |

pub use cellsar_error::exit::*;
