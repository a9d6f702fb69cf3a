#!/usr/bin/env bash
# Golden outputs: regenerate the text figures of the current code into OUTDIR, so that two
# versions of the code can be compared with `diff -r`.
#
#   tests/golden/record.sh OUTDIR            # then: diff -r tests/golden/baseline OUTDIR
#
# Uses the `acc` binary from ${ACC:-target/release/acc} (build it first:
# `cargo build --release -p acc-cli`) and `cargo run --release` for the twin example
# (honours CARGO_TARGET_DIR). Runs from the repository root whatever the working directory.
# GOLDEN_ONLY="paper compare ..." restricts the groups (paper compare twin fault-matrix; default all four).
#
# Files written (one per group):
#   paper.txt        `acc sim` summary of every shipped scenario (paper cases first), the
#                    sha256 of each run.csv, `acc stability` of every preset, and
#                    `acc estimate-eval --no-plot` (seed 000 tables, real data if present).
#   compare.txt      `acc compare --no-plot` of every shipped scenario.
#   fault-matrix.txt `acc fault-matrix` (5x time, the shipped defaults): per row the fault,
#                    board, what, and the columns that are stable run to run (see below).
#   twin.txt         the twin evaluation (crates/acc-ident/examples/twin_lab/twin_eval/mod.rs) on a fixed
#                    small subset: its confusion tables and the per-case rows, sorted.
#
# Determinism. Everything except the fault matrix runs on the simulator's stepped clock with
# fixed seeds and is byte-identical run to run; what is stripped there:
#   - the scratch directory (run logs, history databases) is written as <tmp>;
#   - twin.txt: the wall time in the report's last line ("N s on 2 threads") and the
#     "total time" line; cases.csv is appended in completion order (2 threads), so it is
#     sorted.
# The fault matrix runs two real processes paced by the wall clock (acc run against
# acc board-sim over a pty, plus a python man-in-the-middle for the hostile-line rows), so
# which period a fault lands in varies run to run. Compared over three full runs, these
# columns varied and are dropped: last cmd %, max applied with ACC not driving (follows the
# last command, e.g. knob-down), force before, max force after, the hostile-line counts
# (replies altered, rows flagged), log row counts, and the measured figures inside the
# verdict text (the verdict is reduced to pass / FAIL / unsafe on v1 / not judged). Kept:
# fault, board, what, feed hold after, fault periods raising cmd, operator-labelled
# releases, log complete, acc run exit, verdict kind.
# On a loaded 2-core machine about one row in 20 per run is disturbed (the run already in
# a feed hold when the fault comes, force before 0 N; or a FAIL that does not repeat, e.g.
# v2 garbage-1pct once at 904 N), which also changes feed hold / exit / verdict of that row:
# such rows are run again (see below), so a FAIL in the output failed 3 times in a row.
set -euo pipefail

