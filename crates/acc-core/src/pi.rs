//! PI controller (seed 002, eq. 4) with saturation, quantization, anti-windup and bumpless start.
