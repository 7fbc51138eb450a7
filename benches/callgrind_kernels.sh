#!/usr/bin/env bash
# Instructions per call of each dynamics kernel (callgrind; independent of machine load):
# runs benches/examples/kernel_loop at 2000 and 12000 calls and prints the difference / 10000.
# Usage: benches/callgrind_kernels.sh [robots...]   (default: ur5 paper panda7)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build -q --profile bench -p ivdyn-benches --example kernel_loop
EXE="${CARGO_TARGET_DIR:-target}/release/examples/kernel_loop"
count() {
  valgrind --tool=callgrind --callgrind-out-file=/dev/null "$EXE" "$@" 2>&1 \
    | sed -n 's/.*Collected : \([0-9]*\).*/\1/p'
}
echo "| robot | kernel | instructions per call |"
echo "|---|---|--:|"
robots=("$@")
[ ${#robots[@]} -gt 0 ] || robots=(ur5 paper panda7)
for robot in "${robots[@]}"; do
  for k in rnea regressor mass_matrix forward_dynamics gravity; do
    a=$(count "$robot" "$k" 2000)
    b=$(count "$robot" "$k" 12000)
    echo "| $robot | $k | $(( (b - a) / 10000 )) |"
  done
done
