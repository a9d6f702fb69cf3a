//! `acc-spindle`: Pure spindle signal processing: two-wattmeter power, RMS, no-load model, cutting-force estimators.