if [[ $# -ne 1 ]]; then
    echo "usage: $0 OUTDIR" >&2
    exit 2
fi

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
ACC=${ACC:-target/release/acc}
# Resolve the binary before changing directory (a relative ACC means relative to the caller,
# the default relative to the repository).
if [[ ${ACC} != /* ]]; then
    if [[ -x ${ACC} ]]; then ACC=$(pwd)/${ACC}; else ACC=${ROOT}/${ACC}; fi
fi
[[ -x ${ACC} ]] || { echo "record.sh: no acc binary at ${ACC} (cargo build --release -p acc-cli)" >&2; exit 2; }
mkdir -p "$1"
OUT=$(cd "$1" && pwd)
cd "${ROOT}"

WORK=$(mktemp -d "${TMPDIR:-/tmp}/golden.XXXXXX")
trap 'rm -rf "${WORK}"' EXIT
GROUPS_TO_RUN=${GOLDEN_ONLY:-"paper compare twin fault-matrix"}
want() { [[ " ${GROUPS_TO_RUN} " == *" $1 "* ]]; }

# Replace the scratch directory and the repository root by placeholders.
norm() { sed -e "s#${WORK}#<tmp>#g" -e "s#${ROOT}/##g"; }

# Run a command, stdout normalised; on failure show its stderr and stop.
run() {
    local err=${WORK}/stderr.txt
    if ! "$@" 2>"${err}" | norm; then
        echo "record.sh: failed: $*" >&2
        cat "${err}" >&2
        return 1
    fi
}

# Paper scenarios first (the paper's tables), then the others the docs quote.
SCENARIOS=(
    paper_fixed_gain paper_fixed_gain_dynamometer
    paper_case1 paper_case2 paper_case3 paper_case3_dynamometer paper_case3_tooth paper_case4
    tool_wear tool_wear_dynamometer
    hard_inclusion interrupted tool_breakage overload_alarm hidden_wear two_tools
)
PRESETS=(case1 case2 case3 case4 fixed_gain gentle)

t_start=${SECONDS}
log() { echo "[$((SECONDS - t_start)) s] $*" >&2; }

# ---------------------------------------------------------------- paper.txt
if want paper; then
    log "paper.txt"
    {
        for s in "${SCENARIOS[@]}"; do
            echo "=== acc sim configs/scenarios/${s}.toml --no-plot"
            run "${ACC}" sim "configs/scenarios/${s}.toml" --out "${WORK}/sim/${s}" --no-plot
            echo "run.csv sha256 $(sha256sum <"${WORK}/sim/${s}/run.csv" | cut -d' ' -f1)"
            echo
        done
        for p in "${PRESETS[@]}"; do
            echo "=== acc stability ${p}"
            run "${ACC}" stability "${p}"
            echo
        done
        echo "=== acc estimate-eval --no-plot"
        run "${ACC}" estimate-eval --no-plot
    } >"${OUT}/paper.txt"
fi

# ---------------------------------------------------------------- compare.txt
if want compare; then
    log "compare.txt"
    {
        for s in "${SCENARIOS[@]}"; do
            echo "=== acc compare configs/scenarios/${s}.toml --no-plot"
            run "${ACC}" compare "configs/scenarios/${s}.toml" --no-plot
            echo
        done
    } >"${OUT}/compare.txt"
fi

# ---------------------------------------------------------------- twin.txt
# A fixed subset (28 cases, a few minutes on 2 threads): per channel (power, force) 2 null
# seeds plus three in-library effects (tool wear, Ks step, log delay) and one out-of-library
# effect (depth scale), each at both of its amplitudes, one seed, on the first shipped
# workpiece (steps_1_2_3), and the two pairs with tool wear (the `tool_wear` prefix selects them).
TWIN_ARGS=(--null-seeds 2 --lib-seeds 1 --oob-seeds 1 --wp-limit 1 --threads 2
    --only "tool_wear,Ks step,log delay,depth scale")
if want twin; then
    log "twin.txt"
    cargo build --release -q -p acc-ident --example twin_lab
    {
        echo "=== twin_eval ${TWIN_ARGS[*]}"
        run cargo run --release -q -p acc-ident --example twin_lab -- twin_eval \
            "${TWIN_ARGS[@]}" --out "${WORK}/twin" |
            sed -e 's/; [0-9.]* s on \([0-9]*\) threads (release build) for the rest\./; <wall time> on \1 threads (release build) for the rest./' \
                -e '/^total time: /d'
        echo
        echo "=== cases.csv (sorted)"
        head -n 1 "${WORK}/twin/cases.csv"
        tail -n +2 "${WORK}/twin/cases.csv" | LC_ALL=C sort
    } >"${OUT}/twin.txt"
fi

# ---------------------------------------------------------------- fault-matrix.txt
# One `acc fault-matrix --protocol P --only FAULT` per row (v2 rows, then v1, in the table's
# order), so that a harness error on a loaded machine (e.g. `acc board-sim never reached
# t = 16 s`, or acc run timing out on its first read) costs one row, which is retried up to
# 3 times, instead of the whole matrix. A row is also run again (up to 3 times in all) when
# it looks disturbed by the load: the machine was not cutting when the fault came (force
# before < 100 N), or its verdict is FAIL; after the third try the row is kept as it is.
FM_TRIES=${FM_TRIES:-3}
if want fault-matrix; then
    log "fault-matrix.txt (about 8 min)"
    faults=$( ("${ACC}" fault-matrix --only '?' 2>&1 || true) | sed -n 's/.*allowed: //p' | tr -d ',')
    faults=${FM_FAULTS:-${faults}}
    [[ -n ${faults} ]] || { echo "record.sh: cannot list the faults of acc fault-matrix" >&2; exit 1; }
    rows=${WORK}/fm-rows.md
    : >"${rows}"
    mkdir -p "${WORK}/fm"
    # FM_FROM_RAW=FILE (a table kept with FM_RAW): derive the file from it, run nothing.
    if [[ -n ${FM_FROM_RAW:-} ]]; then
        header=$(head -n 1 "${FM_FROM_RAW}")
        tail -n +2 "${FM_FROM_RAW}" >"${rows}"
        faults=""
    fi
    for proto in 2 1; do
        for f in ${faults}; do
            try=1
            while :; do
                d=${WORK}/fm/v${proto}-${f}-${try}
                rc=0
                "${ACC}" fault-matrix --protocol "${proto}" --only "${f}" --out "${d}" \
                    >/dev/null 2>"${d}.stderr" || rc=$?
                if [[ -s ${d}/fault-matrix.md ]]; then
                    row=$(grep '^| ' "${d}/fault-matrix.md" | grep -v -e '^| fault ' -e '^| --- ')
                    header=$(grep '^| fault ' "${d}/fault-matrix.md")
                    # Disturbed: the machine was not cutting when the fault came (force
                    # before < 100 N; plan-missing never starts the machine), or the
                    # verdict is FAIL.
                    why=$(awk -F' \\| ' '{ if ($6 + 0 < 100 && $1 !~ /plan-missing/) print "force before " $6 " N";
                        else if ($15 ~ /^FAIL/) print "FAIL" }' <<<"${row}")
                    if [[ -z ${why} || ${try} -ge ${FM_TRIES} ]]; then
                        echo "${row}" >>"${rows}"
                        log "  v${proto} ${f}: exit ${rc}${why:+ (${why}, kept after ${try} tries)}"
                        break
                    fi
                    log "  v${proto} ${f}: ${why} (try ${try}), again"
                else
                    log "  v${proto} ${f}: harness error (try ${try}): $(tail -n 1 "${d}.stderr")"
                    if ((try >= FM_TRIES)); then
                        echo "record.sh: fault-matrix row v${proto} ${f} failed ${try} times" >&2
                        exit 1
                    fi
                fi
                try=$((try + 1))
            done
        done
    done
    {
        echo "=== acc fault-matrix (defaults: fault_matrix, 5x time), one row per run; stable columns only"
        # Columns of the table (1-based after the leading '|'): 1 fault, 2 board, 3 what,
        # 8 feed hold after, 9 fault periods raising cmd, 12 operator-labelled releases,
        # 13 log rows (complete), 14 acc run exit, 15 verdict.
        { echo "${header}"; cat "${rows}"; } | awk '
            {
                sub(/^\| /, ""); sub(/ \|$/, "")
                n = split($0, c, / \| /)
                if (n < 15) { print "record.sh: unexpected row: " $0 > "/dev/stderr"; exit 1 }
                if (c[1] == "fault") { print "fault | board | what | feed hold after | fault periods raising cmd | operator-labelled releases | log complete | acc run exit | verdict"; next }
                complete = c[13]; sub(/^[^(]*\(/, "", complete); sub(/\)$/, "", complete)
                v = c[15]
                if (v ~ /^pass/) v = "pass"
                else if (v ~ /^FAIL/) v = "FAIL"
                else if (v ~ /^unsafe on v1/) v = "unsafe on v1"
                else if (v ~ /^not judged/) v = "not judged"
                print c[1] " | " c[2] " | " c[3] " | " c[8] " | " c[9] " | " c[12] " | " complete " | " c[14] " | " v
            }'
    } >"${OUT}/fault-matrix.txt"
    # FM_RAW=FILE keeps the full table (every column) for inspection; not compared.
    if [[ -n ${FM_RAW:-} ]]; then { echo "${header}"; cat "${rows}"; } >"${FM_RAW}"; fi
fi

log "done: ${OUT}"
