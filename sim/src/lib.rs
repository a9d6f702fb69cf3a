//! `acc-sim`: the simulated machine.
