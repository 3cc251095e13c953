#!/bin/bash
# tests/run_tests.sh: everything `make check` runs.
#  1. every tests/test_*.c program, with each rank count its header names
#     ("ranks: 1 2"); their TAP lines "ok"/"not ok" are counted, and a
#     program that crashes or exits non-zero counts as one more failure;
#  2. every broken input of tests/bad/cases, with 1 and 2 ranks: it must
#     fail with a non-zero status, no crash and no hang, print the expected
#     message, and leave no file in its output directory;
#  3. `volknit mesh` on the demo scene with 1 and 2 ranks, compared by
#     tests/tool_compare_mesh (same mesh, masses, embedding, partition).
# Ends with the line "N passed, M failed"; exit status 1 if M > 0.
set -u
cd "$(dirname "$0")/.."
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
MPIEXEC=${MPIEXEC:-mpiexec}
TIMEOUT=${TIMEOUT:-600}
out=tests/out
rm -rf "$out"
mkdir -p "$out"
passed=0
failed=0

ok()     { passed=$((passed + 1)); }
not_ok() { failed=$((failed + 1)); echo "not ok - $*"; }

# 1. test programs
for src in tests/test_*.c; do
  name=$(basename "$src" .c)
  ranks=$(sed -n 's/^ \* ranks: *\([0-9][0-9 ]*[0-9]\|[0-9]\) *\(\*\/\)\{0,1\}$/\1/p' "$src" | head -n 1)
  if [ -z "$ranks" ]; then
    if grep -q 'ranks:' "$src"; then not_ok "$name: unreadable ' * ranks:' line"; fi
    ranks=1
  fi
  for n in $ranks; do
    log="$out/$name.n$n.log"
    timeout "$TIMEOUT" $MPIEXEC -n "$n" "bin/tests/$name" -o "$out/$name.n$n" > "$log" 2>&1
    rc=$?
    p=$(grep -c '^ok ' "$log")
    f=$(grep -c '^not ok ' "$log")
    passed=$((passed + p))
    failed=$((failed + f))
    grep -E '^(not ok|# \[rank)' "$log" | sed "s|^|$name -n $n: |"
    if [ "$rc" -ne 0 ] && [ "$f" -eq 0 ]; then not_ok "$name -n $n exited with status $rc (see $log)"; fi
    printf '%-22s -n %s: %4d passed, %d failed\n' "$name" "$n" "$p" "$f"
  done
done

# 2. broken inputs
k=0
bad_passed=0
while IFS='|' read -r expect args; do
  expect=$(echo "$expect" | sed 's/ *$//')
  case "$expect" in ''|'#'*) continue ;; esac
  k=$((k + 1))
  for n in 1 2; do
    dir="$out/bad/$k.n$n"
    log="$out/bad/$k.n$n.log"
    mkdir -p "$out/bad"
    # shellcheck disable=SC2086
    set -- $args   # the command, then its options; our -o comes first so a case may override it
    cmd=$1
    shift
    # one rank runs as an MPI singleton: mpiexec itself waits 2 s after a failed job
    if [ "$n" -eq 1 ]; then launch=""; else launch="$MPIEXEC -n $n"; fi
    timeout 120 $launch bin/volknit "$cmd" -o "$dir" "$@" > "$log" 2>&1 </dev/null
    rc=$?
    why=""
    if [ "$rc" -eq 0 ]; then why="exit status 0"
    elif [ "$rc" -eq 124 ]; then why="hung (timeout)"
    elif grep -qiE 'segmentation|caught signal|SIGSEGV|SIGBUS|SIGFPE|core dumped|AddressSanitizer' "$log"; then why="crashed"
    elif ! grep -qF -- "$expect" "$log"; then why="message '$expect' not printed"
    elif [ -d "$dir" ] && [ -n "$(find "$dir" -type f)" ]; then why="left files in $dir: $(find "$dir" -type f | tr '\n' ' ')"
    fi
    if [ -z "$why" ]; then ok; bad_passed=$((bad_passed + 1)); else not_ok "bad input $k (-n $n): volknit $args: $why (see $log)"; fi
  done
