#!/usr/bin/env bash
# The program tables of docs/programs.md: every program below planned by `acc plan` and run
# by `acc sim` on the paper's machine and tool (scenario paper_case3) with ACC feedback
# alone, with ACC and the plan's look-ahead (`--plan`), and at the program's constant safe
# feed (`--law constant-safe`: the one override whose predicted peak over the whole program
# is ≤ Fr), on the stock given; then rewritten by `acc optimize` and the optimized program
# run at a constant 100 % override (`--law constant`, no ACC), with ACC, and with ACC and
# the look-ahead of the optimized program's own plan. The feedback-alone run also computes
# the program's oracle (`--oracle`: the lowest force RMS error a law on the board's grid
# that knows the engagement ahead reaches, free, with every period at or below 1.05 Fr, and
# per override: with no override whose force over a whole period is above 1.05 Fr),
# and the ACC runs get their ratio to it; the look-ahead is run with its cap only and with
# the plan's lead (`--plan-lead`).
# Prints four markdown tables (feedback alone; with the plan; with the plan's lead; cycle
# time and peak force of every way).
#
#   tests/nc/table.sh                      # uses ${ACC:-target/release/acc}
#   ACC=target/debug/acc tests/nc/table.sh # the dev-profile build
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
ACC=${ACC:-${ROOT}/target/release/acc}
NC3=${ROOT}/../shared/data/nc
cd "${ROOT}"
OUT=$(mktemp -d "${TMPDIR:-/tmp}/programs.XXXXXX")
LIST='tests/nc/pocket_rect.ngc -20,-20,-10,60,50,0
tests/nc/contour_inside_corners.ngc -10,-10,-10,70,65,0
tests/nc/stepped_face.ngc -10,-5,-10,70,45,0
nc3:linuxcnc_hk_ba20_testmill.ngc -150,-20,-20,80,220,0
nc3:linuxcnc_arcspiral.ngc -60,-60,-10,60,60,0
nc3:linuxcnc_3D_Chips.ngc -50,-50,-50,50,50,0
nc3:linuxcnc_inside_corners.ngc -13,-13,-5,102,107,0'
ev() { sed -n "s/^$1: \([0-9]*\); highest true peak \([0-9.]*\) Fr.*mean peak \([0-9.]*\) Fr/\1: \2 \/ \3/p" <<<"$2"; }
cyc() { local c; c=$(sed -n 's/^cycle time \([0-9.]*\) s;.*/\1/p' <<<"$1"); grep -q "ended before the end" <<<"$1" && c="${c} (did not finish)"; echo "${c}"; }
rms() { sed -n 's/.*force RMS error while cutting \([0-9.]*\) N.*/\1/p' <<<"$1"; }
orms() { sed -n 's/^oracle force RMS error \([0-9.]*\) N.*/\1/p' <<<"$1"; }
wrms() { sed -n 's/^oracle force RMS error within 1.05 Fr \([0-9.]*\) N.*/\1/p' <<<"$1"; }
hrms() { sed -n 's/^oracle force RMS error within 1.05 Fr per override \([0-9.]*\) N.*/\1/p' <<<"$1"; }
oratio() { awk -v a="$1" -v b="$2" 'BEGIN{if (b > 0) printf "%.2f", a/b; else printf "-"}'; }
declare -A FB LA LEAD SAFE PLAN OPT OPT100 OPTACC OPTLA
while read -r prog stock; do
    file=${prog/#nc3:/${NC3}/}
    [[ -f ${file} ]] || continue
    name=$(basename "${file}")
    d=${OUT}/${name}
    PLAN[${name}]=$("${ACC}" plan "${file}" --stock-box="${stock}" --no-plot --out "${d}/plan" 2>/dev/null)
    run() { "${ACC}" sim paper_case3 --program "${file}" --stock-box="${stock}" --no-plot --out "${d}/$1" "${@:2}" 2>/dev/null; }
    FB[${name}]=$(run fb --law ours --oracle)
    LA[${name}]=$(run la --law ours --plan "${d}/plan/plan.csv")
    LEAD[${name}]=$(run lead --law ours --plan "${d}/plan/plan.csv" --plan-lead)
    SAFE[${name}]=$(run safe --law constant-safe)
    OPT[${name}]=$("${ACC}" optimize "${file}" --stock-box="${stock}" --out "${d}/opt/${name%.ngc}.opt.ngc" 2>/dev/null)
    runopt() { "${ACC}" sim paper_case3 --program "${d}/opt/${name%.ngc}.opt.ngc" --stock-box="${stock}" --no-plot --out "${d}/$1" "${@:2}" 2>/dev/null; }
    OPT100[${name}]=$(runopt opt100 --law constant)
    OPTACC[${name}]=$(runopt optacc --law ours)
    "${ACC}" plan "${d}/opt/${name%.ngc}.opt.ngc" --stock-box="${stock}" --no-plot --out "${d}/optplan" >/dev/null 2>&1
    OPTLA[${name}]=$(runopt optla --law ours --plan "${d}/optplan/plan.csv")
done <<<"${LIST}"
echo "Feedback alone (ACC, no plan):"
echo
echo "| program | stock, mm | pieces | entries: highest / mean peak, Fr | corners: highest / mean peak, Fr | force RMS error, N | oracle's force RMS error, N | RMS / oracle | cycle with ACC, s | program's constant safe feed, % | cycle at it, s | ratio |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
while read -r prog stock; do
    file=${prog/#nc3:/${NC3}/}
    name=$(basename "${file}")
    [[ -f ${file} ]] || { echo "| ${name} | absent | | | | | | | | | | |"; continue; }
    o=${FB[${name}]}; s=${SAFE[${name}]}; orc=$(orms "${o}")
    pieces=$(sed -n 's/^program: \([0-9]*\) pieces.*/\1/p' <<<"${o}")
    pct=$(sed -n 's/^constant safe feed of the program: \([0-9]*\) %/\1/p' <<<"${s}")
    c1=$(cyc "${o}"); c0=$(cyc "${s}")
    ratio=$(awk -v a="${c1%% *}" -v b="${c0%% *}" 'BEGIN{printf "%.2f", a/b}')
    echo "| ${name} | ${stock} | ${pieces} | $(ev entries "${o}") | $(ev corners "${o}" || true) | $(rms "${o}") | ${orc} | $(oratio "$(rms "${o}")" "${orc}") | ${c1} | ${pct} | ${c0} | ${ratio} |" | sed 's/|  |/| none |/g'
done <<<"${LIST}"
echo
echo "ACC with the plan's look-ahead (\`acc plan\`, then \`acc sim --plan\`):"
echo
echo "| program | plan rows | predicted peak at 100 %, Fr | entries: highest / mean peak, Fr | corners: highest / mean peak, Fr | force RMS error, N | RMS / oracle | oracle within 1.05 Fr, N | RMS / oracle within 1.05 Fr | cycle, s | disagreement periods |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
while read -r prog stock; do
    file=${prog/#nc3:/${NC3}/}
    name=$(basename "${file}")
    [[ -f ${file} ]] || { echo "| ${name} | absent | | | | | | | | | |"; continue; }
    o=${LA[${name}]}; p=${PLAN[${name}]}; w=$(wrms "${FB[${name}]}")
    rows=$(sed -n 's/^\([0-9]*\) rows.*/\1/p' <<<"${p}")
    peak=$(sed -n 's/^predicted peak of the feed moves at 100 %: [0-9]* N = \([0-9.]*\) Fr.*/\1/p' <<<"${p}")
    dis=$(grep -c plan_disagree "${OUT}/${name}/la/run.csv" || true)
    echo "| ${name} | ${rows} | ${peak} | $(ev entries "${o}") | $(ev corners "${o}") | $(rms "${o}") | $(oratio "$(rms "${o}")" "$(orms "${FB[${name}]}")") | ${w} | $(oratio "$(rms "${o}")" "${w}") | $(cyc "${o}") | ${dis} |" | sed 's/|  |/| none |/g'
done <<<"${LIST}"
echo
echo "ACC with the plan's lead (\`acc sim --plan … --plan-lead\`):"
echo
echo "| program | entries: highest / mean peak, Fr | corners: highest / mean peak, Fr | force RMS error, N | RMS / oracle | RMS / oracle within 1.05 Fr | oracle within 1.05 Fr per override, N | RMS / oracle within 1.05 Fr per override | cycle, s | cutting periods led by the plan | disagreement periods |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
while read -r prog stock; do
    file=${prog/#nc3:/${NC3}/}
    name=$(basename "${file}")
    [[ -f ${file} ]] || { echo "| ${name} | absent | | | | | | | | | |"; continue; }
    o=${LEAD[${name}]}; w=$(wrms "${FB[${name}]}"); h=$(hrms "${FB[${name}]}")
    dis=$(grep -c plan_disagree "${OUT}/${name}/lead/run.csv" || true)
    # Cutting periods (force above 5 % of Fr, the summary's rule) whose command the lead set.
    led=$(python3 -c 'import csv,sys; r=[x for x in csv.DictReader(open(sys.argv[1])) if x["force_n"] and float(x["force_n"])>0.05*float(x["force_ref_n"] or 0)]; n=sum("plan_lead:" in x["flags"] for x in r); print(f"{n} of {len(r)}")' "${OUT}/${name}/lead/run.csv")
    echo "| ${name} | $(ev entries "${o}") | $(ev corners "${o}") | $(rms "${o}") | $(oratio "$(rms "${o}")" "$(orms "${FB[${name}]}")") | $(oratio "$(rms "${o}")" "${w}") | ${h} | $(oratio "$(rms "${o}")" "${h}") | $(cyc "${o}") | ${led} | ${dis} |" | sed 's/|  |/| none |/g'
done <<<"${LIST}"
echo
echo "Cycle time, s, and the run's highest force / Fr (\`acc sim\`; the optimized program by \`acc optimize\`):"
echo
echo "| program | constant safe feed | ACC alone | ACC + look-ahead | optimized, 100 % (no ACC) | optimized + ACC | optimized + ACC + look-ahead | ratio to the constant safe feed: optimized + ACC / + look-ahead |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- |"
# The run's highest force: the largest peak/Fr of the per-tool table.
peak() { awk '/^ tool  blocks/{t=1;next} /^highest peaks/{t=0} t&&NF>=6{if($6>m)m=$6} END{printf "%.2f", m}' <<<"$1"; }
cell() { echo "$(cyc "$1") ($(peak "$1"))"; }
while read -r prog stock; do
    file=${prog/#nc3:/${NC3}/}
    name=$(basename "${file}")
    [[ -f ${file} ]] || { echo "| ${name} | absent | | | | | | |"; continue; }
    s=${SAFE[${name}]}; o=${OPTACC[${name}]}; l=${OPTLA[${name}]}
    ratio() { awk -v a="$(cyc "$1" | cut -d' ' -f1)" -v b="$(cyc "${s}" | cut -d' ' -f1)" 'BEGIN{printf "%.2f", a/b}'; }
    echo "| ${name} | $(cell "${s}") | $(cell "${FB[${name}]}") | $(cell "${LA[${name}]}") | $(cell "${OPT100[${name}]}") | $(cell "${o}") | $(cell "${l}") | $(ratio "${o}") / $(ratio "${l}") |"
done <<<"${LIST}"
rm -rf "${OUT}"
