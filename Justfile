# Recipes mirror CI exactly: `just ci` is what .ci/run does.

# Install the protocol peers (mbpoll, pymodbus) the interop tests talk to.
deps:
    bash .ci/deps

# Run all tests (the README's test command).
test:
    cargo test --workspace

# What CI runs.
ci: deps test

# Lints as CI would want them.
lint:
    cargo fmt --all -- --check
    cargo clippy --workspace --all-targets -- -D warnings

# The main job on the built-in simulated machine.
demo:
    cargo run --release -p acc-cli -- stability configs/presets/case3.toml --plot out/case3-poles.svg

# Benchmarks (criterion); figures go in the README.
bench:
    cargo bench --workspace
