#!/usr/bin/env bash
# The program table of docs/programs.md: every program below run by `acc sim` on the paper's
# machine and tool (scenario paper_case3) with ACC (the adaptive law) and with the constant
# safe feed, on the stock given. Prints one markdown row per program.
#
#   tests/nc/table.sh            # uses ${ACC:-target/release/acc}
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
ACC=${ACC:-${ROOT}/target/release/acc}
NC3=${ROOT}/../shared/data/nc
cd "${ROOT}"
OUT=$(mktemp -d "${TMPDIR:-/tmp}/programs.XXXXXX")
echo "| program | stock, mm | pieces | entries: highest / mean peak, Fr | corners: highest / mean peak, Fr | peak / Fr (block) | force RMS error, N | cycle with ACC, s | cycle at the constant safe feed, s | ratio |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
while read -r prog stock; do
    [[ -z ${prog} || ${prog} == \#* ]] && continue
    file=${prog/#nc3:/${NC3}/}
    [[ -f ${file} ]] || { echo "| ${prog} | absent | | | | | | | | |"; continue; }
    run() { "${ACC}" sim paper_case3 --program "${file}" --stock-box="${stock}" --no-plot --law "$1" --out "${OUT}/$1" 2>/dev/null; }
    ours=$(run ours)
    safe=$(run constant-safe)
    pieces=$(sed -n 's/^program: \([0-9]*\) pieces.*/\1/p' <<<"${ours}")
    peak=$(awk '/^highest peaks/{getline; getline; printf "%.2f (%s)", $6, $2; exit}' <<<"${ours}")
    rms=$(sed -n 's/.*force RMS error while cutting \([0-9.]*\) N.*/\1/p' <<<"${ours}")
    c1=$(sed -n 's/^cycle time \([0-9.]*\) s;.*/\1/p' <<<"${ours}")
    c0=$(sed -n 's/^cycle time \([0-9.]*\) s;.*/\1/p' <<<"${safe}")
    ev() { sed -n "s/^$1: \([0-9]*\); highest true peak \([0-9.]*\) Fr.*mean peak \([0-9.]*\) Fr/\1: \2 \/ \3/p" <<<"${ours}"; }
    entries=$(ev entries); corners=$(ev corners)
    ratio=$(awk -v a="${c1}" -v b="${c0}" 'BEGIN{printf "%.2f", a/b}')
    end=""; grep -q "ended before the end" <<<"${ours}" && end=" (did not finish)"
    echo "| $(basename "${file}") | ${stock} | ${pieces} | ${entries:-none} | ${corners:-none} | ${peak} | ${rms} | ${c1}${end} | ${c0} | ${ratio} |"
done <<'LIST'
tests/nc/pocket_rect.ngc -20,-20,-10,60,50,0
tests/nc/contour_inside_corners.ngc -10,-10,-10,70,65,0
tests/nc/stepped_face.ngc -10,-5,-10,70,45,0
nc3:linuxcnc_hk_ba20_testmill.ngc -150,-20,-20,80,220,0
nc3:linuxcnc_arcspiral.ngc -60,-60,-10,60,60,0
nc3:linuxcnc_3D_Chips.ngc -50,-50,-50,50,50,0
LIST
rm -rf "${OUT}"