done < tests/bad/cases
printf '%-22s       : %4d passed, %d failed\n' "broken inputs" "$bad_passed" "$((2 * k - bad_passed))"

# 3. the mesh command with 1 and 2 ranks gives the same mesh
cmp_passed=$passed
cmp_failed=$failed
for d in 1 2; do
  for n in 1 2; do
    timeout "$TIMEOUT" $MPIEXEC -n "$n" bin/volknit mesh -options_file options/demo.opts -dd_domains "$d" -o "$out/cmp.d$d.n$n" > "$out/cmp.d$d.n$n.log" 2>&1 \
      || not_ok "volknit mesh -dd_domains $d with $n ranks failed (see $out/cmp.d$d.n$n.log)"
  done
  log="$out/cmp.d$d.log"
  bin/tests/tool_compare_mesh "$out/cmp.d$d.n1/mesh.h5" "$out/cmp.d$d.n2/mesh.h5" > "$log" 2>&1
  rc=$?
  p=$(grep -c '^ok ' "$log"); f=$(grep -c '^not ok ' "$log")
  passed=$((passed + p)); failed=$((failed + f))
  grep '^not ok' "$log" | sed "s|^|mesh -dd_domains $d, 1 vs 2 ranks: |"
  if [ "$rc" -ne 0 ] && [ "$f" -eq 0 ]; then not_ok "tool_compare_mesh exited with status $rc (see $log)"; fi
done
printf '%-22s       : %4d passed, %d failed\n' "mesh, 1 vs 2 ranks" "$((passed - cmp_passed))" "$((failed - cmp_failed))"

# 4. the example programs: ex1's printed mass balance and reproduction error,
#    ex2's stretch of the driven yarns (1.5 x the rest width)
for n in 1 2; do
  log="$out/ex1.n$n.log"
  timeout "$TIMEOUT" $MPIEXEC -n "$n" bin/examples/ex1_chart_mesh -ex_chart meshes/moss_rib.knit -ex_wales 9 -ex_courses 7 -o "$out/ex1.n$n" > "$log" 2>&1
  rc=$?
  dm=$(sed -n 's/.*(relative difference \([^)]*\)).*/\1/p' "$log" | tail -n 1)
  dx=$(sed -n 's/.*reproduces the rest yarn to \([^ ]*\) m.*/\1/p' "$log")
  if [ "$rc" -eq 0 ] && [ -n "$dm" ] && [ -n "$dx" ] && awk -v a="$dm" -v b="$dx" 'BEGIN { exit !(a < 1e-12 && b < 3e-15) }'; then ok
  else not_ok "ex1_chart_mesh -n $n: status $rc, mass difference '$dm' (< 1e-12), reproduction '$dx' m (< 3e-15 = 1e-12 h) (see $log)"; fi
done
for n in 1 2; do
  log="$out/ex2.n$n.log"
  timeout "$TIMEOUT" $MPIEXEC -n "$n" bin/examples/ex2_stretch -ts_dt 0.02 -o "$out/ex2.n$n" > "$log" 2>&1
  rc=$?
  ratio=$(sed -n 's/.*after the stretch (ratio \([^)]*\)).*/\1/p' "$log")
  if [ "$rc" -eq 0 ] && [ -n "$ratio" ] && [ -s "$out/ex2.n$n/sim.h5" ] && awk -v r="$ratio" 'BEGIN { exit !(r > 1.49 && r < 1.51) }'; then ok
  else not_ok "ex2_stretch -n $n: status $rc, width ratio '$ratio' (1.5 expected), sim.h5 written (see $log)"; fi
done
printf '%-22s       : examples ex1_chart_mesh, ex2_stretch with 1 and 2 ranks\n' "examples"

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
