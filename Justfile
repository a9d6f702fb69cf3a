# Recipes mirror CI exactly: `just ci` is what .ci/run does.

# Install the protocol peers (mbpoll, pymodbus) the interop tests talk to.
deps:
    bash .ci/deps

# Run all tests (the README's test command).
test:
    cargo test --workspace

# What CI runs (.ci/run): deps, then lint, then the README's test command.
ci: deps lint test

# Formatting check and clippy with warnings as errors, as CI runs them.
lint:
    cargo fmt --all -- --check
    cargo clippy --workspace --all-targets -- -D warnings
    cargo clippy -p acc-cli -- -D warnings

# The main job on the built-in simulated machine (the README's first command).
demo:
    cargo run --release -p acc-cli -- sim configs/scenarios/paper_case3.toml --out out/case3

# The Debian package of the release build: target/debian/acc_<version>_<arch>.deb (docs/linuxcnc.md).
deb:
    cargo build --release -p acc-cli --features full
    cargo run -p xtask -- deb

# One scenario on the simulated machine: `just sim configs/scenarios/paper_case1.toml`.
sim scenario:
    cargo run --release -p acc-cli -- sim {{scenario}} --out out/sim

# The tool-breakage scenario and its one-page HTML report (docs/shop.md).
report:
    cargo run --release -p acc-cli -- sim tool_breakage --out out/breakage --no-plot
    cargo run --release -p acc-cli -- report out/breakage/run.csv --out out/breakage/report

# All baselines and ours on one scenario.
compare scenario:
    cargo run --release -p acc-cli -- compare {{scenario}} --out out/compare

# Pole map and stability figures of a controller preset.
stability preset="case3":
    cargo run --release -p acc-cli -- stability {{preset}} --plot out/{{preset}}-poles.svg

# Spindle force estimator accuracy (simulated sweep, real data).
estimate-eval:
    cargo run --release -p acc-cli -- estimate-eval

# Golden runs: determinism and paper reproductions only.
golden:
    cargo test -p acc-tests --test paper -- determinism:: cases:: fixed_gain::

# Every text figure of the product against tests/golden/baseline (about 15 min).
golden-figures out="/tmp/acc-golden":
    cargo build --release -p acc-cli
    tests/golden/record.sh {{out}} && diff -r tests/golden/baseline {{out}}

# Benchmarks (criterion); figures in docs/results.md.
bench:
    cargo bench --workspace

# The stock engagement benchmark (issue 28: a 10 000-block program over 200 × 200 mm in
# under 10 s); figures in docs/stock.md.
stock-bench:
    cargo bench -p acc-stock --bench engagement

# The discrepancy workflow's full hidden-effect sweep (confusion matrix, recovery vs size; ~12 min).
ident-sweep:
    cargo run --release -p acc-ident --example twin_lab -- sweep --seeds 10 --enr 0.25,0.5,1,2,4,8 --fdr 200 --pairs 10 --out out/sweep

# Loop timing: the real ticker for 36 000 periods at T = 1 ms.
jitter:
    cargo run --release -p acc-runtime --example ticker_jitter -- 1000 36000

# The reliability fault matrix (every fault at the deepest cut, v2 and v1 boards): the xtask
# runs `acc fault-matrix --out out/fault-matrix` and splices its table into
# docs/reliability.md (~5.5 min).
fault-matrix:
    cargo run -p xtask -- fault-matrix-doc

# One hour of machine time at 10x against board-sim with a random fault every few seconds
# (~6 min): memory growth, lost rows, dead threads; the xtask runs `acc soak --out out/soak`
# and splices its table into docs/reliability.md.
soak:
    cargo run -p xtask -- soak-doc

# Period jitter of the threaded loop, telemetry off vs live view + SHDR + MQTT with clients vs
# the OPC UA server with 3 asyncua clients (docs/telemetry.md "Live view", docs/opcua.md
# "Jitter"; dev profile: the jitter is the scheduler's, not the code's).
live-jitter:
    cargo bench --profile dev -p acc-telemetry --bench loop_jitter -- --periods 1000 --period-ms 10 --rounds 6

# The NC interpreter against LinuxCNC's rs274 on tests/nc and ../shared/data/nc (docs/nc.md).
nc-oracle:
    cargo test -p acc-nc --test interpreter oracle_rs274 -- --nocapture

# The OPC UA server against asyncua and node-opcua (docs/opcua.md "Peers we did not write").
opcua-peers:
    cargo test -p acc-tests --test telemetry opcua::
