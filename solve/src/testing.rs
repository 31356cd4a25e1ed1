//! The toy solver of the crate's tests.

use std::fmt;

use crate::{Finish, Iterate, Snapshot, Termination, Watch};

/// A solver that halves its cost each iteration: it polls the watch's
/// clock as each iteration starts (unless [`ignoring_the_clock`](Self::ignoring_the_clock)), ends with `ends_with` after `ends_at`
/// iterations, and fails with [`Negative`] from a negative point.
pub(crate) struct Halving {
    pub(crate) x: [f64; 1],
    pub(crate) it: usize,
    ends_at: usize,
    ends_with: Termination,
    polls: bool,
}

impl Halving {
    /// From `x0`, ending with `ends_with` after `ends_at` iterations.
    pub(crate) fn new(x0: f64, ends_at: usize, ends_with: Termination) -> Self {
        Self {
            x: [x0],
            it: 0,
            ends_at,
            ends_with,
            polls: true,
        }
    }

    /// The same solver, never polling the clock (the time limit is then
    /// the driver's to check).
    pub(crate) fn ignoring_the_clock(mut self) -> Self {
        self.polls = false;
        self
    }
}

/// [`Halving`]'s error.
#[derive(Debug, PartialEq)]
pub(crate) struct Negative;

impl fmt::Display for Negative {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("negative")
    }
}

impl std::error::Error for Negative {}

impl Iterate for Halving {
    type Status = Termination;
    type Error = Negative;
    const NAME: &'static str = "halving";
    fn next_iter(&mut self, watch: &Watch<'_>) -> Result<Option<Termination>, Negative> {
        if let Some(why) = watch.out_of_time().filter(|_| self.polls) {
            return Ok(Some(why.into()));
        }
        if self.it == self.ends_at {
            return Ok(Some(self.ends_with));
        }
        if self.x[0] < 0.0 {
            return Err(Negative);
        }
        self.x[0] *= 0.5;
        self.it += 1;
        Ok(None)
    }
    fn snapshot(&self) -> Snapshot<'_> {
        Snapshot {
            iteration: self.it,
            evals: 2 * self.it,
            cost: self.x[0],
            x: &self.x,
        }
    }
}

impl Finish for Halving {
    type Output = (usize, Termination);
    fn finish(self, status: Termination) -> (usize, Termination) {
        (self.it, status)
    }
}
