//! `acc-runtime`: Fixed-period real-time loop, threads, fault policy and shutdown for acc.
