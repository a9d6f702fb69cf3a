//! `acc-ident`: Model-discrepancy workflow: replay, residuals, candidate effects, selection, report.
