#!/usr/bin/env bash
# Runs a fixed set of `ivdyn` commands on the fixtures and keeps every output (JSON, URDF,
# side files, stdout) in OUT_DIR. Used while moving code: run it with the binary before and
# after the move, then `diff -r` the two folders (they must be byte-identical; binary MCAP
# outputs are compared by checksum).
#   tools/golden-cli.sh path/to/ivdyn OUT_DIR
set -euo pipefail
BIN=$(realpath "$1")
OUT=$2
ROOT=$(cd "$(dirname "$0")/.." && pwd)
rm -rf "$OUT"; mkdir -p "$OUT"; cd "$OUT"
UR5=(--urdf "$ROOT/fixtures/ur5.urdf" --base base_link --tip tool0)
FR=(--fc 2,2,1.5,0.6,0.6,0.4 --fv 0.8,0.8,0.5,0.2,0.2,0.1)
run() { local name=$1; shift; local rc=0; "$BIN" "$@" --quiet > "$name.stdout" 2> "$name.stderr" || rc=$?; echo "exit $rc" >> "$name.stdout"; }
run sim0 simulate "${UR5[@]}" "${FR[@]}" --noise 0.1 --seed 1 --duration 8 --out u0.mcap --json sim0.json
run sim1 simulate "${UR5[@]}" "${FR[@]}" --noise 0.1 --seed 2 --duration 8 --payload-mass 2 --payload-com 0.01,-0.02,0.05 --out u1.mcap
run simcsv simulate "${UR5[@]}" --noise 0.1 --seed 3 --duration 4 --no-velocity --command --out u2.csv --json simcsv.json
run idw identify "${UR5[@]}" --log u0.mcap --json idw.json --out-params p.json --write-urdf w.urdf --out-mcap pred.mcap
run idmem identify "${UR5[@]}" --log u0.mcap --in-memory --json idmem.json
run idiv identify "${UR5[@]}" --log u0.mcap --method iv --json idiv.json
run idim identify "${UR5[@]}" --log u0.mcap --method idim-iv --json idim.json
run idcons identify "${UR5[@]}" --log u0.mcap --consistent --friction coulomb --no-offset --json idcons.json --out-params pc.json
run idcsv identify "${UR5[@]}" --log u2.csv --validate u2.csv --json idcsv.json
run idpar identify "${UR5[@]}" --params p.json --log u1.mcap --json idpar.json
run idside identify --urdf w.urdf --base base_link --tip tool0 --log u0.mcap --json idside.json
run pay payload "${UR5[@]}" --log u1.mcap --before u0.mcap --json pay.json --write-urdf pay.urdf
run paycut payload "${UR5[@]}" --log u1.mcap --cutoff 10 --decimate 2 --json paycut.json
run diag diagnose "${UR5[@]}" --log "$ROOT/fixtures/diagnose/viscous_payload.mcap" --out diag --json diag.json
run exc excite "${UR5[@]}" --duration 5 --starts 1 --iterations 20 --random 5 --out exc.csv --out-mcap exc.mcap --json exc.json
run bad1 identify "${UR5[@]}" --log nope.mcap
run bad2 simulate "${UR5[@]}" --payload-mass=-1 --out x.mcap
for f in *.mcap diag/*.mcap; do [ -f "$f" ] && sha256sum "$f" > "$f.sha256" && rm "$f"; done
rm -f diag/report.html.sha256
[ -f diag/report.html ] && sha256sum diag/report.html > diag/report.html.sha256 && rm diag/report.html
true
