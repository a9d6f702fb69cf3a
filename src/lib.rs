//! Test-only root package: the integration tests live in `tests/`.
